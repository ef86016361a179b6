// Paging: backs the pages this frame's pixels requested with physical pages,
// on the GPU, least recently used first. After marking:
// `age_pages` sorts the physical pages no visible tile used this frame into
// age buckets (free pages first, then the oldest), `page_offsets` turns the
// bucket sizes into offsets, `list_candidates` lists the pages in that
// order, and `allocate` gives the i-th request the i-th candidate, taking it
// from the virtual page it backed before. Requests beyond the candidates
// fail this frame (their pixels are shaded forward in the gather) and the
// budget raises the mip bias.
#import shadespace::contract::{COUNT_PAGES_REQUESTED, COUNT_PAGES_BACKED, COUNT_PAGES_FAILED, COUNT_CANDIDATES,
    AGE_BUCKET_BASE, AGE_BUCKETS}
#import shadespace::objectspace::{params, counters, page_table, page_used, page_owner, page_requests, request_list,
    candidates, backed}
#import shadespace::objectspace_dispatch::{write_dispatch, ALLOCATE_ARGS, BACKED_ARGS}

// Bucket 0: free pages; 1: unused for 128 frames or more; ...; 8: used last frame.
fn age_bucket(page: u32) -> u32 {
    if page_owner[page] == 0u {
        return 0u;
    }
    let age = params.stamp - atomicLoad(&page_used[page]);
    return AGE_BUCKETS - 1u - min(firstLeadingBit(age), AGE_BUCKETS - 2u);
}

fn evictable(page: u32) -> bool {
    return page < params.physical_pages && atomicLoad(&page_used[page]) != params.stamp;
}

@compute @workgroup_size(64)
fn age_pages(@builtin(global_invocation_id) id: vec3u) {
    if evictable(id.x) {
        atomicAdd(&counters[AGE_BUCKET_BASE + age_bucket(id.x)], 1u);
    }
}

// This frame's listed requests (the list holds one per physical page).
fn requests() -> u32 {
    return min(atomicLoad(&counters[COUNT_PAGES_REQUESTED]), params.physical_pages);
}

@compute @workgroup_size(1)
fn page_offsets() {
    var offset = 0u;
    for (var b = 0u; b < AGE_BUCKETS; b++) {
        let n = atomicLoad(&counters[AGE_BUCKET_BASE + b]);
        atomicStore(&counters[AGE_BUCKET_BASE + b], offset);
        offset += n;
    }
    atomicStore(&counters[COUNT_CANDIDATES], offset);
    write_dispatch(ALLOCATE_ARGS, (requests() + 63u) / 64u);
}

@compute @workgroup_size(64)
fn list_candidates(@builtin(global_invocation_id) id: vec3u) {
    if evictable(id.x) {
        candidates[atomicAdd(&counters[AGE_BUCKET_BASE + age_bucket(id.x)], 1u)] = id.x;
    }
}

@compute @workgroup_size(64)
fn allocate(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
            @builtin(local_invocation_index) lid: u32) {
    let i = (wg.y * groups.x + wg.x) * 64u + lid;
    if i >= requests() {
        return;
    }
    let request = request_list[i];
    let page = request.x;
    if i >= atomicLoad(&counters[COUNT_CANDIDATES]) {
        // No page left: forget the tiles asked for (next frame asks again).
        atomicAdd(&counters[COUNT_PAGES_FAILED], 1u);
        atomicStore(&page_requests[page], 0u);
        return;
    }
    let physical = candidates[i];
    // The evicted page was not used this frame, so no request names it.
    let evicted = page_owner[physical];
    if evicted != 0u {
        page_table[evicted - 1u] = 0u;
    }
    page_table[page] = physical + 1u;
    page_owner[physical] = page + 1u;
    atomicStore(&page_used[physical], params.stamp);
    backed[i] = vec4u(page, request.y, physical, 0u);
    atomicAdd(&counters[COUNT_PAGES_BACKED], 1u);
}

@compute @workgroup_size(1)
fn backed_args() {
    write_dispatch(BACKED_ARGS, atomicLoad(&counters[COUNT_PAGES_BACKED]));
}
