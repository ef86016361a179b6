//! Object-space (texel) shading: visible surface tiles are shaded by compute
//! into per-object squares of a shared atlas, reused across frames, and the
//! frame is gathered from those shades.
//!
//! Per frame (each a pass, timed): *visibility* (raster: object and triangle
//! id per pixel) -> *mark* (compute per pixel: mip level, bilinear footprint,
//! tiles marked visible; the first marker of a tile queues it when its shade
//! is `reuse` frames old or stale) -> *queue* (indirect dispatch arguments)
//! -> *shade* (one workgroup per queued tile) -> *gather* (compute per pixel:
//! bilinear from the atlas). No CPU read-back inside the frame: the counters
//! are copied out and read a few frames later.

pub mod atlas;
pub mod cpu;
pub mod trimap;

use bytemuck::{Pod, Zeroable};
use serde::Serialize;
use wgpu::util::DeviceExt;

use super::targets::HDR_FORMAT;
use super::{DepthMode, FrameContext, Pipeline, ShadingCounters, scene_raster_pipeline};
use crate::gpu::readback::{self, ReadbackRing};
use crate::gpu::timing::GpuTimer;
use crate::gpu::{GpuContext, GpuError};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{self, ShaderError, ShaderLibrary};
use atlas::{AtlasError, AtlasLayout};

pub const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;
/// Largest atlas page side (the adapter's limit may be lower).
pub const MAX_PAGE_SIZE: u32 = 8192;
/// Mip chains stop at this side: the procedural scenes' chart gutters are
/// 1/128 of the square and generated charts have 4 texels at 256 or more, so
/// below 128 texels neighbouring charts would share texels.
pub const COARSEST_LEVEL: u32 = 128;
/// Default atlas budget: 64 Mi texels (768 MiB with the triangle maps).
pub const DEFAULT_ATLAS_BUDGET: u64 = 64 << 20;

/// Debug views that replace the gathered shade (`render --view`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum DebugView {
    /// The shaded image.
    #[default]
    Shade,
    /// Chart UV as red/green.
    ChartUv,
    /// Mip level per pixel (red = 0, orange = 1, yellow = 2, ...).
    MipLevel,
    /// Tile mask: red tiles were shaded this frame, green ones reused.
    TileMask,
    /// Cache age of the tile: black = shaded this frame, white = `reuse` frames old.
    CacheAge,
}

impl DebugView {
    fn mode(self) -> u32 {
        self as u32
    }
}

/// Settings of the object-space pipeline.
#[derive(Clone, Debug)]
pub struct ObjectSpaceOptions {
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
    /// forward (per pixel, in the gather).
    pub texture_sizes: Vec<Option<u32>>,
    /// Most atlas texels (all objects, mip chains included); sizes are halved
    /// uniformly until they fit (see [`atlas::fit_budget`]).
    pub atlas_budget_texels: u64,
    /// Lay down depth before the id pass, which then writes each pixel once
    /// (on the H100: 1.65 instead of 1.82 ms at 1920x1080 on Sponza).
    pub visibility_prepass: bool,
}

impl Default for ObjectSpaceOptions {
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
        }
    }
}

/// Mirrors `Params` in `shaders/objectspace.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuParams {
    stamp: u32,
    reuse: u32,
    tile_size: u32,
    view_mode: u32,
    mip_bias: f32,
    variable_rate: f32,
    max_queue: u32,
    pad: u32,
}

/// Memory the pipeline holds, in bytes.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct MemoryUse {
    pub atlas_bytes: u64,
    pub triangle_map_bytes: u64,
    /// Tile stamps (visible, shaded) and the work queue.
    pub tile_bytes: u64,
    pub visibility_bytes: u64,
}

/// Per object: its shading texture and what it costs.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectMemory {
    pub object: usize,
    pub texture_size: u32,
    pub levels: u32,
    pub texels: u64,
    pub tiles: u64,
    /// Atlas (8 B/texel) + triangle map (4 B/texel) + tile state (16 B/tile).
    pub bytes: u64,
}

/// Memory in total and per object.
#[derive(Clone, Debug, Serialize)]
pub struct MemoryReport {
    pub total: MemoryUse,
    /// Times the requested texture sizes were halved to fit the budget.
    pub budget_halvings: u32,
    pub atlas_pages: u32,
    pub page_size: u32,
    pub tile_count: u32,
    pub objects: Vec<ObjectMemory>,
}

