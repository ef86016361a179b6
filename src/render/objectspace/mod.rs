//! Object-space (texel) shading: visible surface tiles are shaded by compute
//! into per-object squares of a shared atlas, reused across frames, and the
//! frame is gathered from those shades.
//!
//! Each object's shading texture is virtual ([`atlas`]): only the pages
//! visible tiles need are backed by pages of one physical atlas, which the
//! GPU allocates and evicts (least recently used) itself.
//!
//! Per frame ([`ObjectSpace::encode`]): *visibility* (object and triangle id
//! per pixel: hardware raster after an optional depth pre-pass, or the
//! compute rasterizer) -> *mark*
//! (compute per 2x2 pixels: mip level, bilinear footprint, tiles marked
//! visible; the first marker of a tile queues it when its shade is `reuse`
//! frames old or stale; tiles on pages with no physical page request one)
//! -> *paging* (requested pages get physical pages) -> *triangle maps* of
//! the pages backed this frame -> *mark backed* (their requested tiles) ->
//! *queue* (the queued tiles packed) -> *shade* (one workgroup per queued
//! tile, indirect) -> *gather* (compute per 2x2 pixels: bilinear from the
//! atlas, at the chart point and levels marking recorded). Mark through
//! gather are stages of one compute pass (fewer pass boundaries; wgpu puts
//! the barriers between its dispatches). Texels are lit by
//! the global lights and the lights of their cell of the world grid (Oxide's
//! light matrix), built on the GPU when the lights change; no CPU light culling. No
//! CPU read-back inside the frame: the counters are copied out and read a few
//! frames later. Alpha-blended objects, which are not in the visibility
//! buffer, are marked and gathered by raster passes over them ([`blended`]).

pub mod atlas;
pub mod atlas_view;
pub mod blended;
pub mod budget;
pub mod cpu;
pub mod debug;
pub mod gather;
pub mod mark;
pub mod paging;
pub mod reach;
pub mod residency;
pub mod resources;
pub mod shade;
pub mod slots;
pub mod trimap;

use blended::{BlendedObjects, gather_blended, mark_blended};
use budget::Budget;
use std::str::FromStr;

use serde::Serialize;

use super::culling::Frustum;
use super::frame::Frame;
use super::gpu_types::GpuView;
use super::passes::background::{Background, Coverage, background};
use super::passes::depth_prepass::{DepthPrepass, culled_depth_prepass};
use super::passes::light_grid::LightGrid;
use super::passes::light_grid::world::{WorldGrid, build_world_grid};
use super::passes::visibility::VisibilityBuffer;
use super::passes::visibility::compute::{ComputeVisibility, ComputeVisibilityError, compute_visibility};
use super::passes::visibility::{VisibilityMethod, VisibilityPass, visibility};
use super::report::{Counters, ObjectMemory, PipelineReport};
use super::scene_gpu::SceneGpu;
use super::scene_gpu::gpu_view;
use super::targets::Targets;
use super::{Pipeline, PipelineConfig};
use crate::gpu::GpuContext;
use crate::gpu::readback::ReadbackRing;
use crate::scene::{Camera, Scene};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};
use atlas::{AtlasError, AtlasLayout, PagePool};
use atlas_view::{AtlasPages, AtlasPagesError, AtlasViewPass, draw_atlas_pages};
use gather::{GatherPass, gather};
use mark::{MarkPass, mark_backed_pages, mark_tiles, write_shade_args};
use paging::resize::{ResizePass, compact_pages, copy_pages};
use paging::{PagingPass, back_pages, release_slots};
use residency::Residency;
use resources::Resources;
use shade::{ShadePass, shade_tiles};
use slots::Slots;
use trimap::{TrimapPass, build_triangle_maps};

/// The WGSL modules every object-space pass imports (`shadespace::objectspace`,
/// `shadespace::objectspace_dispatch`, `shadespace::objectspace_mark_backed`).
pub const SHARED_WGSL: [ShaderSource; 3] = [
    ShaderSource::new("objectspace.wgsl", include_str!("objectspace.wgsl")),
    ShaderSource::new("dispatch.wgsl", include_str!("dispatch.wgsl")),
    mark::MARK_BACKED_WGSL,
];

/// The object-space pass shaders, for the test that validates every shader.
pub const PASS_SHADERS: &[ShaderSource] = &[
    mark::SHADER,
    // paging::SHADER: only with its defs (`paging::VARIANTS`).
    paging::RELEASE_SHADER,
    paging::resize::SHADER,
    trimap::SHADER,
    shade::SHADER,
    gather::SHADER,
    atlas_view::SHADER,
];

/// Texture sides that texel densities clamp to (`--texture-size` may go to
/// [`atlas::MAX_TEXTURE_SIZE`]).
pub const MAX_DENSITY_SIZE: u32 = 8192;
/// Mip chains stop at this side: the procedural scenes' chart gutters are
/// 1/128 of the square and generated charts have 4 texels at 256 or more, so
/// below 128 texels neighbouring charts would share texels (objects charted
/// as one island go on down to one tile: `coarsest_levels`).
pub const COARSEST_LEVEL: u32 = 128;
/// The coarsest level's side per object: [`COARSEST_LEVEL`], or one tile
/// (the layout raises it to the tile size) for an object whose chart is one
/// island, a terrain patch say: with no neighbouring chart to share texels
/// with, its levels may go on down, so that a distant patch covering a few
/// pixels is not shaded at 128 x 128 texels. Instances of a mesh that
/// several objects share go down to one tile too: there are many of them,
/// mostly far (a city's buildings), and a floor of 128 x 128 texels each
/// made the texels a frame sees grow with the instances in view rather
/// than with the pixels (the default city seen from above at 320x180:
/// 16,399 tiles, the atlas full, against 5,481 tiles); at levels where
/// neighbouring charts share texels the gather keeps each pixel's taps
/// within its own chart island.
fn coarsest_levels(scene: &Scene) -> Vec<u32> {
    let mut users = vec![0usize; scene.meshes.len()];
    for o in &scene.objects {
        users[o.mesh] += 1;
    }
    let down_to_a_tile: Vec<bool> = scene
        .meshes
        .iter()
        .zip(&users)
        .map(|(m, &users)| {
            users > 1
                || m.uv1.as_ref().is_some_and(|uv| {
                    let islands = crate::charts::islands::triangle_islands(&m.indices, uv);
                    islands.iter().all(|&i| Some(&i) == islands.first())
                })
        })
        .collect();
    scene.objects.iter().map(|o| if down_to_a_tile[o.mesh] { 1 } else { COARSEST_LEVEL }).collect()
}

/// Default page side of the virtual textures (raised to the tile size).
/// Pages of one tile: the pages in use hold just the visible texels (on
/// Sponza at 1920x1080, pages of 16 hold 1.6 times them, 3.0 at 32). The
/// two-level page table keeps the four times more pages cheap (7.6 MB at
/// 1080p against 2.4 MB at 16, most of it one chunk per physical page).
pub const DEFAULT_PAGE_SIZE: u32 = 8;
/// Default physical atlas at 1920x1080: this many texels per screen pixel.
/// Sponza along its path at the default density sees 1.36 M texels in
/// visible tiles (median; 1.16 M at path frame 120), on pages of one tile:
/// the atlas (2.1 M) holds them with room for newly visible pages, at
/// most 2x their bytes on all but the emptiest frames.
pub const DEFAULT_TEXELS_PER_PIXEL: f64 = 1.0;
/// ... and at least this many texels (12 MiB of shades and triangle maps):
/// small frames need room for the few tiles each of many charts.
pub const MIN_DEFAULT_ATLAS_TEXELS: u64 = 1 << 20;

/// The default physical atlas for a frame of `pixels` pixels: it grows as
/// the square root of the pixels, as the texels a frame sees do (Sponza at
/// 3840x2160 sees 2.58 M texels, 2.0 times 1920x1080 for 4 times the pixels:
/// near surfaces reach their finest level).
pub fn default_atlas_texels(pixels: u64) -> u64 {
    let reference = 1920.0 * 1080.0;
    let texels = DEFAULT_TEXELS_PER_PIXEL * reference * (pixels as f64 / reference).sqrt();
    (texels as u64).max(MIN_DEFAULT_ATLAS_TEXELS)
}

/// The largest physical atlas `--atlas-budget` takes, Mi texels (192 GiB
/// with the triangle maps: past any adapter's memory).
pub const MAX_ATLAS_BUDGET_MI: u64 = 1 << 14;

/// The page budget: past this share of the physical pages in use, the mip
/// bias rises (the rest is room for newly visible pages).
const PAGE_FILL: f64 = 0.95;

/// Debug views that replace the gathered shade (`render --view`); the values
/// are exported to WGSL as `VIEW_*`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DebugView {
    /// The shaded image.
    #[default]
    Shade = 0,
    /// Chart UV as red/green.
    ChartUv = 1,
    /// Mip level per pixel (red = 0, orange = 1, yellow = 2, ...).
    MipLevel = 2,
    /// Tile mask: red tiles were shaded this frame, green ones reused.
    TileMask = 3,
    /// Cache age of the tile: black = shaded this frame, white = `reuse` frames old.
    CacheAge = 4,
    /// One object's virtual shading texture at one mip level, through the
    /// page table: backed pages show their shades, the others a dark
    /// checker ([`atlas_view`]).
    AtlasPages = 5,
}

