// The environment as the background (`render::passes::background`): a
// full-screen triangle at the far plane whose fragments return the
// environment's radiance seen through the pixel (the prefiltered map's
// level 0, the unfiltered source) times the frame's environment lights,
// added into the HDR target where no opaque surface covers the pixel, in
// linear HDR before exposure and tone mapping. Which pixels are uncovered:
// - by default the pipeline's depth test (`Equal` to the cleared far plane,
//   per sample under MSAA), so the fragment runs only there;
// - COVERAGE_SAMPLES: the multisampled depth read here, for a one-sample
//   target resolved from it, the radiance scaled by the share of uncovered
//   samples (whose resolved colour was black);
// - COVERAGE_IDS: the visibility buffer's ids (0: background), where the
//   compute rasterizer left the depth target unwritten; under MSAA a layer
//   per sample, the radiance scaled by the share of uncovered samples.
#import shadespace::scene_bindings::view
#import shadespace::environment::{env_specular, env_sampler}

// Mirrors `render::passes::background::GpuBackground`.
struct Background {
    // Inverse of the view-projection with the camera at the origin: (NDC x,
    // y, 1, 1) -> direction from the eye through that point (homogeneous).
    direction_from_ndc: mat4x4f,
    // Sum of the frame's environment lights' colour times intensity.
    radiance: vec3f,
    pad: u32,
}

@group(1) @binding(0) var<uniform> background: Background;
#ifdef COVERAGE_SAMPLES
@group(1) @binding(1) var depth: texture_depth_multisampled_2d;
#endif
#ifdef COVERAGE_IDS
#ifdef MSAA
@group(1) @binding(1) var ids: texture_2d_array<u32>;
#else
@group(1) @binding(1) var ids: texture_2d<u32>;
#endif
#endif

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {
    let corner = vec2f(f32((i << 1u) & 2u), f32(i & 2u));
    // Depth 0: the far plane, what the depth target is cleared to (reversed Z).
    return vec4f(corner * 2.0 - 1.0, 0.0, 1.0);
}

// The environment's radiance towards the point `xy` (pixels from the top-left
// corner) of the image.
fn sky(xy: vec2f) -> vec3f {
    let uv = xy * view.viewport.zw;
    let d = background.direction_from_ndc * vec4f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 1.0, 1.0);
    return textureSampleLevel(env_specular, env_sampler, d.xyz / d.w, 0.0).rgb * background.radiance;
}

@fragment
fn fs_background(@builtin(position) p: vec4f) -> @location(0) vec4f {
    var share = 1.0;
#ifdef COVERAGE_SAMPLES
    let pixel = vec2u(p.xy);
    let samples = textureNumSamples(depth);
    var uncovered = 0u;
    for (var s = 0u; s < samples; s++) {
        if textureLoad(depth, pixel, s) == 0.0 {
            uncovered += 1u;
        }
    }
    if uncovered == 0u {
        discard;
    }
    share = f32(uncovered) / f32(samples);
#endif
#ifdef COVERAGE_IDS
#ifdef MSAA
    let samples = textureNumLayers(ids);
    var uncovered = 0u;
    for (var s = 0u; s < samples; s++) {
        if textureLoad(ids, vec2u(p.xy), s, 0).x == 0u {
            uncovered += 1u;
        }
    }
    if uncovered == 0u {
        discard;
    }
    share = f32(uncovered) / f32(samples);
#else
    if textureLoad(ids, vec2u(p.xy), 0).x != 0u {
        discard;
    }
#endif
#endif
    return vec4f(sky(p.xy) * share, 0.0);
}