/// The object-space marking state after a frame, read back from the GPU.
#[derive(Clone, Debug)]
pub struct MarkState {
    /// The frame's stamp (frames rendered so far; 0 in the tile buffers means never).
    pub stamp: u32,
    /// Per scene object: shades stamped before this are stale.
    pub valid_since: Vec<u32>,
    /// Per pixel, row-major: (object + 1, triangle); object 0 = background.
    pub visibility: Vec<[u32; 2]>,
    /// Per tile: stamp of the last frame it was visible.
    pub tile_visible: Vec<u32>,
    /// Per tile: stamp of the last frame it was shaded.
    pub tile_shaded: Vec<u32>,
    /// This frame's shade queue: (global tile, object << 8 | level), in GPU order.
    pub queue: Vec<[u32; 2]>,
    /// Queued, visible, new tiles (and one spare).
    pub counters: [u32; 4],
}

#[derive(Debug, thiserror::Error)]
pub enum ObjectSpaceError {
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error(transparent)]
    Atlas(#[from] AtlasError),
    #[error("reuse must be at least 1 (got {0})")]
    BadReuse(u32),
    #[error("the object-space pipeline needs the PRIMITIVE_INDEX feature, which {0} lacks")]
    NoPrimitiveIndex(String),
    #[error("{0} texture sizes given for {1} objects")]
    SizeCount(usize, usize),
}

pub struct ObjectSpace {
    options: ObjectSpaceOptions,
    pub layout: AtlasLayout,
    pub atlas: wgpu::Texture,
    visibility: wgpu::Texture,
    params: wgpu::Buffer,
    entries: wgpu::Buffer,
    entry_data: Vec<atlas::GpuAtlasEntry>,
    counters: wgpu::Buffer,
    tile_visible: wgpu::Buffer,
    tile_shaded: wgpu::Buffer,
    work_queue: wgpu::Buffer,
    shade_dispatch: wgpu::Buffer,
    raster: wgpu::RenderPipeline,
    depth_prepass: Option<wgpu::RenderPipeline>,
    mark: wgpu::ComputePipeline,
    queue_args: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    shared: wgpu::BindGroup,
    shade_args: wgpu::BindGroup,
    shade_outputs: wgpu::BindGroup,
    gather_io: wgpu::BindGroup,
    readback: ReadbackRing<u64>,
    /// Frames rendered so far; stamps are `frames + 1` so that 0 means never.
    frames: u32,
    memory: MemoryUse,
    budget_halvings: u32,
}

