// Shade gathering, in compute over the visibility buffer: each pixel selects
// the same mip levels as tile marking did (one, or two blended) and filters
// the object's shades bilinearly in each (by hand, with taps clamped inside
// the level's square, so no tap reads a neighbour in the atlas, and only taps
// in the pixel's chart island), at its chart point or, with `--os-aniso`, at
// up to N points along its footprint's longer axis, averaged. Objects outside the atlas (forward-only) are
// shaded here per pixel, with the world grid's lights. Debug views replace
// the shade.
// Under MSAA a pixel gathers once per group of its samples that see one
// chart surface (`sample_group`: once at its centre where all do, the usual
// case), at the group's centroid, and writes the groups' mean weighted by
// their samples (background samples black): the resolve, in linear HDR.
// With `--os-msaa-gather sample` every sample is its own group.
// Reads per pixel, one level: the visibility buffer; its object and
// triangle's three indices; the three vertices (positions, chart UVs); the
// atlas entry and level; the page of each distinct page the four taps lie
// on (directory and table word: one page but where the taps cross a page
// edge, not one per tap); per tap its triangle-map texel and shade, and the
// tap's chart island only where its triangle is not the pixel's own (a
// triangle is in its own island; the pixel's island is then read too).
// With `PIXEL_RECORD` (`--os-gather record`), a pixel of an object in the
// atlas reads marking's record of its chart UV and levels (16 bytes) in
// place of the object, indices, vertices and footprint. With `FORWARD_LIST`
// too (the record gather of the shaded image, no debug view) the pixels to
// shade forward (objects outside the atlas, taps on pages the atlas could
// not back) are listed and shaded by `shade_forward_pixels`, a dispatch of
// their own: the lighting model compiled into the gather made every gather
// invocation hold its registers, and fewer ran at once (the gather took
// 0.095 ms at 1920x1080 on an H200 with it, 0.081 without, the same
// image); `BILINEAR_ONLY` leaves the cubic filters out of it likewise.
#import shadespace::contract::{VIEW_CHART_UV, VIEW_MIP_LEVEL, VIEW_TILE_MASK, VIEW_CACHE_AGE}
#import shadespace::scene_bindings::objects
#import shadespace::pixel_surface::{sample_pixel, sample_pixel_again, pixel_surface, PixelSample}
#ifdef MSAA
#import shadespace::pixel_surface::sample_pixel_at
#import shadespace::objectspace::{sample_group, visibility_samples}
#endif
#import shadespace::objectspace::visibility_ids
#import shadespace::light_grid::{world_cell_of, light_surface_in_cell}
#import shadespace::objectspace::{params, atlas_entries, entry_level, tile_shaded, visibility, chart_footprint, select_levels,
    bilinear, AtlasTexel, atlas_texel, triangle_charts, physical_page, virtual_page, physical_tile,
    NOT_BACKED, BlendedVertex, blended_vertex, FILTER_BILINEAR, FILTER_MITCHELL, AnisoTaps, aniso_taps, aniso_tap, AtlasEntry}
#import shadespace::alpha_mask::opacity
#import shadespace::objectspace::{LevelPair, island_code}
#ifdef PIXEL_RECORD
#import shadespace::contract::VIEW_SHADE
#endif

