// Clustered forward shading: every visible object drawn once after the depth
// pre-pass; each fragment finds its cluster (screen tile, depth slice) and
// loops over the global lights and the cluster's lights.
#import shadespace::raster_surface::{VertexOut, object_vertex, sample_albedo, sample_normal_map, sample_material,
    fragment_surface}
#import shadespace::scene_bindings::objects
#import shadespace::cluster_draws::scene_vertex
#import shadespace::light_grid::{cluster_of, light_surface_in_cell}
#import shadespace::alpha_mask::opacity
#ifdef ALPHA_MASK
#import shadespace::alpha_mask::masked_out
#endif

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> VertexOut {
    let d = scene_vertex(vertex_index, instance_index);
    let vi = d.vertex;
    let object = d.object;
    return object_vertex(object, vi, object);
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4f {
#ifdef ALPHA_MASK
    if masked_out(in.tag, in.uv) {
        discard;
    }
#endif
    let o = objects[in.tag];
    let s = fragment_surface(o, in, sample_albedo(o, in), sample_normal_map(o, in), sample_material(o, in));
    return vec4f(light_surface_in_cell(o, s, cluster_of(in.clip.xy, in.world)), 1.0);
}

// An alpha-blended object's fragment (`passes::blended`): its radiance from
// its cluster's lights times its opacity, and the opacity (premultiplied).
@fragment
fn fs_blend(in: VertexOut) -> @location(0) vec4f {
    let a = opacity(in.tag, in.uv);
    let o = objects[in.tag];
    let s = fragment_surface(o, in, sample_albedo(o, in), sample_normal_map(o, in), sample_material(o, in));
    return vec4f(a * light_surface_in_cell(o, s, cluster_of(in.clip.xy, in.world)), a);
}
