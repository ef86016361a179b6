// Bloom in compute (after Jimenez, "Next generation post processing in Call
// of Duty: Advanced Warfare", SIGGRAPH 2014): a chain of half-size levels
// down-sampled with a 13-tap filter (Karis-weighted on the first level, so a
// single very bright pixel cannot flicker into a big square), then up-sampled
// with a 3x3 tent, each level adding the one below it, and a composite back
// into the HDR target. Sources are single-mip views sampled bilinearly
// (clamp to edge), so every tap is a 2x2 box.

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var linear: sampler;
// The pass's target: a level of the chain, or the HDR image (composite).
// Read-write because the up-sample and composite passes add into it.
@group(0) @binding(2) var dst: texture_storage_2d<rgba16float, read_write>;
// x: strength (0..1), y: 1 / number of levels.
@group(0) @binding(3) var<uniform> params: vec4f;

fn tap(uv: vec2f, texel: vec2f, x: f32, y: f32) -> vec3f {
    return max(textureSampleLevel(src, linear, uv + texel * vec2f(x, y), 0.0).rgb, vec3f(0.0));
}

fn luma(c: vec3f) -> f32 {
    return dot(c, vec3f(0.2126, 0.7152, 0.0722));
}

// The 13 taps (in source texels around the destination texel's centre) as
// five overlapping 2x2-tap boxes: the centre box (weight 1/2) and the four
// corner boxes (1/8 each). With `karis`, each box is also weighted by
// 1 / (1 + its luma).
fn down13(id: vec2u, karis: bool) -> vec3f {
    let size = textureDimensions(dst);
    let uv = (vec2f(id) + 0.5) / vec2f(size);
    let t = 1.0 / vec2f(textureDimensions(src));
    let a = tap(uv, t, -2.0, -2.0);
    let b = tap(uv, t, 0.0, -2.0);
    let c = tap(uv, t, 2.0, -2.0);
    let d = tap(uv, t, -2.0, 0.0);
    let e = tap(uv, t, 0.0, 0.0);
    let f = tap(uv, t, 2.0, 0.0);
    let g = tap(uv, t, -2.0, 2.0);
    let h = tap(uv, t, 0.0, 2.0);
    let i = tap(uv, t, 2.0, 2.0);
    let j = tap(uv, t, -1.0, -1.0);
    let k = tap(uv, t, 1.0, -1.0);
    let l = tap(uv, t, -1.0, 1.0);
    let m = tap(uv, t, 1.0, 1.0);
    let boxes = array<vec3f, 5>(
        (j + k + l + m) * 0.25,
        (a + b + d + e) * 0.25,
        (b + c + e + f) * 0.25,
        (d + e + g + h) * 0.25,
        (e + f + h + i) * 0.25,
    );
    var sum = vec3f(0.0);
    var total = 0.0;
    for (var n = 0; n < 5; n++) {
        var w = select(0.125, 0.5, n == 0);
        if karis {
            w /= 1.0 + luma(boxes[n]);
        }
        sum += boxes[n] * w;
        total += w;
    }
    return sum / total;
}

@compute @workgroup_size(8, 8)
fn down_first(@builtin(global_invocation_id) id: vec3u) {
    if all(id.xy < textureDimensions(dst)) {
        textureStore(dst, id.xy, vec4f(down13(id.xy, true), 1.0));
    }
}

@compute @workgroup_size(8, 8)
fn down(@builtin(global_invocation_id) id: vec3u) {
    if all(id.xy < textureDimensions(dst)) {
        textureStore(dst, id.xy, vec4f(down13(id.xy, false), 1.0));
    }
}

// 3x3 tent (1 2 1 / 2 4 2 / 1 2 1, over 16) of the source, one source texel
// apart, at the centre of the target texel `id`.
fn tent(id: vec2u) -> vec3f {
    let uv = (vec2f(id) + 0.5) / vec2f(textureDimensions(dst));
    let t = 1.0 / vec2f(textureDimensions(src));
    var sum = tap(uv, t, 0.0, 0.0) * 4.0;
    sum += (tap(uv, t, -1.0, 0.0) + tap(uv, t, 1.0, 0.0) + tap(uv, t, 0.0, -1.0) + tap(uv, t, 0.0, 1.0)) * 2.0;
    sum += tap(uv, t, -1.0, -1.0) + tap(uv, t, 1.0, -1.0) + tap(uv, t, -1.0, 1.0) + tap(uv, t, 1.0, 1.0);
    return sum / 16.0;
}

// Level i += tent(level i + 1).
@compute @workgroup_size(8, 8)
fn up(@builtin(global_invocation_id) id: vec3u) {
    if all(id.xy < textureDimensions(dst)) {
        let here = textureLoad(dst, id.xy);
        textureStore(dst, id.xy, vec4f(here.rgb + tent(id.xy), 1.0));
    }
}

// HDR = lerp(HDR, bloom, strength), where bloom is level 0 (the sum of every
// level's blur) divided by the number of levels: an average of blurs, which
// keeps the image's mean brightness.
@compute @workgroup_size(8, 8)
fn composite(@builtin(global_invocation_id) id: vec3u) {
    if all(id.xy < textureDimensions(dst)) {
        let hdr = textureLoad(dst, id.xy);
        let bloom = tent(id.xy) * params.y;
        textureStore(dst, id.xy, vec4f(mix(hdr.rgb, bloom, params.x), hdr.a));
    }
}