impl ObjectSpace {
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        adapter_name: &str,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        options: ObjectSpaceOptions,
    ) -> Result<Self, ObjectSpaceError> {
        if options.reuse == 0 {
            return Err(ObjectSpaceError::BadReuse(0));
        }
        if !device.features().contains(wgpu::Features::PRIMITIVE_INDEX) {
            return Err(ObjectSpaceError::NoPrimitiveIndex(adapter_name.to_string()));
        }
        if options.texture_sizes.len() != scene.draws.len() {
            return Err(ObjectSpaceError::SizeCount(options.texture_sizes.len(), scene.draws.len()));
        }
        let max_page = MAX_PAGE_SIZE.min(device.limits().max_texture_dimension_2d);
        let (sizes, halvings) = atlas::fit_budget(&options.texture_sizes, options.atlas_budget_texels, 64);
        if halvings > 0 {
            tracing::info!("atlas budget: every object's shading texture halved {halvings} time(s)");
        }
        let layout = AtlasLayout::new(&sizes, options.tile_size, max_page, COARSEST_LEVEL)?;
        let (triangle_map, _rings) = trimap::build(device, queue, shaders, scene, &layout)?;

        let atlas = layout.page_array_texture(
            device,
            "shading atlas",
            ATLAS_FORMAT,
            wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
        );
        let visibility = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("visibility"),
            size: wgpu::Extent3d { width: targets.width, height: targets.height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: VISIBILITY_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let entry_data = layout.gpu_entries();
        let storage = |label, size: u64, extra| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            })
        };
        let tiles = layout.tile_count as u64;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("object-space params"),
            size: size_of::<GpuParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let entries = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("atlas entries"),
            contents: bytemuck::cast_slice(&entry_data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        // Zero-initialised: 0 = never visible / never shaded.
        let tile_visible = storage("tile visible", tiles * 4, wgpu::BufferUsages::COPY_SRC);
        let tile_shaded = storage("tile shaded", tiles * 4, wgpu::BufferUsages::COPY_SRC);
        let work_queue = storage("shade queue", tiles * 8, wgpu::BufferUsages::COPY_SRC);
        let counters = storage("counters", 16, wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
        let shade_dispatch = storage("shade dispatch", 16, wgpu::BufferUsages::INDIRECT);

        let shared_layout = shared_layout(device);
        let view = |t: &wgpu::Texture, dim| {
            t.create_view(&wgpu::TextureViewDescriptor { dimension: Some(dim), ..Default::default() })
        };
        let shared = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("object space"),
            layout: &shared_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: entries.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: tile_visible.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: tile_shaded.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: work_queue.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: counters.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(&view(&visibility, wgpu::TextureViewDimension::D2)),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::TextureView(&view(
                        &triangle_map,
                        wgpu::TextureViewDimension::D2Array,
                    )),
                },
            ],
        });
        // Its own group: the shade pass reads it as INDIRECT, which excludes storage use.
        let args_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade dispatch"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let shade_args = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade dispatch"),
            layout: &args_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: shade_dispatch.as_entire_binding() }],
        });
        let atlas_array = view(&atlas, wgpu::TextureViewDimension::D2Array);
        let shade_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade outputs"),
            entries: &[storage_texture(0, ATLAS_FORMAT, wgpu::TextureViewDimension::D2Array)],
        });
        let shade_outputs = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade outputs"),
            layout: &shade_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&atlas_array) }],
        });
        let gather_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gather io"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                storage_texture(1, HDR_FORMAT, wgpu::TextureViewDimension::D2),
            ],
        });
        let gather_io = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gather io"),
            layout: &gather_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&atlas_array) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&targets.hdr_view) },
            ],
        });

        let compute = |shader, entry: &str, groups: &[Option<&wgpu::BindGroupLayout>]| -> Result<_, ShaderError> {
            let module = shaders.module(device, shader)?;
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: groups,
                immediate_size: 0,
            });
            Ok(device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            }))
        };
        let s = Some(&scene.layout);
        let o = Some(&shared_layout);
        // Each call borrows `shaders` mutably, so they run one after another.
        let mut compute = compute;
        let mark = compute(shaders::MARK, "mark", &[s, o])?;
        let queue_args = compute(shaders::MARK, "queue_args", &[s, o, Some(&args_layout)])?;
        let shade = compute(shaders::SHADE, "shade", &[s, o, Some(&shade_layout)])?;
        let gather = compute(shaders::GATHER, "gather", &[s, o, Some(&gather_layout)])?;
        let raster = visibility_pipeline(device, shaders, &scene.layout, options.visibility_prepass, false)?;
        let depth_prepass = options
            .visibility_prepass
            .then(|| visibility_pipeline(device, shaders, &scene.layout, true, true))
            .transpose()?;

        let texels = layout.atlas_texels();
        let memory = MemoryUse {
            atlas_bytes: texels * 8,
            triangle_map_bytes: texels * 4,
            tile_bytes: tiles * 16,
            visibility_bytes: targets.width as u64 * targets.height as u64 * 8,
        };
        Ok(Self {
            options,
            layout,
            atlas,
            visibility,
            params,
            entries,
            entry_data,
            counters,
            tile_visible,
            tile_shaded,
            work_queue,
            shade_dispatch,
            raster,
            depth_prepass,
            mark,
            queue_args,
            shade,
            gather,
            shared,
            shade_args,
            shade_outputs,
            gather_io,
            readback: ReadbackRing::new("object-space counters", 16),
            frames: 0,
            memory,
            budget_halvings: halvings,
        })
    }

    /// Memory in total and per object in the atlas: texture size, levels,
    /// texels, tiles, and bytes (atlas 8 B/texel + triangle map 4 B/texel +
    /// tile state 16 B/tile).
    pub fn memory_report(&self) -> MemoryReport {
        let t = self.layout.tile_size;
        let objects = self
            .layout
            .objects
            .iter()
            .enumerate()
            .filter_map(|(object, a)| {
                let a = a.as_ref()?;
                let (texels, tiles) = (a.texels(), a.tiles(t));
                Some(ObjectMemory {
                    object,
                    texture_size: a.size,
                    levels: a.levels.len() as u32,
                    texels,
                    tiles,
                    bytes: texels * 12 + tiles * 16,
                })
            })
            .collect();
        MemoryReport {
            total: self.memory,
            budget_halvings: self.budget_halvings,
            atlas_pages: self.layout.pages,
            page_size: self.layout.page_size,
            tile_count: self.layout.tile_count,
            objects,
        }
    }

    /// The marking state after the last frame, for tests that check tile
    /// marking against its CPU twin. Blocks on the GPU.
    pub fn read_mark_state(&self, ctx: &GpuContext) -> Result<MarkState, GpuError> {
        let buffer = |b: &wgpu::Buffer| -> Result<Vec<u32>, GpuError> {
            let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("mark state read-back"),
                size: b.size(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(b, 0, &staging, 0, b.size());
            ctx.queue.submit([encoder.finish()]);
            Ok(bytemuck::pod_collect_to_vec(&readback::read_buffer(ctx, &staging)?))
        };
        let tiles = self.layout.tile_count as usize;
        let mut tile_visible = buffer(&self.tile_visible)?;
        let mut tile_shaded = buffer(&self.tile_shaded)?;
        tile_visible.truncate(tiles);
        tile_shaded.truncate(tiles);
        let counters = buffer(&self.counters)?;
        let queued = (counters[0] as usize).min(tiles);
        let queue = buffer(&self.work_queue)?.chunks_exact(2).take(queued).map(|c| [c[0], c[1]]).collect();
        let visibility = bytemuck::pod_collect_to_vec::<u8, u32>(&readback::read_texture(ctx, &self.visibility, 8)?)
            .chunks_exact(2)
            .map(|c| [c[0], c[1]])
            .collect();
        Ok(MarkState {
            stamp: self.frames,
            valid_since: self.entry_data.iter().map(|e| e.valid_since).collect(),
            visibility,
            tile_visible,
            tile_shaded,
            queue,
            counters: [counters[0], counters[1], counters[2], counters[3]],
        })
    }

    pub fn options(&self) -> &ObjectSpaceOptions {
        &self.options
    }

    /// One mip level of one object's shades as an image (Reinhard tone
    /// mapped, sRGB), for the atlas debug view. Blocks on the GPU.
    pub fn read_atlas(&self, ctx: &GpuContext, object: usize, level: usize) -> Result<image::RgbaImage, GpuError> {
        let Some(l) = self.layout.objects.get(object).and_then(|o| o.as_ref()).and_then(|o| o.levels.get(level)) else {
            return Err(GpuError::Readback(format!("object {object} has no atlas level {level}")));
        };
        let bytes = readback::read_texture_region(ctx, &self.atlas, 8, (l.x, l.y, l.page), (l.size, l.size))?;
        let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(&bytes);
        let encode = |v: f32| {
            let c = (v.max(0.0) / (1.0 + v.max(0.0))).min(1.0);
            let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
            (s * 255.0 + 0.5) as u8
        };
        let pixels = halves
            .chunks_exact(4)
            .flat_map(|p| [encode(p[0].to_f32()), encode(p[1].to_f32()), encode(p[2].to_f32()), 255]);
        Ok(image::RgbaImage::from_raw(l.size, l.size, pixels.collect()).expect("size matches"))
    }
}

