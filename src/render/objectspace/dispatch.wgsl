// The object-space stages' indirect dispatch arguments: one buffer, three
// dispatches, bound as storage (group 2) by the small dispatches that write
// them; the dispatches they launch, later in the same pass, read it as
// INDIRECT, which excludes storage use by the launched pipeline itself (a
// dispatch's usage is its pipeline's bind groups and its arguments).
#define_import_path shadespace::objectspace_dispatch

// Word offsets of the three dispatches.
const ALLOCATE_ARGS: u32 = 0u;
const BACKED_ARGS: u32 = 4u;
const SHADE_ARGS: u32 = 8u;

@group(2) @binding(0) var<storage, read_write> dispatch: array<u32, 12>;

// `n` workgroups at word `at`, spread over x and y because one dimension
// holds at most 65535 groups.
fn write_dispatch(at: u32, n: u32) {
    let x = min(n, 65535u);
    dispatch[at] = x;
    dispatch[at + 1u] = select(0u, (n + x - 1u) / max(x, 1u), n > 0u);
    dispatch[at + 2u] = 1u;
}
