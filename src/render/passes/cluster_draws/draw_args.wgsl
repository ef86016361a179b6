// The indirect draws of `cull.wgsl`'s two cluster lists for the hardware
// raster passes (`passes::cluster_draws`): per list, an instanced draw of
// 3 * CLUSTER_TRIANGLES vertices, an instance per listed cluster.

// Mirrors `clusters::CLUSTER_TRIANGLES`.
const TRIANGLES: u32 = 64u;

// `cull.wgsl`'s counts: the lists' lengths first.
@group(0) @binding(0) var<storage, read> counts: array<u32, 6>;
// Two `draw_indirect` arguments (vertex count, instance count, first
// vertex, first instance).
@group(0) @binding(1) var<storage, read_write> args: array<vec4u, 2>;

@compute @workgroup_size(1)
fn draw_args() {
    args[0] = vec4u(3u * TRIANGLES, counts[0], 0u, 0u);
    args[1] = vec4u(3u * TRIANGLES, counts[1], 0u, 0u);
}
