// Tiled deferred lighting, one workgroup per 16x16 (or 8x8) screen tile, one thread
// per pixel:
// 1. the tile's depth range: workgroup atomic min/max over its pixels' depths
//    (background pixels, depth 0, are left out; an all-background tile is
//    written black and leaves);
// 2. the tile's frustum: four side planes through its pixel edges and two
//    depth planes at its range, taken from rows of the view-projection;
// 3. the point and spot lights (every light after the global ones), in
//    chunks of one per thread, tested against it by bounding sphere
//    (`light_bounds`: a point light's range, a spot light's sector);
//    survivors are appended to a workgroup list in light order (a ballot of
//    bits and population counts, so the image does not depend on thread
//    timing);
// 4. when the list could not take another whole chunk, and after the last
//    chunk, every pixel shades with the lights listed so far and the list is
//    emptied: so no light is ever dropped, however many reach a tile;
// 5. each pixel adds emission and the ambient and directional lights.
// Pixels come from the G-buffer, or, with VISIBILITY_BUFFER defined, from the
// compute visibility pass (`shadespace::visibility_read`). With MSAA defined
// the G-buffer is multisampled (or the visibility buffer has a layer per sample): the depth range spans every sample, a pixel
// whose samples see one surface is shaded once at its centre, an edge pixel
// (`gbuffer_pixel`) sample by sample and averaged, and the frame's lit and
// edge pixels are counted.
#import shadespace::contract::{TILED_LIST_CAPACITY, TILED_SMALL_SIDE, TILED_LARGE_SIDE}
#import shadespace::lighting::{Surface, light_radiance}
#import shadespace::light_bounds::{light_bounds, sphere_touches}
#import shadespace::scene_bindings::{view, lights}
#import shadespace::surface::emission_and_globals
#ifdef LAYERS
#import shadespace::layers::{layer_at, layer_mask, layer_surface}
#endif
#ifdef VISIBILITY_BUFFER
#ifdef MSAA
#import shadespace::visibility_read::{GbufferTexel, PixelSamples, gbuffer_pixel, gbuffer_samples, gbuffer_depth_sample, gbuffer_sample_texel, gbuffer_centre_texel}
#else
#import shadespace::visibility_read::{GbufferTexel, gbuffer_depth_at, gbuffer_texel}
#endif
#else
#ifdef MSAA
#import shadespace::gbuffer::{GbufferTexel, PixelSamples, gbuffer_pixel, gbuffer_samples, gbuffer_depth_sample, gbuffer_sample_texel, gbuffer_centre_texel}
#else
#import shadespace::gbuffer::{GbufferTexel, gbuffer_depth_at, gbuffer_texel}
#endif
#endif

// The tile's side in pixels (`deferred_compute::TileSide`, whose sides the
// dispatch uses too), and the lights culled a step, one per invocation.
#ifdef SMALL_TILES
const TILED_TILE_SIZE: u32 = TILED_SMALL_SIDE;
#else
const TILED_TILE_SIZE: u32 = TILED_LARGE_SIDE;
#endif
const TILED_CHUNK: u32 = TILED_TILE_SIZE * TILED_TILE_SIZE;
// Words of a chunk's bits (`chunk_bits`).
const CHUNK_WORDS: u32 = TILED_CHUNK / 32u;

@group(2) @binding(0) var hdr: texture_storage_2d<rgba16float, write>;
#ifdef MSAA
// The frame's lit pixels and, of those, edge pixels (cleared every frame).
@group(2) @binding(1) var<storage, read_write> edge_counts: array<atomic<u32>, 2>;
var<workgroup> tile_lit: atomic<u32>;
var<workgroup> tile_edges: atomic<u32>;
#endif

// Bit patterns of the tile's smallest and largest non-background depth
// (positive floats order like their bits).
var<workgroup> depth_min_bits: atomic<u32>;
var<workgroup> depth_max_bits: atomic<u32>;
// The tile's device-depth range (x: min, y: max), or (1, 0) when empty.
var<workgroup> tile_range: vec2f;
// This chunk's lights that touch the tile, one bit per thread.
var<workgroup> chunk_bits: array<atomic<u32>, CHUNK_WORDS>;
var<workgroup> list: array<u32, TILED_LIST_CAPACITY>;
var<workgroup> list_count: u32;

// Row `i` of the view-projection (WGSL matrices are column-major).
fn view_proj_row(i: u32) -> vec4f {
    let m = view.view_proj;
    return vec4f(m[0][i], m[1][i], m[2][i], m[3][i]);
}