impl DebugView {
    pub const ALL: [Self; 6] =
        [Self::Shade, Self::ChartUv, Self::MipLevel, Self::TileMask, Self::CacheAge, Self::AtlasPages];

    /// The name `--view` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Shade => "shade",
            Self::ChartUv => "chart-uv",
            Self::MipLevel => "mip-level",
            Self::TileMask => "tile-mask",
            Self::CacheAge => "cache-age",
            Self::AtlasPages => "atlas-pages",
        }
    }

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Shade => "VIEW_SHADE",
            Self::ChartUv => "VIEW_CHART_UV",
            Self::MipLevel => "VIEW_MIP_LEVEL",
            Self::TileMask => "VIEW_TILE_MASK",
            Self::CacheAge => "VIEW_CACHE_AGE",
            Self::AtlasPages => "VIEW_ATLAS_PAGES",
        }
    }
}

impl FromStr for DebugView {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|v| v.name() == s).ok_or_else(|| {
            let names: Vec<_> = Self::ALL.iter().map(|v| v.name()).collect();
            format!("'{s}' is not a view ({})", names.join(", "))
        })
    }
}

/// The GPU's tile and page counters, one `u32` slot each (exported to WGSL
/// as `COUNT_*`), followed by the paging pass's age buckets.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileCounter {
    /// Tiles queued for shading this frame.
    Queued = 0,
    /// Tiles some pixel needs this frame.
    Visible = 1,
    /// Visible tiles that were not visible in the previous frame.
    New = 2,
    /// Physical pages already backing a page that visible tiles used.
    PagesUsed = 3,
    /// Virtual pages visible tiles needed that had no physical page.
    PagesRequested = 4,
    /// Requested pages that got a physical page this frame.
    PagesBacked = 5,
    /// Requested pages that found none (the atlas or the page table's
    /// chunks were full).
    PagesFailed = 6,
    /// Physical pages no visible tile used this frame (free or evictable).
    Candidates = 7,
    /// With several views: tiles on backed pages summed over the views (what
    /// independent views would each mark).
    ViewTiles = 8,
    /// Tiles marked on the pages backed this frame (after paging).
    BackedTiles = 9,
    /// Pixels shaded through the atlas (summed over the views).
    AtlasPixels = 10,
    /// Of those, pixels whose level holds fewer than one texel per pixel.
    UnderShadedPixels = 11,
    /// Page-table chunks free after this frame's evictions.
    FreeChunks = 12,
    /// Free chunks given to blocks this frame (or wanted: may exceed the free ones).
    ChunksTaken = 13,
    /// Page-table chunks in use after this frame's paging.
    TableChunks = 14,
    /// Pages whose triangle maps the triangle-map pass built this frame
    /// (the pages backed this frame that found no map to copy: none when
    /// none is new).
    TrimapPages = 15,
    /// With [`ObjectSpaceConfig::count_mark_atomics`]: tile marks the mark
    /// pass made in the global buffers (per pixel and tile of its footprint,
    /// or per distinct tile of a workgroup: [`Marking`]).
    MarkTiles = 25,
    /// With [`ObjectSpaceConfig::count_mark_atomics`]: the global atomics
    /// those marks issued (page table, requests, tile and page stamps,
    /// counters; not the per-workgroup pixel counts).
    MarkAtomics = 26,
    /// Chart-grid entries the triangle-map pass weighed for this frame's
    /// pages (each a triangle tested against a texel): over
    /// [`Self::TrimapPages`], the pass's work per page.
    TrimapWeighed = 27,
    /// With [`ObjectSpaceConfig::trimap_share`]: pages backed this frame
    /// whose triangle maps were copied from a page holding the map of the
    /// same mesh, level and page (another instance's, [`trimap`]).
    TrimapShared = 28,
    /// With [`ObjectSpaceConfig::count_mark_atomics`]: the mark pass's
    /// claims of a tile in its workgroup's table (one per pixel and tile of
    /// its footprint, or per distinct tile of a subgroup with
    /// [`Marking::Subgroup`]).
    MarkClaims = 29,
    /// Under MSAA, of [`Self::AtlasPixels`]: those marked (and gathered)
    /// at more than one point ([`MsaaGather`]: their samples see more than
    /// one surface, or background beside one; with
    /// [`MsaaGather::Sample`], every one with more than one sample covered).
    MsaaEdgePixels = 30,
    /// Under MSAA: the points marked (and gathered) on surfaces in the atlas.
    MsaaPoints = 31,
}

impl TileCounter {
    pub const ALL: [Self; 23] = [
        Self::Queued,
        Self::Visible,
        Self::New,
        Self::PagesUsed,
        Self::PagesRequested,
        Self::PagesBacked,
        Self::PagesFailed,
        Self::Candidates,
        Self::ViewTiles,
        Self::BackedTiles,
        Self::AtlasPixels,
        Self::UnderShadedPixels,
        Self::FreeChunks,
        Self::ChunksTaken,
        Self::TableChunks,
        Self::TrimapPages,
        Self::MarkTiles,
        Self::MarkAtomics,
        Self::TrimapWeighed,
        Self::TrimapShared,
        Self::MarkClaims,
        Self::MsaaEdgePixels,
        Self::MsaaPoints,
    ];
    /// First slot of the age buckets (free pages, then unused for 128 or
    /// more frames, 64-127, ..., 1 frame).
    pub const AGE_BUCKET_BASE: usize = 16;
    pub const AGE_BUCKETS: usize = 9;
    /// Slots in the counter buffer (a multiple of four: 16-byte rows).
    pub const SLOTS: usize = 32;
    /// Copies of the slots after the first that the counts many workgroups
    /// add to are spread over, by workgroup (`count` in `objectspace.wgsl`),
    /// and the CPU sums ([`Self::fold`]): atomics on one word serialize at
    /// about one a clock, and one word per counter made the mark pass wait
    /// on them (its own time fell from 0.146 to 0.055 ms at 1920x1080 on
    /// the H100 with them knocked out: BENCHMARKS.md, "Where marking's time
    /// goes").
    pub const STRIPES: usize = 64;
    /// Words of the counter buffer: the slots, then the stripes.
    pub const WORDS: usize = Self::SLOTS * (1 + Self::STRIPES);

    /// The counters from the counter buffer's words: each slot plus its
    /// stripes.
    pub fn fold(words: &[u32]) -> [u32; Self::SLOTS] {
        std::array::from_fn(|slot| {
            (0..=Self::STRIPES)
                .filter_map(|k| words.get(k * Self::SLOTS + slot))
                .fold(0u32, |sum, &w| sum.wrapping_add(w))
        })
    }

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Queued => "COUNT_QUEUED",
            Self::Visible => "COUNT_VISIBLE",
            Self::New => "COUNT_NEW",
            Self::PagesUsed => "COUNT_PAGES_USED",
            Self::PagesRequested => "COUNT_PAGES_REQUESTED",
            Self::PagesBacked => "COUNT_PAGES_BACKED",
            Self::PagesFailed => "COUNT_PAGES_FAILED",
            Self::Candidates => "COUNT_CANDIDATES",
            Self::ViewTiles => "COUNT_VIEW_TILES",
            Self::BackedTiles => "COUNT_BACKED_TILES",
            Self::AtlasPixels => "COUNT_ATLAS_PIXELS",
            Self::UnderShadedPixels => "COUNT_UNDER_SHADED_PIXELS",
            Self::FreeChunks => "COUNT_FREE_CHUNKS",
            Self::ChunksTaken => "COUNT_CHUNKS_TAKEN",
            Self::TableChunks => "COUNT_TABLE_CHUNKS",
            Self::TrimapPages => "COUNT_TRIMAP_PAGES",
            Self::MarkTiles => "COUNT_MARK_TILES",
            Self::MarkAtomics => "COUNT_MARK_ATOMICS",
            Self::TrimapWeighed => "COUNT_TRIMAP_WEIGHED",
            Self::TrimapShared => "COUNT_TRIMAP_SHARED",
            Self::MarkClaims => "COUNT_MARK_CLAIMS",
            Self::MsaaEdgePixels => "COUNT_MSAA_EDGE_PIXELS",
            Self::MsaaPoints => "COUNT_MSAA_POINTS",
        }
    }
}

/// Views besides the frame's camera that mark into the same atlas in the
/// same frame: each tile is shaded once for all of them, and each view
/// gathers its own image.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExtraViews {
    #[default]
    None,
    /// A stereo pair: the frame's camera is the left eye, the right eye is
    /// this far (scene units) along the camera's right.
    Stereo { eye_distance: f32 },
    /// Fixed cameras (for example a scene's other fixed cameras).
    Cameras(Vec<Camera>),
}

impl ExtraViews {
    pub fn count(&self) -> usize {
        match self {
            Self::None => 0,
            Self::Stereo { .. } => 1,
            Self::Cameras(c) => c.len(),
        }
    }

