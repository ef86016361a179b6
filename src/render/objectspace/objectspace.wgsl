// What the object-space passes share: the atlas table, the tile buffers, the
// visibility buffer, and the per-pixel mip selection that tile marking and
// gathering must compute identically.
#define_import_path shadespace::objectspace
#import shadespace::contract::{MAX_LEVELS, TILE_COUNTER_SLOTS, TILE_COUNTER_WORDS, COUNTER_STRIPES, BLOCK_SIDE,
    AGE_BUCKETS}
#import shadespace::scene_bindings::{vertices, objects, triangle_vertices, object_clip_position}
#import shadespace::scene::vertex_uv0
#import shadespace::pixel_surface::{PixelSample, interpolate2}
#ifdef MSAA
#import shadespace::pixel_surface::standard_sample_position
#endif

struct AtlasLevel {
    size: u32,
    // Virtual index of the level's first page (pages are numbered in blocks
    // of BLOCK_SIDE x BLOCK_SIDE), and global index of its first tile.
    page_base: u32,
    tile_base: u32,
    pad: u32,
}

// Mirrors `objectspace::atlas::GpuAtlasEntry` (and `AtlasLevel` its
// `GpuAtlasLevel`).
struct AtlasEntry {
    size: u32,
    level_count: u32,
    valid_since: u32,
    mip_bias: f32,
    levels: array<AtlasLevel, MAX_LEVELS>,
}

// Mirrors `objectspace::resources::GpuParams`.
struct Params {
    // frame + 1: 0 in the stamp buffers means "never".
    stamp: u32,
    // Re-shade a visible tile when its shade is this many frames old (N).
    reuse: u32,
    tile_size: u32,
    // 0 = shade, else a debug view (see gather.wgsl).
    view_mode: u32,
    mip_bias: f32,
    // Strength of the per-pixel variable-rate bias (0 = off).
    variable_rate: f32,
    max_queue: u32,
    // 1: a due tile waits for its phase frame (decoupled shading rate).
    spread: u32,
    page_size: u32,
    // Physical pages, and pages per layer side of the physical atlas.
    physical_pages: u32,
    layer_pages: u32,
    // Virtual page numbers (a multiple of the block's pages).
    virtual_pages: u32,
    // Word of `page_requests` where the tile bits start.
    request_tile_base: u32,
    // Chunks of the page table.
    table_chunks: u32,
    // Slots of the page request list (the budget's pages, whatever the
    // atlas's size now: a shrunk atlas still lists what the frame asks).
    request_capacity: u32,
    // Stamp of the first frame with this frame's view (camera): with reuse
    // above 1, a tile shaded since then keeps its shade (it would be the same).
    view_since: u32,
    // Width of the band of levels over which a pixel blends the two levels
    // around its footprint (0: the rounded level alone; 1: trilinear).
    level_blend: f32,
    // How the gather filters a level (`GatherFilter::code`): FILTER_BILINEAR
    // over 2x2 texels, else a cubic over 4x4 (marking marks one texel more
    // each side).
    gather_filter: u32,
    // Points per side of a texel that shading averages (1: its centre alone).
    texel_sample_side: u32,
    // Most gather taps along the footprint's longer axis (`--os-aniso`; 1:
    // isotropic, the level follows the longer axis).
    aniso: u32,
    // Under MSAA, which samples share a gather point (`sample_group`):
    // MSAA_GATHER_PIXEL or MSAA_GATHER_SAMPLE (`--os-msaa-gather`).
    msaa_gather: u32,
}

const MSAA_GATHER_PIXEL: u32 = 0u;
const MSAA_GATHER_SAMPLE: u32 = 1u;

const FILTER_BILINEAR: u32 = 0u;
const FILTER_BSPLINE: u32 = 1u;
const FILTER_MITCHELL: u32 = 2u;

// Texels the gather's filter reads beyond the bilinear pair on each side.
fn filter_margin() -> u32 {
    return select(1u, 0u, params.gather_filter == FILTER_BILINEAR);
}

