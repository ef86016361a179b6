// Single-pass forward shading: every object drawn once, its fragments loop
// over the lights that CPU culling found for the object.
#import shadespace::raster_surface::{VertexOut, object_vertex, sample_albedo, sample_normal_map, sample_material,
    fragment_surface}
#import shadespace::scene_bindings::objects
#import shadespace::cluster_draws::scene_vertex
#import shadespace::surface::light_surface
#import shadespace::alpha_mask::opacity
#ifdef ALPHA_MASK
#import shadespace::alpha_mask::masked_out
#endif

// The index buffer holds mesh-local indices; `vertex_index` includes the
// draw's base vertex. `instance_index` is the object (`scene_vertex`: or
// the cluster drawn, with culling).
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
    return vec4f(light_surface(o, s), 1.0);
}

// An alpha-blended object's fragment (`passes::blended`): its radiance times
// its opacity, and the opacity (premultiplied alpha).
@fragment
fn fs_blend(in: VertexOut) -> @location(0) vec4f {
    let a = opacity(in.tag, in.uv);
    let o = objects[in.tag];
    let s = fragment_surface(o, in, sample_albedo(o, in), sample_normal_map(o, in), sample_material(o, in));
    return vec4f(a * light_surface(o, s), a);
}