    /// The `k`-th extra camera for a frame seen by `camera`.
    pub fn camera(&self, k: usize, camera: &Camera) -> Camera {
        match self {
            Self::None => unreachable!("no extra views"),
            Self::Stereo { eye_distance } => {
                let right = camera.forward.cross(camera.up).normalize();
                Camera { position: camera.position + right * *eye_distance, ..*camera }
            }
            Self::Cameras(c) => c[k],
        }
    }
}

/// One extra view's own resources: its view uniform, visibility buffer
/// and rasterizer, and HDR image.
struct ExtraView {
    uniform: wgpu::Buffer,
    visibility: Box<ComputeVisibility>,
    pub hdr: wgpu::Texture,
}

/// How the mark pass writes the tiles its pixels need into the global tile
/// state (`mark/mark.wgsl`); both mark the same tiles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Marking {
    /// Each pixel marks every tile of its footprint (most find it marked).
    PerPixel,
    /// The first pixel of a workgroup to need a tile marks it, found in a
    /// workgroup hash table: global atomics per distinct tile of the
    /// workgroup, not per pixel.
    #[default]
    Workgroup,
    /// As [`Self::Workgroup`], but the invocations of a subgroup that need
    /// one tile elect one of them to claim it in the workgroup table
    /// (subgroup operations: the adapter must have `SUBGROUP`), so the
    /// table's compare-exchanges follow the distinct tiles of each
    /// subgroup rather than its pixels.
    Subgroup,
}

/// How the passes between marking and shading that back requested pages are
/// recorded (`--os-paging`); both back, build and queue the same pages and
/// tiles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PagingChain {
    /// Seven dispatches (stages of object space's one pass): paging (rank
    /// and chunk release, allocate and claim blocks, bind pages, backed
    /// args), triangle maps, mark backed, and the queue stage that writes
    /// the shade pass's dispatch from the shade list's length.
    Split,
    /// Four dispatches: the ranking writes the backed pages' and the shade
    /// pass's dispatch arguments as bounds (known once marking is done;
    /// extra workgroups return), and the triangle-map workgroup of a page also marks its
    /// requested tiles: no backed args, mark backed or queue dispatch, each
    /// a launch and a barrier. The default: 0.04 ms less a frame along
    /// Sponza's path at 1920x1080 on the H200 when each was a pass of its
    /// own (BENCHMARKS.md, "Object space's variants").
    #[default]
    Fused,
}

/// What the gather reads to find a pixel's chart UV and levels
/// (`--os-gather`); all give the same image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum GatherInput {
    /// [`Self::Record`] where it can serve (one view, one sample per pixel,
    /// `--os-aniso 1`), else [`Self::Surface`]: along Sponza's path on the
    /// H100 the records took 0.015-0.019 ms off a frame at 1920x1080 and
    /// 0.057-0.063 at 3840x2160, once marking and gathering went two by
    /// two (BENCHMARKS.md, "Marking without same-word atomics"). The
    /// configuration reports which it became.
    #[default]
    Auto,
    /// Rebuilds the pixel's surface as marking did: visibility, object,
    /// indices, vertices, footprint, level, then page, texel, shade.
    Surface,
    /// Marking writes each pixel's chart UV and levels (16 bytes) and the
    /// gather reads them: a write and a read per pixel against a chain of
    /// dependent loads. One view, one sample per pixel.
    Record,
}

impl GatherInput {
    /// What [`Self::Auto`] becomes for `views` views of `samples` samples
    /// per pixel gathered with `aniso` taps; the others stay.
    pub fn resolve(self, views: u32, samples: u32, aniso: u32) -> Self {
        match self {
            Self::Auto if views == 1 && samples == 1 && aniso == 1 => Self::Record,
            Self::Auto => Self::Surface,
            chosen => chosen,
        }
    }
}

/// How the gather reconstructs a pixel's shade from a level's texels
/// (`--os-filter`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum GatherFilter {
    /// The 2x2 texels around the chart point, weighted bilinearly: a pixel
    /// on a texel's centre reads that texel alone and one between texels the
    /// mean of two or four, so how much it blurs follows the grid's
    /// sub-pixel phase, which moves with the camera.
    #[default]
    Bilinear,
    /// The 4x4 texels around it, weighted by the cubic B-spline: a blur that
    /// changes little with the phase (and more of it). Marking marks one
    /// texel more on each side, so a few more tiles are shaded.
    Bspline,
    /// The 4x4 texels around it, weighted by the Mitchell-Netravali cubic
    /// (B = C = 1/3): sharper than the B-spline (small negative lobes), its
    /// blur between B-spline's and bilinear's in how it follows the phase.
    /// Marks as `bspline`.
    Mitchell,
}

impl GatherFilter {
    /// Texels a pixel reads beyond the bilinear pair, on each side.
    pub fn margin(self) -> u32 {
        match self {
            Self::Bilinear => 0,
            Self::Bspline | Self::Mitchell => 1,
        }
    }

    /// The filter's code in `Params::gather_filter` (`objectspace.wgsl`).
    pub fn code(self) -> u32 {
        self as u32
    }
}

/// Under MSAA, which samples of a pixel the gather (and marking) take as
/// one point (`--os-msaa-gather`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum MsaaGather {
    /// The samples that see one chart surface (one object, one chart
    /// island: `same_chart_surface` in `objectspace.wgsl`) are one point,
    /// at their centroid (the pixel's centre where all of a pixel's
    /// samples do): the gather's cost follows the surfaces in a pixel, not
    /// its samples.
    #[default]
    Pixel,
    /// Every sample is gathered at its own position: the cost grows with
    /// the sample count (the reference the pixel gather approximates).
    Sample,
}

impl MsaaGather {
    /// The mode's code in `Params::msaa_gather` (`objectspace.wgsl`).
    pub fn code(self) -> u32 {
        self as u32
    }
}

/// The triangle-map pass's invocations per texel (`--os-trimap-lanes`).
pub const TRIMAP_LANES: [u32; 4] = [1, 2, 4, 8];
/// [`ObjectSpaceConfig::trimap_lanes`]'s default on a GPU: the
/// triangle-map pass took 0.061 ms with 4 lanes against 0.177 with 1 and
/// 0.051 with 8 along Sponza's path at 1920x1080 on the H200; 4 lanes make
/// workgroups of 256 invocations, the most every adapter must allow (8 make
/// 512).
pub const DEFAULT_TRIMAP_LANES: u32 = 4;
/// [`ObjectSpaceConfig::trimap_lanes`]'s default on a CPU adapter
/// (lavapipe): there a workgroup's invocations run one after another in a
/// thread and each barrier between the lanes is a switch, so one lane a
/// texel is fastest (the atrium at 96x54: 0.14-0.19 s of triangle maps
/// against 1.3-1.5 s with 4 lanes).
pub const CPU_TRIMAP_LANES: u32 = 1;

/// The triangle-map lanes `config` asks for on `adapter`: its own, else
/// [`CPU_TRIMAP_LANES`] on a CPU adapter and [`DEFAULT_TRIMAP_LANES`] on others.
pub fn trimap_lanes(config: &ObjectSpaceConfig, adapter: &wgpu::AdapterInfo) -> u32 {
    config.trimap_lanes.unwrap_or(match adapter.device_type {
        wgpu::DeviceType::Cpu => CPU_TRIMAP_LANES,
        _ => DEFAULT_TRIMAP_LANES,
    })
}
/// [`ObjectSpaceConfig::trimap_store`]'s default on a GPU: each mesh's
/// triangle maps of the levels up to 512 texels wide are stored (350,000
/// texels, 1.4 MB, a mesh; 22 MB on Sponza); on Sponza's path at 1920x1080
/// on the H200 the pass took 0.029 ms, against 0.033 storing up to 256
/// (5.6 MB) and 0.049 searching every level (BENCHMARKS.md, "Paging in
/// three dispatches").
pub const DEFAULT_TRIMAP_STORE: u32 = 512;
/// The widest level [`ObjectSpaceConfig::trimap_store`] takes (5.6 M texels
/// a mesh).
pub const MAX_TRIMAP_STORE: u32 = 2048;

/// The widest level whose triangle maps are stored, `config`'s on
/// `adapter`: its own, else none on a CPU adapter (lavapipe: building them
/// costs seconds a scene there, and the pass is not what its frames wait
/// on) and [`DEFAULT_TRIMAP_STORE`] on others.
pub fn trimap_store(config: &ObjectSpaceConfig, adapter: &wgpu::AdapterInfo) -> u32 {
    config.trimap_store.unwrap_or(match adapter.device_type {
        wgpu::DeviceType::Cpu => 0,
        _ => DEFAULT_TRIMAP_STORE,
    })
}

/// Most [`ObjectSpaceConfig::trimap_grid`] (`--os-trimap-grid`).
pub const MAX_TRIMAP_GRID: u32 = 4;

/// How the triangle-map pass searches the chart grid's cells for a texel
/// the triangles of its centre's cell do not settle (`--os-trimap-search`);
/// both give the same maps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum TrimapSearch {
    /// Ring by ring round the centre's cell, stopping once no cell left can
    /// hold a nearer triangle: at a coarse level of a mesh of many small
    /// charts (the city's buildings) a texel's 3x3 neighbourhood spans
    /// hundreds of cells, most of which need no look.
    #[default]
    Rings,
    /// Every cell of the texel's 3x3 neighbourhood (the search before the
    /// rings, for comparison).
    Neighbourhood,
}