@group(2) @binding(0) var atlas: texture_2d_array<f32>;
@group(2) @binding(1) var hdr: texture_storage_2d<rgba16float, write>;
// Per atlas texel: triangle + 1 covering it; 0 = empty.
@group(2) @binding(2) var triangle_map: texture_2d_array<u32>;
#ifdef PIXEL_RECORD
// Per pixel: what marking found (`mark.wgsl`): chart UV, level weight, levels.
@group(2) @binding(3) var<storage, read> pixel_records: array<vec4u>;
#endif
#ifdef FORWARD_LIST
// The pixels the gather leaves to `shade_forward_pixels`: their count, then
// each pixel as x | y << 16 (room for every pixel of the view).
struct ForwardPixels {
    count: atomic<u32>,
    pixels: array<u32>,
}
@group(2) @binding(4) var<storage, read_write> forward_pixels: ForwardPixels;
// `shade_forward_pixels`'s dispatch (x, 1, 1): x is raised to cover the
// pixels listed. (That dispatch, reading it as INDIRECT, binds a stand-in.)
@group(2) @binding(5) var<storage, read_write> forward_dispatch: array<atomic<u32>, 3>;
// Invocations of a `shade_forward_pixels` workgroup.
const FORWARD_GROUP: u32 = 64u;
#endif
#ifdef PIXEL_CLASSES
// Per pixel, written by `classify` (`debug::PixelClass`): what its gather
// reads, packed as the `CLASS_*` fields below; y and z: texels per pixel at
// that level along the footprint's longer and shorter axis (f32 bits).
@group(2) @binding(3) var<storage, read_write> pixel_classes: array<vec4u>;
#endif

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

// Chart island of triangle `triangle` of `object`.
fn island(object: u32, triangle: u32) -> u32 {
    return triangle_charts[objects[object].first_index / 3u + triangle];
}

// The pixel's object and triangle, whose chart island the island filter
// keeps, and (`ISLAND_IN_ALPHA`) that island's code in the atlas's alpha.
struct OwnSurface {
    object: u32,
    triangle: u32,
    code: f32,
}

fn own_surface(object: u32, triangle: u32) -> OwnSurface {
#ifdef ISLAND_IN_ALPHA
    return OwnSurface(object, triangle, island_code(island(object, triangle)));
#else
    return OwnSurface(object, triangle, 0.0);
#endif
}

// 1 when `texel`, the atlas texel at `at`, belongs to the pixel's chart
// island, else 0: with `ISLAND_IN_ALPHA` its alpha holds its island's code
// (the shade pass writes it), else its triangle map names the pixel's
// triangle or another of that island.
fn in_island(own: OwnSurface, at: AtlasTexel, texel: vec4f) -> f32 {
#ifdef ISLAND_IN_ALPHA
    return select(0.0, 1.0, texel.a == own.code);
#else
    let id = textureLoad(triangle_map, at.xy, at.layer, 0).x;
    if id == 0u {
        return 0.0;
    }
    // The pixel's own triangle, the usual case inside a triangle: no lookup.
    if id - 1u == own.triangle {
        return 1.0;
    }
    return select(0.0, 1.0, island(own.object, id - 1u) == island(own.object, own.triangle));
#endif
}

// Shades the pixel here, as forward shading would.
fn shade_forward(p: PixelSample) -> vec4f {
    let s = pixel_surface(p);
    return vec4f(light_surface_in_cell(objects[p.object], s, world_cell_of(s.position)), 1.0);
}