// A world-space plane (unit normal, offset) from a clip-space half-space
// `dot(row, p) >= 0` (Gribb-Hartmann).
fn normalized(p: vec4f) -> vec4f {
    return p / length(p.xyz);
}

// The tile's frustum: pixels `lo` to `hi` (exclusive), device depths
// `range.x` (farthest) to `range.y` (nearest).
fn tile_frustum(lo: vec2f, hi: vec2f, range: vec2f) -> array<vec4f, 6> {
    let ndc_lo = lo * view.viewport.zw * vec2f(2.0, -2.0) + vec2f(-1.0, 1.0);
    let ndc_hi = hi * view.viewport.zw * vec2f(2.0, -2.0) + vec2f(-1.0, 1.0);
    let rx = view_proj_row(0u);
    let ry = view_proj_row(1u);
    let rz = view_proj_row(2u);
    let rw = view_proj_row(3u);
    // Pixel rows grow downwards, NDC y upwards: ndc_hi.y is the bottom.
    // Reversed Z: depth falls with distance.
    return array<vec4f, 6>(
        normalized(rx - ndc_lo.x * rw),
        normalized(ndc_hi.x * rw - rx),
        normalized(ry - ndc_hi.y * rw),
        normalized(ndc_lo.y * rw - ry),
        normalized(rz - range.x * rw),
        normalized(range.y * rw - rz),
    );
}

// Shades `texel` with the first `count` listed lights; a layered material
// each of its layers (`shadespace::layers`), layer by layer.
fn shade_listed(texel: GbufferTexel, count: u32) -> vec3f {
#ifdef LAYERS
    let s = texel.surface;
    var color = vec3f(0.0);
    var remaining = 1.0;
    for (var i = s.layer_count; i > 0u && remaining > 0.0; i--) {
        let l = layer_at(s, i);
        let w = layer_mask(l, s) * remaining;
        remaining -= w;
        if w > 0.0 {
            color += w * shade_listed_one(layer_surface(l, s), texel.to_eye, count);
        }
    }
    if remaining > 0.0 {
        color += remaining * shade_listed_one(s, texel.to_eye, count);
    }
    return color;
#else
    return shade_listed_one(texel.surface, texel.to_eye, count);
#endif
}

// `shade_listed` of one surface (a material or one of its layers).
fn shade_listed_one(s: Surface, to_eye: vec3f, count: u32) -> vec3f {
    var color = vec3f(0.0);
    for (var i = 0u; i < count; i++) {
        color += light_radiance(lights[list[i]], s, to_eye);
    }
    return color;
}

#ifdef MSAA
// A texel's shade: with `globals` its emission and the ambient and
// directional lights, else the first `count` listed lights.
fn shade_texel(texel: GbufferTexel, count: u32, globals: bool) -> vec3f {
    if globals {
        return emission_and_globals(texel.surface, texel.to_eye);
    }
    return shade_listed(texel, count);
}

// A pixel's `shade_texel`: once at its centre (`centre`, read once for all
// the lights) where its samples see one surface, else the mean over its
// samples, each shaded at its own position (background samples black, as
// forward's cleared samples are). One call of `shade_texel` for both: a
// driver inlines every call with the lighting model in it, and a call per
// case doubled the shader (a CPU driver took seconds longer to compile it).
fn shade_msaa(pixel: vec2u, samples: PixelSamples, centre: GbufferTexel, count: u32, globals: bool) -> vec3f {
    let n = select(1u, gbuffer_samples(), samples.edge);
    var sum = vec3f(0.0);
    for (var s = 0u; s < n; s++) {
        var texel = centre;
        var covered = true;
        if samples.edge {
            let d = gbuffer_depth_sample(pixel, s);
            covered = d > 0.0;
            if covered {
                texel = gbuffer_sample_texel(pixel, s, d);
            }
        }
        if covered {
            sum += shade_texel(texel, count, globals);
        }
    }
    return sum / f32(n);
}
#endif