@group(1) @binding(0) var<uniform> params: Params;
@group(1) @binding(1) var<storage, read> atlas_entries: array<AtlasEntry>;
// Per physical tile: stamp of the last frame it was visible.
@group(1) @binding(2) var<storage, read_write> tile_visible: array<atomic<u32>>;
// Per physical tile: stamp of the last frame it was shaded (the cache age).
@group(1) @binding(3) var<storage, read_write> tile_shaded: array<u32>;
// The shade queue, per physical tile: (global virtual tile, object << 8 |
// level), this frame's where `tile_shaded` holds this frame's stamp; the
// shade list names the queued ones.
@group(1) @binding(4) var<storage, read_write> queue: array<vec2u>;
// Indexed by the `COUNT_*` constants; then COUNTER_STRIPES copies of them,
// which `count` spreads counts over (the CPU sums them).
@group(1) @binding(5) var<storage, read_write> counters: array<atomic<u32>, TILE_COUNTER_WORDS>;

// This invocation's copy of the counters for `count` (`set_stripe`).
var<private> stripe: u32;

// Spreads this invocation's counts over the stripes by its workgroup's
// linear index: neighbouring workgroups, which run together, add to
// different words.
fn set_stripe(workgroup: vec3u, groups: vec3u) {
    stripe = (workgroup.y * groups.x + workgroup.x) % COUNTER_STRIPES;
}

// Adds `n` to counter `counter` in this invocation's stripe: for counts
// that many workgroups add to in one pass (atomics on one word serialize,
// about one a clock); read them on the CPU, summed (`TileCounter::fold`),
// never on the GPU.
fn count(counter: u32, n: u32) {
    atomicAdd(&counters[TILE_COUNTER_SLOTS * (1u + stripe) + counter], n);
}
// Visibility buffer: (object + 1, triangle); 0 = background. Under MSAA one
// per sample: multisampled from the raster pass, a layer per sample from
// the compute rasterizer (`VISIBILITY_LAYERS`). Read with `visibility_ids`.
#ifdef MSAA
#ifdef VISIBILITY_LAYERS
@group(1) @binding(6) var visibility: texture_2d_array<u32>;
#else
@group(1) @binding(6) var visibility: texture_multisampled_2d<u32>;
#endif
#else
@group(1) @binding(6) var visibility: texture_2d<u32>;
#endif

// The ids of sample `s` of `pixel` (without MSAA, where `s` is 0: the pixel's).
fn visibility_ids(pixel: vec2u, s: u32) -> vec2u {
#ifdef VISIBILITY_LAYERS
    return textureLoad(visibility, pixel, s, 0).xy;
#else
    return textureLoad(visibility, pixel, s).xy;
#endif
}

#ifdef MSAA
// Samples per pixel of the visibility buffer.
fn visibility_samples() -> u32 {
#ifdef VISIBILITY_LAYERS
    return textureNumLayers(visibility);
#else
    return textureNumSamples(visibility);
#endif
}
#endif
// Per triangle of the scene's index buffer: its chart island (a number
// shared by the triangles of one island of its mesh's chart UVs).
@group(1) @binding(7) var<storage, read> triangle_charts: array<u32>;