// The shade of chart point `uv` in level `level_index`, filtered bilinearly
// over the taps in the pixel's chart island (a tap on a neighbouring chart's
// texel, closer than a texel at coarse levels, would bleed its colour across
// the border; with no tap in the island, a sliver thinner than the level's
// texels, all four are kept). Alpha -1 when a tap's page has no physical
// page (the atlas was full this frame).
fn filter_level(own: OwnSurface, level_index: u32, uv: vec2f) -> vec4f {
#ifndef BILINEAR_ONLY
    if params.gather_filter != FILTER_BILINEAR {
        return filter_level_cubic(own, level_index, uv);
    }
#endif
    let l = entry_level(own.object, level_index);
    let b = bilinear(l, uv);
    let lo = vec2u(b.texel);
    let hi = vec2u(b.texel_hi);
    // The taps share a page but across a page edge: each distinct page is
    // looked up once (the same pages as a lookup per tap).
    let crosses = hi / params.page_size != lo / params.page_size;
    let page_lo = page_of(virtual_page(l, lo));
    var page_x = page_lo;
    var page_y = page_lo;
    if crosses.x {
        page_x = physical_page(virtual_page(l, vec2u(hi.x, lo.y)));
    }
    if crosses.y {
        page_y = physical_page(virtual_page(l, vec2u(lo.x, hi.y)));
    }
    var page_xy = select(page_lo, page_x, crosses.x);
    if crosses.x && crosses.y {
        page_xy = physical_page(virtual_page(l, hi));
    } else if crosses.y {
        page_xy = page_y;
    }
    if page_lo == NOT_BACKED || page_x == NOT_BACKED || page_y == NOT_BACKED || page_xy == NOT_BACKED {
        return vec4f(0.0, 0.0, 0.0, -1.0);
    }
    let taps = array<AtlasTexel, 4>(
        atlas_texel(page_lo, lo),
        atlas_texel(page_x, vec2u(hi.x, lo.y)),
        atlas_texel(page_y, vec2u(lo.x, hi.y)),
        atlas_texel(page_xy, hi),
    );
    var w = vec4f(
        (1.0 - b.weight.x) * (1.0 - b.weight.y),
        b.weight.x * (1.0 - b.weight.y),
        (1.0 - b.weight.x) * b.weight.y,
        b.weight.x * b.weight.y,
    );
    let texels = array<vec4f, 4>(
        textureLoad(atlas, taps[0].xy, taps[0].layer, 0),
        textureLoad(atlas, taps[1].xy, taps[1].layer, 0),
        textureLoad(atlas, taps[2].xy, taps[2].layer, 0),
        textureLoad(atlas, taps[3].xy, taps[3].layer, 0),
    );
    let keep = vec4f(
        in_island(own, taps[0], texels[0]),
        in_island(own, taps[1], texels[1]),
        in_island(own, taps[2], texels[2]),
        in_island(own, taps[3], texels[3]),
    );
    let kept = dot(w, keep);
    if kept > 0.0 {
        w = w * keep / kept;
    }
    return vec4f(texels[0].rgb * w.x + texels[1].rgb * w.y + texels[2].rgb * w.z + texels[3].rgb * w.w, 1.0);
}

// Cubic B-spline weights of the four texels around a point at fraction `f`
// past the second one's centre (they sum to 1 and are C2 in the point).
fn bspline_weights(f: f32) -> vec4f {
    let g = 1.0 - f;
    let f2 = f * f;
    let f3 = f2 * f;
    return vec4f(g * g * g, 3.0 * f3 - 6.0 * f2 + 4.0, -3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0, f3) / 6.0;
}

// The Mitchell-Netravali cubic (B = C = 1/3) at distance `x` (0 to 2) from a texel.
fn mitchell(x: f32) -> f32 {
    if x < 1.0 {
        return ((7.0 * x - 12.0) * x * x + 16.0 / 3.0) / 6.0;
    }
    return (((-7.0 / 3.0 * x + 12.0) * x - 20.0) * x + 32.0 / 3.0) / 6.0;
}

// The weights of the four texels around a point at fraction `f` past the
// second one's centre, for the cubic filter `params.gather_filter`.
fn cubic_weights(f: f32) -> vec4f {
    if params.gather_filter == FILTER_MITCHELL {
        return vec4f(mitchell(1.0 + f), mitchell(f), mitchell(1.0 - f), mitchell(2.0 - f));
    }
    return bspline_weights(f);
}

