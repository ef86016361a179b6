// Light volumes of deferred shading: one instance of a low-poly sphere per
// point light and of a cone per spot light (instance i of a draw is entry i
// of its list from `classify.wgsl`). Each fragment lights the G-buffer
// surface behind it with its one light, blended additively into the HDR
// target. Seen from outside, only front faces are drawn, depth-tested
// against the scene (volumes behind walls cost nothing); seen from inside,
// back faces, untested. The lighting model's own range cut-off decides which
// covered pixels are lit, so the meshes only need to enclose the light.
// Under MSAA the G-buffer's depth is multisampled and the volumes are drawn
// into the resolved HDR target without a depth attachment: the fragment
// tests each sample's depth itself and adds the mean of its samples' light
// (per pixel where the samples see one surface, else per sample).
#import shadespace::contract::{VOLUME_POINT_OUTSIDE, VOLUME_POINT_INSIDE, VOLUME_SPOT_OUTSIDE, VOLUME_SPOT_INSIDE}
#import shadespace::layers::layered_radiance
#import shadespace::scene_bindings::{view, lights}
#import shadespace::gbuffer::{gbuffer_depth_at, gbuffer_texel}
#ifdef MSAA
#import shadespace::gbuffer::{gbuffer_pixel, gbuffer_samples, gbuffer_depth_sample, gbuffer_sample_texel, gbuffer_texel_at, world_position}
#endif
#import shadespace::deferred::{VolumeParams, cone_tan}

@group(2) @binding(0) var<uniform> params: VolumeParams;
// The sphere's and the cone's vertices (xyz; w unused).
@group(2) @binding(1) var<storage, read> mesh: array<vec4f>;
@group(2) @binding(2) var<storage, read> lists: array<u32>;

struct VolumeOut {
    @builtin(position) clip: vec4f,
    @location(0) @interpolate(flat) light: u32,
}

fn listed(list: u32, instance: u32) -> u32 {
    return lists[list * params.capacity + instance];
}

fn project(world: vec3f, light: u32, inside: bool) -> VolumeOut {
    var out: VolumeOut;
    out.clip = view.view_proj * vec4f(world, 1.0);
    // From inside, back faces beyond the far plane would be clipped away with
    // the pixels they cover; keep them on it instead (their depth is not
    // tested). Clip z < 0 happens only beyond the far plane (reversed Z).
    if inside && out.clip.w > 0.0 {
        out.clip.z = max(out.clip.z, 0.0);
    }
    out.light = light;
    return out;
}

// The unit-radius sphere mesh scaled to the light's range.
fn point_volume(vi: u32, light: u32, inside: bool) -> VolumeOut {
    let l = lights[light];
    return project(l.position + mesh[vi].xyz * l.radius, light, inside);
}

// The unit cone mesh (apex at the origin, axis +z, base at z = 1 around the
// unit circle) turned along the light, as long as its range and as wide as
// its outer cone there: it encloses the cone cut at the range.
fn spot_volume(vi: u32, light: u32, inside: bool) -> VolumeOut {
    let l = lights[light];
    let d = l.direction;
    // A right-handed basis (u, w, d), so the mesh keeps its winding.
    let u = normalize(cross(d, select(vec3f(1.0, 0.0, 0.0), vec3f(0.0, 1.0, 0.0), abs(d.x) > 0.9)));
    let w = cross(d, u);
    let m = mesh[vi].xyz;
    let t = cone_tan(l);
    return project(l.position + l.radius * (t * (m.x * u + m.y * w) + m.z * d), light, inside);
}

@vertex
fn vs_point_outside(@builtin(vertex_index) vi: u32, @builtin(instance_index) i: u32) -> VolumeOut {
    return point_volume(vi, listed(VOLUME_POINT_OUTSIDE, i), false);
}

@vertex
fn vs_point_inside(@builtin(vertex_index) vi: u32, @builtin(instance_index) i: u32) -> VolumeOut {
    return point_volume(vi, listed(VOLUME_POINT_INSIDE, i), true);
}

@vertex
fn vs_spot_outside(@builtin(vertex_index) vi: u32, @builtin(instance_index) i: u32) -> VolumeOut {
    return spot_volume(vi, listed(VOLUME_SPOT_OUTSIDE, i), false);
}

@vertex
fn vs_spot_inside(@builtin(vertex_index) vi: u32, @builtin(instance_index) i: u32) -> VolumeOut {
    return spot_volume(vi, listed(VOLUME_SPOT_INSIDE, i), true);
}

#ifdef MSAA
// The light on the samples of `pixel` whose surface is not in front of
// device depth `front` (the volume's face from outside; beyond every depth
// from inside), averaged over all samples.
fn light_samples(pixel: vec2u, light: u32, front: f32) -> vec3f {
    let p = gbuffer_pixel(pixel);
    if !p.lit {
        return vec3f(0.0);
    }
    if !p.edge {
        if front < p.depth_mean {
            return vec3f(0.0);
        }
        let t = gbuffer_texel_at(pixel, 0u, world_position(pixel, p.depth_mean));
        return layered_radiance(lights[light], t.surface, t.to_eye);
    }
    let n = gbuffer_samples();
    var sum = vec3f(0.0);
    for (var s = 0u; s < n; s++) {
        let d = gbuffer_depth_sample(pixel, s);
        if d > 0.0 && front >= d {
            let t = gbuffer_sample_texel(pixel, s, d);
            sum += layered_radiance(lights[light], t.surface, t.to_eye);
        }
    }
    return sum / f32(n);
}

// From outside: the samples behind the volume's front face (reversed Z: a
// depth at most the face's), as the depth test `GreaterEqual` passes them.
@fragment
fn fs_light(in: VolumeOut) -> @location(0) vec4f {
    return vec4f(light_samples(vec2u(in.clip.xy), in.light, in.clip.z), 0.0);
}

// From inside: every sample (the back faces are not tested).
@fragment
fn fs_light_inside(in: VolumeOut) -> @location(0) vec4f {
    return vec4f(light_samples(vec2u(in.clip.xy), in.light, 2.0), 0.0);
}
#else
@fragment
fn fs_light(in: VolumeOut) -> @location(0) vec4f {
    let pixel = vec2u(in.clip.xy);
    let depth = gbuffer_depth_at(pixel);
    if depth <= 0.0 {
        return vec4f(0.0);
    }
    let t = gbuffer_texel(pixel, depth);
    return vec4f(layered_radiance(lights[in.light], t.surface, t.to_eye), 0.0);
}
#endif
