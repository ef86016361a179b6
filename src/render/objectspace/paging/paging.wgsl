// Paging: backs the pages this frame's pixels requested with physical pages,
// on the GPU, least recently used first. After marking:
// `age_pages` sorts the physical pages no visible tile used this frame into
// age buckets (free pages first, then the oldest), `page_offsets` turns the
// bucket sizes into offsets (paging's listing finds them itself),
// `list_candidates` lists the pages in that order, and `allocate` gives the i-th request the i-th candidate, taking it
// from the virtual page it backed before. The page table has two levels (a
// directory word per block of pages, a chunk of page words per block with
// backed pages): ranking also frees the chunks left with no page (by the
// slots given back or a resize) and lists the free ones, the allocation
// frees those whose last page it takes away, `claim_blocks` gives a chunk to each
// requested block that has none, and `bind_pages` writes the pages into
// their chunks and lists them as backed. Requests beyond the candidates (or
// the free chunks) fail this frame (their pixels are shaded forward in the
// gather) and the budget raises the mip bias.
#import shadespace::contract::{TILE_COUNTER_SLOTS, COUNT_QUEUED, COUNT_PAGES_REQUESTED, COUNT_PAGES_BACKED, COUNT_PAGES_FAILED, COUNT_CANDIDATES,
    COUNT_FREE_CHUNKS, COUNT_CHUNKS_TAKEN, COUNT_TABLE_CHUNKS, AGE_BUCKET_BASE, AGE_BUCKETS}
#import shadespace::objectspace::{params, atlas_entries, counters, page_table, page_used, page_owner, request_list,
    candidates, backed, page_directory, table_chunks, free_chunks, forget_request, unbind_page, age_bucket, BLOCK_PAGES}
#import shadespace::objectspace_dispatch::{write_dispatch, ALLOCATE_ARGS, BACKED_ARGS, SHADE_ARGS}

fn evictable(page: u32) -> bool {
    return page < params.physical_pages && atomicLoad(&page_used[page]) != params.stamp;
}

// A workgroup's pages per age bucket, then where its first in each bucket
// goes: one global atomic per bucket and workgroup, not one per page on
// nine words (thousands of evictable pages a frame).
var<workgroup> bucket_pages: array<atomic<u32>, AGE_BUCKETS>;
var<workgroup> bucket_base: array<u32, AGE_BUCKETS>;

// This invocation's page's age bucket (AGE_BUCKETS where it is not ranked
// or not evictable) and its slot among the workgroup's pages of that
// bucket; `bucket_pages` then holds the workgroup's count per bucket.
fn bucket_slot(page: u32, lid: u32, ranked: bool) -> vec2u {
    if lid < AGE_BUCKETS {
        atomicStore(&bucket_pages[lid], 0u);
    }
    workgroupBarrier();
    var bucket = AGE_BUCKETS;
    var slot = 0u;
    if ranked && evictable(page) {
        bucket = age_bucket(page);
        slot = atomicAdd(&bucket_pages[bucket], 1u);
    }
    workgroupBarrier();
    return vec2u(bucket, slot);
}

// Adds this workgroup's count of each bucket to the bucket's global count,
// keeping where its pages of the bucket start (after `page_offsets` the
// global counts are offsets: what `list` places its pages by).
fn add_bucket_counts(lid: u32) {
    if lid < AGE_BUCKETS {
        let n = atomicLoad(&bucket_pages[lid]);
        if n > 0u {
            bucket_base[lid] = atomicAdd(&counters[AGE_BUCKET_BASE + lid], n);
        }
    }
}

// Counts the evictable pages per age bucket (when `ranked`).
fn age(page: u32, lid: u32, ranked: bool) {
    _ = bucket_slot(page, lid, ranked);
    add_bucket_counts(lid);
}

// Lists the evictable pages at their buckets' offsets (when `ranked`).
fn list(page: u32, lid: u32, ranked: bool) {
    let at = bucket_slot(page, lid, ranked);
    add_bucket_counts(lid);
    workgroupBarrier();
    if at.x < AGE_BUCKETS {
        candidates[bucket_base[at.x] + at.y] = page;
    }
}

// Ranking for a resize (`resize.wgsl` moves pages onto the candidates).
@compute @workgroup_size(64)
fn age_pages(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lid: u32) {
    age(id.x, lid, true);
}

@compute @workgroup_size(64)
fn list_candidates(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lid: u32) {
    list(id.x, lid, true);
}

