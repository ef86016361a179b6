// Alpha masking (glTF `MASK`) in the raster passes over the scene bind group,
// and the opacity of alpha-blended surfaces (glTF `BLEND`).
// Only their ALPHA_MASK variants call it, and only for the masked objects
// (`passes::ScenePipeline`): a fragment shader that may discard costs opaque
// objects their early depth test.
#define_import_path shadespace::alpha_mask
#import shadespace::scene::alpha_cut
#import shadespace::scene_bindings::{view, objects, albedo, albedo_sampler}

// Whether the fragment of `object` at `uv0` is cut away (implicit
// derivatives, biased by the view's texture_lod_bias as every material
// sample is: call it in uniform control flow).
fn masked_out(object: u32, uv0: vec2f) -> bool {
    let o = objects[object];
    return alpha_cut(o, textureSampleBias(albedo, albedo_sampler, uv0, o.albedo_layer, view.texture_lod_bias).a);
}

// The opacity of `object` at `uv0` (base colour factor alpha times texture
// alpha, as `scene::Material::opacity`), for alpha-blended objects
// (implicit derivatives: call it in uniform control flow).
fn opacity(object: u32, uv0: vec2f) -> f32 {
    let o = objects[object];
    return clamp(o.base_color.a * textureSampleBias(albedo, albedo_sampler, uv0, o.albedo_layer, view.texture_lod_bias).a, 0.0, 1.0);
}