// `filter_level` with a cubic over the 4x4 texels around the point
// (`--os-filter bspline` or `mitchell`): the B-spline's blur hardly changes
// with the point's phase in the texel grid, where bilinear's goes from none
// (on a texel's centre) to the mean of four (between centres). Taps are
// clamped into the level and island-filtered as bilinear's; marking marked
// their tiles (`filter_margin`). The 4 texels along an axis cross at most
// one page edge, so at most four pages are looked up.
fn filter_level_cubic(own: OwnSurface, level_index: u32, uv: vec2f) -> vec4f {
    let l = entry_level(own.object, level_index);
    let b = bilinear(l, uv);
    let base = vec2i(floor(uv * f32(l.size) - 0.5));
    let last = vec2i(i32(l.size) - 1);
    let first = vec2u(clamp(base - 1, vec2i(0), last));
    let end = vec2u(clamp(base + 2, vec2i(0), last));
    let crosses = end / params.page_size != first / params.page_size;
    let page_00 = physical_page(virtual_page(l, first));
    var page_10 = page_00;
    var page_01 = page_00;
    var page_11 = page_00;
    if crosses.x {
        page_10 = physical_page(virtual_page(l, vec2u(end.x, first.y)));
    }
    if crosses.y {
        page_01 = physical_page(virtual_page(l, vec2u(first.x, end.y)));
    }
    if crosses.x && crosses.y {
        page_11 = physical_page(virtual_page(l, end));
    } else if crosses.x {
        page_11 = page_10;
    } else if crosses.y {
        page_11 = page_01;
    }
    if page_00 == NOT_BACKED || page_10 == NOT_BACKED || page_01 == NOT_BACKED || page_11 == NOT_BACKED {
        return vec4f(0.0, 0.0, 0.0, -1.0);
    }
    let wx = cubic_weights(b.weight.x);
    let wy = cubic_weights(b.weight.y);
    let first_page = first / params.page_size;
    var all = vec3f(0.0);
    var sum = vec3f(0.0);
    var kept = 0.0;
    for (var j = 0; j < 4; j++) {
        for (var i = 0; i < 4; i++) {
            let texel = vec2u(clamp(base + vec2i(i - 1, j - 1), vec2i(0), last));
            let second = texel / params.page_size != first_page;
            let page = select(select(page_00, page_10, second.x), select(page_01, page_11, second.x), second.y);
            let at = atlas_texel(page, texel);
            let w = wx[i] * wy[j];
            let texel_shade = textureLoad(atlas, at.xy, at.layer, 0);
            let c = texel_shade.rgb * w;
            let keep = in_island(own, at, texel_shade);
            all += c;
            sum += c * keep;
            kept += w * keep;
        }
    }
    // As bilinear's: the kept taps renormalized, or all of them when none is kept.
    if kept > 0.0 {
        return vec4f(sum / kept, 1.0);
    }
    return vec4f(all, 1.0);
}

// The last virtual page `page_of` looked up (+ 1; 0: none) and its
// physical page: a quad's pixels mostly read one page.
var<private> last_page: vec2u;

// `physical_page(page)`, looked up once for consecutive calls on one page.
fn page_of(page: u32) -> u32 {
    if last_page.x != page + 1u {
        last_page = vec2u(page + 1u, physical_page(page));
    }
    return last_page.y;
}

#ifndef MSAA
// Pixels along a side of the square an invocation gathers
// (`mark::quad_side`): a 2x2 quad, whose pixels mostly share a triangle
// and a page, loaded and looked up once for them.
const QUAD: u32 = 2u;

// Gathers `pixel` (in the image).
fn gather_pixel(pixel: vec2u, size: vec2u) {
    let ids = visibility_ids(pixel, 0u);
    if ids.x == 0u {
        textureStore(hdr, pixel, vec4f(0.0, 0.0, 0.0, 1.0));
        return;
    }
#ifdef FORWARD_LIST
    let c = gather_recorded(pixel, ids, size);
    if c.w < 0.0 {
        defer_forward(pixel);
    } else {
        textureStore(hdr, pixel, c);
    }
#else
#ifdef PIXEL_RECORD
    textureStore(hdr, pixel, gather_recorded(pixel, ids, size));
#else
    textureStore(hdr, pixel, gather_surface(sample_pixel_again(pixel, ids)));
#endif
#endif
}
#endif

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(visibility);
#ifndef MSAA
    for (var q = 0u; q < QUAD * QUAD; q++) {
        let pixel = id.xy * QUAD + vec2u(q % QUAD, q / QUAD);
        if all(pixel < size) {
            gather_pixel(pixel, size);
        }
    }
