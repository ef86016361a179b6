//! Object-space (texel) shading: visible surface tiles are shaded by compute
//! into per-object squares of a shared atlas, reused across frames, and the
//! frame is gathered from those shades.
//!
//! Per frame ([`ObjectSpace::encode`]): *visibility* (object and triangle id
//! per pixel: hardware raster after an optional depth pre-pass, or the
//! compute rasterizer) -> *mark*
//! (compute per pixel: mip level, bilinear footprint, tiles marked visible;
//! the first marker of a tile queues it when its shade is `reuse` frames old
//! or stale) -> *shade* (one workgroup per queued tile, indirect) ->
//! *gather* (compute per pixel: bilinear from the atlas). Texels are lit by
//! the global lights and the lights of their cell of the world grid (Oxide's
//! light matrix), built on the GPU before shading; no CPU light culling. No
//! CPU read-back inside the frame: the counters are copied out and read a few
//! frames later.

pub mod atlas;
pub mod cpu;
pub mod debug;
pub mod gather;
pub mod mark;
pub mod resources;
pub mod shade;
pub mod shade_budget;
pub mod trimap;

use shade_budget::ShadeBudget;
use std::str::FromStr;

use serde::Serialize;

use super::frame::Frame;
use super::passes::depth_prepass::{DepthPrepass, depth_prepass};
use super::passes::light_grid::LightGrid;
use super::passes::light_grid::world::{WorldGrid, build_world_grid};
use super::passes::visibility::compute::{ComputeVisibility, ComputeVisibilityError, compute_visibility};
use super::passes::visibility::{VisibilityMethod, VisibilityPass, visibility};
use super::report::{Counters, ObjectMemory, PipelineReport};
use super::scene_gpu::SceneGpu;
use super::targets::Targets;
use super::{Pipeline, PipelineConfig};
use crate::gpu::GpuContext;
use crate::gpu::readback::ReadbackRing;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};
use atlas::{AtlasError, AtlasLayout};
use gather::{GatherPass, gather};
use mark::{MarkPass, mark_tiles};
use resources::Resources;
use shade::{ShadePass, shade_tiles};

/// The WGSL module every object-space pass imports (`shadespace::objectspace`).
pub const SHARED_WGSL: ShaderSource = ShaderSource::new("objectspace.wgsl", include_str!("objectspace.wgsl"));

/// The object-space pass shaders, for the test that validates every shader.
pub const PASS_SHADERS: &[ShaderSource] =
    &[mark::SHADER, shade::SHADER, gather::SHADER, trimap::SHADER, trimap::DILATE];

/// Largest atlas page side (the adapter's limit may be lower).
pub const MAX_PAGE_SIZE: u32 = 8192;
/// Mip chains stop at this side: the procedural scenes' chart gutters are
/// 1/128 of the square and generated charts have 4 texels at 256 or more, so
/// below 128 texels neighbouring charts would share texels.
pub const COARSEST_LEVEL: u32 = 128;
/// Default atlas budget: 64 Mi texels (768 MiB with the triangle maps).
pub const DEFAULT_ATLAS_BUDGET: u64 = 64 << 20;
/// Bytes per atlas texel: the shade (`Rgba16Float`) and the triangle map (`R32Uint`).
const BYTES_PER_TEXEL: u64 = 8 + 4;
/// Bytes per tile: two stamps and a queue slot.
const BYTES_PER_TILE: u64 = 4 + 4 + 8;

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
}

impl DebugView {
    pub const ALL: [Self; 5] = [Self::Shade, Self::ChartUv, Self::MipLevel, Self::TileMask, Self::CacheAge];

    /// The name `--view` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Shade => "shade",
            Self::ChartUv => "chart-uv",
            Self::MipLevel => "mip-level",
            Self::TileMask => "tile-mask",
            Self::CacheAge => "cache-age",
        }
    }

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Shade => "VIEW_SHADE",
            Self::ChartUv => "VIEW_CHART_UV",
            Self::MipLevel => "VIEW_MIP_LEVEL",
            Self::TileMask => "VIEW_TILE_MASK",
            Self::CacheAge => "VIEW_CACHE_AGE",
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

/// The GPU's tile counters, one `u32` slot each (exported to WGSL as `COUNT_*`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileCounter {
    /// Tiles queued for shading this frame.
    Queued = 0,
    /// Tiles some pixel needs this frame.
    Visible = 1,
    /// Visible tiles that were not visible in the previous frame.
    New = 2,
}

impl TileCounter {
    pub const ALL: [Self; 3] = [Self::Queued, Self::Visible, Self::New];
    /// Slots in the counter buffer (one spare keeps it 16 bytes).
    pub const SLOTS: usize = 4;

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Queued => "COUNT_QUEUED",
            Self::Visible => "COUNT_VISIBLE",
            Self::New => "COUNT_NEW",
        }
    }
}

