// Paging: backs the pages this frame's pixels requested with physical pages,
// on the GPU, least recently used first. After marking, `rank_pages` lists
// the physical pages no visible tile used this frame by age bucket (free
// pages first, then the oldest; a list per bucket), and `allocate` gives the
// i-th request the i-th of them (`candidate`), taking it from the virtual
// page it backed before. (A resize ranks them into one list: `age_pages`
// counts them per bucket, `page_offsets` turns the counts into offsets and
// `list_candidates` places them.) The page table has two levels (a
// directory word per block of pages, a chunk of page words per block with
// backed pages): ranking also frees the chunks left with no page (by the
// slots given back, a resize or the last frame's allocation) and lists the
// free ones, the allocation also gives a chunk to each requested block that
// has none, and `bind_pages` writes the pages into their chunks and lists
// them as backed. Requests beyond the candidates (or
// the free chunks) fail this frame (their pixels are shaded forward in the
// gather) and the budget raises the mip bias.
#import shadespace::contract::{COUNT_QUEUED, COUNT_PAGES_REQUESTED, COUNT_PAGES_BACKED, COUNT_PAGES_FAILED, COUNT_CANDIDATES,
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
// keeping where its pages of the bucket start: in the bucket's own list
// (`rank_pages`), or, after `page_offsets` turned the counts into offsets,
// in the resize's one list (`list`).
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

// Ranking for paging, in one dispatch: each workgroup appends its pages to
// their buckets' lists (`candidates` holds AGE_BUCKETS lists side by side,
// `bucket_stride` entries each), so no workgroup waits for the others'
// counts (and `candidate` finds the i-th page across the lists). Nothing to
// rank in a frame that requested no page (the allocation then dispatches
// no workgroup). Chunk `id.x` is released here too (`release_chunk`),
// before the allocation: one dispatch where the ranking (with the release)
// and the listing were two (a launch and a barrier each).
@compute @workgroup_size(64)
fn rank_pages(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lid: u32) {
    let at = bucket_slot(id.x, lid, requests() > 0u);
    add_bucket_counts(lid);
    workgroupBarrier();
    if at.x < AGE_BUCKETS {
        candidates[at.x * bucket_stride() + bucket_base[at.x] + at.y] = id.x;
    }
    release_chunk(id.x, lid);
    if id.x == 0u {
        write_paging_args();
    }
}

// Entries of each bucket's list in paging's `candidates`.
fn bucket_stride() -> u32 {
    return arrayLength(&candidates) / AGE_BUCKETS;
}

// Where each bucket's pages end among the candidates (the counts summed),
// read once for the workgroup by `load_bucket_ends`: a page's lookup then
// walks workgroup memory, not nine atomic loads one after another.
var<workgroup> bucket_ends: array<u32, AGE_BUCKETS>;

// Fills `bucket_ends` (called by every invocation `lid` of the workgroup).
fn load_bucket_ends(lid: u32) {
    if lid == 0u {
        var end = 0u;
        for (var b = 0u; b < AGE_BUCKETS; b++) {
            end += atomicLoad(&counters[AGE_BUCKET_BASE + b]);
            bucket_ends[b] = end;
        }
    }
    workgroupBarrier();
}

// The pages `rank_pages` listed, over every bucket (after `load_bucket_ends`).
fn candidate_count() -> u32 {
    return bucket_ends[AGE_BUCKETS - 1u];
}

// The `i`-th page `rank_pages` listed, in bucket order (free pages first,
// then the oldest), `i` below `candidate_count()` (after `load_bucket_ends`).
fn candidate(i: u32) -> u32 {
    var b = 0u;
    while b < AGE_BUCKETS - 1u && i >= bucket_ends[b] {
        b++;
    }
    let start = select(0u, bucket_ends[max(b, 1u) - 1u], b > 0u);
    return candidates[b * bucket_stride() + i - start];
}

