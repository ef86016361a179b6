// Shade gathering, in compute over the visibility buffer: each pixel selects
// the same mip level as tile marking did and filters the object's shades
// bilinearly (by hand, with taps clamped inside the level's square, so no tap
// reads a neighbour in the atlas, and only taps in the pixel's chart island). Objects outside the atlas (forward-only)
// are shaded here per pixel, with the world grid's lights. Debug views replace
// the shade.
#import shadespace::contract::{VIEW_CHART_UV, VIEW_MIP_LEVEL, VIEW_TILE_MASK, VIEW_CACHE_AGE}
#import shadespace::scene_bindings::objects
#import shadespace::pixel_surface::{sample_pixel, pixel_surface}
#import shadespace::light_grid::{world_cell_of, light_surface_in_cell}
#import shadespace::objectspace::{params, atlas_entries, tile_shaded, visibility, chart_footprint, select_level,
    bilinear, level_origin, AtlasLevel, triangle_map, triangle_charts}

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

// Chart island of triangle `triangle` of `object`.
fn island(object: u32, triangle: u32) -> u32 {
    return triangle_charts[objects[object].first_index / 3u + triangle];
}

// 1 when texel `texel` of level `l` belongs to chart island `own` of
// `object` (its triangle map names a triangle of that island), else 0.
fn in_island(object: u32, own: u32, l: AtlasLevel, texel: vec2i) -> f32 {
    let id = textureLoad(triangle_map, level_origin(l) + vec2u(texel), l.page, 0).x;
    return select(0.0, 1.0, id != 0u && island(object, id - 1u) == own);
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
            // Bilinear over the taps in the pixel's own chart island: a tap
            // on a neighbouring chart's texel (closer than a texel at coarse
            // levels) would bleed its colour across the border. With no tap
            // in the island (a sliver thinner than the level's texels), all
            // four are kept.
            let t10 = vec2i(b.texel_hi.x, b.texel.y);
            let t01 = vec2i(b.texel.x, b.texel_hi.y);
            let own = island(p.object, ids.y);
            var w = vec4f(
                (1.0 - b.weight.x) * (1.0 - b.weight.y),
                b.weight.x * (1.0 - b.weight.y),
                (1.0 - b.weight.x) * b.weight.y,
                b.weight.x * b.weight.y,
            );
            let keep = vec4f(
                in_island(p.object, own, l, b.texel),
                in_island(p.object, own, l, t10),
                in_island(p.object, own, l, t01),
                in_island(p.object, own, l, b.texel_hi),
            );
            let kept = dot(w, keep);
            if kept > 0.0 {
                w = w * keep / kept;
            }
            let c = fetch(l, b.texel) * w.x + fetch(l, t10) * w.y + fetch(l, t01) * w.z + fetch(l, b.texel_hi) * w.w;
            out = vec4f(c, 1.0);
        }
    }
    textureStore(hdr, id.xy, out);
}
