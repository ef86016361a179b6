// Tangent-space normal maps (MikkTSpace convention, as glTF and the bakers
// that follow it use): the map's texel is a unit vector in the frame of the
// interpolated tangent, bitangent and normal. The tangent is not
// re-orthogonalised per pixel and the bitangent is not normalised: that is
// what MikkTSpace's bakers assume, so the map reproduces the baked surface.
#define_import_path shadespace::normal_map
#import shadespace::contract::NO_TEXTURE

// The normal at a point whose interpolated (world) normal is `n` and tangent
// `t` (xyz, bitangent sign in w), given the map's texel `texel` (RGB in 0..1)
// of layer `layer` (NO_TEXTURE: no map, `n` normalised).
fn mapped_normal(n: vec3f, t: vec4f, texel: vec3f, layer: u32) -> vec3f {
    let unit_n = normalize(n);
    if layer == NO_TEXTURE || dot(t.xyz, t.xyz) < 1e-12 {
        return unit_n;
    }
    let m = texel * 2.0 - 1.0;
    let b = t.w * cross(n, t.xyz);
    let mapped = m.x * t.xyz + m.y * b + m.z * n;
    if dot(mapped, mapped) < 1e-12 {
        return unit_n;
    }
    return normalize(mapped);
}

// The layer to sample for `layer` (any valid one when there is no map: the
// sample is taken in uniform control flow and then ignored).
fn sample_layer(layer: u32) -> u32 {
    return select(layer, 0u, layer == NO_TEXTURE);
}
