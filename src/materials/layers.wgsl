// Layered materials (`materials::Layer`, Oxide's material layers): a
// material is an ordered list of layers over its own surface; each layer is
// a kind (one function below, giving the layer's own Surface, hence its own
// BRDF) and a mask (one function per mask kind). Every pipeline lights each
// layer's surface with every light it gives the point and blends the results
// by mask, bottom to top ("over"): layer i keeps weight
// m_i * (1 - m_{i+1}) * ... * (1 - m_top), and the material's own surface
// what no layer covers. Lighting is linear in radiance, so the blend can be
// taken per light (multi-pass, light volumes) or over all lights at once:
// both give the same image. Callers walk the layers top down
// (`layer_count`, `layer_at`, `layer_mask`), keeping the weight not yet
// given out: a layer of weight 0 is not lit, and an opaque one ends the walk
// (nothing below it shows). The cost is one lighting evaluation per layer
// that shows, so it grows with the layer count.
//
// A Surface carries its material's layer range (`layer_first`,
// `layer_count`, 0 for an unlayered material) and its UV0 and texture mip
// (`uv`, `uv_lod`, for texture masks); without LAYERS (no layered material
// in the scene) none of this is compiled and every function below is the
// unlayered lighting.
#define_import_path shadespace::layers
#import shadespace::contract::{LAYER_BASE, LAYER_PAINTED_METAL, LAYER_BARE_METAL, LAYER_DIRT,
    LAYER_SNOW, LAYER_EMISSIVE, MASK_TEXTURE, MASK_NOISE, MASK_SLOPE_HEIGHT, MASK_DECAL}
#import shadespace::lighting::{Light, Surface, light_radiance, shininess_from_roughness}
#import shadespace::scene_bindings::{albedo, texel_sampler, linear_maps}

// 112 bytes; mirrors `materials::GpuLayer` (field meanings per kind there).
struct Layer {
    // LAYER_*.
    kind: u32,
    // MASK_*.
    mask: u32,
    // MASK_TEXTURE: the texture-array layer; MASK_NOISE: the seed.
    mask_index: u32,
    // MASK_TEXTURE: channel 0-3, plus 4 for the linear array; MASK_NOISE:
    // octaves; MASK_DECAL: 1 for a round footprint.
    mask_mode: u32,
    // The kind's colours (rgb) and roughnesses (a).
    color_a: vec4f,
    color_b: vec4f,
    // The kind's scalars.
    params: vec4f,
    // The mask's parameters.
    mask_a: vec4f,
    mask_b: vec4f,
    mask_c: vec4f,
    // Threshold, softness, invert (0 or 1), opacity.
    mask_shape: vec4f,
}

@group(0) @binding(13) var<storage, read> material_layers: array<Layer>;

// 0 below `edge - width / 2`, 1 above `edge + width / 2`, linear between
// (a step at `edge` for width 0).
fn ramp(edge: f32, width: f32, x: f32) -> f32 {
    if width <= 0.0 {
        return select(0.0, 1.0, x >= edge);
    }
    return clamp((x - edge) / width + 0.5, 0.0, 1.0);
}

// 1 between `lo` and `hi`, fading over `fade` at each end.
fn band(x: f32, lo: f32, hi: f32, fade: f32) -> f32 {
    return ramp(lo, fade, x) * (1.0 - ramp(hi, fade, x));
}

// An integer hash (lowbias32), so that noise is the same in every pipeline
// and on every adapter.
fn hash_u32(x: u32) -> u32 {
    var h = x;
    h ^= h >> 16u;
    h *= 0x7feb352du;
    h ^= h >> 15u;
    h *= 0x846ca68bu;
    h ^= h >> 16u;
    return h;
}