// What the shade pass writes in a texel's alpha: its triangle's chart
// island `island` as a half float (0 where no triangle covers it), so the
// gather's island filter reads it with the shade instead of the triangle
// map. The half floats' bit patterns from 1024 are normal numbers, each its
// own value: codes for islands below `gather::ISLAND_CODES`, one each.
fn island_code(island: u32) -> f32 {
    return unpack2x16float(1024u + island).x;
}
// The page table's second level: chunks of one word per page of a block,
// its physical page + 1 (0 = not backed); a block's chunk is found in
// `page_directory`.
@group(1) @binding(8) var<storage, read_write> page_table: array<u32>;
// Per physical page: stamp of the last frame a visible tile used it.
@group(1) @binding(9) var<storage, read_write> page_used: array<atomic<u32>>;
// Per physical page: the virtual page it backs + 1; 0 = free.
@group(1) @binding(10) var<storage, read_write> page_owner: array<u32>;
// Request bits: one per virtual page (it was listed in `request_list`
// this frame), then, from word `params.request_tile_base`, one per virtual
// tile (this frame's pixels need it while its page has no physical page).
@group(1) @binding(11) var<storage, read_write> page_requests: array<atomic<u32>>;
// This frame's requests (at most one per physical page): (virtual page, object << 8 | level).
@group(1) @binding(12) var<storage, read_write> request_list: array<vec2u>;
// Physical pages that may be taken this frame, oldest first.
@group(1) @binding(13) var<storage, read_write> candidates: array<u32>;
// Pages backed this frame: (virtual page, object << 8 | level, physical page, 0).
@group(1) @binding(14) var<storage, read_write> backed: array<vec4u>;

// Mirrors `objectspace::resources::GpuViewSlot`.
struct ViewSlot {
    index: u32,
    count: u32,
    pad_a: u32,
    pad_b: u32,
}

// The view this pass records for (several views mark into one atlas). A
// storage buffer, not a second uniform: lavapipe (Mesa 22.3) crashes on a
// second uniform buffer in this group.
@group(1) @binding(15) var<storage, read> view_slot: ViewSlot;
// Per physical tile: the views that marked it this frame, one bit each.
@group(1) @binding(16) var<storage, read_write> tile_views: array<atomic<u32>>;
// The page table's first level: per block of pages, its chunk + 1 (0 = no
// page of the block is backed).
#ifdef DIRECTORY_ATOMIC
@group(1) @binding(17) var<storage, read_write> page_directory: array<atomic<u32>>;
#else
// Passes that do not write the directory (all but paging's) read it with
// plain loads, which the GPU may cache: an atomic load goes to L2 every
// time, and marking and the gather read it for every pixel.
@group(1) @binding(17) var<storage, read_write> page_directory: array<u32>;
#endif

// The directory's word for block `block`: its chunk + 1, or 0.
fn directory_word(block: u32) -> u32 {
#ifdef DIRECTORY_ATOMIC
    return atomicLoad(&page_directory[block]);
#else
    return page_directory[block];
#endif
}

// A chunk's state, kept by the GPU alone (tests read it back as
// `debug::PageTableState::chunks`).
struct TableChunk {
    // Backed pages whose table word is in the chunk (0: the chunk is free).
    pages: atomic<u32>,
    // The block whose chunk it is + 1 (0 = free).
    block: u32,
}

@group(1) @binding(18) var<storage, read_write> table_chunks: array<TableChunk>;
// This frame's free chunks (their count in COUNT_FREE_CHUNKS).
@group(1) @binding(19) var<storage, read_write> free_chunks: array<u32>;
// This frame's queued physical tiles, COUNT_QUEUED of them, for the shade
// pass's dispatch: appended by marking, a workgroup's with one atomic (one
// per tile, 28,000 a frame along Sponza's path at 1920x1080, would
// serialize on the word), and by the backed pages' marking.
@group(1) @binding(20) var<storage, read_write> shade_list: array<u32>;

const BLOCK_PAGES: u32 = BLOCK_SIDE * BLOCK_SIDE;

// Bucket 0: free pages; 1: unused for 128 frames or more; ...; 8: used last frame.
fn age_bucket(page: u32) -> u32 {
    if page_owner[page] == 0u {
        return 0u;
    }
    let age = params.stamp - atomicLoad(&page_used[page]);
    return AGE_BUCKETS - 1u - min(firstLeadingBit(age), AGE_BUCKETS - 2u);
}

// The table word of virtual page `page`, which is backed (its block has a chunk).
fn table_word(page: u32) -> u32 {
    return (directory_word(page / BLOCK_PAGES) - 1u) * BLOCK_PAGES + page % BLOCK_PAGES;
}