/// Settings of the object-space pipeline.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectSpaceConfig {
    /// Tile side in texels: 8, 16, 32 or 64.
    pub tile_size: u32,
    /// Re-shade a visible tile when its shade is this many frames old (N >= 1)
    /// and the view (camera) changed since it was shaded: with N >= 2 a static
    /// camera and static lights shade nothing; N = 1 shades every visible
    /// tile every frame.
    pub reuse: u32,
    /// Spread re-shading over the N frames (decoupled shading rate): each
    /// tile is shaded again on its own phase frame, so every frame shades
    /// about 1/N of the visible tiles instead of all of them every N frames.
    pub spread_reshading: bool,
    /// Added to every pixel's mip level (positive: coarser shading).
    pub mip_bias: f32,
    /// Strength of the per-pixel variable-rate bias (0 = off): up to this
    /// many levels coarser where a triangle's normals do not vary.
    pub variable_rate: f32,
    /// Width, in levels, of the band around each level switch over which a
    /// pixel blends the two levels around its footprint (both are marked
    /// and shaded): 0 reads the rounded level alone, so a pixel's shade
    /// jumps where its level changes between frames; 1 is trilinear
    /// filtering (every pixel between two levels reads both). 0 to 1.
    pub level_blend: f32,
    /// How the gather filters each level's texels (marking marks what it reads).
    pub gather_filter: GatherFilter,
    /// Anisotropic gathering: the most filter taps a pixel reads along its
    /// footprint's longer axis, one of [`ANISO_RATIOS`]. The level follows
    /// the shorter axis, limited so that the longer needs at most this many
    /// taps (`lod = log2(max(major / N, minor))`), and the gather averages
    /// its taps spread along the longer axis; marking marks every tap's
    /// tiles. 1: isotropic (the level follows the longer axis, one tap).
    pub aniso: u32,
    /// Under MSAA, which samples of a pixel are gathered as one point.
    pub msaa_gather: MsaaGather,
    /// Points each shaded texel averages, spread over it on a square grid:
    /// 1 (its centre) or 4 (pre-filtered shading: the shade over the
    /// texel's footprint, so a highlight narrower than a texel is not
    /// sampled in or out as the texel grid moves; 4x the shading work).
    pub texel_samples: u32,
    pub view: DebugView,
    /// Virtual shading-texture side per scene object; `None` shades the
    /// object forward (per pixel, in the gather). Reported per object instead.
    #[serde(skip)]
    pub texture_sizes: Vec<Option<u32>>,
    /// Page side of the virtual textures (a power of two, at most four
    /// times the tile size; raised to the tile size).
    pub page_size: u32,
    /// Most texels of the physical atlas; `None`: [`default_atlas_texels`]
    /// per view. The atlas starts there and follows the pages the frames
    /// need ([`residency`]); when a frame needs more pages than the budget
    /// holds, the mip bias rises ([`budget`]).
    pub atlas_budget_texels: Option<u64>,
    /// Lay down depth before the id pass, which then writes each pixel once
    /// (on the H100: 1.65 instead of 1.82 ms at 1920x1080 on Sponza).
    /// Raster visibility only.
    pub visibility_prepass: bool,
    /// Hardware or compute rasterization of the visibility buffer. Raster
    /// here (it runs on every adapter); the CLI's `--visibility auto` takes
    /// [`VisibilityMethod::preferred`].
    pub visibility: VisibilityMethod,
    /// Compute visibility: count the rasterizer's work every frame into the
    /// counters (adds atomics: for profiling, not timing).
    pub count_visibility: bool,
    /// How marking writes the global tile state.
    pub marking: Marking,
    /// Count the mark pass's global tile marks and atomics every frame into
    /// the counters `mark_tiles` and `mark_atomics` (adds workgroup atomics:
    /// for profiling, not timing).
    pub count_mark_atomics: bool,
    /// Most texels shaded per frame: above it the mip levels are biased
    /// coarser until the shading fits ([`budget`]). `None`: no limit.
    pub shade_budget_texels: Option<u64>,
    /// Views besides the frame's camera that share the atlas (compute
    /// visibility only).
    pub extra_views: ExtraViews,
    /// Frames an object stays out of every view's frustum before its page
    /// directory slot (and the pages in it) goes back ([`slots`]).
    pub slot_timeout: u32,
    /// How the paging chain is recorded.
    pub paging_chain: PagingChain,
    /// Invocations weighing each texel's triangles in the triangle-map
    /// pass, one of [`TRIMAP_LANES`] (1: one per texel); `None`: the
    /// adapter's ([`trimap_lanes`]). The maps are the same whatever it is.
    pub trimap_lanes: Option<u32>,
    /// The widest level (a power of two, or 0 for none) whose triangle maps
    /// are built once per mesh and copied into the pages backed after
    /// (`trimap`); `None`: the adapter's ([`trimap_store`]). The maps are
    /// the same whatever it is.
    pub trimap_store: Option<u32>,
    /// How the triangle-map pass searches the chart grids.
    pub trimap_search: TrimapSearch,
    /// The chart grids' cells per side, this many times the default (about
    /// two triangles per cell; 1 to [`MAX_TRIMAP_GRID`]): finer cells list
    /// fewer triangles for the texels of fine levels to weigh.
    pub trimap_grid: u32,
    /// A page's triangle map is copied from a page already holding the map
    /// of the same mesh, level and page (another instance's) where one is
    /// found, instead of built again ([`trimap`]); the same maps.
    pub trimap_share: bool,
    /// What the gather reads for a pixel's chart UV and levels.
    pub gather_input: GatherInput,
}

/// The ratios [`ObjectSpaceConfig::aniso`] takes (`--os-aniso`).
pub const ANISO_RATIOS: [u32; 5] = [1, 2, 4, 8, 16];

/// [`ObjectSpaceConfig::slot_timeout`]'s default: a second at 60 Hz, so that
/// an object glanced away from keeps its shades.
pub const DEFAULT_SLOT_TIMEOUT: u32 = 60;

impl Default for ObjectSpaceConfig {
    fn default() -> Self {
        Self {
            tile_size: 8,
            reuse: 1,
            spread_reshading: false,
            mip_bias: 0.0,
            variable_rate: 0.0,
            level_blend: 0.0,
            gather_filter: GatherFilter::Bilinear,
            aniso: 1,
            msaa_gather: MsaaGather::Pixel,
            texel_samples: 1,
            view: DebugView::Shade,
            texture_sizes: Vec::new(),
            page_size: DEFAULT_PAGE_SIZE,
            atlas_budget_texels: None,
            visibility_prepass: true,
            visibility: VisibilityMethod::Raster,
            count_visibility: false,
            marking: Marking::Workgroup,
            count_mark_atomics: false,
            shade_budget_texels: None,
            extra_views: ExtraViews::None,
            slot_timeout: DEFAULT_SLOT_TIMEOUT,
            paging_chain: PagingChain::Fused,
            trimap_lanes: None,
            trimap_store: None,
            trimap_search: TrimapSearch::Rings,
            trimap_grid: 1,
            trimap_share: true,
            gather_input: GatherInput::Auto,
        }
    }
}

