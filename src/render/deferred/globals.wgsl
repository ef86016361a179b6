// The full-screen pass of deferred shading, in compute: every pixel gets its
// emission and the ambient and directional lights (background: black). It
// writes every pixel, so it is also the clear that the additive light-volume
// passes after it build on.
#import shadespace::scene_bindings::view
#import shadespace::surface::emission_and_globals
#import shadespace::gbuffer::{gbuffer_depth_at, gbuffer_texel}

@group(2) @binding(0) var hdr: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn lights_globals(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= vec2u(view.viewport.xy)) {
        return;
    }
    let depth = gbuffer_depth_at(id.xy);
    var color = vec3f(0.0);
    if depth > 0.0 {
        let t = gbuffer_texel(id.xy, depth);
        color = emission_and_globals(t.surface, t.to_eye);
    }
    textureStore(hdr, id.xy, vec4f(color, 1.0));
}