// Takes physical page `physical` from the virtual page it backs, if any (a
// chunk left with no page is freed by paging's next ranking, `release_chunk`).
fn unbind_page(physical: u32) {
    let owner = page_owner[physical];
    if owner == 0u {
        return;
    }
    let word = table_word(owner - 1u);
    page_table[word] = 0u;
    page_owner[physical] = 0u;
    atomicSub(&table_chunks[word / BLOCK_PAGES].pages, 1u);
}

const NOT_BACKED: u32 = 0xffffffffu;

// Pages per row of level `l` (the last row and column may be partly outside it).
fn pages_per_row(l: AtlasLevel) -> u32 {
    return (l.size + params.page_size - 1u) / params.page_size;
}

// Blocks per row of level `l`.
fn blocks_per_row(l: AtlasLevel) -> u32 {
    return (pages_per_row(l) + BLOCK_SIDE - 1u) / BLOCK_SIDE;
}

// Virtual page of texel `texel` of level `l` (mirrors `AtlasLevel::page_number`).
fn virtual_page(l: AtlasLevel, texel: vec2u) -> u32 {
    let p = texel / params.page_size;
    let b = p / BLOCK_SIDE;
    let i = p % BLOCK_SIDE;
    return l.page_base + (b.y * blocks_per_row(l) + b.x) * BLOCK_PAGES + i.y * BLOCK_SIDE + i.x;
}

// First texel (level-local) of virtual page `page` of level `l` (mirrors
// `AtlasLevel::page_position`).
fn page_origin(l: AtlasLevel, page: u32) -> vec2u {
    let local = page - l.page_base;
    let block = local / BLOCK_PAGES;
    let i = local % BLOCK_PAGES;
    let b = vec2u(block % blocks_per_row(l), block / blocks_per_row(l));
    return (b * BLOCK_SIDE + vec2u(i % BLOCK_SIDE, i / BLOCK_SIDE)) * params.page_size;
}

// The physical page backing virtual page `page`, or NOT_BACKED: the block's
// chunk from the directory, the page's word in the chunk.
fn physical_page(page: u32) -> u32 {
    let chunk = directory_word(page / BLOCK_PAGES);
    if chunk == 0u {
        return NOT_BACKED;
    }
    return page_table[(chunk - 1u) * BLOCK_PAGES + page % BLOCK_PAGES] - 1u;
}

// Virtual page `page`'s request bit: (word, mask).
fn page_request_bit(page: u32) -> vec2u {
    return vec2u(page / 32u, 1u << (page % 32u));
}

// Virtual tile `tile`'s request bit: (word, mask).
fn tile_request_bit(tile: u32) -> vec2u {
    return vec2u(params.request_tile_base + tile / 32u, 1u << (tile % 32u));
}

// Global virtual tile of texel `texel` of level `l`.
fn virtual_tile(l: AtlasLevel, texel: vec2u) -> u32 {
    let t = texel / params.tile_size;
    return l.tile_base + t.y * (l.size / params.tile_size) + t.x;
}

// Level-local first texel of tile `t` (row-major) of the page at `origin`;
// outside the level when the page is only partly in it.
fn page_tile_origin(origin: vec2u, t: u32) -> vec2u {
    let per_row = params.page_size / params.tile_size;
    return origin + vec2u(t % per_row, t / per_row) * params.tile_size;
}

// Forgets virtual page `page` of level `l`'s request (it found no physical
// page: a later frame asks again): its page bit first, then its tiles'
// bits, so that a pixel setting a tile bit in between lists the page again
// rather than finding it listed.
fn forget_request(l: AtlasLevel, page: u32) {
    let p = page_request_bit(page);
    atomicAnd(&page_requests[p.x], ~p.y);
    let origin = page_origin(l, page);
    let per_row = params.page_size / params.tile_size;
    for (var t = 0u; t < per_row * per_row; t++) {
        let texel = page_tile_origin(origin, t);
        if all(texel < vec2u(l.size)) {
            let b = tile_request_bit(virtual_tile(l, texel));
            atomicAnd(&page_requests[b.x], ~b.y);
        }
    }
}

