// Shade gathering, in compute over the visibility buffer: each pixel selects
// the same mip levels as tile marking did (one, or two blended) and filters
// the object's shades bilinearly in each (by hand, with taps clamped inside
// the level's square, so no tap reads a neighbour in the atlas, and only taps
// in the pixel's chart island). Objects outside the atlas (forward-only) are
// shaded here per pixel, with the world grid's lights. Debug views replace
// the shade.
// Under MSAA a pixel whose samples see different chart surfaces
// (`same_chart_surface`) gathers each sample at its own position and writes
// their mean (background samples black): the resolve, in linear HDR; the
// others gather once.
#import shadespace::contract::{VIEW_CHART_UV, VIEW_MIP_LEVEL, VIEW_TILE_MASK, VIEW_CACHE_AGE}
#import shadespace::scene_bindings::objects
#import shadespace::pixel_surface::{sample_pixel, pixel_surface, PixelSample}
#ifdef MSAA
#import shadespace::pixel_surface::{sample_pixel_at, standard_sample_position}
#import shadespace::objectspace::same_chart_surface
#endif
#import shadespace::light_grid::{world_cell_of, light_surface_in_cell}
#import shadespace::objectspace::{params, atlas_entries, entry_level, tile_shaded, visibility, chart_footprint, select_levels,
    bilinear, AtlasTexel, triangle_charts, locate, physical_page, virtual_page, physical_tile,
    NOT_BACKED, BlendedVertex, blended_vertex}
#import shadespace::alpha_mask::opacity

@group(2) @binding(0) var atlas: texture_2d_array<f32>;
@group(2) @binding(1) var hdr: texture_storage_2d<rgba16float, write>;
// Per atlas texel: triangle + 1 covering it; 0 = empty.
@group(2) @binding(2) var triangle_map: texture_2d_array<u32>;

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

fn fetch(at: AtlasTexel) -> vec3f {
    return textureLoad(atlas, at.xy, at.layer, 0).rgb;
}

// Chart island of triangle `triangle` of `object`.
fn island(object: u32, triangle: u32) -> u32 {
    return triangle_charts[objects[object].first_index / 3u + triangle];
}

// 1 when the texel at `at` belongs to chart island `own` of `object` (its
// triangle map names a triangle of that island), else 0.
fn in_island(object: u32, own: u32, at: AtlasTexel) -> f32 {
    let id = textureLoad(triangle_map, at.xy, at.layer, 0).x;
    return select(0.0, 1.0, id != 0u && island(object, id - 1u) == own);
}

// Shades the pixel here, as forward shading would.
fn shade_forward(p: PixelSample) -> vec4f {
    let s = pixel_surface(p);
    return vec4f(light_surface_in_cell(objects[p.object], s, world_cell_of(s.position)), 1.0);
}

// The shade of chart point `uv` in level `level_index`, filtered bilinearly
// over the taps in chart island `own` (a tap on a neighbouring chart's
// texel, closer than a texel at coarse levels, would bleed its colour across
// the border; with no tap in the island, a sliver thinner than the level's
// texels, all four are kept). Alpha -1 when a tap's page has no physical
// page (the atlas was full this frame).
fn filter_level(object: u32, own: u32, level_index: u32, uv: vec2f) -> vec4f {
    let l = entry_level(object, level_index);
    let b = bilinear(l, uv);
    let taps = array<AtlasTexel, 4>(
        locate(l, b.texel),
        locate(l, vec2i(b.texel_hi.x, b.texel.y)),
        locate(l, vec2i(b.texel.x, b.texel_hi.y)),
        locate(l, b.texel_hi),
    );
    if taps[0].layer == NOT_BACKED || taps[1].layer == NOT_BACKED || taps[2].layer == NOT_BACKED
        || taps[3].layer == NOT_BACKED {
        return vec4f(0.0, 0.0, 0.0, -1.0);
    }
    var w = vec4f(
        (1.0 - b.weight.x) * (1.0 - b.weight.y),
        b.weight.x * (1.0 - b.weight.y),
        (1.0 - b.weight.x) * b.weight.y,
        b.weight.x * b.weight.y,
    );
    let keep = vec4f(
        in_island(object, own, taps[0]),
        in_island(object, own, taps[1]),
        in_island(object, own, taps[2]),
        in_island(object, own, taps[3]),
    );
    let kept = dot(w, keep);
    if kept > 0.0 {
        w = w * keep / kept;
    }
    return vec4f(fetch(taps[0]) * w.x + fetch(taps[1]) * w.y + fetch(taps[2]) * w.z + fetch(taps[3]) * w.w, 1.0);
}

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(visibility);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let ids = textureLoad(visibility, id.xy, 0).xy;
#ifdef MSAA
    let n = textureNumSamples(visibility);
    var edge = false;
    for (var s = 1u; s < n; s++) {
        edge = edge || !same_chart_surface(textureLoad(visibility, id.xy, s).xy, ids);
    }
    if edge {
        var sum = vec3f(0.0);
        for (var s = 0u; s < n; s++) {
            let sample_ids = textureLoad(visibility, id.xy, s).xy;
            if sample_ids.x != 0u {
                sum += gather_surface(sample_pixel_at(id.xy, standard_sample_position(n, s), sample_ids)).rgb;
            }
        }
        textureStore(hdr, id.xy, vec4f(sum / f32(n), 1.0));
        return;
    }
