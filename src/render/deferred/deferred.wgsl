// What the light-volume passes of deferred shading share (`classify.wgsl`
// sorts the lights into volume lists, `volumes.wgsl` draws them). Mirrors
// `render::deferred::volumes`.
#define_import_path shadespace::deferred
#import shadespace::contract::LIGHT_SPOT
#import shadespace::lighting::Light

// Mirrors `render::deferred::volumes::GpuVolumeParams`.
struct VolumeParams {
    // The view frustum's planes (world space, unit normals, inside >= 0).
    frustum: array<vec4f, 6>,
    // Distance from the eye to the near plane's corners: a volume that
    // stays this far from the eye cannot be cut by the near plane.
    near_reach: f32,
    // Places per list: list k is lists[k * capacity ..].
    capacity: u32,
    // Spot lights with a larger `cos_outer` are drawn as cones, others
    // (wide ones) as spheres.
    cone_min_cos: f32,
    // Farthest vertex of the sphere mesh from its centre (its faces are at
    // least 1 away).
    sphere_reach: f32,
    // Circumradius of the cone mesh's base polygon (it circumscribes the
    // unit circle).
    cone_ring: f32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

// Whether the light is drawn as a cone (else as a sphere).
fn drawn_as_cone(p: VolumeParams, l: Light) -> bool {
    return l.kind == LIGHT_SPOT && l.cos_outer > p.cone_min_cos;
}

// tan of a spot light's outer half-angle (cos_outer > 0).
fn cone_tan(l: Light) -> f32 {
    return sqrt(max(1.0 - l.cos_outer * l.cos_outer, 0.0)) / l.cos_outer;
}

// Farthest point of the light's volume mesh from the light.
fn volume_reach(p: VolumeParams, l: Light) -> f32 {
    if drawn_as_cone(p, l) {
        let t = cone_tan(l) * p.cone_ring;
        return l.radius * sqrt(1.0 + t * t);
    }
    return l.radius * p.sphere_reach;
}