// Index of texel `texel`'s tile inside its page.
fn tile_in_page(texel: vec2u) -> u32 {
    let per_row = params.page_size / params.tile_size;
    let t = (texel % params.page_size) / params.tile_size;
    return t.y * per_row + t.x;
}

// Physical tile (index into the tile stamps) of texel `texel` on physical page `page`.
fn physical_tile(page: u32, texel: vec2u) -> u32 {
    let per_page = (params.page_size / params.tile_size) * (params.page_size / params.tile_size);
    return page * per_page + tile_in_page(texel);
}

// Where texel `texel` (level-local) lies on physical page `page`: (x, y) and layer.
struct AtlasTexel {
    xy: vec2u,
    layer: u32,
}

fn atlas_texel(page: u32, texel: vec2u) -> AtlasTexel {
    let per_layer = params.layer_pages * params.layer_pages;
    let i = page % per_layer;
    var out: AtlasTexel;
    out.layer = page / per_layer;
    out.xy = vec2u(i % params.layer_pages, i / params.layer_pages) * params.page_size + texel % params.page_size;
    return out;
}

// Chart UV of the pixel and its screen derivatives.
struct ChartFootprint {
    uv: vec2f,
    du_dx: vec2f,
    du_dy: vec2f,
}

fn chart_footprint(p: PixelSample) -> ChartFootprint {
    let a = vertices[p.tri.x].chart_uv;
    let c = vertices[p.tri.y].chart_uv;
    let d = vertices[p.tri.z].chart_uv;
    var f: ChartFootprint;
    f.uv = interpolate2(p.b, a, c, d);
    f.du_dx = interpolate2(p.b_dx, a, c, d) - f.uv;
    f.du_dy = interpolate2(p.b_dy, a, c, d) - f.uv;
    return f;
}

// Variable rate: a positive bias (coarser shading) where the triangle is flat,
// none where its vertex normals diverge.
fn variable_rate_bias(p: PixelSample) -> f32 {
    if params.variable_rate <= 0.0 {
        return 0.0;
    }
    let n0 = normalize(vertices[p.tri.x].normal);
    let n1 = normalize(vertices[p.tri.y].normal);
    let n2 = normalize(vertices[p.tri.z].normal);
    let min_dot = min(dot(n0, n1), min(dot(n1, n2), dot(n0, n2)));
    let curvature = clamp((1.0 - min_dot) * 8.0, 0.0, 1.0);
    return params.variable_rate * (1.0 - curvature);
}

// The mip level a pixel shades at and gathers from:
// round(log2(max(major / N, minor) * size) + biases), clamped to the levels,
// where major and minor are the lengths of the longer and shorter of
// dUV/dx, dUV/dy and N is `params.aniso` (1: the longer axis alone).
// Level-0 texels per gather tap, as a level: log2 of it (negative where
// level 0 is magnified). With N = 1, log2(max(|dUV/dx|, |dUV/dy|) * size)
// bit for bit (x / 1 is x).
fn footprint_level(e: AtlasEntry, f: ChartFootprint) -> f32 {
    let a = length(f.du_dx);
    let b = length(f.du_dy);
    let rho = max(max(a, b) / f32(params.aniso), min(a, b)) * f32(e.size);
    return log2(max(rho, 1e-8));
}

// Where the gather reads a pixel's shade (`--os-aniso`): `count` chart
// points spread evenly along the footprint's longer axis `axis` (one
// pixel's dUV along it), centred on `uv`, each filtered at the pixel's
// levels and averaged with equal weights. Marking marks every tap's
// footprint from the same arithmetic.
struct AnisoTaps {
    uv: vec2f,
    axis: vec2f,
    count: u32,
}