// Ranking for paging: nothing to rank in a frame that requested no page
// (the allocation then dispatches no workgroup). Chunk `id.x` is released
// here too (`release_chunk`), before the allocation: one dispatch where the
// release was one of its own after it (a launch and a barrier).
@compute @workgroup_size(64)
fn age_pages_and_release_chunks(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lid: u32) {
    age(id.x, lid, requests() > 0u);
    release_chunk(id.x, lid);
}

// Paging's listing leaves the ranking's counts per bucket as they are:
// each workgroup adds up the buckets before its pages' own, where
// `page_offsets` turned the counts into offsets in a dispatch of its own
// (a launch and a barrier), and places its pages past those the workgroups
// before it placed in the bucket, counted in the bucket's first stripe copy
// (no count uses it; the CPU's fold adds it to the bucket's count, which
// nothing reads). The first invocation writes what `page_offsets` writes.
@compute @workgroup_size(64)
fn list_candidates_if_requested(@builtin(global_invocation_id) id: vec3u,
                                @builtin(local_invocation_index) lid: u32) {
    let at = bucket_slot(id.x, lid, requests() > 0u);
    if lid < AGE_BUCKETS {
        let n = atomicLoad(&bucket_pages[lid]);
        if n > 0u {
            var offset = 0u;
            for (var b = 0u; b < lid; b++) {
                offset += atomicLoad(&counters[AGE_BUCKET_BASE + b]);
            }
            bucket_base[lid] = offset + atomicAdd(&counters[TILE_COUNTER_SLOTS + AGE_BUCKET_BASE + lid], n);
        }
    }
    workgroupBarrier();
    if at.x < AGE_BUCKETS {
        candidates[bucket_base[at.x] + at.y] = id.x;
    }
    if id.x == 0u {
        var total = 0u;
        for (var b = 0u; b < AGE_BUCKETS; b++) {
            total += atomicLoad(&counters[AGE_BUCKET_BASE + b]);
        }
        write_paging_args(total);
    }
}

// This frame's listed requests.
fn requests() -> u32 {
    return min(atomicLoad(&counters[COUNT_PAGES_REQUESTED]), params.request_capacity);
}

@compute @workgroup_size(1)
fn page_offsets() {
    var offset = 0u;
    for (var b = 0u; b < AGE_BUCKETS; b++) {
        let n = atomicLoad(&counters[AGE_BUCKET_BASE + b]);
        atomicStore(&counters[AGE_BUCKET_BASE + b], offset);
        offset += n;
    }
    write_paging_args(offset);
}

// The candidates' count (`candidates` pages), the allocation's dispatch
// and, with the fused chain, the bounds below.
fn write_paging_args(candidates: u32) {
    atomicStore(&counters[COUNT_CANDIDATES], candidates);
    write_dispatch(ALLOCATE_ARGS, (requests() + 63u) / 64u);
#ifdef FUSED_PAGING
    // The fused chain records no pass after paging to count what it did:
    // the backed pages' dispatch takes a bound known now (a request may
    // still fail in `bind_pages`; its extra workgroups see the count and
    // return), and so does the shade pass's: the tiles marking listed and
    // every tile of those pages (the triangle-map pass lists their
    // requested tiles; the workgroups past the list's end return).
    let backed = min(requests(), candidates);
    write_dispatch(BACKED_ARGS, backed);
    let per_row = params.page_size / params.tile_size;
    write_dispatch(SHADE_ARGS, min(atomicLoad(&counters[COUNT_QUEUED]) + backed * per_row * per_row, params.max_queue));
#endif
}


// Request `i` of this frame's list, when there is one.
fn request_index(wg: vec3u, groups: vec3u, lid: u32) -> u32 {
    return (wg.y * groups.x + wg.x) * 64u + lid;
}

// Requests that got a candidate page.
fn allocated() -> u32 {
    return min(requests(), atomicLoad(&counters[COUNT_CANDIDATES]));
}

// Forgets request `request` (no page for it this frame).
fn fail(request: vec2u) {
    atomicAdd(&counters[COUNT_PAGES_FAILED], 1u);
    forget_request(atlas_entries[request.y >> 8u].levels[request.y & 0xffu], request.x);
}

@compute @workgroup_size(64)
fn allocate(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
            @builtin(local_invocation_index) lid: u32) {
    let i = request_index(wg, groups, lid);
    if i >= requests() {
        return;
    }
    if i >= atomicLoad(&counters[COUNT_CANDIDATES]) {
        fail(request_list[i]);
        return;
    }
    // The evicted page was not used this frame, so no request names it.
    unbind_and_release(candidates[i]);
    let physical = candidates[i];
    page_owner[physical] = request_list[i].x + 1u;
    atomicStore(&page_used[physical], params.stamp);
}

