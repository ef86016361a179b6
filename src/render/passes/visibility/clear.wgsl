// Clears the compute rasterizer's 64-bit depth-and-payload buffer to
// background: 16 bytes (two entries) per invocation, in order. On the
// H100 this took 0.009 ms at 1920x1080 where an invocation per pixel
// writing its 8 bytes took 0.025 (BENCHMARKS.md, "Compute visibility
// without its serial tail"). The buffer is sized to a whole number of 16
// bytes.

@group(0) @binding(0) var<storage, read_write> words: array<vec4u>;

const CLEAR_WORKGROUP: u32 = 256u;

@compute @workgroup_size(CLEAR_WORKGROUP)
fn clear(@builtin(workgroup_id) group: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_index) local: u32) {
    let i = (group.y * groups.x + group.x) * CLEAR_WORKGROUP + local;
    if i < arrayLength(&words) {
        words[i] = vec4u(0u);
    }
}