// The taps of footprint `f` of object entry `e`: as many as the longer axis
// spans texels of the level the pixel reads (level 0 at least), up to N;
// one, at `uv`, with N = 1. Both axes are first capped at what the object's
// coarsest level resolves, the longer at N of its texels and the shorter at
// one: a pixel whose footprint is wider than that (its neighbours' rays
// meet the triangle's plane far off the triangle, at a silhouette or a
// grazing edge) reads the coarsest level anyway, and its taps would reach
// far past the surface it sees, at chart points the footprint's rounding
// moves by texels. Below the cap the taps are as without it, bit for bit.
fn aniso_taps(e: AtlasEntry, f: ChartFootprint) -> AnisoTaps {
    var out: AnisoTaps;
    out.uv = f.uv;
    out.count = 1u;
    out.axis = vec2f(0.0);
    if params.aniso <= 1u {
        return out;
    }
    let a = length(f.du_dx);
    let b = length(f.du_dy);
    // Level-0 texels of one texel of the coarsest level.
    let coarsest = f32(1u << (e.level_count - 1u));
    let longer = max(a, b) * f32(e.size);
    let major = min(longer, f32(params.aniso) * coarsest);
    let minor = min(min(a, b) * f32(e.size), coarsest);
    let per_tap = max(max(major / f32(params.aniso), minor), 1.0);
    out.count = clamp(u32(ceil(major / per_tap)), 1u, params.aniso);
    out.axis = select(f.du_dy, f.du_dx, a >= b);
    if longer > major {
        out.axis *= major / longer;
    }
    return out;
}

// Chart point of tap `i` of `t`: at (i + 0.5) / count - 0.5 of the axis
// from the centre (the centre itself for one tap).
fn aniso_tap(t: AnisoTaps, i: u32) -> vec2f {
    if t.count == 1u {
        return t.uv;
    }
    return t.uv + t.axis * ((f32(i) + 0.5) / f32(t.count) - 0.5);
}

fn select_level(e: AtlasEntry, p: PixelSample, f: ChartFootprint) -> u32 {
    let lod = footprint_level(e, f) + params.mip_bias + e.mip_bias + variable_rate_bias(p);
    return u32(clamp(round(lod), 0.0, f32(e.level_count - 1u)));
}

// The levels a pixel shades at and gathers from: `lo`, and `hi` (lo + 1, or
// lo at the last level) with weight `t`. A pixel uses `lo` where t < 1 and
// `hi` where t > 0: marking and gathering must agree on both.
struct LevelPair {
    lo: u32,
    hi: u32,
    t: f32,
}

// With no blend, the rounded level alone (`select_level`): where a pixel's
// level crosses x.5 between frames its shade jumps to a level twice as
// coarse or fine. With blend width w, the weight of the coarser level rises
// from 0 to 1 over the w levels around x.5 (w = 1: trilinear, the weight is
// the level's fraction), so the shade changes smoothly.
fn select_levels(e: AtlasEntry, p: PixelSample, f: ChartFootprint) -> LevelPair {
    var out: LevelPair;
    if params.level_blend <= 0.0 {
        out.lo = select_level(e, p, f);
        out.hi = out.lo;
        out.t = 0.0;
        return out;
    }
    let lod = footprint_level(e, f) + params.mip_bias + e.mip_bias + variable_rate_bias(p);
    let clamped = clamp(lod, 0.0, f32(e.level_count - 1u));
    let base = floor(clamped);
    out.lo = u32(base);
    out.hi = min(out.lo + 1u, e.level_count - 1u);
    out.t = clamp((clamped - base - 0.5) / params.level_blend + 0.5, 0.0, 1.0);
    if out.hi == out.lo {
        out.t = 0.0;
    }
    return out;
}

// Level `level` of object `object`'s atlas entry, read through the storage
// buffer: a copy of the entry indexed by a runtime level would go through
// the whole levels array (naga spills a dynamically indexed value array to
// function memory).
fn entry_level(object: u32, level: u32) -> AtlasLevel {
    return atlas_entries[object].levels[level];
}