/// Settings of the object-space pipeline.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectSpaceConfig {
    /// Tile side in texels: 8, 16, 32 or 64.
    pub tile_size: u32,
    /// Re-shade a visible tile when its shade is this many frames old (N >= 1).
    pub reuse: u32,
    /// Added to every pixel's mip level (positive: coarser shading).
    pub mip_bias: f32,
    /// Strength of the per-pixel variable-rate bias (0 = off): up to this
    /// many levels coarser where a triangle's normals do not vary.
    pub variable_rate: f32,
    pub view: DebugView,
    /// Shading-texture side per scene object; `None` shades the object
    /// forward (per pixel, in the gather). Reported per object instead.
    #[serde(skip)]
    pub texture_sizes: Vec<Option<u32>>,
    /// Most atlas texels (all objects, mip chains included); sizes are halved
    /// uniformly until they fit (see [`atlas::fit_budget`]).
    pub atlas_budget_texels: u64,
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
    /// Most texels shaded per frame: above it the mip levels are biased
    /// coarser until the shading fits ([`shade_budget`]). `None`: no limit.
    pub shade_budget_texels: Option<u64>,
}

impl Default for ObjectSpaceConfig {
    fn default() -> Self {
        Self {
            tile_size: 8,
            reuse: 1,
            mip_bias: 0.0,
            variable_rate: 0.0,
            view: DebugView::Shade,
            texture_sizes: Vec::new(),
            atlas_budget_texels: DEFAULT_ATLAS_BUDGET,
            visibility_prepass: true,
            visibility: VisibilityMethod::Raster,
            count_visibility: false,
            shade_budget_texels: None,
        }
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
    #[error("the object-space pipeline needs the PRIMITIVE_INDEX feature, which {0} lacks")]
    NoPrimitiveIndex(String),
    #[error("{0} texture sizes given for {1} objects")]
    SizeCount(usize, usize),
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
    shade: ShadePass,
    gather: GatherPass,
    grid: WorldGrid,
    readback: ReadbackRing<u64>,
    /// Frames rendered so far; stamps are `frames + 1` so that 0 means never.
    frames: u32,
    budget_halvings: u32,
    shade_budget: Option<ShadeBudget>,
    /// The bias the budget added to each frame still in flight.
    budget_bias: std::collections::BTreeMap<u64, f32>,
}

impl ObjectSpace {
    pub fn new(
        ctx: &GpuContext,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        config: ObjectSpaceConfig,
    ) -> Result<Self, ObjectSpaceError> {
        let device = &ctx.device;
        if config.reuse == 0 {
            return Err(ObjectSpaceError::BadReuse(0));
        }
        if !config.mip_bias.is_finite() || !config.variable_rate.is_finite() {
            return Err(ObjectSpaceError::BadBias(config.mip_bias, config.variable_rate));
        }
        if !device.features().contains(wgpu::Features::PRIMITIVE_INDEX) {
            return Err(ObjectSpaceError::NoPrimitiveIndex(ctx.info.name.clone()));
        }
        if config.texture_sizes.len() != scene.draws.len() {
            return Err(ObjectSpaceError::SizeCount(config.texture_sizes.len(), scene.draws.len()));
        }
        let max_page = MAX_PAGE_SIZE.min(device.limits().max_texture_dimension_2d);
        let (sizes, budget_halvings) = atlas::fit_budget(&config.texture_sizes, config.atlas_budget_texels, 64);
        if budget_halvings > 0 {
            tracing::info!("atlas budget: every object's shading texture halved {budget_halvings} time(s)");
        }
        let layout = AtlasLayout::new(&sizes, config.tile_size, max_page, COARSEST_LEVEL)?;
        let triangle_map = trimap::build(device, &ctx.queue, shaders, scene, &layout)?;
        let res = Resources::new(device, &layout, &triangle_map, &scene.triangle_charts, targets);
        let visibility = match config.visibility {
            VisibilityMethod::Raster => Visibility::Raster {
                prepass: config.visibility_prepass.then(|| DepthPrepass::new(device, shaders, scene)).transpose()?,
                ids: VisibilityPass::new(device, shaders, scene, config.visibility_prepass)?,
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
        let shade_budget = config.shade_budget_texels.map(|t| ShadeBudget::new(t as f64));
        Ok(Self {
            visibility,
            mark: MarkPass::new(device, shaders, scene, &res)?,
            shade: ShadePass::new(device, shaders, scene, &res, &grid.grid)?,
            gather: GatherPass::new(device, shaders, scene, &res, targets, &grid.grid)?,
            grid,
            res,
            layout,
            config,
            readback: ReadbackRing::new("tile counters", TileCounter::SLOTS as u64 * 4),
            frames: 0,
            budget_halvings,
            shade_budget,
            budget_bias: Default::default(),
        })
    }

    pub fn config(&self) -> &ObjectSpaceConfig {
        &self.config
    }

    /// The world grid (its last build can be read back).
    pub fn light_grid(&self) -> &LightGrid {
        &self.grid.grid
    }
}

impl Pipeline for ObjectSpace {
    fn encode(&mut self, frame: &mut Frame) {
        self.frames += 1;
        let stale = frame.lights_changed || self.frames == 1;
        let max_queue = self.layout.tile_count;
        let added = self.shade_budget.as_ref().map_or(0.0, |b| b.bias);
        if self.shade_budget.is_some() {
            self.budget_bias.insert(frame.number, added);
        }
        let mip_bias = self.config.mip_bias + added;
        self.res.begin_frame(frame.queue, frame.encoder, self.frames, stale, &self.config, mip_bias, max_queue);
        match &mut self.visibility {
            Visibility::Raster { prepass, ids } => {
                if let Some(prepass) = prepass {
                    depth_prepass(frame, prepass);
                }
                visibility(frame, ids, &self.res.visibility);
            }
            Visibility::Compute(pass) => compute_visibility(frame, pass),
        }
        mark_tiles(frame, &self.mark, &self.res);
        build_world_grid(frame, &mut self.grid);
        shade_tiles(frame, &self.shade, &self.res, &self.grid.grid);
        gather(frame, &self.gather, &self.res, &self.grid.grid);
        let counter_bytes = TileCounter::SLOTS as u64 * 4;
        self.readback.copy(frame.device, frame.encoder, &self.res.counters, counter_bytes, frame.number);
    }

    fn uses_object_light_lists(&self) -> bool {
        false
    }

    fn after_submit(&mut self) {
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
    /// `shaded_texels_per_pixel` (after reuse); with `count_visibility`, the
    /// compute rasterizer's counts too (in entries of their own).
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        let counts = match &mut self.visibility {
            Visibility::Compute(pass) => pass.collect_counts(device, wait),
            Visibility::Raster { .. } => Vec::new(),
        };
        let tile_texels = (self.layout.tile_size * self.layout.tile_size) as f64;
        let pixels = self.res.visibility.texture.width() as f64 * self.res.visibility.texture.height() as f64;
        self.readback
            .collect(device, wait)
            .into_iter()
            .map(|(frame, bytes)| {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
                let count = |t: TileCounter| c[t as usize] as f64;
                let (shaded, visible, new) =
                    (count(TileCounter::Queued), count(TileCounter::Visible), count(TileCounter::New));
                let counters = [
                    ("visible_tiles", visible),
                    ("shaded_tiles", shaded),
                    ("reused_tiles", (visible - shaded).max(0.0)),
                    ("new_tiles", new),
                    ("new_fraction", new / visible.max(1.0)),
                    ("shaded_texels", shaded * tile_texels),
                    ("visible_texels", visible * tile_texels),
                    ("overshading", visible * tile_texels / pixels),
                    ("shaded_texels_per_pixel", shaded * tile_texels / pixels),
                ];
                let mut counters: Counters = counters.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
                if let Some(budget) = &mut self.shade_budget {
                    let used = self.budget_bias.remove(&frame).unwrap_or_default();
                    budget.observe(frame, used, shaded * tile_texels);
                    counters.insert("shade_budget_bias".into(), used as f64);
                }
                (frame, counters)
            })
            .chain(counts)
            .collect()
    }

    /// Memory: atlas (8 B/texel), triangle maps (4 B/texel), tile state
    /// (16 B/tile), visibility buffer; per object: texture size, levels,
    /// texels, tiles and bytes.
    fn report(&self) -> PipelineReport {
        let t = self.layout.tile_size;
        let texels = self.layout.atlas_texels();
        let tiles = self.layout.tile_count as u64;
        let mut report = PipelineReport::new(PipelineConfig::ObjectSpace(self.config.clone()))
            .memory("atlas", texels * 8)
            .memory("triangle_maps", texels * 4)
            .memory("tile_state", tiles * BYTES_PER_TILE)
            .memory("visibility", self.res.visibility.bytes())
            .memory("world_grid", self.grid.grid.bytes())
            .setup("budget_halvings", self.budget_halvings as u64)
            .setup("atlas_pages", self.layout.pages as u64)
            .setup("page_size", self.layout.page_size as u64)
            .setup("tile_count", tiles)
            .setup("world_grid_list_capacity", self.grid.grid.capacity())
            .setup("world_grid_list_peak", self.grid.grid.peak_entries());
        report.objects = (self.layout.objects.iter().enumerate())
            .filter_map(|(object, a)| {
                let a = a.as_ref()?;
                let (texels, tiles) = (a.texels(), a.tiles(t));
                Some(ObjectMemory {
                    object,
                    texture_size: a.size,
                    levels: a.levels.len() as u32,
                    texels,
                    tiles,
                    bytes: texels * BYTES_PER_TEXEL + tiles * BYTES_PER_TILE,
                })
            })
            .collect();
        report
    }
}
