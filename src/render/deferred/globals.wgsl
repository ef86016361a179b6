// The full-screen pass of deferred shading, in compute: every pixel gets its
// emission and the ambient and directional lights (background: black). It
// writes every pixel, so it is also the clear that the additive light-volume
// passes after it build on. Under MSAA a pixel whose samples see one surface
// is shaded once at its centre, the others per sample, and the mean written.
#import shadespace::scene_bindings::view
#import shadespace::surface::emission_and_globals
#import shadespace::gbuffer::{gbuffer_depth_at, gbuffer_texel}
#ifdef MSAA
#import shadespace::gbuffer::{GbufferTexel, gbuffer_pixel, gbuffer_samples, gbuffer_depth_sample, gbuffer_sample_texel, gbuffer_texel_at, world_position}

// Emission and the ambient and directional lights (every layer's, with
// layers) of one surface of the G-buffer.
fn globals(t: GbufferTexel) -> vec3f {
    return emission_and_globals(t.surface, t.to_eye);
}
#endif

@group(2) @binding(0) var hdr: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn lights_globals(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= vec2u(view.viewport.xy)) {
        return;
    }
    var color = vec3f(0.0);
#ifdef MSAA
    let p = gbuffer_pixel(id.xy);
    if p.lit && !p.edge {
        color = globals(gbuffer_texel_at(id.xy, 0u, world_position(id.xy, p.depth_mean)));
    } else if p.lit {
        let n = gbuffer_samples();
        for (var s = 0u; s < n; s++) {
            let d = gbuffer_depth_sample(id.xy, s);
            if d > 0.0 {
                color += globals(gbuffer_sample_texel(id.xy, s, d));
            }
        }
        color /= f32(n);
    }
#else
    let depth = gbuffer_depth_at(id.xy);
    if depth > 0.0 {
        let t = gbuffer_texel(id.xy, depth);
        color = emission_and_globals(t.surface, t.to_eye);
    }
#endif
    textureStore(hdr, id.xy, vec4f(color, 1.0));
}