// The bilinear footprint at a level: top-left texel (level-local, clamped so
// that both taps lie in the level) and the weight of the right/lower taps.
struct Bilinear {
    texel: vec2i,
    texel_hi: vec2i,
    weight: vec2f,
}

fn bilinear(l: AtlasLevel, uv: vec2f) -> Bilinear {
    let s = i32(l.size);
    let t = uv * f32(l.size) - 0.5;
    let base = floor(t);
    var out: Bilinear;
    out.weight = t - base;
    out.texel = clamp(vec2i(base), vec2i(0), vec2i(s - 1));
    out.texel_hi = clamp(vec2i(base) + 1, vec2i(0), vec2i(s - 1));
    return out;
}

// Whether two visibility-buffer ids (object + 1, triangle) see one chart
// surface: both background, or one object's triangles in one chart island
// (whose shades are continuous, so a pixel whose samples all do is marked
// and gathered once under MSAA).
fn same_chart_surface(a: vec2u, b: vec2u) -> bool {
    if a.x != b.x {
        return false;
    }
    if a.x == 0u || a.y == b.y {
        return true;
    }
    let first = objects[a.x - 1u].first_index / 3u;
    return triangle_charts[first + a.y] == triangle_charts[first + b.y];
}

#ifdef MSAA
// Samples of a pixel that marking and the gather treat as one point.
struct SampleGroup {
    // The ids of its first sample (its object and the triangle whose plane
    // the point is rebuilt on); x = 0: background.
    ids: vec2u,
    // The point marked and gathered (0..1 in the pixel): the centroid of
    // the samples' positions, the pixel's centre when they are all its samples.
    at: vec2f,
    // Its samples (the weight of its gather in the pixel's resolve).
    count: u32,
    // The samples of `left` not in it.
    left: u32,
}

// The group of the lowest sample in `left` (a bit per sample of `pixel`,
// `n` samples): with MSAA_GATHER_PIXEL the samples of `left` that see that
// sample's chart surface (`same_chart_surface`), with MSAA_GATHER_SAMPLE the
// sample alone. Marking and the gather both call this, so they mark and read
// the same points bit for bit.
fn sample_group(pixel: vec2u, n: u32, left: u32) -> SampleGroup {
    let first = firstTrailingBit(left);
    let ids = visibility_ids(pixel, first);
    var mask = 1u << first;
    if params.msaa_gather == MSAA_GATHER_PIXEL {
        for (var s = first + 1u; s < n; s++) {
            if (left & (1u << s)) != 0u && same_chart_surface(visibility_ids(pixel, s), ids) {
                mask |= 1u << s;
            }
        }
    }
    let count = countOneBits(mask);
    var at = vec2f(0.5);
    if count < n {
        var sum = vec2f(0.0);
        for (var s = first; s < n; s++) {
            if (mask & (1u << s)) != 0u {
                sum += standard_sample_position(n, s);
            }
        }
        at = sum / f32(count);
    }
    return SampleGroup(ids, at, count, left & ~mask);
}
#endif

// A vertex of an alpha-blended object in object space's raster passes over
// them (`objectspace::blended`), which draw without the index buffer: vertex
// `k` of the draw is corner k % 3 of triangle k / 3, and the fragments carry
// the ids a visibility buffer would hold for them.
struct BlendedVertex {
    @builtin(position) @invariant clip: vec4f,
    // (object + 1, triangle), as in the visibility buffer; UV0 (the opacity).
    @location(0) @interpolate(flat) ids: vec2u,
    @location(1) texcoord: vec2f,
}

fn blended_vertex(k: u32, object: u32) -> BlendedVertex {
    let triangle = k / 3u;
    let vi = triangle_vertices(objects[object], triangle)[k % 3u];
    var out: BlendedVertex;
    out.clip = object_clip_position(object, vi);
    out.ids = vec2u(object + 1u, triangle);
    out.texcoord = vertex_uv0(vertices[vi]);
    return out;
}