fn lattice(c: vec3i, seed: u32) -> f32 {
    let h = hash_u32(bitcast<u32>(c.x) ^ hash_u32(bitcast<u32>(c.y) ^ hash_u32(bitcast<u32>(c.z) ^ seed)));
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// Value noise in [0, 1] on the integer lattice, smoothly interpolated.
fn value_noise(p: vec3f, seed: u32) -> f32 {
    let i = floor(p);
    let f = p - i;
    let u = f * f * (3.0 - 2.0 * f);
    let c = vec3i(i);
    let x00 = mix(lattice(c, seed), lattice(c + vec3i(1, 0, 0), seed), u.x);
    let x10 = mix(lattice(c + vec3i(0, 1, 0), seed), lattice(c + vec3i(1, 1, 0), seed), u.x);
    let x01 = mix(lattice(c + vec3i(0, 0, 1), seed), lattice(c + vec3i(1, 0, 1), seed), u.x);
    let x11 = mix(lattice(c + vec3i(0, 1, 1), seed), lattice(c + vec3i(1, 1, 1), seed), u.x);
    return mix(mix(x00, x10, u.y), mix(x01, x11, u.y), u.z);
}

// Fractal sum of `octaves` octaves of value noise, in [0, 1].
fn fbm(p: vec3f, octaves: u32, seed: u32) -> f32 {
    var sum = 0.0;
    var total = 0.0;
    var amplitude = 0.5;
    var q = p;
    for (var o = 0u; o < max(octaves, 1u); o++) {
        sum += amplitude * value_noise(q, seed + o);
        total += amplitude;
        q = q * 2.03 + vec3f(17.1, -3.7, 5.3);
        amplitude *= 0.5;
    }
    return sum / total;
}

// MASK_TEXTURE: a channel of one of the scene's texture layers at UV0 times
// `mask_a.x`, at the surface's mip (shifted by the repeat and the array's
// size), isotropic in every pipeline (one level, not gradients, is what the
// G-buffer keeps).
fn mask_texture(l: Layer, s: Surface) -> f32 {
    let scale = l.mask_a.x;
    let uv = s.uv * scale;
    var v: vec4f;
    if l.mask_mode >= 4u {
        let lod = s.uv_lod + log2(scale * f32(textureDimensions(linear_maps).x) / f32(textureDimensions(albedo).x));
        v = textureSampleLevel(linear_maps, texel_sampler, uv, l.mask_index, max(lod, 0.0));
    } else {
        v = textureSampleLevel(albedo, texel_sampler, uv, l.mask_index, max(s.uv_lod + log2(scale), 0.0));
    }
    return v[l.mask_mode & 3u];
}

// MASK_NOISE: fractal noise of world position times `mask_a.x` (1 / metres).
fn mask_noise(l: Layer, s: Surface) -> f32 {
    return fbm(s.position * l.mask_a.x, l.mask_mode, l.mask_index);
}

// MASK_SLOPE_HEIGHT: height along the unit axis `mask_a.xyz` within
// `mask_b` (low, high, fade) times the normal's cosine to the axis within
// `mask_c` (low, high, fade).
fn mask_slope_height(l: Layer, s: Surface) -> f32 {
    let axis = l.mask_a.xyz;
    let h = band(dot(s.position, axis), l.mask_b.x, l.mask_b.y, l.mask_b.z);
    return h * band(dot(s.normal, axis), l.mask_c.x, l.mask_c.y, l.mask_c.z);
}

// MASK_DECAL: rows `mask_a`, `mask_b`, `mask_c` take world points into the
// projector's box (-1..1 on each axis, projecting along +z); inside its
// footprint (square, or round) the weight falls to 0 over `softness` at the
// edge, on surfaces facing the projector.
fn mask_decal(l: Layer, s: Surface) -> f32 {
    let p4 = vec4f(s.position, 1.0);
    let p = vec3f(dot(l.mask_a, p4), dot(l.mask_b, p4), dot(l.mask_c, p4));
    if abs(p.z) > 1.0 {
        return 0.0;
    }
    var r = max(abs(p.x), abs(p.y));
    if l.mask_mode == 1u {
        r = length(p.xy);
    }
    let edge = clamp((1.0 - r) / max(l.mask_shape.y, 1e-4), 0.0, 1.0);
    let facing = ramp(0.1, 0.2, dot(s.normal, -normalize(l.mask_c.xyz)));
    return edge * facing;
}

// The layer's mask at the surface point, times its opacity.
fn layer_mask(l: Layer, s: Surface) -> f32 {
    var m = 1.0;
    if l.mask == MASK_TEXTURE {
        m = ramp(l.mask_shape.x, l.mask_shape.y, mask_texture(l, s));
    } else if l.mask == MASK_NOISE {
        m = ramp(l.mask_shape.x, l.mask_shape.y, mask_noise(l, s));
    } else if l.mask == MASK_SLOPE_HEIGHT {
        m = mask_slope_height(l, s);
    } else if l.mask == MASK_DECAL {
        m = mask_decal(l, s);
    }
    m = mix(m, 1.0 - m, l.mask_shape.z);
    return m * l.mask_shape.w;
}

// A surface of the material's position, normal and occlusion with other
// BRDF parameters (Phong's strength and exponent follow them) and no emission.
fn restyled(s: Surface, albedo: vec3f, metallic: f32, roughness: f32) -> Surface {
    var r = s;
    r.albedo = albedo;
    r.metallic = metallic;
    r.roughness = roughness;
    r.specular = mix(0.5 * (1.0 - roughness), 1.0, metallic);
    r.shininess = shininess_from_roughness(roughness);
    r.emission = vec3f(0.0);
    return r;
}

// LAYER_BASE: the material's own surface, albedo tinted by `color_a.rgb`;
// metallic `params.x` and roughness `params.y` where not negative.
fn layer_base(l: Layer, s: Surface) -> Surface {
    var r = s;
    r.albedo = s.albedo * l.color_a.rgb;
    if l.params.x >= 0.0 {
        r.metallic = l.params.x;
    }
    if l.params.y >= 0.0 {
        r.roughness = l.params.y;
        r.shininess = shininess_from_roughness(l.params.y);
    }
    return r;
}

// LAYER_PAINTED_METAL: paint (`color_a`: colour, roughness) chipped where
// noise of frequency `params.y` (seed `params.z`) passes 1 - `params.x`
// (the chipped share), showing metal (`color_b`) with soft chip edges.
fn layer_painted_metal(l: Layer, s: Surface) -> Surface {
    let n = fbm(s.position * l.params.y, 3u, u32(l.params.z));
    let chipped = ramp(1.0 - l.params.x, 0.04, n);
    let albedo = mix(l.color_a.rgb, l.color_b.rgb, chipped);
    return restyled(s, albedo, chipped, mix(l.color_a.a, l.color_b.a, chipped));
}

// LAYER_BARE_METAL: metal of colour `color_a.rgb`, its roughness `color_a.a`
// varied by brushed streaks (noise stretched 8x along y, frequency `params.x`).
fn layer_bare_metal(l: Layer, s: Surface) -> Surface {
    let f = l.params.x;
    let n = value_noise(s.position * vec3f(f, 8.0 * f, f), 7u);
    let roughness = clamp(l.color_a.a * (0.6 + 0.8 * n), 0.02, 1.0);
    return restyled(s, l.color_a.rgb * (0.9 + 0.2 * n), 1.0, roughness);
}

// LAYER_DIRT: grime of colour `color_a.rgb` and roughness `color_a.a`, its
// albedo and the ambient occlusion varied by 4-octave noise of frequency
// `params.x`.
fn layer_dirt(l: Layer, s: Surface) -> Surface {
    let n = fbm(s.position * l.params.x, 4u, 11u);
    var r = restyled(s, l.color_a.rgb * (0.5 + n), 0.0, l.color_a.a);
    r.occlusion = s.occlusion * (0.6 + 0.4 * n);
    return r;
}

// LAYER_SNOW: snow (`color_a`) turning to ice (`color_b`) by `params.x`,
// its normal bent towards +y by `params.y` (snow fills the relief).
fn layer_snow(l: Layer, s: Surface) -> Surface {
    let ice = l.params.x;
    var r = restyled(s, mix(l.color_a.rgb, l.color_b.rgb, ice), 0.0, mix(l.color_a.a, l.color_b.a, ice));
    let bent = mix(s.normal, vec3f(0.0, 1.0, 0.0), l.params.y);
    if dot(bent, bent) > 1e-8 {
        r.normal = normalize(bent);
    }
    return r;
}

// LAYER_EMISSIVE: the material's surface, albedo scaled by `params.x`,
// emitting `color_a.rgb` more.
fn layer_emissive(l: Layer, s: Surface) -> Surface {
    var r = s;
    r.albedo = s.albedo * l.params.x;
    r.emission = s.emission + l.color_a.rgb;
    return r;
}

// LAYER_DECAL: a printed surface of colour `color_a.rgb`, roughness
// `color_a.a` and metallic `params.x`.
fn layer_decal(l: Layer, s: Surface) -> Surface {
    return restyled(s, l.color_a.rgb, l.params.x, l.color_a.a);
}

// The surface of layer `l` over the material's surface `s`.
fn layer_surface(l: Layer, s: Surface) -> Surface {
    if l.kind == LAYER_BASE {
        return layer_base(l, s);
    } else if l.kind == LAYER_PAINTED_METAL {
        return layer_painted_metal(l, s);
    } else if l.kind == LAYER_BARE_METAL {
        return layer_bare_metal(l, s);
    } else if l.kind == LAYER_DIRT {
        return layer_dirt(l, s);
    } else if l.kind == LAYER_SNOW {
        return layer_snow(l, s);
    } else if l.kind == LAYER_EMISSIVE {
        return layer_emissive(l, s);
    }
    return layer_decal(l, s);
}

// Layer `i` (1 = the bottom one, `s.layer_count` the top) of the material of `s`.
fn layer_at(s: Surface, i: u32) -> Layer {
    return material_layers[s.layer_first + i - 1u];
}

// Every layered shading function (here, `surface::light_surface` and
// `emission_and_globals`, the light grid's, the tiled pass's and object
// space's shade with its tile's light list) spells out the same top-down
// walk over the layers. One shared walk, a struct stepped
// through a pointer, gave the same images but cost object space 7 % and
// deferred-compute 2 % more on the H100 (Sponza, 8 layers, 30 shadowed
// lights: 2.604 against 2.428 ms, 2.898 against 2.841), so the loop stays
// written out where it is used.
// What one light reflects from the layered surface `s` towards `to_eye`:
// for passes that see one light at a time (multi-pass forward, light volumes).
fn layered_radiance(light: Light, s: Surface, to_eye: vec3f) -> vec3f {
#ifdef LAYERS
    var color = vec3f(0.0);
    var remaining = 1.0;
    for (var i = s.layer_count; i > 0u && remaining > 0.0; i--) {
        let l = layer_at(s, i);
        let w = layer_mask(l, s) * remaining;
        remaining -= w;
        if w > 0.0 {
            color += w * light_radiance(light, layer_surface(l, s), to_eye);
        }
    }
    if remaining > 0.0 {
        color += remaining * light_radiance(light, s, to_eye);
    }
    return color;
#else
    return light_radiance(light, s, to_eye);
#endif
}

// The emission of the layered surface `s`.
fn layered_emission(s: Surface) -> vec3f {
#ifdef LAYERS
    var color = vec3f(0.0);
    var remaining = 1.0;
    for (var i = s.layer_count; i > 0u && remaining > 0.0; i--) {
        let l = layer_at(s, i);
        let w = layer_mask(l, s) * remaining;
        remaining -= w;
        if w > 0.0 {
            color += w * layer_surface(l, s).emission;
        }
    }
    return color + remaining * s.emission;
#else
    return s.emission;
#endif
}
