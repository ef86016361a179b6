// Test read-back of a multisampled visibility buffer (`VisibilityBuffer::
// read_samples`): multisampled textures cannot be copied, so each pixel's
// samples are copied side by side into a buffer.

@group(0) @binding(0) var ids: texture_multisampled_2d<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<vec2u>;

@compute @workgroup_size(8, 8)
fn copy_samples(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(ids);
    if any(id.xy >= size) {
        return;
    }
    let n = textureNumSamples(ids);
    for (var s = 0u; s < n; s++) {
        out[(id.y * size.x + id.x) * n + s] = textureLoad(ids, id.xy, s).xy;
    }
}