#else
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    // One call site for every group: a pixel of two surfaces costs its
    // subgroup two gathers, not one and then one per sample.
    let n = visibility_samples();
    var left = (1u << n) - 1u;
    var sum = vec3f(0.0);
    loop {
        let g = sample_group(id.xy, n, left);
        left = g.left;
        if g.ids.x != 0u {
            sum += gather_surface(sample_pixel_at(id.xy, g.at, g.ids)).rgb * f32(g.count);
        }
        if left == 0u {
            break;
        }
    }
    textureStore(hdr, id.xy, vec4f(sum / f32(n), 1.0));
#endif
}

#ifdef PIXEL_RECORD
// `gather_surface` of an object in the atlas from the chart UV and levels
// marking recorded for the pixel: no rebuilding of its surface (object,
// indices, vertices, footprint) before the level's page can be read.
fn gather_recorded(pixel: vec2u, ids: vec2u, size: vec2u) -> vec4f {
    let object = ids.x - 1u;
#ifdef FORWARD_LIST
    // Shaded forward by `shade_forward_pixels`.
    if atlas_entries[object].size == 0u {
        return vec4f(-1.0);
    }
#else
    if atlas_entries[object].size == 0u || params.view_mode != VIEW_SHADE {
        return gather_surface(sample_pixel(pixel, ids));
    }
#endif
    let r = pixel_records[pixel.y * size.x + pixel.x];
    // One tap: `--os-aniso` above 1 is refused with records.
    let c = gather_levels(own_surface(object, ids.y), LevelPair(r.w & 0xffffu, r.w >> 16u, bitcast<f32>(r.z)),
        AnisoTaps(bitcast<vec2f>(r.xy), vec2f(0.0), 1u));
#ifndef FORWARD_LIST
    if c.w < 0.0 {
        return shade_forward(sample_pixel(pixel, ids));
    }
#endif
    return c;
}
#endif

#ifdef FORWARD_LIST
// Lists `pixel` for `shade_forward_pixels` and raises its dispatch to cover it.
fn defer_forward(pixel: vec2u) {
    let i = atomicAdd(&forward_pixels.count, 1u);
    if i < arrayLength(&forward_pixels.pixels) {
        forward_pixels.pixels[i] = pixel.x | (pixel.y << 16u);
    }
    atomicMax(&forward_dispatch[0], min(i / FORWARD_GROUP + 1u, 65535u));
}

// The pixels the gather listed, shaded forward (what the gather without
// the list does in place), each invocation every (groups x FORWARD_GROUP)-th.
@compute @workgroup_size(FORWARD_GROUP)
fn shade_forward_pixels(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = min(atomicLoad(&forward_pixels.count), arrayLength(&forward_pixels.pixels));
    for (var i = id.x; i < count; i += groups.x * FORWARD_GROUP) {
        let p = forward_pixels.pixels[i];
        let pixel = vec2u(p & 0xffffu, p >> 16u);
        textureStore(hdr, pixel, shade_forward(sample_pixel(pixel, visibility_ids(pixel, 0u))));
    }
}
#endif

// The mean of level `level_index`'s filter at the anisotropic taps `taps`
// (box weights: the pixel's footprint along its longer axis is a box, as
// the supersampled reference's resolve; a single tap is `filter_level`
// alone). Alpha -1 when a tap's page has no physical page.
fn filter_taps(own: OwnSurface, level_index: u32, taps: AnisoTaps) -> vec4f {
    // One call of `filter_level` (inlined with both filters): a single tap
    // is the loop's one turn, and divided by 1 is its shade exactly.
    var c = vec3f(0.0);
    for (var i = 0u; i < taps.count; i++) {
        let s = filter_level(own, level_index, aniso_tap(taps, i));
        if s.w < 0.0 {
            return s;
        }
        c += s.rgb;
    }
    return vec4f(c / f32(taps.count), 1.0);
}