#endif
    if ids.x == 0u {
        textureStore(hdr, id.xy, vec4f(0.0, 0.0, 0.0, 1.0));
        return;
    }
    textureStore(hdr, id.xy, gather_surface(sample_pixel(id.xy, ids)));
}

// An alpha-blended object's vertex (`objectspace::blended`).
@vertex
fn vs_blended(@builtin(vertex_index) k: u32, @builtin(instance_index) object: u32) -> BlendedVertex {
    return blended_vertex(k, object);
}

// An alpha-blended object's fragment: its shade gathered from the atlas as
// a pixel of it in the visibility buffer would gather it, times its
// opacity, and the opacity (premultiplied, composited over the frame).
@fragment
fn fs_gather_blended(in: BlendedVertex) -> @location(0) vec4f {
    let a = opacity(in.ids.x - 1u, in.texcoord);
    let c = gather_surface(sample_pixel(vec2u(in.clip.xy), in.ids));
    return vec4f(a * c.rgb, a);
}

// The shade of one surface point: its object's shades filtered (or a debug
// view's colour), or shaded here when the object or its page is not in the atlas.
fn gather_surface(p: PixelSample) -> vec4f {
    let e = atlas_entries[p.object];
    if e.size == 0u {
        return shade_forward(p);
    }
    let f = chart_footprint(p);
    let levels = select_levels(e, p, f);
    // The debug views show the level of the larger weight.
    let level_index = select(levels.lo, levels.hi, levels.t >= 0.5);
    let l = entry_level(p.object, level_index);
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
            let t = vec2u(b.texel);
            let page = physical_page(virtual_page(l, t));
            let age = params.stamp - tile_shaded[physical_tile(page, t)];
            let tile = t / params.tile_size;
            if page == NOT_BACKED {
                // Magenta: no physical page (the atlas was full).
                out = display(vec3f(0.9, 0.1, 0.9));
            } else if params.view_mode == VIEW_TILE_MASK {
                // Red: shaded this frame; green: reused. Darker checker per tile.
                let checker = f32((tile.x + tile.y) & 1u) * 0.25;
                out = display(select(vec3f(0.1, 0.8, 0.2), vec3f(0.9, 0.15, 0.1), age == 0u) * (1.0 - checker));
            } else {
                out = display(vec3f(f32(age) / f32(max(params.reuse, 1u))));
            }
        }
        default: {
            // The levels around the footprint, blended by the coarser one's
            // weight (one level where the weight is 0 or 1).
            let own = island(p.object, p.triangle);
            var c = vec3f(0.0);
            var backed = true;
            if levels.t < 1.0 {
                let fine = filter_level(p.object, own, levels.lo, f.uv);
                backed = fine.w >= 0.0;
                c = fine.rgb * (1.0 - levels.t);
            }
            if levels.t > 0.0 {
                let coarse = filter_level(p.object, own, levels.hi, f.uv);
                backed = backed && coarse.w >= 0.0;
                c += coarse.rgb * levels.t;
            }
            if !backed {
                // The atlas was full this frame: shade the pixel forward.
                return shade_forward(p);
            }
            out = vec4f(c, 1.0);
        }
    }
    return out;
}
