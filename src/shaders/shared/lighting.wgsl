// The lighting model of every pipeline (forward and object space), so that
// all of them compute the same image.
//
// Phong: diffuse max(N.L, 0), specular max(R.V, 0)^p, point/spot attenuation
// 1 / (1 + d^2) cut off at the light's radius, spot factor
// (cos(theta) - cos_outer) / (cos_inner - cos_outer) clamped, times albedo,
// times the shadow factor of lights that cast shadows (`shadows.wgsl`).
#define_import_path shadespace::lighting

#import shadespace::contract::{LIGHT_AMBIENT, LIGHT_DIRECTIONAL, LIGHT_SPOT}
#import shadespace::shadows::shadow_factor

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
    specular: f32,
    shininess: f32,
}

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
        return light.radiance * s.albedo;
    }
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
    let r = reflect(-to_light, s.normal);
    let spec = s.specular * pow(max(dot(r, to_eye), 0.0), s.shininess);
    return light.radiance * falloff * (s.albedo * n_dot_l + vec3f(spec));
}
