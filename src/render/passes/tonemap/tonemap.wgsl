// HDR -> display: exposure, Reinhard per channel, sRGB encoding. Compute, so
// that it runs on every SM of compute-heavy GPUs.

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var ldr: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(2) var<uniform> exposure: vec4f;

fn srgb_encode(c: vec3f) -> vec3f {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3f(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3f(0.0031308));
}

@compute @workgroup_size(8, 8)
fn tonemap(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(hdr);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let c = max(textureLoad(hdr, id.xy, 0).rgb * exposure.x, vec3f(0.0));
    let mapped = c / (1.0 + c);
    textureStore(ldr, id.xy, vec4f(srgb_encode(mapped), 1.0));
}