// This frame's listed requests.
fn requests() -> u32 {
    return min(atomicLoad(&counters[COUNT_PAGES_REQUESTED]), params.request_capacity);
}

// The resize's ranking: the bucket counts turned into offsets, the
// candidates' count.
@compute @workgroup_size(1)
fn page_offsets() {
    var offset = 0u;
    for (var b = 0u; b < AGE_BUCKETS; b++) {
        let n = atomicLoad(&counters[AGE_BUCKET_BASE + b]);
        atomicStore(&counters[AGE_BUCKET_BASE + b], offset);
        offset += n;
    }
    atomicStore(&counters[COUNT_CANDIDATES], offset);
}

// The allocation's dispatch and, with the fused chain, the bounds below,
// for at most a page backed per request (the candidates are not counted
// yet when `rank_pages` writes them).
fn write_paging_args() {
    write_dispatch(ALLOCATE_ARGS, (requests() + 63u) / 64u);
#ifdef FUSED_PAGING
    // The fused chain records no pass after paging to count what it did:
    // the backed pages' dispatch takes a bound known now (a request may
    // still fail in `bind_pages`; its extra workgroups see the count and
    // return), and so does the shade pass's: the tiles marking listed and
    // every tile of those pages (the triangle-map pass lists their
    // requested tiles; the workgroups past the list's end return).
    let backed = requests();
    write_dispatch(BACKED_ARGS, backed);
    let per_row = params.page_size / params.tile_size;
    write_dispatch(SHADE_ARGS, min(atomicLoad(&counters[COUNT_QUEUED]) + backed * per_row * per_row, params.max_queue));
#endif
}


// Request `i` of this frame's list, when there is one.
fn request_index(wg: vec3u, groups: vec3u, lid: u32) -> u32 {
    return (wg.y * groups.x + wg.x) * 64u + lid;
}

// Requests that got a candidate page (after `load_bucket_ends`).
fn allocated() -> u32 {
    return min(requests(), candidate_count());
}

// Forgets request `request` (no page for it this frame).
fn fail(request: vec2u) {
    atomicAdd(&counters[COUNT_PAGES_FAILED], 1u);
    forget_request(atlas_entries[request.y >> 8u].levels[request.y & 0xffu], request.x);
}

// Per request: the i-th candidate page, taken from the virtual page it
// backed, and a chunk for the request's block where it has none (the first
// request of such a block takes a free one; the others find it taken). A
// chunk the page's old block is left with no page keeps its block until the
// next frame's ranking releases it (`release_chunk`): a request of this
// frame may bind into it, and the chunks this dispatch takes come from the
// ranking's free list alone, complete before it. (Claims were a dispatch of
// their own after the allocation, which released the chunks it emptied:
// a launch and a barrier more.)
@compute @workgroup_size(64)
fn allocate(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
            @builtin(local_invocation_index) lid: u32) {
    let i = request_index(wg, groups, lid);
    load_bucket_ends(lid);
    if i >= requests() {
        return;
    }
    let request = request_list[i];
    if i >= candidate_count() {
        fail(request);
        return;
    }
    // The evicted page was not used this frame, so no request names it.
    let physical = candidate(i);
    unbind_page(physical);
    page_owner[physical] = request.x + 1u;
    atomicStore(&page_used[physical], params.stamp);
    claim_block(request.x / BLOCK_PAGES);
}

// A directory word while one request of its block takes a chunk for it.
const CLAIMING: u32 = 0xffffffffu;

// Gives `block` a free chunk unless it has one (or another request is
// giving it one).
fn claim_block(block: u32) {
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

// Per allocated request: the page's word in its block's chunk, and the
// backed-page list; a request whose block found no chunk gives its
// physical page back.
@compute @workgroup_size(64)
fn bind_pages(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
              @builtin(local_invocation_index) lid: u32) {
    let i = request_index(wg, groups, lid);
    load_bucket_ends(lid);
    if i >= allocated() {
        return;
    }
    let request = request_list[i];
    let page = request.x;
    let physical = candidate(i);
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