@compute @workgroup_size(TILED_TILE_SIZE, TILED_TILE_SIZE)
fn tiled_lighting(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(local_invocation_index) thread: u32,
    @builtin(workgroup_id) tile: vec3u,
) {
    let size = vec2u(view.viewport.xy);
    let in_image = all(id.xy < size);
    if thread == 0u {
        atomicStore(&depth_min_bits, 0xffffffffu);
        atomicStore(&depth_max_bits, 0u);
        list_count = 0u;
#ifdef MSAA
        atomicStore(&tile_lit, 0u);
        atomicStore(&tile_edges, 0u);
#endif
    }
    if thread < CHUNK_WORDS {
        atomicStore(&chunk_bits[thread], 0u);
    }
    workgroupBarrier();
#ifdef MSAA
    var samples = PixelSamples(false, false, 1.0, 0.0, 0.0);
    if in_image {
        samples = gbuffer_pixel(id.xy);
    }
    let lit = samples.lit;
    if lit {
        atomicMin(&depth_min_bits, bitcast<u32>(samples.depth_min));
        atomicMax(&depth_max_bits, bitcast<u32>(samples.depth_max));
        atomicAdd(&tile_lit, 1u);
        if samples.edge {
            atomicAdd(&tile_edges, 1u);
        }
    }
#else
    var depth = 0.0;
    if in_image {
        depth = gbuffer_depth_at(id.xy);
    }
    let lit = depth > 0.0;
    if lit {
        atomicMin(&depth_min_bits, bitcast<u32>(depth));
        atomicMax(&depth_max_bits, bitcast<u32>(depth));
    }
#endif
    workgroupBarrier();
    if thread == 0u {
#ifdef MSAA
        atomicAdd(&edge_counts[0], atomicLoad(&tile_lit));
        atomicAdd(&edge_counts[1], atomicLoad(&tile_edges));
#endif
        tile_range = vec2f(bitcast<f32>(atomicLoad(&depth_min_bits)), bitcast<f32>(atomicLoad(&depth_max_bits)));
        if atomicLoad(&depth_max_bits) == 0u {
            tile_range = vec2f(1.0, 0.0);
        }
    }
    let range = workgroupUniformLoad(&tile_range);
    if range.x > range.y {
        if in_image {
            textureStore(hdr, id.xy, vec4f(0.0, 0.0, 0.0, 1.0));
        }
        return;
    }
    let lo = vec2f(tile.xy * TILED_TILE_SIZE);
    let hi = vec2f(min((tile.xy + 1u) * TILED_TILE_SIZE, size));
    let frustum = tile_frustum(lo, hi, range);
    var color = vec3f(0.0);
#ifdef MSAA
    // Without edges the surface is rebuilt (the visibility buffer) or read
    // once, not per light list.
    var centre: GbufferTexel;
    if lit && !samples.edge {
        centre = gbuffer_centre_texel(id.xy, samples);
    }
    if lit {
        color = shade_msaa(id.xy, samples, centre, 0u, true);
    }
#else
    var texel: GbufferTexel;
    if lit {
        texel = gbuffer_texel(id.xy, depth);
        color = emission_and_globals(texel.surface, texel.to_eye);
    }
#endif
    let word = thread / 32u;
    let bit = 1u << (thread % 32u);
    let count = view.light_count;
    for (var first = view.global_light_count; first < count; first += TILED_CHUNK) {
        // Cull: one light per thread.
        let index = first + thread;
        var touches = false;
        if index < count {
            touches = sphere_touches(frustum, light_bounds(lights[index]));
        }
        if touches {
            atomicOr(&chunk_bits[word], bit);
        }
        let listed = workgroupUniformLoad(&list_count);
        // Append in light order: this light's place is the number of
        // survivors on lower threads.
        var total = 0u;
        var below = 0u;
        for (var w = 0u; w < CHUNK_WORDS; w++) {
            let bits = atomicLoad(&chunk_bits[w]);
            total += countOneBits(bits);
            if w < word {
                below += countOneBits(bits);
            } else if w == word {
                below += countOneBits(bits & (bit - 1u));
            }
        }
        if touches {
            list[listed + below] = index;
        }
        workgroupBarrier();
        if thread < CHUNK_WORDS {
            atomicStore(&chunk_bits[thread], 0u);
        }
        if thread == 0u {
            list_count = listed + total;
        }
        // Shade the list when another chunk might not fit, and at the end.
        let filled = workgroupUniformLoad(&list_count);
        let last = first + TILED_CHUNK >= count;
        if filled > TILED_LIST_CAPACITY - TILED_CHUNK || (last && filled > 0u) {
            if lit {
#ifdef MSAA
                color += shade_msaa(id.xy, samples, centre, filled, false);
#else
                color += shade_listed(texel, filled);
#endif
            }
            // Everyone has read the list before the next chunk writes it:
            // the next `workgroupUniformLoad` is a barrier.
            if thread == 0u {
                list_count = 0u;
            }
        }
    }
    if in_image {
        textureStore(hdr, id.xy, vec4f(color, 1.0));
    }
}
