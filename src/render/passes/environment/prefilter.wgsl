// Prefilters the environment (`--env`) once at load, in compute
// (docs/environment.md): the source radiance into a cube map with a box mip
// chain (`source_sky`, `source_equirect`, `downsample`), then from it the
// GGX-prefiltered cube map of the split sum, one roughness per mip
// (`prefilter`, importance sampled), and the irradiance cube map
// (`irradiance`, summed over every texel of a 32x32 level), and the split
// sum's BRDF lookup table (`brdf_lut`, importance sampled). Faces in
// Vulkan's order (+x, -x, +y, -y, +z, -z) and orientation, as cube sampling
// reads them; `render::passes::environment::cpu` is the CPU twin.

// Mirrors `render::passes::environment::GpuEnvParams`.
struct EnvParams {
    sun_direction: vec3f,
    sun_sharpness: f32,
    sun_color: vec3f,
    // Side of the faces this dispatch writes.
    size: u32,
    zenith: vec3f,
    // GGX perceptual roughness of the level written (prefilter).
    roughness: f32,
    horizon: vec3f,
    // Importance samples per texel (prefilter).
    samples: u32,
    ground: vec3f,
    // Side of the source cube's level 0 (prefilter's source level choice).
    source_size: u32,
    // The equirectangular image's size (source_equirect).
    equirect_width: u32,
    equirect_height: u32,
    // Source taps per texel side (source_equirect: an image sharper than the
    // cube is averaged, not point sampled).
    taps: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> params: EnvParams;
@group(0) @binding(1) var output: texture_storage_2d_array<rgba16float, write>;
@group(0) @binding(2) var<storage, read> equirect: array<vec4f>;
@group(0) @binding(3) var source_level: texture_2d_array<f32>;
@group(0) @binding(4) var source_cube: texture_cube<f32>;
@group(0) @binding(5) var source_sampler: sampler;

const PI: f32 = 3.14159265;

// Largest finite half float, less a margin: a brighter texel (the sun of a
// real HDR image) would become infinite.
const HALF_MAX: f32 = 65000.0;

// The direction through point `uv` ([-1, 1]²) of cube face `face`, not
// normalized.
fn face_point(face: u32, uv: vec2f) -> vec3f {
    switch face {
        case 0u: { return vec3f(1.0, -uv.y, -uv.x); }
        case 1u: { return vec3f(-1.0, -uv.y, uv.x); }
        case 2u: { return vec3f(uv.x, 1.0, uv.y); }
        case 3u: { return vec3f(uv.x, -1.0, -uv.y); }
        case 4u: { return vec3f(uv.x, -uv.y, 1.0); }
        default: { return vec3f(-uv.x, -uv.y, -1.0); }
    }
}

// Face point of offset `o` ([0, 1]²) inside texel `xy` of a `size` face.
fn texel_uv(xy: vec2u, o: vec2f, size: u32) -> vec2f {
    return (vec2f(xy) + o) / f32(size) * 2.0 - 1.0;
}

// Mirrors `scene::environment::Sky::radiance`.
fn sky(d: vec3f) -> vec3f {
    let t = sqrt(abs(d.y));
    var base = mix(params.horizon, params.ground, t);
    if d.y >= 0.0 {
        base = mix(params.horizon, params.zenith, t);
    }
    return base + params.sun_color * exp(params.sun_sharpness * (dot(d, params.sun_direction) - 1.0));
}

fn equirect_texel(x: i32, y: i32) -> vec3f {
    let w = i32(params.equirect_width);
    let h = i32(params.equirect_height);
    let xi = ((x % w) + w) % w;
    let yi = clamp(y, 0, h - 1);
    return equirect[yi * w + xi].rgb;
}

// Bilinear radiance of the image at unit direction `d`; the mapping mirrors
// `scene::environment::equirect_uv` (wrapping around in azimuth).
fn equirect_radiance(d: vec3f) -> vec3f {
    let uv = vec2f(0.5 + atan2(d.x, -d.z) / (2.0 * PI), acos(clamp(d.y, -1.0, 1.0)) / PI);
    let p = uv * vec2f(f32(params.equirect_width), f32(params.equirect_height)) - 0.5;
    let f = floor(p);
    let t = p - f;
    let i = vec2i(f);
    let top = mix(equirect_texel(i.x, i.y), equirect_texel(i.x + 1, i.y), t.x);
    let bottom = mix(equirect_texel(i.x, i.y + 1), equirect_texel(i.x + 1, i.y + 1), t.x);
    return mix(top, bottom, t.y);
}

fn store(id: vec3u, c: vec3f) {
    textureStore(output, id.xy, id.z, vec4f(min(c, vec3f(HALF_MAX)), 1.0));
}

// Level 0 of the source cube from the sky, 2x2 samples per texel (the sun is
// a few texels wide).
@compute @workgroup_size(8, 8, 1)
fn source_sky(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.size || id.y >= params.size {
        return;
    }
    var c = vec3f(0.0);
    for (var j = 0u; j < 4u; j++) {
        let o = vec2f(f32(j & 1u), f32(j >> 1u)) * 0.5 + 0.25;
        c += sky(normalize(face_point(id.z, texel_uv(id.xy, o, params.size))));
    }
    store(id, c * 0.25);
}

// Level 0 of the source cube from the image, `taps` x `taps` bilinear
// samples per texel.
@compute @workgroup_size(8, 8, 1)
fn source_equirect(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.size || id.y >= params.size {
        return;
    }
    let n = params.taps;
    var c = vec3f(0.0);
    for (var j = 0u; j < n * n; j++) {
        let o = (vec2f(f32(j % n), f32(j / n)) + 0.5) / f32(n);
        c += equirect_radiance(normalize(face_point(id.z, texel_uv(id.xy, o, params.size))));
    }
    store(id, c / f32(n * n));
}

// One level of the source's box mip chain from the level above it.
@compute @workgroup_size(8, 8, 1)
fn downsample(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.size || id.y >= params.size {
        return;
    }
    let p = vec2i(id.xy) * 2;
    let f = i32(id.z);
    var c = textureLoad(source_level, p, f, 0).rgb + textureLoad(source_level, p + vec2i(1, 0), f, 0).rgb;
    c += textureLoad(source_level, p + vec2i(0, 1), f, 0).rgb + textureLoad(source_level, p + vec2i(1, 1), f, 0).rgb;
    store(id, c * 0.25);
}

// Point i of n of the Hammersley set.
fn hammersley(i: u32, n: u32) -> vec2f {
    return vec2f((f32(i) + 0.5) / f32(n), f32(reverseBits(i)) * 2.3283064365386963e-10);
}

// A half vector drawn from the GGX distribution of `alpha` around `n`.
fn ggx_half_vector(xi: vec2f, alpha: f32, n: vec3f) -> vec3f {
    let phi = 2.0 * PI * xi.x;
    let a2 = alpha * alpha;
    let cos_t = sqrt((1.0 - xi.y) / (1.0 + (a2 - 1.0) * xi.y));
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    var up = vec3f(1.0, 0.0, 0.0);
    if abs(n.z) < 0.999 {
        up = vec3f(0.0, 0.0, 1.0);
    }
    let tx = normalize(cross(up, n));
    let ty = cross(n, tx);
    return tx * (sin_t * cos(phi)) + ty * (sin_t * sin(phi)) + n * cos_t;
}

// One level of the split sum's prefiltered map (Karis 2013, with n = v = r):
// the mean of the source over GGX-sampled light directions, weighted by
// N.L, each read at the source level whose texels cover the sample's share
// of the lobe (filtered importance sampling, Colbert and Krivanek 2007), so
// that few samples give no noise.
@compute @workgroup_size(8, 8, 1)
fn prefilter(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.size || id.y >= params.size {
        return;
    }
    let n = normalize(face_point(id.z, texel_uv(id.xy, vec2f(0.5), params.size)));
    let alpha = params.roughness * params.roughness;
    let a2 = alpha * alpha;
    let texel_solid_angle = 4.0 * PI / (6.0 * f32(params.source_size * params.source_size));
    var sum = vec3f(0.0);
    var weight = 0.0;
    for (var i = 0u; i < params.samples; i++) {
        let h = ggx_half_vector(hammersley(i, params.samples), alpha, n);
        let n_dot_h = dot(n, h);
        let l = 2.0 * n_dot_h * h - n;
        let n_dot_l = dot(n, l);
        if n_dot_l > 0.0 {
            let denom = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
            // The pdf of l: D(h) N.H / (4 V.H), with V = N.
            let pdf = a2 / (PI * denom * denom) * 0.25;
            let sample_solid_angle = 1.0 / (f32(params.samples) * pdf + 1e-6);
            let lod = max(0.5 * log2(sample_solid_angle / texel_solid_angle) + 1.0, 0.0);
            sum += textureSampleLevel(source_cube, source_sampler, l, lod).rgb * n_dot_l;
            weight += n_dot_l;
        }
    }
    store(id, sum / max(weight, 1e-6));
}

// Irradiance / pi at the normal through each texel: the source's level of
// `source_level` summed over every texel, weighted by its solid angle and
// N.L (exact up to that level's resolution; the cosine lobe is smooth).
@compute @workgroup_size(8, 8, 1)
fn irradiance(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.size || id.y >= params.size {
        return;
    }
    let n = normalize(face_point(id.z, texel_uv(id.xy, vec2f(0.5), params.size)));
    let s = textureDimensions(source_level).x;
    var sum = vec3f(0.0);
    var solid_angle = 0.0;
    for (var face = 0u; face < 6u; face++) {
        for (var y = 0u; y < s; y++) {
            for (var x = 0u; x < s; x++) {
                let p = face_point(face, texel_uv(vec2u(x, y), vec2f(0.5), s));
                let len2 = dot(p, p);
                let w = 1.0 / (len2 * sqrt(len2));
                solid_angle += w;
                let n_dot_l = dot(n, p) * inverseSqrt(len2);
                if n_dot_l > 0.0 {
                    sum += textureLoad(source_level, vec2u(x, y), face, 0).rgb * (w * n_dot_l);
                }
            }
        }
    }
    // The weights, normalized to the sphere's 4 pi.
    store(id, sum * (4.0 / solid_angle));
}

// The split sum's BRDF factor (Karis 2013) at N.V = u and perceptual
// roughness = v of each texel centre: the scale (red) and bias (green) of
// F0 in the mean of GGX's reflectance times N.L over GGX-sampled light, with
// the height-correlated Smith visibility and Schlick Fresnel of
// `lighting.wgsl` (and its floor on alpha).
@compute @workgroup_size(8, 8, 1)
fn brdf_lut(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= params.size || id.y >= params.size {
        return;
    }
    let n_dot_v = (f32(id.x) + 0.5) / f32(params.size);
    let roughness = (f32(id.y) + 0.5) / f32(params.size);
    let alpha = max(roughness * roughness, 2e-3);
    let a2 = alpha * alpha;
    let v = vec3f(sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v);
    let n = vec3f(0.0, 0.0, 1.0);
    var scale = 0.0;
    var bias = 0.0;
    for (var i = 0u; i < params.samples; i++) {
        let h = ggx_half_vector(hammersley(i, params.samples), alpha, n);
        let v_dot_h = dot(v, h);
        let l = 2.0 * v_dot_h * h - v;
        if l.z > 0.0 && v_dot_h > 0.0 {
            let vis_l = n_dot_v * sqrt(l.z * l.z * (1.0 - a2) + a2);
            let vis_v = l.z * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
            let vis = 0.5 / (vis_l + vis_v);
            // D vis N.L over the pdf of l, D N.H / (4 V.H).
            let g = 4.0 * vis * l.z * v_dot_h / h.z;
            let fc = pow(1.0 - v_dot_h, 5.0);
            scale += (1.0 - fc) * g;
            bias += fc * g;
        }
    }
    let n_samples = f32(params.samples);
    textureStore(output, id.xy, 0, vec4f(scale / n_samples, bias / n_samples, 0.0, 1.0));
}
