// Shadow-map faces: the depth of the casters seen from a light, into one layer
// of the shadow atlas (reversed Z, like the camera's depth). Depth only; the
// ALPHA_MASK variant, for alpha-masked casters, has a fragment stage that cuts
// them. Not the scene bind group: that one samples the atlas, which this pass
// renders into. The CLUSTER_DRAW variant draws the clusters the shadow
// maps' culling kept (`shadows::cull`): indexed draws of the cluster-ordered
// index buffer, each draw's first instance its run's entry of the list.
#import shadespace::scene::{Vertex, Object}

@group(0) @binding(0) var<storage, read> objects: array<Object>;
@group(0) @binding(1) var<storage, read> vertices: array<Vertex>;
// The face's view-projection (bound at a dynamic offset per face).
@group(0) @binding(2) var<uniform> face_view_proj: mat4x4f;

#ifdef CLUSTER_DRAW
// `cull.wgsl`'s ranges, (caster, ..., face), and its list of (range, cluster).
@group(1) @binding(0) var<storage, read> ranges: array<vec4u>;
@group(1) @binding(1) var<storage, read> cluster_lists: array<vec2u>;

// The object an instance draws: the caster of its run's list entry.
fn caster(instance: u32) -> u32 {
    return ranges[cluster_lists[instance].x].x;
}
#else
// The object an instance draws: plain draws give it as the instance.
fn caster(instance: u32) -> u32 {
    return instance;
}
#endif

#ifdef ALPHA_MASK
#import shadespace::scene::{alpha_cut, vertex_uv0}

// The scene's colour textures and sampler (its bindings 5 and 6).
@group(0) @binding(3) var albedo: texture_2d_array<f32>;
@group(0) @binding(4) var albedo_sampler: sampler;

struct VertexOut {
    @builtin(position) clip: vec4f,
    @location(0) uv0: vec2f,
    @location(1) @interpolate(flat) object: u32,
}

@vertex
fn vs_shadow(@builtin(vertex_index) vi: u32, @builtin(instance_index) instance: u32) -> VertexOut {
    let object = caster(instance);
    let clip = face_view_proj * (objects[object].model * vec4f(vertices[vi].position, 1.0));
    return VertexOut(clip, vertex_uv0(vertices[vi]), object);
}

@fragment
fn fs_alpha_mask(in: VertexOut) {
    let o = objects[in.object];
    if alpha_cut(o, textureSample(albedo, albedo_sampler, in.uv0, o.albedo_layer).a) {
        discard;
    }
}
#else
@vertex
fn vs_shadow(@builtin(vertex_index) vi: u32, @builtin(instance_index) instance: u32) -> @builtin(position) vec4f {
    let object = caster(instance);
    return face_view_proj * (objects[object].model * vec4f(vertices[vi].position, 1.0));
}
#endif
