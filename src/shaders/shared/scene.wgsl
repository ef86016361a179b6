// Scene data shared by every pipeline: vertices, objects and the view. Mirrors
// `render::gpu_types` (compared member by member by `shaders::layout`).
#define_import_path shadespace::scene

// 64 bytes. Vertices are pulled from a storage buffer by index, so raster and
// compute passes read the same data.
struct Vertex {
    position: vec3f,
    uv0_x: f32,
    normal: vec3f,
    uv0_y: f32,
    // MikkTSpace tangent (xyz) and bitangent sign (w), for normal maps.
    tangent: vec4f,
    // The object's unique chart (object-space shading).
    chart_uv: vec2f,
    pad_a: f32,
    pad_b: f32,
}

struct Object {
    model: mat4x4f,
    // Inverse transpose of `model` (upper 3x3 used).
    normal_model: mat4x4f,
    base_color: vec4f,
    emissive: vec3f,
    albedo_layer: u32,
    light_offset: u32,
    light_count: u32,
    first_index: u32,
    base_vertex: u32,
    // Phong's specular strength and exponent; GGX's metallic and roughness.
    specular: f32,
    shininess: f32,
    metallic: f32,
    roughness: f32,
    // Layers of the material's textures, or NO_TEXTURE: the normal map, the
    // metallic-roughness and the occlusion map in the linear array
    // (`linear_maps`), the emissive texture in the colour array (`albedo`).
    normal_layer: u32,
    emissive_layer: u32,
    metal_rough_layer: u32,
    occlusion_layer: u32,
    // Occlusion is 1 + occlusion_strength * (red - 1), on ambient light only.
    occlusion_strength: f32,
    // Fragments whose alpha (base colour factor times texture) is below this
    // are cut away (alpha masking, `alpha_mask.wgsl`); 0 for opaque objects.
    alpha_cutoff: f32,
    // The material's layers: `material_layers[layer_first..][..layer_count]`
    // (`shadespace::layers`); 0 layers for a plain material.
    layer_first: u32,
    layer_count: u32,
    // 1 where the material is single-sided: its back faces are culled.
    cull_back: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

struct View {
    view_proj: mat4x4f,
    camera_position: vec4f,
    // width, height, 1/width, 1/height
    viewport: vec4f,
    // Lights in the light buffer; the first `global_light_count` are ambient
    // or directional (they reach everywhere, so light grids list only the
    // others).
    light_count: u32,
    global_light_count: u32,
    // SHADING_PHONG or SHADING_PBR.
    shading: u32,
    // Added to the mip level of every material texture sample taken from a
    // footprint (hardware or computed derivatives); 0 by default. The
    // supersampled reference sets -log2(N) so each of its N x N samples per
    // pixel filters the footprint it would have in a frame N times larger.
    texture_lod_bias: f32,
}

// Whether the surface of `o` is cut away where its base colour texel's alpha
// is `texel_alpha` (never for opaque objects, whose cutoff is 0).
fn alpha_cut(o: Object, texel_alpha: f32) -> bool {
    return alpha_cut_by(o.base_color.a, o.alpha_cutoff, texel_alpha);
}

// `alpha_cut` from an object's base colour alpha and cutoff.
fn alpha_cut_by(base_alpha: f32, cutoff: f32, texel_alpha: f32) -> bool {
    return base_alpha * texel_alpha < cutoff;
}

fn vertex_uv0(v: Vertex) -> vec2f {
    return vec2f(v.uv0_x, v.uv0_y);
}