fn storage_texture(
    binding: u32,
    format: wgpu::TextureFormat,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture { access: wgpu::StorageTextureAccess::WriteOnly, format, view_dimension },
        count: None,
    }
}

/// Group 1 of the object-space passes; mirrors `shaders/objectspace.wgsl`.
fn shared_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let buffer = |binding, ty| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    };
    let rw = wgpu::BufferBindingType::Storage { read_only: false };
    let texture = |binding, view_dimension| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Uint,
            view_dimension,
            multisampled: false,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("object space"),
        entries: &[
            buffer(0, wgpu::BufferBindingType::Uniform),
            buffer(1, wgpu::BufferBindingType::Storage { read_only: true }),
            buffer(2, rw),
            buffer(3, rw),
            buffer(4, rw),
            buffer(5, rw),
            texture(6, wgpu::TextureViewDimension::D2),
            texture(7, wgpu::TextureViewDimension::D2Array),
        ],
    })
}

/// The id pass, or (`depth_only`) its depth pre-pass. After a pre-pass the id
/// pass tests `Equal` and writes no depth.
fn visibility_pipeline(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    scene_layout: &wgpu::BindGroupLayout,
    after_prepass: bool,
    depth_only: bool,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    let module = shaders.module(device, shaders::VISIBILITY)?;
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("visibility"),
        bind_group_layouts: &[Some(scene_layout)],
        immediate_size: 0,
    });
    Ok(if depth_only {
        scene_raster_pipeline(device, "visibility depth", &module, &layout, "vs_depth", None, DepthMode::Write)
    } else {
        let depth = if after_prepass { DepthMode::EqualAfterPrepass } else { DepthMode::Write };
        let fragment = Some(("fs_main", VISIBILITY_FORMAT));
        scene_raster_pipeline(device, "visibility", &module, &layout, "vs_main", fragment, depth)
    })
}

