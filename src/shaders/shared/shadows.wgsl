// The shadow term of the lighting model: how much of a shadowed light reaches
// a surface point, read from the shadow maps that `render::passes::shadows`
// renders (reversed Z, nearer is greater): the atlas, one depth layer per
// face (one for a spot light, six cube faces for a point light), and the
// sun's cascades.
//
// These are bindings 8-11 of the scene bind group (group 0, built in
// `render::scene_gpu`). They are declared here rather than in
// `scene_bindings`, which imports `lighting`: the lighting model calls this
// module, and naga_oil composes no import cycles.
#define_import_path shadespace::shadows
#import shadespace::contract::LIGHT_DIRECTIONAL

@group(0) @binding(8) var shadow_atlas: texture_depth_2d_array;
// Comparison `GreaterEqual` with linear filtering: a tap is lit when the
// point is at least as near the light as the caster (reversed Z), and each
// tap blends the four texels around it.
@group(0) @binding(9) var shadow_sampler: sampler_comparison;
// Per face: the light's view-projection.
@group(0) @binding(10) var<storage, read> shadow_faces: array<mat4x4f>;
// The sun's cascades, finest first.
@group(0) @binding(11) var sun_cascades: texture_depth_2d_array;

// Bias, in shadow-map texels at the point's distance (so it scales with the
// map's resolution and the distance to the light, not with scene units).
// The 3x3 bilinear PCF kernel reads up to 2 texels from the centre, where a
// receiver tilted by theta is 2 tan(theta) texels nearer the light: the
// slope term covers that; the normal offset (1 texel) moves the lookup off
// the surface so that grazing angles need less of it; the constant covers
// depth quantisation. Larger values detach shadows from contact points
// (peter-panning); the slope is capped at tan = 8 (83 degrees).
const SHADOW_NORMAL_OFFSET: f32 = 1.0;
const SHADOW_CONSTANT_BIAS: f32 = 0.5;
const SHADOW_SLOPE_BIAS: f32 = 2.0;
const SHADOW_MAX_SLOPE: f32 = 8.0;

// The cube face (0..5: +x, -x, +y, -y, +z, -z) that direction `d` leaves through.
fn cube_face(d: vec3f) -> u32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, d.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, d.y >= 0.0);
    }
    return select(5u, 4u, d.z >= 0.0);
}

// `position` moved towards the light by the bias, for the face whose
// view-projection is `m` and whose maps are `size` texels wide.
fn biased_position(m: mat4x4f, size: f32, position: vec3f, normal: vec3f, to_light: vec3f, n_dot_l: f32) -> vec3f {
    // One texel's width in world units at the point: 2 w / (size * P00),
    // where |row 0| of a view-projection is the projection's x scale P00
    // (w = 1 for the sun's orthographic cascades).
    let w = (m * vec4f(position, 1.0)).w;
    let texel = 2.0 * w / (size * length(vec3f(m[0].x, m[1].x, m[2].x)));
    let tan_theta = min(sqrt(max(1.0 - n_dot_l * n_dot_l, 0.0)) / n_dot_l, SHADOW_MAX_SLOPE);
    return position + normal * (SHADOW_NORMAL_OFFSET * texel)
        + to_light * ((SHADOW_CONSTANT_BIAS + SHADOW_SLOPE_BIAS * tan_theta) * texel);
}

// Shadow-map coordinates (uv, depth) of `p` seen through `m`; x < 0 when it
// lies outside the face (beyond a spot's cone, the light's range or a
// cascade's square, where the map says nothing).
fn face_coords(m: mat4x4f, p: vec3f) -> vec3f {
    let clip = m * vec4f(p, 1.0);
    if clip.w <= 0.0 {
        return vec3f(-1.0);
    }
    let ndc = clip.xyz / clip.w;
    let uv = ndc.xy * vec2f(0.5, -0.5) + 0.5;
    if any(uv < vec2f(0.0)) || any(uv > vec2f(1.0)) || ndc.z < 0.0 || ndc.z > 1.0 {
        return vec3f(-1.0);
    }
    return vec3f(uv, ndc.z);
}

// 3x3 taps one texel apart, each a bilinear 2x2 comparison against `depth`.
fn pcf(maps: texture_depth_2d_array, layer: u32, uv: vec2f, depth: f32, size: f32) -> f32 {
    var lit = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let tap = uv + vec2f(f32(x), f32(y)) / size;
            lit += textureSampleCompareLevel(maps, shadow_sampler, tap, layer, depth);
        }
    }
    return lit / 9.0;
}

// The sun: the finest cascade whose square holds the point (with room for
// the kernel); beyond the last, unshadowed.
fn sun_shadow(first_face: u32, cascades: u32, position: vec3f, normal: vec3f, to_light: vec3f, n_dot_l: f32) -> f32 {
    let size = f32(textureDimensions(sun_cascades).x);
    let edge = 2.0 / size;
    for (var i = 0u; i < cascades; i++) {
        let m = shadow_faces[first_face + i];
        let c = face_coords(m, biased_position(m, size, position, normal, to_light, n_dot_l));
        if all(c.xy >= vec2f(edge)) && all(c.xy <= vec2f(1.0 - edge)) {
            return pcf(sun_cascades, i, c.xy, c.z, size);
        }
    }
    return 1.0;
}

// Fraction (0..1) of a shadowed light of `kind` reaching `position`, whose
// unit normal is `normal`, `to_light` the unit vector to the light and
// `n_dot_l` their cosine (> 0). `first_face` and `faces` locate the light's
// faces (1: spot, 6: cube, else the sun's cascades). No derivatives: valid in
// compute and in non-uniform control flow.
fn shadow_factor(
    kind: u32,
    first_face: u32,
    faces: u32,
    light_position: vec3f,
    position: vec3f,
    normal: vec3f,
    to_light: vec3f,
    n_dot_l: f32,
) -> f32 {
    if kind == LIGHT_DIRECTIONAL {
        return sun_shadow(first_face, faces, position, normal, to_light, n_dot_l);
    }
    var face = first_face;
    if faces == 6u {
        face += cube_face(position - light_position);
    }
    let size = f32(textureDimensions(shadow_atlas).x);
    let biased = biased_position(shadow_faces[face], size, position, normal, to_light, n_dot_l);
    if faces == 6u {
        // The offset may cross into the neighbouring face; each face's
        // frustum is a few texels wider than 90 degrees for that.
        face = first_face + cube_face(biased - light_position);
    }
    let c = face_coords(shadow_faces[face], biased);
    if c.x < 0.0 {
        // Outside the face: beyond the spot's cone or the light's range,
        // where the light does not reach anyway.
        return 1.0;
    }
    return pcf(shadow_atlas, face, c.xy, c.z, size);
}
