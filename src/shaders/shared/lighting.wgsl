// The lighting models of every pipeline (forward and object space), so that
// all of them compute the same image. Two models (`View.shading`, carried by
// each Surface):
//
// Phong (the studies'): diffuse max(N.L, 0), specular max(R.V, 0)^p.
// GGX metallic-roughness (glTF 2.0's BRDF): Cook-Torrance with the GGX
// distribution, height-correlated Smith visibility and Schlick Fresnel;
// diffuse Lambert on the non-metallic part.
// Both: ambient light and the environment map (LIGHT_ENVIRONMENT,
// `environment_reflectance`) scaled by the surface's occlusion; point/spot
// attenuation 1 / (1 + d^2) cut off at the light's radius,
// spot factor (cos(theta) - cos_outer) / (cos_inner - cos_outer) clamped,
// times the shadow factor of lights that cast shadows (`shadows.wgsl`).
// Light radiance is in units where a white Lambert surface facing the light
// reflects it unchanged (pi folded into the light), so the two models light a
// rough dielectric alike.
#define_import_path shadespace::lighting

#import shadespace::contract::{LIGHT_AMBIENT, LIGHT_DIRECTIONAL, LIGHT_ENVIRONMENT, LIGHT_SPOT, SHADING_PBR}
#import shadespace::shadows::shadow_factor
#import shadespace::environment::{env_brdf, env_diffuse, env_prefiltered}

// 64 bytes; mirrors `render::gpu_types::GpuLight`.
struct Light {
    position: vec3f,
    kind: u32,
    // Direction the light travels (directional, spot).
    direction: vec3f,
    radius: f32,
    // Colour times intensity.
    radiance: vec3f,
    cos_inner: f32,
    cos_outer: f32,
    // Its first shadow face, and how many it has (0: casts no shadow, 1:
    // spot, 6: cube, else the sun's cascades).
    shadow_face: u32,
    shadow_faces: u32,
    pad_c: u32,
}

// What the lighting model needs to know of a surface point.
struct Surface {
    position: vec3f,
    // Unit normal.
    normal: vec3f,
    albedo: vec3f,
    // Phong's specular strength and exponent.
    specular: f32,
    shininess: f32,
    // GGX's metallic and perceptual roughness.
    metallic: f32,
    roughness: f32,
    // SHADING_PHONG or SHADING_PBR.
    model: u32,
    // Emitted radiance, added once whatever the lights (`surface.wgsl`).
    emission: vec3f,
    // Ambient occlusion, 1 for none: scales ambient and environment light only.
    occlusion: f32,
    // Layered materials only (`shadespace::layers`; zero otherwise): UV0 and
    // the albedo mip there (`albedo_lod`'s, the view's texture_lod_bias
    // included; for texture masks), and the material's layers.
    uv: vec2f,
    uv_lod: f32,
    layer_first: u32,
    layer_count: u32,
}

// The Phong exponent equivalent to a GGX roughness (the Blinn-Phong mapping
// 2/alpha^2 - 2, halved for the reflection-vector form): the twin of
// `Material::shininess_from_roughness`.
fn shininess_from_roughness(roughness: f32) -> f32 {
    let alpha = max(roughness * roughness, 1e-3);
    return clamp((2.0 / (alpha * alpha) - 2.0) * 0.25, 1.0, 512.0);
}

const PI: f32 = 3.14159265;

// Dielectric reflectance at normal incidence (4 %), as glTF specifies.
const DIELECTRIC_F0: f32 = 0.04;

// Reflectance at normal incidence: 4 % for dielectrics, the albedo for metals.
fn specular_color(s: Surface) -> vec3f {
    return mix(vec3f(DIELECTRIC_F0), s.albedo, s.metallic);
}

// GGX reflectance for light arriving along `l` and leaving along `v`, times
// N.L, in the units above (the Lambert term is albedo x N.L, without 1/pi).
fn ggx(s: Surface, l: vec3f, v: vec3f, n_dot_l: f32) -> vec3f {
    let n = s.normal;
    let h = normalize(l + v);
    let n_dot_v = max(dot(n, v), 1e-4);
    let n_dot_h = max(dot(n, h), 0.0);
    let v_dot_h = max(dot(v, h), 0.0);
    // Perceptual roughness squared; floored so that highlights of point
    // lights stay finite.
    let a = max(s.roughness * s.roughness, 2e-3);
    let a2 = a * a;
    let d_denom = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * d_denom * d_denom);
    let vis_l = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    let vis_v = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    let vis = 0.5 / max(vis_l + vis_v, 1e-6);
    let f0 = specular_color(s);
    let f = f0 + (vec3f(1.0) - f0) * pow(1.0 - v_dot_h, 5.0);
    let diffuse = (vec3f(1.0) - f) * s.albedo * (1.0 - s.metallic);
    return (diffuse + PI * d * vis * f) * n_dot_l;
}