impl Pipeline for ObjectSpace {
    fn name(&self) -> &'static str {
        "objectspace"
    }

    fn encode(&mut self, frame: &FrameContext, encoder: &mut wgpu::CommandEncoder, timer: &mut GpuTimer) {
        self.frames += 1;
        let stamp = self.frames;
        if frame.lights_changed || stamp == 1 {
            for e in &mut self.entry_data {
                e.valid_since = stamp;
            }
            frame.queue.write_buffer(&self.entries, 0, bytemuck::cast_slice(&self.entry_data));
        }
        let params = GpuParams {
            stamp,
            reuse: self.options.reuse,
            tile_size: self.options.tile_size,
            view_mode: self.options.view.mode(),
            mip_bias: self.options.mip_bias,
            variable_rate: self.options.variable_rate,
            max_queue: self.layout.tile_count,
            pad: 0,
        };
        frame.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        encoder.clear_buffer(&self.counters, 0, None);

        let scene = frame.scene;
        let draw_visible = |pass: &mut wgpu::RenderPass, pipeline: &wgpu::RenderPipeline| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene.bind_group(), &[]);
            pass.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
            for (i, d) in scene.draws.iter().enumerate().filter(|(i, _)| frame.visible[*i]) {
                let i = i as u32;
                pass.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, i..i + 1);
            }
        };
        let mut depth_load = wgpu::LoadOp::Clear(0.0);
        if let Some(prepass) = &self.depth_prepass {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visibility depth"),
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &frame.targets.depth_view,
                    depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: timer.render_pass("visibility depth"),
                ..Default::default()
            });
            draw_visible(&mut pass, prepass);
            depth_load = wgpu::LoadOp::Load;
        }
        {
            let vis_view = self.visibility.create_view(&Default::default());
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("visibility"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &vis_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &frame.targets.depth_view,
                    depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: timer.render_pass("visibility"),
                ..Default::default()
            });
            draw_visible(&mut pass, &self.raster);
        }
        let (w, h) = (frame.targets.width.div_ceil(8), frame.targets.height.div_ceil(8));
        let mut compute =
            |name: &str, pipeline: &wgpu::ComputePipeline, extra: Option<&wgpu::BindGroup>, dispatch: Dispatch| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(name),
                    timestamp_writes: timer.compute_pass(name),
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, scene.bind_group(), &[]);
                pass.set_bind_group(1, &self.shared, &[]);
                if let Some(g) = extra {
                    pass.set_bind_group(2, g, &[]);
                }
                match dispatch {
                    Dispatch::Direct(x, y) => pass.dispatch_workgroups(x, y, 1),
                    Dispatch::Indirect(buffer) => pass.dispatch_workgroups_indirect(buffer, 0),
                }
            };
        compute("mark", &self.mark, None, Dispatch::Direct(w, h));
        compute("queue", &self.queue_args, Some(&self.shade_args), Dispatch::Direct(1, 1));
        compute("shade", &self.shade, Some(&self.shade_outputs), Dispatch::Indirect(&self.shade_dispatch));
        compute("gather", &self.gather, Some(&self.gather_io), Dispatch::Direct(w, h));
        self.readback.copy(frame.device, encoder, &self.counters, 16, frame.frame);
    }

    fn after_submit(&mut self) {
        self.readback.after_submit();
    }

    fn objectspace(&self) -> Option<&ObjectSpace> {
        Some(self)
    }

    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<ShadingCounters> {
        let tile_texels = (self.layout.tile_size * self.layout.tile_size) as u64;
        self.readback
            .collect(device, wait)
            .into_iter()
            .map(|(frame, bytes)| {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
                let (shaded, visible, new) = (c[0] as u64, c[1] as u64, c[2] as u64);
                ShadingCounters {
                    frame,
                    visible_tiles: visible,
                    shaded_tiles: shaded,
                    reused_tiles: visible.saturating_sub(shaded),
                    new_tiles: new,
                    shaded_texels: shaded * tile_texels,
                    visible_texels: visible * tile_texels,
                }
            })
            .collect()
    }
}

enum Dispatch<'a> {
    Direct(u32, u32),
    Indirect(&'a wgpu::Buffer),
}
