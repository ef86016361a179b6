// The scene bind group (group 0), bound by every pipeline. Mirrors
// `render::scene_gpu::bind_group_layout`.
#define_import_path shadespace::scene_bindings
#import shadespace::scene::{Vertex, Object, View}
#import shadespace::lighting::Light

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> objects: array<Object>;
@group(0) @binding(2) var<storage, read> vertices: array<Vertex>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> light_indices: array<u32>;
@group(0) @binding(5) var albedo: texture_2d_array<f32>;
// The material textures' sampler for samples with a footprint (implicit
// derivatives or `textureSampleGrad`): anisotropic under `--aniso`.
@group(0) @binding(6) var albedo_sampler: sampler;
// Mesh-local indices; add the object's base_vertex.
@group(0) @binding(7) var<storage, read> indices: array<u32>;
// Bindings 8-11 (the shadow maps) are declared in `shadows.wgsl`, which the
// lighting model imports.
// Linear maps, one per layer, sampled with `albedo_sampler`: tangent-space
// normal maps (`normal_map.wgsl`), metallic-roughness maps (blue, green) and
// occlusion maps (red); one layer when a material packs them into one image.
@group(0) @binding(12) var linear_maps: texture_2d_array<f32>;
// Bindings 13-17: material layers (`layers.wgsl`) and the environment
// (`environment.wgsl`).
// Trilinear and isotropic, whatever `--aniso`: for samples at an explicit
// level (`textureSampleLevel`: object space's texels, layer masks), which
// have no footprint to filter along (llvmpipe's compute shaders filter such
// samples anisotropically all the same when the sampler allows it).
@group(0) @binding(18) var texel_sampler: sampler;

// The three (global) vertex indices of an object's triangle.
fn triangle_vertices(o: Object, triangle: u32) -> vec3u {
    let i = o.first_index + 3u * triangle;
    return vec3u(indices[i], indices[i + 1u], indices[i + 2u]) + vec3u(o.base_vertex);
}

// Clip position of vertex `vi` of `object` (the depth and id passes share it,
// so that equal-depth tests see bit-identical positions).
fn object_clip_position(object: u32, vi: u32) -> vec4f {
    return view.view_proj * (objects[object].model * vec4f(vertices[vi].position, 1.0));
}