// `unbind_page`, and the page's chunk freed and listed when this was its
// last page (its block's directory word cleared).
fn unbind_and_release(physical: u32) {
    let emptied = unbind_page(physical);
    if emptied != 0u {
        let chunk = emptied - 1u;
        atomicStore(&page_directory[table_chunks[chunk].block - 1u], 0u);
        table_chunks[chunk].block = 0u;
        free_chunks[atomicAdd(&counters[COUNT_FREE_CHUNKS], 1u)] = chunk;
        atomicSub(&counters[COUNT_TABLE_CHUNKS], 1u);
    }
}

var<workgroup> group_free: atomic<u32>;
var<workgroup> group_used: atomic<u32>;
var<workgroup> group_base: u32;

// Chunk `c`, by invocation `li` of its workgroup: a chunk left with no page
// goes back (its block's directory word cleared); the free ones are listed.
// Counted per workgroup first: one global atomic per 64 chunks, not one per
// chunk on a single word.
fn release_chunk(c: u32, li: u32) {
    if li == 0u {
        atomicStore(&group_free, 0u);
        atomicStore(&group_used, 0u);
    }
    workgroupBarrier();
    var free = false;
    var slot = 0u;
    if c < params.table_chunks {
        let block = table_chunks[c].block;
        if block != 0u && atomicLoad(&table_chunks[c].pages) == 0u {
            atomicStore(&page_directory[block - 1u], 0u);
            table_chunks[c].block = 0u;
        }
        free = table_chunks[c].block == 0u;
        if free {
            slot = atomicAdd(&group_free, 1u);
        } else {
            atomicAdd(&group_used, 1u);
        }
    }
    workgroupBarrier();
    if li == 0u {
        group_base = atomicAdd(&counters[COUNT_FREE_CHUNKS], atomicLoad(&group_free));
        atomicAdd(&counters[COUNT_TABLE_CHUNKS], atomicLoad(&group_used));
    }
    workgroupBarrier();
    if free {
        free_chunks[group_base + slot] = c;
    }
}

// A directory word while one request of its block takes a chunk for it.
const CLAIMING: u32 = 0xffffffffu;

// Per allocated request: the first request of a block with no chunk takes
// a free one (the others of the block find it taken).
@compute @workgroup_size(64)
fn claim_blocks(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
                @builtin(local_invocation_index) lid: u32) {
    let i = request_index(wg, groups, lid);
    if i >= allocated() {
        return;
    }
    let block = request_list[i].x / BLOCK_PAGES;
    // A weak exchange may fail spuriously: retry while the word is still 0.
    for (var attempt = 0u; attempt < 4u; attempt++) {
        if atomicLoad(&page_directory[block]) != 0u {
            return;
        }
        let r = atomicCompareExchangeWeak(&page_directory[block], 0u, CLAIMING);
        if r.exchanged {
            let n = atomicAdd(&counters[COUNT_CHUNKS_TAKEN], 1u);
            if n < atomicLoad(&counters[COUNT_FREE_CHUNKS]) {
                let c = free_chunks[n];
                table_chunks[c].block = block + 1u;
                atomicStore(&page_directory[block], c + 1u);
                atomicAdd(&counters[COUNT_TABLE_CHUNKS], 1u);
            } else {
                // No chunk left (with one chunk per physical page this
                // cannot happen): the block's requests fail this frame.
                atomicStore(&page_directory[block], 0u);
            }
            return;
        }
        if r.old_value != 0u {
            return;
        }
    }
}

// Per allocated request: the page's word in its block's chunk, and the
// backed-page list; a request whose block found no chunk gives its
// physical page back.
@compute @workgroup_size(64)
fn bind_pages(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
              @builtin(local_invocation_index) lid: u32) {
    let i = request_index(wg, groups, lid);
    if i >= allocated() {
        return;
    }
    let request = request_list[i];
    let page = request.x;
    let physical = candidates[i];
    let chunk = atomicLoad(&page_directory[page / BLOCK_PAGES]);
    if chunk == 0u {
        page_owner[physical] = 0u;
        atomicStore(&page_used[physical], 0u);
        fail(request);
        return;
    }
    page_table[(chunk - 1u) * BLOCK_PAGES + page % BLOCK_PAGES] = physical + 1u;
    atomicAdd(&table_chunks[chunk - 1u].pages, 1u);
    backed[atomicAdd(&counters[COUNT_PAGES_BACKED], 1u)] = vec4u(page, request.y, physical, 0u);
}

@compute @workgroup_size(1)
fn backed_args() {
    write_dispatch(BACKED_ARGS, atomicLoad(&counters[COUNT_PAGES_BACKED]));
}