impl ObjectSpaceConfig {
    /// Points per side of a shaded texel: 2 for [`Self::texel_samples`] 4, else 1.
    pub fn texel_sample_side(&self) -> u32 {
        if self.texel_samples == 4 { 2 } else { 1 }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ObjectSpaceError {
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error(transparent)]
    Atlas(#[from] AtlasError),
    #[error(transparent)]
    ComputeVisibility(#[from] ComputeVisibilityError),
    #[error("reuse must be at least 1 (got {0})")]
    BadReuse(u32),
    #[error("mip bias and variable rate must be finite (got {0} and {1})")]
    BadBias(f32, f32),
    #[error("the level blend must be from 0 to 1 (got {0})")]
    BadLevelBlend(f32),
    #[error("samples per shaded texel must be 1 or 4 (got {0})")]
    BadTexelSamples(u32),
    #[error("the anisotropy must be one of 1, 2, 4, 8, 16 (got {0})")]
    BadAniso(u32),
    #[error("--os-gather record reads one tap a pixel: not with --os-aniso {0}")]
    RecordNeedsIsotropic(u32),
    #[error("the object-space pipeline needs the PRIMITIVE_INDEX feature, which {0} lacks")]
    NoPrimitiveIndex(String),
    #[error("{0} texture sizes given for {1} objects")]
    SizeCount(usize, usize),
    #[error("extra views need compute visibility (--visibility compute)")]
    ViewsNeedComputeVisibility,
    #[error("an atlas of {texels} texels needs {bytes} bytes of tile state, more than the adapter's largest buffer")]
    AtlasTooLarge { texels: u64, bytes: u64 },
    #[error("--marking subgroup needs subgroup operations (the SUBGROUP feature), which {0} lacks")]
    MarkingNeedsSubgroups(String),
    #[error("--os-gather record needs one view and one sample per pixel (got {views} views, {samples} samples)")]
    RecordNeedsOneSample { views: u32, samples: u32 },
    #[error("triangle-map lanes must be one of 1, 2, 4, 8 (got {0})")]
    BadTrimapLanes(u32),
    #[error("the chart grid scale must be 1 to {MAX_TRIMAP_GRID} (got {0})")]
    BadTrimapGrid(u32),
    #[error("the widest stored triangle-map level must be 0 or a power of two up to {MAX_TRIMAP_STORE} (got {0})")]
    BadTrimapStore(u32),
    #[error("{lanes} triangle-map lanes need {invocations} invocations per workgroup; {adapter} allows {max}")]
    TrimapLanesTooMany { lanes: u32, invocations: u32, adapter: String, max: u32 },
    #[error("an atlas of {texels} texels takes {layers} layers of {side}x{side}, more than the adapter's {max} layers")]
    AtlasTooManyLayers { texels: u64, layers: u32, side: u32, max: u32 },
}

/// The passes that fill the visibility buffer.
enum Visibility {
    Raster { prepass: Option<DepthPrepass>, ids: VisibilityPass },
    Compute(Box<ComputeVisibility>),
}

pub struct ObjectSpace {
    config: ObjectSpaceConfig,
    pub layout: AtlasLayout,
    res: Resources,
    visibility: Visibility,
    mark: MarkPass,
    paging: PagingPass,
    resize: ResizePass,
    trimap: TrimapPass,
    shade: ShadePass,
    gather: GatherPass,
    /// The debug pass behind [`Self::read_pixel_classes`], built on its first call.
    classify: Option<gather::ClassifyPass>,
    /// With `--view atlas-pages`: the pass drawing `atlas_pages` over the frame.
    atlas_view: Option<AtlasViewPass>,
    atlas_pages: AtlasPages,
    grid: WorldGrid,
    readback: ReadbackRing<u64>,
    /// Frames rendered so far; stamps are `frames + 1` so that 0 means never.
    frames: u32,
    /// The last frame's view uniform, and the stamp since which it is the
    /// same (`GpuParams::view_since`).
    last_view: Option<GpuView>,
    view_since: u32,
    /// Stamp since which nothing that marking, paging or shading read
    /// changed: the view, the lights, the atlas's size, the objects' biases.
    quiet_since: u32,
    /// A frame of the quiet run, at least `reuse` frames into it (every
    /// visible tile shaded with this view), came back having requested no
    /// page and queued no tile: until something changes, every frame would
    /// do the same, so paging, triangle maps and shading are not recorded.
    settled: bool,
    /// `table_chunks` of the last frame that ran paging (reported for the
    /// frames that skip it).
    table_chunks: f64,
    budget: Budget,
    /// The atlas at the whole budget; `res.pool` is what is resident now.
    budget_pool: PagePool,
    residency: Residency,
    /// The page directory's slots, one per object in view.
    slots: Slots,
    /// Ranges given back this frame, freed before it marks.
    released: Vec<[u32; 2]>,
    /// Per object: its least chart-UV stretch per world metre ([`reach`]).
    stretch: Vec<f32>,
    extra_views: Vec<ExtraView>,
    /// For scenes with an environment: drawn where no surface is.
    background: Option<Background>,
    /// For scenes with alpha-blended objects: their marking and gathering.
    blended: Option<BlendedObjects>,
    /// What each frame still in flight was rendered with.
    in_flight: std::collections::BTreeMap<u64, InFlight>,
}

/// What a frame was rendered with, for its counts when they come back.
#[derive(Clone, Copy, Debug)]
struct InFlight {
    /// The bias the budget added.
    bias: f32,
    /// Physical pages of the atlas.
    pages: u32,
    /// Its stamp.
    stamp: u32,
    /// It skipped paging, triangle maps and shading (settled).
    quiet: bool,
    /// Objects with a page-directory slot, and the page numbers in slots.
    slots: u32,
    slot_pages: u64,
    /// Objects in view that found no slot (shaded forward).
    unslotted: u32,
}

impl ObjectSpace {
    pub fn new(
        ctx: &GpuContext,
        shaders: &mut ShaderLibrary,
        scene_cpu: &Scene,
        scene: &SceneGpu,
        targets: &Targets,
        mut config: ObjectSpaceConfig,
    ) -> Result<Self, ObjectSpaceError> {
        let device = &ctx.device;
        if config.reuse == 0 {
            return Err(ObjectSpaceError::BadReuse(0));
        }
        if !config.mip_bias.is_finite() || !config.variable_rate.is_finite() {
            return Err(ObjectSpaceError::BadBias(config.mip_bias, config.variable_rate));
        }
        if !(0.0..=1.0).contains(&config.level_blend) {
            return Err(ObjectSpaceError::BadLevelBlend(config.level_blend));
        }
        if ![1, 4].contains(&config.texel_samples) {
            return Err(ObjectSpaceError::BadTexelSamples(config.texel_samples));
        }
        if !ANISO_RATIOS.contains(&config.aniso) {
            return Err(ObjectSpaceError::BadAniso(config.aniso));
        }
        // The records hold one chart point a pixel, not the footprint's axis.
        if config.gather_input == GatherInput::Record && config.aniso > 1 {
            return Err(ObjectSpaceError::RecordNeedsIsotropic(config.aniso));
        }
        let lanes = trimap_lanes(&config, &ctx.info);
        if !TRIMAP_LANES.contains(&lanes) {
            return Err(ObjectSpaceError::BadTrimapLanes(lanes));
        }
        if !(1..=MAX_TRIMAP_GRID).contains(&config.trimap_grid) {
            return Err(ObjectSpaceError::BadTrimapGrid(config.trimap_grid));
        }
        let store = trimap_store(&config, &ctx.info);
        if store > MAX_TRIMAP_STORE || (store != 0 && !store.is_power_of_two()) {
            return Err(ObjectSpaceError::BadTrimapStore(store));
        }
        let invocations = 64 * lanes;
        let max = device.limits().max_compute_invocations_per_workgroup;
        if invocations > max {
            let adapter = ctx.info.name.clone();
            return Err(ObjectSpaceError::TrimapLanesTooMany { lanes, invocations, adapter, max });
        }
        if config.marking == Marking::Subgroup && !device.features().contains(wgpu::Features::SUBGROUP) {
            return Err(ObjectSpaceError::MarkingNeedsSubgroups(ctx.info.name.clone()));
        }
        if !device.features().contains(wgpu::Features::PRIMITIVE_INDEX) {
            return Err(ObjectSpaceError::NoPrimitiveIndex(ctx.info.name.clone()));
        }
        if config.texture_sizes.len() != scene.draws.len() {
            return Err(ObjectSpaceError::SizeCount(config.texture_sizes.len(), scene.draws.len()));
        }
        let page_size = config.page_size.max(config.tile_size);
        let mut layout = AtlasLayout::unplaced(
            &config.texture_sizes,
            config.tile_size,
            page_size,
            atlas::MAX_TEXTURE_SIZE,
            &coarsest_levels(scene_cpu),
        )?;
        // The slots' page numbers: the request bits (a bit per page and per
        // tile) fit one binding, and tile numbers 32 bits.
        let tiles_per_page = layout.tiles_per_page() as u64;
        let max_pages = (device.limits().max_storage_buffer_binding_size * 8 / (1 + tiles_per_page))
            .min(u32::MAX as u64 / tiles_per_page) as u32;
        let slots = Slots::new(&mut layout, max_pages, config.slot_timeout);
        let stretch = object_stretches(scene_cpu, &config.texture_sizes);
        // Each view sees its own pixels: the default atlas holds all of them.
        let views = 1 + config.extra_views.count() as u64;
        let pixels = targets.width as u64 * targets.height as u64;
        let texels = config.atlas_budget_texels.unwrap_or_else(|| default_atlas_texels(pixels) * views);
        let pool = PagePool::new(page_size, texels, device.limits().max_texture_dimension_2d);
        let max_layers = device.limits().max_texture_array_layers;
        if pool.layers > max_layers {
            let (side, layers) = (pool.layer_pages * page_size, pool.layers);
            return Err(ObjectSpaceError::AtlasTooManyLayers { texels: pool.texels(), layers, side, max: max_layers });
        }
        // The largest per-tile buffer is the shade queue: 8 bytes a tile.
        let queue_bytes = pool.texels() / (config.tile_size as u64).pow(2) * 8;
        if queue_bytes > device.limits().max_storage_buffer_binding_size {
            return Err(ObjectSpaceError::AtlasTooLarge { texels: pool.texels(), bytes: queue_bytes });
        }
        let view_count = 1 + config.extra_views.count() as u32;
        if view_count > 1 && config.visibility != VisibilityMethod::Compute {
            return Err(ObjectSpaceError::ViewsNeedComputeVisibility);
        }
        config.gather_input = config.gather_input.resolve(view_count, targets.samples, config.aniso);
        if config.gather_input == GatherInput::Record && (view_count > 1 || targets.samples > 1) {
            return Err(ObjectSpaceError::RecordNeedsOneSample { views: view_count, samples: targets.samples });
        }
        let records = (config.gather_input == GatherInput::Record).then(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pixel records"),
                size: targets.width as u64 * targets.height as u64 * 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        });
        let mut res =
            Resources::new(device, &layout, pool, &scene.triangle_charts, targets, view_count, config.visibility);
        let visibility = match config.visibility {
            VisibilityMethod::Raster => Visibility::Raster {
                prepass: config
                    .visibility_prepass
                    .then(|| DepthPrepass::new(device, shaders, scene, targets.samples))
                    .transpose()?,
                ids: VisibilityPass::new(device, shaders, scene, config.visibility_prepass, targets.samples)?,
            },
            VisibilityMethod::Compute => {
                let counting = config.count_visibility;
                Visibility::Compute(Box::new(ComputeVisibility::new(
                    device,
                    shaders,
                    scene,
                    targets,
                    &res.visibility,
                    counting,
                )?))
            }
        };
        let grid = WorldGrid::new(device, shaders, scene)?;
        let reads = (records.as_ref(), config.view, config.gather_filter);
        let mut gather = GatherPass::new(device, shaders, scene, &res, targets, &grid.grid, reads)?;
        let mut extra_views = Vec::new();
        for _ in 1..view_count {
            let ids = VisibilityBuffer::new(device, targets, VisibilityMethod::Compute);
            res.add_view(device, &ids.view);
            let hdr = Targets::hdr_texture(device, targets.width, targets.height);
            gather.add_view(device, &res, &hdr.create_view(&Default::default()));
            let uniform = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("extra view"),
                size: size_of::<GpuView>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let visibility = Box::new(ComputeVisibility::new(device, shaders, scene, targets, &ids, false)?);
            extra_views.push(ExtraView { uniform, visibility, hdr });
        }
        // The compute rasterizer leaves the depth target to the blended passes.
        let lay_depth = config.visibility == VisibilityMethod::Compute;
        let blended = BlendedObjects::new(device, shaders, scene, &res, targets, &grid.grid, lay_depth)?;
        let coverage = if lay_depth { Coverage::Ids(&res.visibility) } else { Coverage::Depth };
        let background = Background::new(device, shaders, scene, targets, coverage, false)?;
        Ok(Self {
            background,
            extra_views,
            blended,
            visibility,
            mark: MarkPass::new(
                device,
                shaders,
                scene,
                &res,
                config.marking,
                config.count_mark_atomics,
                records.as_ref(),
            )?,
            paging: PagingPass::new(device, shaders, scene, &res, config.paging_chain)?,
            resize: ResizePass::new(device, shaders, scene, &res)?,
            trimap: TrimapPass::new(ctx, shaders, scene_cpu, scene, &res, &layout, &config)?,
            shade: ShadePass::new(
                device,
                shaders,
                scene,
                &res,
                &grid.grid,
                config.tile_size == 8 && config.texel_sample_side() == 1,
            )?,
            gather,
            classify: None,
            atlas_view: (config.view == DebugView::AtlasPages)
                .then(|| AtlasViewPass::new(device, shaders, scene, &res, targets))
                .transpose()?,
            atlas_pages: AtlasPages::default(),
            grid,
            res,
            layout,
            config,
            readback: ReadbackRing::new("tile counters", TileCounter::WORDS as u64 * 4),
            frames: 0,
            last_view: None,
            view_since: 0,
            quiet_since: 0,
            settled: false,
            table_chunks: 0.0,
            budget: Budget::default(),
            residency: Residency::new(pool.layer_page_count(), pool.layers),
            budget_pool: pool,
            slots,
            released: Vec::new(),
            stretch,
            in_flight: Default::default(),
        })
    }

    pub fn config(&self) -> &ObjectSpaceConfig {
        &self.config
    }

    /// The object and mip level `--view atlas-pages` shows from the next
    /// frame on (checked against the atlas layout).
    pub fn set_atlas_pages(&mut self, pages: AtlasPages) -> Result<(), AtlasPagesError> {
        pages.check(&self.layout)?;
        self.atlas_pages = pages;
        Ok(())
    }

    /// Renders the extra views' visibility and marks their tiles; returns
    /// each view's scene group for its gather.
    fn mark_extra_views(&mut self, frame: &mut Frame, pixel_groups: [u32; 2]) -> Vec<wgpu::BindGroup> {
        let (w, h) = (frame.targets.width, frame.targets.height);
        let mut groups = Vec::new();
        for (k, extra) in self.extra_views.iter_mut().enumerate() {
            let camera = self.config.extra_views.camera(k, frame.camera);
            // The frame's view (its light counts) seen from the other camera.
            let seen = gpu_view(&camera, w, h);
            let view = GpuView { view_proj: seen.view_proj, camera_position: seen.camera_position, ..*frame.view };
            frame.queue.write_buffer(&extra.uniform, 0, bytemuck::bytes_of(&view));
            let frustum = Frustum::from_view_projection(view.view_proj);
            let visible: Vec<bool> = frame.scene.object_bounds.iter().map(|b| frustum.intersects_aabb(b)).collect();
            let group = frame.scene.bind_group_with_view(frame.device, &extra.uniform);
            let mut sub = frame.with_scene_group(&group);
            sub.visible = &visible;
            compute_visibility(&mut sub, &mut extra.visibility);
            let mut cp = sub.compute_pass("mark: other views");
            mark_tiles(&mut cp, &self.mark, &self.res, &group, k + 1, pixel_groups);
            drop(cp);
            groups.push(group);
        }
        groups
    }

    /// The extra views' HDR images (view 1 onwards).
    fn extra_view_images(&self) -> impl Iterator<Item = &wgpu::Texture> {
        self.extra_views.iter().map(|v| &v.hdr)
    }

    /// Resizes the physical atlas to `layers` layers: when shrinking, the
    /// pages beyond the new size move below it first (or are evicted); the
    /// passes bind the new atlas.
    fn resize_atlas(&mut self, frame: &mut Frame, layers: u32) {
        let pool = self.res.pool.with_layers(layers);
        let old_pages = self.res.pool.pages;
        let moves =
            (pool.pages < old_pages).then(|| compact_pages(frame, &self.resize, &self.paging, &self.res, pool.pages));
        tracing::debug!("atlas resized from {old_pages} to {} pages", pool.pages);
        let device = frame.device;
        let old = self.res.resize(device, &mut frame.scope("atlas copy"), pool);
        copy_pages(frame, &self.resize, &self.res, &old, old_pages, moves.as_ref());
        if moves.is_some() {
            // Pages moved onto others: which map a page holds is known no more.
            self.trimap.forget_maps(frame.encoder);
        }
        self.rebind(frame.device);
    }

    /// Binds the passes that keep their own bind groups to `res` again.
    fn rebind(&mut self, device: &wgpu::Device) {
        self.shade.rebind(device, &self.res);
        self.gather.rebind(device, &self.res);
        if let Some(blended) = &mut self.blended {
            blended.rebind(device, &self.res);
        }
        self.trimap.rebind(device, &self.res);
        if let Some(view) = &mut self.atlas_view {
            view.rebind(device, &self.res);
        }
    }

    /// Per object, whether some view's frustum holds it this frame (blended
    /// ones too) and then the finest level any view's pixels may pick on it,
    /// less a level of margin ([`reach`]; every level under the atlas-pages
    /// view, which may show any).
    fn objects_in_view(&self, frame: &Frame) -> Vec<Option<usize>> {
        let (w, h) = (frame.targets.width, frame.targets.height);
        let mut cameras = vec![(*frame.camera, Frustum::from_view_projection(frame.view.view_proj))];
        for k in 0..self.extra_views.len() {
            let camera = self.config.extra_views.camera(k, frame.camera);
            cameras.push((camera, Frustum::from_view_projection(gpu_view(&camera, w, h).view_proj)));
        }
        let every_level = self.config.view == DebugView::AtlasPages;
        (frame.scene.object_bounds.iter().enumerate())
            .map(|(o, b)| {
                let size = self.layout.objects[o].as_ref().map_or(0, |a| a.size);
                let levels = cameras.iter().filter(|(_, f)| f.intersects_aabb(b)).map(|(camera, _)| {
                    let stretch = if every_level { 0.0 } else { self.stretch[o] };
                    reach::finest_level(size, stretch, b, camera, h, self.config.mip_bias, 1)
                });
                levels.min()
            })
            .collect()
    }

    /// Gives the objects in view page-directory slots and takes them from
    /// those out of view past the timeout ([`slots`]), before anything
    /// marks; returns whether the atlas table changed.
    fn update_slots(&mut self, frame: &mut Frame) -> bool {
        let in_view = self.objects_in_view(frame);
        let changes = self.slots.update(&mut self.layout, &in_view, self.frames as u64);
        if changes.grown.is_some() {
            tracing::debug!("page directory grown to {} pages", self.layout.page_count);
            self.res.grow_directory(frame.device, frame.encoder, &self.layout);
            self.rebind(frame.device);
        }
        self.res.set_entries(frame.queue, &self.layout, &changes.moved);
        self.released = changes.released;
        !changes.moved.is_empty()
    }

    /// Bytes of the pixel records marking writes for the gather
    /// ([`GatherInput::Record`]): 16 a pixel; 0 without them.
    fn pixel_record_bytes(&self) -> u64 {
        let (w, h) = (self.res.visibility.texture.width() as u64, self.res.visibility.texture.height() as u64);
        if self.config.gather_input == GatherInput::Record { w * h * 16 } else { 0 }
    }

    /// The world grid (its last build can be read back).
    pub fn light_grid(&self) -> &LightGrid {
        &self.grid.grid
    }
}

/// Per object of `scene`, its least chart-UV stretch per world metre
/// ([`reach::min_stretch`], once per mesh); 0 for objects not in the atlas.
fn object_stretches(scene: &Scene, sizes: &[Option<u32>]) -> Vec<f32> {
    let mut per_mesh: Vec<Option<f32>> = vec![None; scene.meshes.len()];
    (scene.objects.iter().zip(sizes))
        .map(|(o, size)| match size {
            Some(_) => {
                let m = *per_mesh[o.mesh].get_or_insert_with(|| reach::min_stretch(&scene.meshes[o.mesh]));
                m / reach::max_scale(&o.transform)
            }
            None => 0.0,
        })
        .collect()
}

/// The share of the screen that object `o`'s bounding box covers (1 when
/// the camera is inside or near it).
fn screen_share(frame: &Frame, o: usize) -> f32 {
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
    for c in frame.scene.object_bounds[o].corners() {
        let p = frame.view.view_proj * c.extend(1.0);
        if p.w <= 1e-4 {
            return 1.0;
        }
        let ndc = glam::Vec2::new(p.x, p.y) / p.w;
        (lo, hi) = (lo.min(ndc), hi.max(ndc));
    }
    let (lo, hi) = (lo.clamp(glam::Vec2::NEG_ONE, glam::Vec2::ONE), hi.clamp(glam::Vec2::NEG_ONE, glam::Vec2::ONE));
    ((hi - lo).x * (hi - lo).y / 4.0).max(0.0)
}

impl Pipeline for ObjectSpace {
    fn encode(&mut self, frame: &mut Frame) {
        self.frames += 1;
        let stale = frame.lights_changed || self.frames == 1;
        let slotted = self.update_slots(frame);
        let resize = self.residency.resize(self.res.pool.layers);
        if let Some(layers) = resize {
            self.resize_atlas(frame, layers);
        }
        let added = self.budget.bias;
        // Screen shares only matter once the bias goes past its uniform part.
        let ranked = added > budget::UNIFORM_BIAS;
        let shares: Vec<Option<f32>> = (0..frame.scene.object_bounds.len())
            .map(|o| (ranked && frame.visible[o] && self.layout.objects[o].is_some()).then(|| screen_share(frame, o)))
            .collect();
        let biased = self.res.set_object_biases(frame.queue, &budget::object_biases(added, &shares));
        if self.last_view.is_none_or(|v| bytemuck::bytes_of(&v) != bytemuck::bytes_of(frame.view)) {
            self.view_since = self.frames;
            self.last_view = Some(*frame.view);
        }
        let changed = stale || resize.is_some() || biased || slotted;
        if changed || self.view_since == self.frames || self.config.reuse == 1 {
            self.quiet_since = self.frames;
            self.settled = false;
        }
        let quiet = self.settled;
        let (pages, stamp) = (self.res.pool.pages, self.frames);
        let slotted_objects = self.layout.objects.iter().flatten().filter(|o| o.slot.is_some());
        let (slots, slot_pages) =
            (slotted_objects.clone().count() as u32, slotted_objects.map(|o| o.span as u64).sum());
        let unslotted = self.slots.unplaced();
        self.in_flight
            .insert(frame.number, InFlight { bias: added, pages, stamp, quiet, slots, slot_pages, unslotted });
        self.res.begin_frame(frame.queue, frame.encoder, self.frames, stale, self.view_since, &self.config);
        self.gather.begin_frame(frame.queue);
        if !self.released.is_empty() {
            release_slots(frame, &self.paging, &self.res, &std::mem::take(&mut self.released));
        }
        match &mut self.visibility {
            Visibility::Raster { prepass, ids } => {
                if let Some(prepass) = prepass {
                    culled_depth_prepass(frame, prepass);
                }
                visibility(frame, ids, &self.res.visibility, prepass.as_ref().and_then(DepthPrepass::cull));
            }
            Visibility::Compute(pass) => compute_visibility(frame, pass),
        }
        // The world grid reads only the lights: built before the chain.
        build_world_grid(frame, &mut self.grid);
        let groups = mark::pixel_groups(frame.targets, &self.res);
        // Blended surfaces and the extra views are marked by passes of
        // their own (a raster pass; the views' visibility) before paging.
        let mark_apart = self.blended.is_some() || !self.extra_views.is_empty();
        let views = if mark_apart {
            let scene = frame.scene_group;
            mark_tiles(&mut frame.compute_pass("mark"), &self.mark, &self.res, scene, 0, groups);
            if let Some(blended) = &self.blended {
                mark_blended(frame, blended, &self.res);
            }
            self.mark_extra_views(frame, groups)
        } else {
            Vec::new()
        };
        // Marking, paging, triangle maps, the queue, shading and the gather
        // in one compute pass, each stage a dispatch or a few reading what
        // the one before wrote: as passes of their own they cost 0.040 ms
        // more a frame on the H100 (BENCHMARKS.md, "Object space in one pass").
        let scene = frame.scene_group;
        let grid = &self.grid.grid;
        let mut cp = frame.compute_pass("object space");
        if !mark_apart {
            mark_tiles(&mut cp, &self.mark, &self.res, scene, 0, groups);
        }
        if !quiet {
            back_pages(&mut cp, &self.paging, &self.res, scene);
            build_triangle_maps(&mut cp, &mut self.trimap, &self.res, scene);
            if self.config.paging_chain == PagingChain::Split {
                mark_backed_pages(&mut cp, &self.mark, &self.res, scene);
            }
            if self.config.paging_chain == PagingChain::Split {
                write_shade_args(&mut cp, &self.mark, &self.res, scene);
            }
            shade_tiles(&mut cp, &self.shade, &self.res, scene, grid);
        }
        gather(&mut cp, &self.gather, (&self.res, scene, grid), 0, groups);
        drop(cp);
        for (k, group) in views.iter().enumerate() {
            let mut cp = frame.compute_pass("gather: other views");
            gather(&mut cp, &self.gather, (&self.res, group, grid), k + 1, groups);
        }
        if let Some(pass) = &self.background {
            background(frame, pass);
        }
        if let Some(blended) = &self.blended {
            gather_blended(frame, blended, &self.res, &self.grid.grid);
        }
        if let Some(pass) = &self.atlas_view {
            draw_atlas_pages(frame, pass, &self.res, self.atlas_pages);
        }
        let counter_bytes = TileCounter::WORDS as u64 * 4;
        self.readback.copy(frame.device, frame.encoder, &self.res.counters, counter_bytes, frame.number);
    }

    fn uses_object_light_lists(&self) -> bool {
        false
    }

    /// With raster visibility after its depth pre-pass (the compute
    /// rasterizer culls on its own).
    fn enable_cluster_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
    ) -> Result<(), ShaderError> {
        if let Visibility::Raster { prepass: Some(prepass), ids } = &mut self.visibility {
            prepass.enable_cluster_culling(device, shaders, scene, targets, ids.pipeline_mut())?;
        }
        Ok(())
    }

    fn after_submit(&mut self) {
        if let Visibility::Raster { prepass: Some(prepass), .. } = &mut self.visibility {
            prepass.after_submit();
        }
        self.readback.after_submit();
        self.grid.grid.after_submit();
        if let Visibility::Compute(pass) = &mut self.visibility {
            pass.after_submit();
        }
    }

    /// Per frame: `visible_tiles`, `shaded_tiles`, `reused_tiles`,
    /// `new_tiles`, `new_fraction` (of visible), `shaded_texels`,
    /// `visible_texels`, and per screen pixel `overshading` (visible texels:
    /// what shading every visible tile costs, the study's measure) and
    /// `shaded_texels_per_pixel` (after reuse); paging: `pages_in_use`
    /// (backing visible tiles this frame), `pages_backed` (newly),
    /// `pages_failed` (found no page: the atlas was full, at its budget,
    /// before the budget's bias, which follows the counts a few frames late,
    /// rose; those pixels are shaded forward, not under-shaded), `page_texels`
    /// (texels of the pages in use), `table_chunks` (page-table chunks in
    /// use), `slotted_objects` and `slot_pages` (objects holding a
    /// page-directory slot, the virtual pages in their slots: [`slots`]),
    /// `unslotted_objects` (in view, no room left in the directory: shaded
    /// forward), `trimap_pages` (pages whose triangle maps were built),
    /// `trimap_weighed` (chart-grid entries that pass weighed),
    /// `trimap_shared` (pages whose maps were copied from another
    /// instance's page instead), `quiet`
    /// (1: nothing changed and the frame recorded no paging, triangle maps
    /// or shading),
    /// `atlas_pages` and `atlas_texels` (the physical atlas the frame
    /// had: it follows the pages needed, [`residency`]) and `budget_bias`
    /// (levels the budget added); with extra views, `shared_view_tiles` (tiles on pages
    /// backed before this frame, marked once for all views) and
    /// `view_tiles` (the same summed over the views: what independent views
    /// would mark); with `count_visibility`, the compute rasterizer's counts
    /// too (in entries of their own); with raster visibility culling
    /// clusters, the `cull_*` counts in the frame's entry.
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        let counts = match &mut self.visibility {
            Visibility::Compute(pass) => pass.collect_counts(device, wait),
            Visibility::Raster { .. } => Vec::new(),
        };
        // Raster visibility's cluster culling counts join their frame's entry.
        let mut culled: std::collections::BTreeMap<u64, Counters> = match &mut self.visibility {
            Visibility::Raster { prepass: Some(prepass), .. } => {
                prepass.collect_counts(device, wait).into_iter().collect()
            }
            _ => Default::default(),
        };
        let tile_texels = (self.layout.tile_size * self.layout.tile_size) as f64;
        let page_texels = (self.res.pool.page_size as f64).powi(2);
        let budget_pages = self.budget_pool.pages as f64;
        let pixels = self.res.visibility.texture.width() as f64 * self.res.visibility.texture.height() as f64;
        self.readback
            .collect(device, wait)
            .into_iter()
            .map(|(frame, bytes)| {
                let c = TileCounter::fold(&bytemuck::pod_collect_to_vec::<u8, u32>(&bytes));
                let count = |t: TileCounter| c[t as usize] as f64;
                let (shaded, visible, new) =
                    (count(TileCounter::Queued), count(TileCounter::Visible), count(TileCounter::New));
                let backed = count(TileCounter::PagesBacked);
                let in_use = count(TileCounter::PagesUsed) + backed;
                let failed = count(TileCounter::PagesFailed);
                let rendered = self.in_flight.remove(&frame);
                let (used, resident) = rendered.map_or((0.0, self.res.pool.pages), |r| (r.bias, r.pages));
                let quiet = rendered.is_some_and(|r| r.quiet);
                let (slots, slot_pages, unslotted) =
                    rendered.map_or((0, 0, 0), |r| (r.slots, r.slot_pages, r.unslotted));
                // Settled: this frame is `reuse` frames into the quiet run
                // (tiles shaded with an earlier view are due by then) and
                // needed nothing; the quiet run's later frames will not either.
                let requested = count(TileCounter::PagesRequested);
                if let Some(r) = rendered
                    && r.stamp >= self.quiet_since.saturating_add(self.config.reuse)
                    && requested + failed + shaded == 0.0
                {
                    self.settled = true;
                }
                if !quiet {
                    self.table_chunks = count(TileCounter::TableChunks);
                }
                // Demand: the pages this frame needed, against the share of
                // the budget it may fill (the atlas grows up to it) ...
                let mut load = (in_use + failed) / (PAGE_FILL * budget_pages);
                // ... and against the atlas it had.
                self.residency.observe(frame, in_use + failed, resident);
                if let Some(budget) = self.config.shade_budget_texels {
                    load = load.max(shaded * tile_texels / budget as f64);
                }
                self.budget.observe(frame, used, load);
                let mut counters = vec![
                    ("visible_tiles", visible),
                    ("shaded_tiles", shaded),
                    ("reused_tiles", (visible - shaded).max(0.0)),
                    ("new_tiles", new),
                    ("new_fraction", new / visible.max(1.0)),
                    ("shaded_texels", shaded * tile_texels),
                    ("visible_texels", visible * tile_texels),
                    ("overshading", visible * tile_texels / pixels),
                    ("shaded_texels_per_pixel", shaded * tile_texels / pixels),
                    ("pages_in_use", in_use),
                    ("pages_backed", backed),
                    ("pages_failed", failed),
                    ("page_texels", in_use * page_texels),
                    ("atlas_pages", resident as f64),
                    ("atlas_texels", resident as f64 * page_texels),
                    ("table_chunks", self.table_chunks),
                    // Page-directory slots: objects holding one, and the
                    // virtual page numbers in them.
                    ("slotted_objects", slots as f64),
                    ("slot_pages", slot_pages as f64),
                    ("unslotted_objects", unslotted as f64),
                    ("trimap_pages", count(TileCounter::TrimapPages)),
                    ("trimap_weighed", count(TileCounter::TrimapWeighed)),
                    ("trimap_shared", count(TileCounter::TrimapShared)),
                    ("quiet", quiet as u8 as f64),
                    ("budget_bias", used as f64),
                    // Share of the atlas-shaded pixels whose level gives them
                    // fewer than one shading texel (blurrier than the screen).
                    (
                        "under_shaded_share",
                        count(TileCounter::UnderShadedPixels) / count(TileCounter::AtlasPixels).max(1.0),
                    ),
                ];
                if self.res.visibility.samples() > 1 {
                    // As deferred-compute's edge counts: the atlas pixels
                    // gathered at more than one point, their share, and
                    // the points per atlas pixel (1 where no pixel is split).
                    let (atlas, edges) = (count(TileCounter::AtlasPixels), count(TileCounter::MsaaEdgePixels));
                    counters.push(("msaa_edge_pixels", edges));
                    counters.push(("msaa_edge_share", edges / atlas.max(1.0)));
                    counters.push(("msaa_points_per_pixel", count(TileCounter::MsaaPoints) / atlas.max(1.0)));
                }
                if self.config.count_mark_atomics {
                    counters.push(("mark_tiles", count(TileCounter::MarkTiles)));
                    counters.push(("mark_atomics", count(TileCounter::MarkAtomics)));
                    counters.push(("mark_claims", count(TileCounter::MarkClaims)));
                }
                if !self.extra_views.is_empty() {
                    // Like for like: tiles on pages already backed, shared
                    // by the views against summed over them.
                    let backed_tiles = count(TileCounter::BackedTiles);
                    counters.push(("shared_view_tiles", visible - backed_tiles));
                    counters.push(("view_tiles", count(TileCounter::ViewTiles)));
                }
                let mut counters: Counters = counters.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
                counters.extend(culled.remove(&frame).unwrap_or_default());
                (frame, counters)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .chain(counts)
            .chain(culled)
            .collect()
    }

    /// Memory: the physical atlas (8 B/texel), its triangle maps (4 B/texel),
    /// tile state (two stamps and a queue slot per physical tile), the page
    /// table and page state, the chart grids, the shared triangle maps'
    /// table and page keys, the visibility buffer; per
    /// object: virtual texture size, levels, virtual texels, tiles and pages.
    fn report(&self) -> PipelineReport {
        let pool = &self.res.pool;
        let t = self.layout.tile_size;
        let physical_tiles = self.res.max_queue(t) as u64;
        let mut report = PipelineReport::new(PipelineConfig::ObjectSpace(self.config.clone()))
            .memory("atlas", pool.texels() * 8)
            .memory("triangle_maps", pool.texels() * 4)
            .memory("tile_state", physical_tiles * 16)
            .memory("page_table", self.res.page_table_bytes())
            .memory("chart_grids", self.trimap.grid_bytes)
            .memory("trimap_share", self.trimap.share_bytes)
            .memory("trimap_store", self.trimap.store_bytes)
            .memory("visibility", self.res.visibility.bytes())
            .memory("pixel_records", self.pixel_record_bytes())
            .memory("world_grid", self.grid.grid.bytes())
            .setup("physical_pages", pool.pages as u64)
            .setup("budget_pages", self.budget_pool.pages as u64)
            .setup("page_size", pool.page_size as u64)
            .setup("trimap_lanes", self.trimap.lanes as u64)
            .setup("virtual_pages", self.layout.page_count as u64)
            .setup("virtual_texels", self.layout.virtual_texels())
            .setup("virtual_tiles", self.layout.tile_count as u64)
            .setup("world_grid_list_capacity", self.grid.grid.capacity())
            .setup("world_grid_list_peak", self.grid.grid.peak_entries());
        let page = self.layout.page_size;
        report.objects = (self.layout.objects.iter().enumerate())
            .filter_map(|(object, a)| {
                let a = a.as_ref()?;
                let pages = a.levels.iter().map(|l| (l.pages_per_row(page) as u64).pow(2)).sum();
                Some(ObjectMemory {
                    object,
                    texture_size: a.size,
                    levels: a.levels.len() as u32,
                    texels: a.texels(),
                    tiles: a.tiles(t),
                    pages,
                })
            })
            .collect();
        report
    }
}

#[cfg(test)]
mod tests {
    use super::TileCounter;

    /// Each counter is its slot plus its copy in every stripe; a buffer
    /// shorter than the stripes (an older read-back) folds what it has.
    #[test]
    fn striped_counts_fold_into_their_slots() {
        let mut words = vec![0u32; TileCounter::WORDS];
        let queued = TileCounter::Queued as usize;
        let visible = TileCounter::Visible as usize;
        words[queued] = 5;
        for k in 1..=TileCounter::STRIPES {
            words[k * TileCounter::SLOTS + queued] = k as u32;
            words[k * TileCounter::SLOTS + visible] = 1;
        }
        let folded = TileCounter::fold(&words);
        let stripes = TileCounter::STRIPES as u32;
        assert_eq!(folded[queued], 5 + stripes * (stripes + 1) / 2);
        assert_eq!(folded[visible], stripes);
        assert_eq!(folded[TileCounter::New as usize], 0);
        assert_eq!(TileCounter::fold(&words[..TileCounter::SLOTS])[queued], 5);
    }
}
