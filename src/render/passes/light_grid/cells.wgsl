// The per-cell passes of a light-grid build: the exclusive prefix sum of the
// counts (a workgroup scan per block of SCAN_BLOCK cells, a scan of the block
// totals, then each block's first entry added to its cells), and `finish`,
// which sets each cell's range to the entries `fill` wrote and zeroes the
// counts for the next build. Sums saturate at 0xffffffff rather than wrap, so
// an impossibly large grid overflows the list (detected) instead of aliasing.
#import shadespace::light_grid_build::{params, counts, cells, block_sums, status}

const THREADS: u32 = 256u;
const PER_THREAD: u32 = 4u;
// Cells per workgroup of `scan_blocks` (and per entry of `block_sums`).
const SCAN_BLOCK: u32 = 1024u;

var<workgroup> partial: array<u32, THREADS>;

fn sat_add(a: u32, b: u32) -> u32 {
    let s = a + b;
    return select(s, 0xffffffffu, s < a);
}

// Inclusive scan of one value per thread (Hillis-Steele in workgroup memory,
// 8 steps). Afterwards `partial[i]` holds thread i's inclusive sum. Must be
// called in uniform control flow.
fn workgroup_scan(lid: u32, value: u32) {
    partial[lid] = value;
    workgroupBarrier();
    for (var step = 1u; step < THREADS; step <<= 1u) {
        var v = partial[lid];
        if lid >= step {
            v = sat_add(v, partial[lid - step]);
        }
        workgroupBarrier();
        partial[lid] = v;
        workgroupBarrier();
    }
}

// Thread `lid`'s exclusive sum after `workgroup_scan`.
fn exclusive(lid: u32) -> u32 {
    return select(0u, partial[max(lid, 1u) - 1u], lid > 0u);
}

// Per block: cells get (offset within the block, count); the block's total
// goes to `block_sums`.
@compute @workgroup_size(256)
fn scan_blocks(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let base = wg.x * SCAN_BLOCK + lid * PER_THREAD;
    var c: array<u32, PER_THREAD>;
    var sum = 0u;
    for (var i = 0u; i < PER_THREAD; i++) {
        let cell = base + i;
        c[i] = select(0u, atomicLoad(&counts[min(cell, params.cell_count - 1u)]), cell < params.cell_count);
        sum = sat_add(sum, c[i]);
    }
    workgroup_scan(lid, sum);
    var running = exclusive(lid);
    for (var i = 0u; i < PER_THREAD; i++) {
        let cell = base + i;
        if cell < params.cell_count {
            cells[cell] = vec2u(running, c[i]);
        }
        running = sat_add(running, c[i]);
    }
    if lid == THREADS - 1u {
        block_sums[wg.x] = partial[lid];
    }
}

// One workgroup: the block totals become each block's first entry, in
// chunks of SCAN_BLOCK blocks with a carry (one chunk up to 1 Mi cells).
@compute @workgroup_size(256)
fn scan_sums(@builtin(local_invocation_index) lid: u32) {
    let blocks = (params.cell_count + SCAN_BLOCK - 1u) / SCAN_BLOCK;
    var carry = 0u;
    for (var start = 0u; start < blocks; start += SCAN_BLOCK) {
        let base = start + lid * PER_THREAD;
        var v: array<u32, PER_THREAD>;
        var sum = 0u;
        for (var i = 0u; i < PER_THREAD; i++) {
            let b = base + i;
            v[i] = select(0u, block_sums[min(b, blocks - 1u)], b < blocks);
            sum = sat_add(sum, v[i]);
        }
        workgroup_scan(lid, sum);
        var running = sat_add(carry, exclusive(lid));
        for (var i = 0u; i < PER_THREAD; i++) {
            let b = base + i;
            if b < blocks {
                block_sums[b] = running;
            }
            running = sat_add(running, v[i]);
        }
        carry = sat_add(carry, partial[THREADS - 1u]);
        // Every thread has read `partial` before the next chunk writes it.
        workgroupBarrier();
    }
    if lid == 0u {
        status[0] = carry;
    }
}

// Each cell's first entry: its offset within its block plus the block's.
@compute @workgroup_size(256)
fn scan_add(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let cell = id.y * groups.x * THREADS + id.x;
    if cell >= params.cell_count {
        return;
    }
    cells[cell].x = sat_add(cells[cell].x, block_sums[cell / SCAN_BLOCK]);
}

// After `fill`: the count left in a cell is the number of its slots fill did
// not reach (fill takes slots from the top), so its entries are the rest.
// Count and fill run the same test and agree; should a compiler round them
// differently, a light at the binning margin's edge is left out rather than
// a stale slot read. Counts are zeroed for the next build.
@compute @workgroup_size(256)
fn finish(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let cell = id.y * groups.x * THREADS + id.x;
    if cell >= params.cell_count {
        return;
    }
    let range = cells[cell];
    var unfilled = atomicLoad(&counts[cell]);
    // Wrapped below zero: fill found more than count (the extra were skipped).
    if unfilled > range.y {
        unfilled = 0u;
    }
    cells[cell] = vec2u(sat_add(range.x, unfilled), range.y - unfilled);
    atomicStore(&counts[cell], 0u);
}
