// Shade gathering, in compute over the visibility buffer: each pixel selects
// the same mip level as tile marking did and filters the object's shades
// bilinearly (by hand, with taps clamped inside the level's square, so no tap
// reads a neighbour in the atlas). Objects outside the atlas (forward-only)
// are shaded here per pixel, with the world grid's lights. Debug views replace
// the shade.
#import shadespace::contract::{VIEW_CHART_UV, VIEW_MIP_LEVEL, VIEW_TILE_MASK, VIEW_CACHE_AGE}
#import shadespace::scene_bindings::objects
#import shadespace::pixel_surface::{sample_pixel, pixel_surface}
#import shadespace::light_grid::{world_cell_of, light_surface_in_cell}
#import shadespace::objectspace::{params, atlas_entries, tile_shaded, visibility, chart_footprint, select_level,
    bilinear, level_origin, AtlasLevel}

@group(2) @binding(0) var atlas: texture_2d_array<f32>;
@group(2) @binding(1) var hdr: texture_storage_2d<rgba16float, write>;

// Debug colours go through the tone mapper: pre-invert Reinhard so that they
// come out as written.
fn display(c: vec3f) -> vec4f {
    let d = clamp(c, vec3f(0.0), vec3f(0.99));
    return vec4f(d / (1.0 - d), 1.0);
}

fn level_color(level: u32) -> vec3f {
    let palette = array<vec3f, 8>(
        vec3f(0.9, 0.1, 0.1), vec3f(0.9, 0.6, 0.1), vec3f(0.8, 0.9, 0.1), vec3f(0.2, 0.9, 0.2),
        vec3f(0.1, 0.8, 0.9), vec3f(0.2, 0.3, 0.9), vec3f(0.7, 0.2, 0.9), vec3f(0.9, 0.9, 0.9));
    return palette[min(level, 7u)];
}

fn fetch(l: AtlasLevel, texel: vec2i) -> vec3f {
    return textureLoad(atlas, level_origin(l) + vec2u(texel), l.page, 0).rgb;
}

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(visibility);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let ids = textureLoad(visibility, id.xy, 0).xy;
    if ids.x == 0u {
        textureStore(hdr, id.xy, vec4f(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let p = sample_pixel(id.xy, ids);
    let e = atlas_entries[p.object];
    if e.size == 0u {
        let o = objects[p.object];
        let s = pixel_surface(p);
        textureStore(hdr, id.xy, vec4f(light_surface_in_cell(o, s, world_cell_of(s.position)), 1.0));
        return;
    }
    let f = chart_footprint(p);
    let level_index = select_level(e, p, f);
    let l = e.levels[level_index];
    let b = bilinear(l, f.uv);
    var out: vec4f;
    switch params.view_mode {
        case VIEW_CHART_UV: {
            out = display(vec3f(fract(f.uv), 0.0));
        }
        case VIEW_MIP_LEVEL: {
            out = display(level_color(level_index));
        }
        case VIEW_TILE_MASK, VIEW_CACHE_AGE: {
            let tiles_per_row = l.size / params.tile_size;
            let t = vec2u(b.texel) / params.tile_size;
            let tile = l.tile_base + t.y * tiles_per_row + t.x;
            let age = params.stamp - tile_shaded[tile];
            if params.view_mode == VIEW_TILE_MASK {
                // Red: shaded this frame; green: reused. Darker checker per tile.
                let checker = f32((t.x + t.y) & 1u) * 0.25;
                out = display(select(vec3f(0.1, 0.8, 0.2), vec3f(0.9, 0.15, 0.1), age == 0u) * (1.0 - checker));
            } else {
                out = display(vec3f(f32(age) / f32(max(params.reuse, 1u))));
            }
        }
        default: {
            let c00 = fetch(l, b.texel);
            let c10 = fetch(l, vec2i(b.texel_hi.x, b.texel.y));
            let c01 = fetch(l, vec2i(b.texel.x, b.texel_hi.y));
            let c11 = fetch(l, b.texel_hi);
            let top = mix(c00, c10, b.weight.x);
            let bottom = mix(c01, c11, b.weight.x);
            out = vec4f(mix(top, bottom, b.weight.y), 1.0);
        }
    }
    textureStore(hdr, id.xy, out);
}
