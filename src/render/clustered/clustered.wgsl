// Clustered forward shading: every visible object drawn once after the depth
// pre-pass; each fragment finds its cluster (screen tile, depth slice) and
// loops over the global lights and the cluster's lights. Its clip position is
// `object_clip_position`'s expression, so the depth pre-pass matches it.
#import shadespace::lighting::Surface
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::{view, objects, vertices, albedo, albedo_sampler}
#import shadespace::light_grid::{cluster_of, light_surface_in_cell}

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) uv0: vec2f,
    @location(3) @interpolate(flat) object: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) object: u32) -> VertexOut {
    let o = objects[object];
    let v = vertices[vi];
    let world = o.model * vec4f(v.position, 1.0);
    var out: VertexOut;
    out.clip = view.view_proj * world;
    out.world = world.xyz;
    out.normal = (o.normal_model * vec4f(v.normal, 0.0)).xyz;
    out.uv0 = vertex_uv0(v);
    out.object = object;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4f {
    let o = objects[in.object];
    var s: Surface;
    s.position = in.world;
    s.normal = normalize(in.normal);
    s.albedo = textureSample(albedo, albedo_sampler, in.uv0, o.albedo_layer).rgb * o.base_color.rgb;
    s.specular = o.specular;
    s.shininess = o.shininess;
    return vec4f(light_surface_in_cell(o, s, cluster_of(in.clip.xy, in.world)), 1.0);
}