// What an ambient light of unit radiance reflects: the albedo (Phong), or
// the diffuse colour plus the reflectance at normal incidence (GGX: uniform
// light from every direction; no environment map, so no split-sum integral).
fn ambient_reflectance(s: Surface) -> vec3f {
    if s.model == SHADING_PBR {
        return s.albedo * (1.0 - s.metallic) + specular_color(s);
    }
    return s.albedo;
}

#ifdef ENVIRONMENT
// What the environment map (of unit scale) reflects towards `to_eye`:
// diffuse from the irradiance map, specular by the split sum (the prefiltered
// map at the reflection vector, times the BRDF's scale and bias of F0).
// Phong's specular (R.L)^p is, with pi folded into the light, the
// environment's mean over that lobe times 2 / (p + 1) (its integral over the
// sphere over pi), read at the GGX roughness whose lobe matches p (the
// inverse of `shininess_from_roughness`).
fn environment_reflectance(s: Surface, to_eye: vec3f) -> vec3f {
    let n = s.normal;
    let r = reflect(-to_eye, n);
    if s.model == SHADING_PBR {
        let n_dot_v = max(dot(n, to_eye), 1e-4);
        let specular = env_prefiltered(r, s.roughness) * env_brdf(specular_color(s), s.roughness, n_dot_v);
        return s.albedo * (1.0 - s.metallic) * env_diffuse(n) + specular;
    }
    let p = max(s.shininess, 1.0);
    let roughness = sqrt(sqrt(2.0 / (4.0 * p + 2.0)));
    return s.albedo * env_diffuse(n) + vec3f(s.specular * 2.0 / (p + 1.0)) * env_prefiltered(r, roughness);
}
#endif

// The cut-off at the radius is a linear fade over the last tenth of it, so a
// light's edge is not a visible ring (which bilinear filtering of object-space
// shades would blur differently from forward shading).
fn attenuation(d: f32, radius: f32) -> f32 {
    let fade = clamp((radius - d) / (0.1 * radius), 0.0, 1.0);
    return fade / (1.0 + d * d);
}

// Radiance reflected towards `to_eye` (unit vector from the point to the eye).
fn light_radiance(light: Light, s: Surface, to_eye: vec3f) -> vec3f {
    if light.kind == LIGHT_AMBIENT {
        return light.radiance * ambient_reflectance(s) * s.occlusion;
    }
#ifdef ENVIRONMENT
    if light.kind == LIGHT_ENVIRONMENT {
        return light.radiance * environment_reflectance(s, to_eye) * s.occlusion;
    }
#endif
    var to_light: vec3f;
    var falloff = 1.0;
    if light.kind == LIGHT_DIRECTIONAL {
        to_light = -light.direction;
    } else {
        let d = light.position - s.position;
        let dist = length(d);
        if dist >= light.radius {
            return vec3f(0.0);
        }
        to_light = d / max(dist, 1e-6);
        falloff = attenuation(dist, light.radius);
        if light.kind == LIGHT_SPOT {
            let cos_theta = dot(-to_light, light.direction);
            falloff *= clamp((cos_theta - light.cos_outer) / max(light.cos_inner - light.cos_outer, 1e-4), 0.0, 1.0);
        }
    }
    let n_dot_l = dot(s.normal, to_light);
    if n_dot_l <= 0.0 || falloff <= 0.0 {
        return vec3f(0.0);
    }
    if light.shadow_faces != 0u {
        falloff *= shadow_factor(light.kind, light.shadow_face, light.shadow_faces, light.position, s.position, s.normal, to_light, n_dot_l);
    }
    if s.model == SHADING_PBR {
        return light.radiance * falloff * ggx(s, to_light, to_eye, n_dot_l);
    }
    let r = reflect(-to_light, s.normal);
    let spec = s.specular * pow(max(dot(r, to_eye), 0.0), s.shininess);
    return light.radiance * falloff * (s.albedo * n_dot_l + vec3f(spec));
}
