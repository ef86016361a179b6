// Slots given back (`objectspace::slots`): every physical page backing a
// virtual page of a released range is freed, so that its chunk goes back
// in this frame's paging and the range can hold another object's pages.
#import shadespace::objectspace::{params, page_owner, page_used, unbind_page}

// Released ranges of virtual pages: (first, end).
@group(2) @binding(0) var<storage, read> released: array<vec2u>;

@compute @workgroup_size(64)
fn release_slots(@builtin(global_invocation_id) id: vec3u) {
    let page = id.x;
    if page >= params.physical_pages || page_owner[page] == 0u {
        return;
    }
    let owner = page_owner[page] - 1u;
    for (var i = 0u; i < arrayLength(&released); i++) {
        if owner >= released[i].x && owner < released[i].y {
            unbind_page(page);
            // Free: the first candidate a request takes.
            atomicStore(&page_used[page], 0u);
            return;
        }
    }
}