// The shade of the pixel's taps from the levels around its footprint,
// blended by the coarser one's weight (one level where the weight is 0 or
// 1); alpha -1 when a tap's page has no physical page (the atlas was full).
fn gather_levels(own: OwnSurface, levels: LevelPair, taps: AnisoTaps) -> vec4f {
    var c = vec3f(0.0);
    var backed = true;
    // The fine level, then the coarse one, through one call of
    // `filter_taps` (a call per level doubled the shader, as `gather` says).
    for (var k = 0u; k < 2u; k++) {
        let weight = select(1.0 - levels.t, levels.t, k == 1u);
        if (k == 0u && levels.t < 1.0) || (k == 1u && levels.t > 0.0) {
            let level = filter_taps(own, select(levels.lo, levels.hi, k == 1u), taps);
            backed = backed && level.w >= 0.0;
            c += level.rgb * weight;
        }
    }
    return vec4f(c, select(-1.0, 1.0, backed));
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
// view's colour), or shaded here when the object or its page is not in the
// atlas (one call of `shade_forward` for both, as `gather` says why).
fn gather_surface(p: PixelSample) -> vec4f {
    let e = atlas_entries[p.object];
    if e.size != 0u {
        let c = gather_atlas(p, e);
        if c.w >= 0.0 {
            return c;
        }
    }
    return shade_forward(p);
}

// `gather_surface` of an object in the atlas; alpha -1 when a tap's page has
// no physical page (the atlas was full this frame).
fn gather_atlas(p: PixelSample, e: AtlasEntry) -> vec4f {
    let f = chart_footprint(p);
    let levels = select_levels(e, p, f);
    // The debug views show the level of the larger weight.
    let level_index = select(levels.lo, levels.hi, levels.t >= 0.5);
    let l = entry_level(p.object, level_index);
    let b = bilinear(l, f.uv);
    switch params.view_mode {
        case VIEW_CHART_UV: {
            return display(vec3f(fract(f.uv), 0.0));
        }
        case VIEW_MIP_LEVEL: {
            return display(level_color(level_index));
        }
        case VIEW_TILE_MASK, VIEW_CACHE_AGE: {
            let t = vec2u(b.texel);
            let page = physical_page(virtual_page(l, t));
            let age = params.stamp - tile_shaded[physical_tile(page, t)];
            let tile = t / params.tile_size;
            if page == NOT_BACKED {
                // Magenta: no physical page (the atlas was full).
                return display(vec3f(0.9, 0.1, 0.9));
            } else if params.view_mode == VIEW_TILE_MASK {
                // Red: shaded this frame; green: reused. Darker checker per tile.
                let checker = f32((tile.x + tile.y) & 1u) * 0.25;
                return display(select(vec3f(0.1, 0.8, 0.2), vec3f(0.9, 0.15, 0.1), age == 0u) * (1.0 - checker));
            }
            return display(vec3f(f32(age) / f32(max(params.reuse, 1u))));
        }
        default: {
            return gather_levels(own_surface(p.object, p.triangle), levels, aniso_taps(e, f));
        }
    }
}

#ifdef PIXEL_CLASSES
// `pixel_classes[i].x`: coverage (bits 0-1), source (2-3), level (4-7),
// island taps (8-9), tile age in frames, at most 255 (10-17), blended
// between two levels (18). Mirrors `debug::PixelClass::from_words`.
const CLASS_BACKGROUND: u32 = 0u;
const CLASS_INTERIOR: u32 = 1u;
const CLASS_EDGE: u32 = 2u;
const SOURCE_ATLAS: u32 = 0u;
const SOURCE_FORWARD: u32 = 1u;
const SOURCE_NOT_BACKED: u32 = 2u;
const TAPS_ALL: u32 = 0u;
const TAPS_SOME: u32 = 1u;
const TAPS_NONE: u32 = 2u;

// The island taps of the filter `filter_level` runs at `uv` in level
// `level_index`: TAPS_ALL in the pixel's island, TAPS_SOME (it renormalizes
// over the rest) or TAPS_NONE (it keeps all: a sliver); NOT_BACKED where a
// tap's page has no physical page. One page lookup per tap: slower than
// the gather's, the same texels.
fn island_taps(own: OwnSurface, level_index: u32, uv: vec2f) -> u32 {
    let l = entry_level(own.object, level_index);
    let last = vec2i(i32(l.size) - 1);
    var first = vec2i(bilinear(l, uv).texel);
    var count = 2;
    if params.gather_filter != FILTER_BILINEAR {
        first = vec2i(floor(uv * f32(l.size) - 0.5)) - 1;
        count = 4;
    }
    var kept = 0;
    for (var j = 0; j < count; j++) {
        for (var i = 0; i < count; i++) {
            let texel = vec2u(clamp(first + vec2i(i, j), vec2i(0), last));
            let page = physical_page(virtual_page(l, texel));
            if page == NOT_BACKED {
                return NOT_BACKED;
            }
            let at = atlas_texel(page, texel);
            kept += i32(in_island(own, at, textureLoad(atlas, at.xy, at.layer, 0)));
        }
    }
    if kept == count * count {
        return TAPS_ALL;
    }
    return select(TAPS_SOME, TAPS_NONE, kept == 0);
}

// What the gather of surface point `p` reads: (source | level | taps | age
// | blended packed as `pixel_classes`' x, less coverage; texels per pixel
// along the longer and the shorter axis).
fn surface_class(p: PixelSample) -> vec4u {
    let e = atlas_entries[p.object];
    if e.size == 0u {
        return vec4u(SOURCE_FORWARD << 2u, 0u, 0u, 0u);
    }
    let f = chart_footprint(p);
    let levels = select_levels(e, p, f);
    let level_index = select(levels.lo, levels.hi, levels.t >= 0.5);
    let l = entry_level(p.object, level_index);
    let texels = max(length(f.du_dx), length(f.du_dy)) * f32(l.size);
    let minor = min(length(f.du_dx), length(f.du_dy)) * f32(l.size);
    let blended = select(0u, 1u, levels.t > 0.0 && levels.t < 1.0);
    let taps = island_taps(own_surface(p.object, p.triangle), level_index, f.uv);
    let t = vec2u(bilinear(l, f.uv).texel);
    let page = physical_page(virtual_page(l, t));
    if taps == NOT_BACKED || page == NOT_BACKED {
        return vec4u(SOURCE_NOT_BACKED << 2u | level_index << 4u, bitcast<u32>(texels), bitcast<u32>(minor), 0u);
    }
    let age = min(params.stamp - tile_shaded[physical_tile(page, t)], 255u);
    return vec4u(SOURCE_ATLAS << 2u | level_index << 4u | taps << 8u | age << 10u | blended << 18u,
        bitcast<u32>(texels), bitcast<u32>(minor), 0u);
}

// Debug read-back (`ObjectSpace::read_pixel_classes`), run after a frame
// and outside it: per pixel, whether its samples see one surface, and what
// the gather read for it (for an edge pixel, for its first group of samples
// on a surface): the source of its shade, level, texels per pixel, taps outside
// the chart island, and the age of its tile's shade.
@compute @workgroup_size(8, 8)
fn classify(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(visibility);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let i = id.y * size.x + id.x;
#ifdef MSAA
    // Its first group on a surface, gathered at the group's point
    // (`sample_group`); an edge where the samples make more than one group.
    let n = visibility_samples();
    var g = sample_group(id.xy, n, (1u << n) - 1u);
    let coverage = select(CLASS_EDGE, CLASS_INTERIOR, g.left == 0u);
    while g.ids.x == 0u && g.left != 0u {
        g = sample_group(id.xy, n, g.left);
    }
    if g.ids.x == 0u {
        pixel_classes[i] = vec4u(CLASS_BACKGROUND, 0u, 0u, 0u);
        return;
    }
    let c = surface_class(sample_pixel_at(id.xy, g.at, g.ids));
#else
    let ids = visibility_ids(id.xy, 0u);
    if ids.x == 0u {
        pixel_classes[i] = vec4u(CLASS_BACKGROUND, 0u, 0u, 0u);
        return;
    }
    let coverage = CLASS_INTERIOR;
    let c = surface_class(sample_pixel(id.xy, ids));
#endif
    pixel_classes[i] = vec4u(coverage | c.x, c.yzw);
}
#endif
