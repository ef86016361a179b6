// The prefiltered environment map (`--env`), read by lights of kind
// LIGHT_ENVIRONMENT (`lighting.wgsl`). Built once at load by
// `render/passes/environment/` (docs/environment.md): a cube map whose mip
// k holds the radiance prefiltered with the GGX lobe of roughness
// k / (levels - 1) (split-sum, Karis 2013), and a small cube map of
// irradiance / pi (what a white Lambert surface facing it reflects), and
// the split sum's BRDF lookup table. Bindings 14-17 of the scene group
// (`render::scene_gpu`); a scene without an environment binds black 1x1 maps.
#define_import_path shadespace::environment

@group(0) @binding(14) var env_specular: texture_cube<f32>;
@group(0) @binding(15) var env_irradiance: texture_cube<f32>;
@group(0) @binding(16) var env_sampler: sampler;
@group(0) @binding(17) var env_brdf_lut: texture_2d<f32>;

// Radiance around `dir` prefiltered at perceptual `roughness`, between the
// map's levels. Level selection by explicit lod: no derivatives, so it runs in
// compute and in non-uniform control flow.
fn env_prefiltered(dir: vec3f, roughness: f32) -> vec3f {
    let top = f32(textureNumLevels(env_specular) - 1u);
    return textureSampleLevel(env_specular, env_sampler, dir, clamp(roughness, 0.0, 1.0) * top).rgb;
}

// Irradiance / pi arriving at a surface whose normal is `n`.
fn env_diffuse(n: vec3f) -> vec3f {
    return textureSampleLevel(env_irradiance, env_sampler, n, 0.0).rgb;
}

// The split sum's second factor: F0 times the scale plus the bias that the
// lookup table holds at (N.V, roughness) (GGX with this model's visibility
// and Fresnel, integrated at load: `brdf_lut` in `prefilter.wgsl`).
fn env_brdf(f0: vec3f, roughness: f32, n_dot_v: f32) -> vec3f {
    let ab = textureSampleLevel(env_brdf_lut, env_sampler, vec2f(n_dot_v, roughness), 0.0).rg;
    return f0 * ab.x + ab.y;
}
