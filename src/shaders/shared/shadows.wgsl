// The shadow term of the lighting model: how much of a shadowed light reaches
// a surface point, read from the shadow atlas that `render::passes::shadows`
// renders (one depth layer per face: one for a spot light, six cube faces for
// a point light; reversed Z, nearer is greater).
//
// These are bindings 8-10 of the scene bind group (group 0, built in
// `render::scene_gpu`). They are declared here rather than in
// `scene_bindings`, which imports `lighting`: the lighting model calls this
// module, and naga_oil composes no import cycles.
#define_import_path shadespace::shadows

@group(0) @binding(8) var shadow_atlas: texture_depth_2d_array;
// Comparison `GreaterEqual` with linear filtering: a tap is lit when the
// point is at least as near the light as the caster (reversed Z), and each
// tap blends the four texels around it.
@group(0) @binding(9) var shadow_sampler: sampler_comparison;
// Per face: the light's view-projection.
@group(0) @binding(10) var<storage, read> shadow_faces: array<mat4x4f>;

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

// Fraction (0..1) of a shadowed light reaching `position`, whose unit
// normal is `normal`, `to_light` the unit vector to the light and `n_dot_l`
// their cosine (> 0). `first_face` and `faces` (1: spot, 6: cube) locate the
// light's faces in the atlas. No derivatives: valid in compute and in
// non-uniform control flow.
fn shadow_factor(
    first_face: u32,
    faces: u32,
    light_position: vec3f,
    position: vec3f,
    normal: vec3f,
    to_light: vec3f,
    n_dot_l: f32,
) -> f32 {
    var face = first_face;
    if faces == 6u {
        face += cube_face(position - light_position);
    }
    var m = shadow_faces[face];
    let size = f32(textureDimensions(shadow_atlas).x);
    // One texel's width in world units at the point: 2 w / (size * P00),
    // where |row 0| of a view-projection is the projection's x scale P00.
    let w = (m * vec4f(position, 1.0)).w;
    let texel = 2.0 * w / (size * length(vec3f(m[0].x, m[1].x, m[2].x)));
    let tan_theta = min(sqrt(max(1.0 - n_dot_l * n_dot_l, 0.0)) / n_dot_l, SHADOW_MAX_SLOPE);
    let biased = position + normal * (SHADOW_NORMAL_OFFSET * texel)
        + to_light * ((SHADOW_CONSTANT_BIAS + SHADOW_SLOPE_BIAS * tan_theta) * texel);
    if faces == 6u {
        // The offset may cross into the neighbouring face; each face's
        // frustum is a few texels wider than 90 degrees for that.
        face = first_face + cube_face(biased - light_position);
        m = shadow_faces[face];
    }
    let clip = m * vec4f(biased, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    let uv = ndc.xy * vec2f(0.5, -0.5) + 0.5;
    if any(uv < vec2f(0.0)) || any(uv > vec2f(1.0)) || ndc.z < 0.0 || ndc.z > 1.0 {
        // Outside the face: beyond the spot's cone or the light's range,
        // where the light does not reach anyway.
        return 1.0;
    }
    // 3x3 taps one texel apart, each a bilinear 2x2 comparison.
    var lit = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let tap = uv + vec2f(f32(x), f32(y)) / size;
            lit += textureSampleCompareLevel(shadow_atlas, shadow_sampler, tap, face, ndc.z);
        }
    }
    return lit / 9.0;
}
