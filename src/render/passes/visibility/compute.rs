//! Compute visibility: a software rasterizer that fills the same
//! [`VisibilityBuffer`] as the raster pass, with no vertex or fragment work
//! (the H100 runs those on a few of its SMs only).
//!
//! Passes, each timed under its name: `vis: clear` (the 64-bit buffer to
//! background), `vis: raster` (one thread per visible triangle: near-plane
//! clipped bounds, homogeneous edge functions with the top-left rule, and one
//! 64-bit `atomicMax(depth << 32 | payload)` per covered pixel (with
//! [`SceneGpu::vis_depth_test`], off by default, only where a load of the
//! pixel finds nothing nearer: fewer atomics, but slower on the H200); triangles
//! whose bounds exceed 256 pixels ([`SceneGpu::vis_small_area`]) are set up
//! once into a buffer), `vis: raster big` (their 32x32 tiles listed, a
//! workgroup per big triangle, then a workgroup per tile,
//! [`SceneGpu::vis_big_workgroups`] of them looping over the list: its 8x8
//! squares are tested against the triangle's edges, then every pixel of the
//! squares that pass) and `vis: resolve` (payload to (object + 1, triangle)).
//!
//! Under MSAA (the targets' samples, shaders built with `MSAA`) each pixel
//! has one 64-bit entry per sample, tested at Vulkan's standard sample
//! positions as the hardware tests them (coverage and depth per sample; an
//! alpha-masked triangle's cut once per pixel, at its centre, as a fragment
//! shader's discard), and the output visibility buffer is a 2D array with a
//! layer per sample (multisampled textures cannot be written by compute
//! passes; the consumers read it with `VISIBILITY_LAYERS`).
//! For scenes with alpha-masked materials the raster passes are compiled
//! with `ALPHA_MASK`: a masked triangle keeps a pixel only where its base
//! colour alpha passes the cutoff (the other scenes run the same code as
//! without masks).
//!
//! Payload: the complement of the triangle's index in the scene's numbering
//! (objects' triangles back to back, in object order: at equal depth the
//! first drawn without culling wins, as in the raster path, whatever culling
//! skipped; 0 stays background). A per-frame list of the visible objects'
//! (object, first index in the frame's list, first index in the scene's
//! numbering) drives the dispatch without culling (a thread finds its object
//! by binary search) and the resolve; the 32 bits hold any mix of object and
//! triangle counts up to 2^32 - 1 triangles, where packing fixed bit fields
//! would have to cap one of them.
//!
//! Culling ([`SceneGpu::culling`], `--culling`; `cull.wgsl`, `hiz.wgsl`): with
//! `frustum` or `occlusion` the triangles are rasterized cluster by cluster
//! ([`crate::render::clusters`]): `vis: cull` tests every cluster of the
//! visible objects (frustum, normal cone where back faces are culled) and
//! lists the survivors, `vis: raster` (one workgroup per listed cluster,
//! dispatched indirectly) and `vis: raster big` draw them. With occlusion
//! the early list holds only the clusters visible last frame; then `vis:
//! hiz` builds a depth pyramid from what they drew, `vis: cull late` tests
//! the rest against it (and remembers every cluster's visibility for the
//! next frame), and `vis: raster late` / `vis: raster big late` draw the
//! newly visible. The visibility buffer is the same in every mode (tested).
//!
//! The depth target is not written: the consumers are all compute passes
//! (object space's, tiled deferred's), which read depth, where they need it,
//! from the rasterizer's own 64-bit buffer (`visibility_read.wgsl`); a
//! full-screen depth write would be a fragment pass, the slow kind on the H100.

use super::VisibilityBuffer;
use crate::gpu::readback::ReadbackRing;
use crate::render::clusters::Culling;
use crate::render::frame::Frame;
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline, compute_pipeline_with};
use crate::render::report::Counters;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ALPHA_MASK, ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const RASTER: ShaderSource = ShaderSource::new("raster.wgsl", include_str!("raster.wgsl"));
/// `raster.wgsl` culling the back faces of single-sided objects
/// ([`crate::scene::Material::double_sided`]), counting its work
/// ([`RasterCount`]), or both.
pub const RASTER_CULLING: ShaderSource = RASTER.with_defs(&["CULL_BACK"]);
pub const RASTER_COUNTING: ShaderSource = RASTER.with_defs(&["COUNT"]);
pub const RASTER_CULLING_COUNTING: ShaderSource = RASTER.with_defs(&["CULL_BACK", "COUNT"]);
pub const RESOLVE: ShaderSource = ShaderSource::new("resolve.wgsl", include_str!("resolve.wgsl"));
/// The clear of the 64-bit buffer (`vis: clear`).
pub const CLEAR: ShaderSource = ShaderSource::new("clear.wgsl", include_str!("clear.wgsl"));
/// Threads per workgroup of `clear.wgsl` (`CLEAR_WORKGROUP`), 16 bytes each.
const CLEAR_WORKGROUP: u64 = 256;
/// Cluster culling (`cull_early`, `cull_late`, `finish`), shared with the
/// hardware raster passes' ([`crate::render::passes::cluster_draws`]).
pub const CULL: ShaderSource = ShaderSource::new("cull.wgsl", include_str!("cull.wgsl"));
/// The depth pyramid of occlusion culling.
pub const HIZ: ShaderSource = ShaderSource::new("hiz.wgsl", include_str!("hiz.wgsl"));
/// The module lighting passes import to read the output as a G-buffer
/// (`shadespace::visibility_read`, group 1: [`ComputeVisibility::read_layout`]).
pub const SHARED_WGSL: ShaderSource = ShaderSource::new("visibility_read.wgsl", include_str!("visibility_read.wgsl"));

/// Threads per workgroup of `raster` (`RASTER_WORKGROUP` in `raster.wgsl`),
/// and of `raster_clusters`: one cluster's triangles.
const RASTER_WORKGROUP: u32 = 64;
const _: () = assert!(crate::render::clusters::CLUSTER_TRIANGLES as u32 == RASTER_WORKGROUP);
/// Clusters per workgroup of `cull.wgsl` (`CULL_WORKGROUP`): one object's,
/// a thread each (an object with more takes several).
pub(crate) const CULL_CHUNK: u32 = 64;

/// Workgroups of `queue_big`, which loop over the big triangles.
const QUEUE_BIG_WORKGROUPS: u32 = 1024;
/// Most workgroups along x of one dispatch (WebGPU's limit is 65535).
const MAX_GROUPS_X: u32 = 32768;

/// The features the compute rasterizer needs: 64-bit integers and 64-bit
/// atomic max on storage buffers (lavapipe and the H100 have both).
pub const FEATURES: wgpu::Features = wgpu::Features::SHADER_INT64.union(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX);

gpu_struct! {
    /// Per-frame settings of `raster.wgsl` (`RasterParams`).
    pub struct GpuRasterParams as "RasterParams" {
        /// Visible objects (entries of the range list).
        pub range_count: u32,
        /// Visible triangles: the threads of `raster`.
        pub triangle_count: u32,
        /// Entries of the big-tile queue.
        pub big_capacity: u32,
        /// Entries of the big-triangle setups.
        pub setup_capacity: u32,
        /// Samples per pixel (1 without MSAA).
        pub samples: u32,
        /// 1: test each pixel with a load before its atomic
        /// ([`SceneGpu::vis_depth_test`]).
        pub depth_test: u32,
        /// Most pixels of a triangle's bounds that its own thread rasterizes
        /// ([`SceneGpu::vis_small_area`]); bigger ones are set up and queued.
        pub small_area: u32,
        pub pad_c: u32,
    }
}

gpu_struct! {
    /// Per-frame settings of `cull.wgsl` (`CullParams`).
    pub struct GpuCullParams as "CullParams" {
        /// Visible objects (entries of the range list).
        pub range_count: u32,
        /// [`CULL_CONE`] | [`CULL_OCCLUSION`].
        pub flags: u32,
        /// Entries of each cluster list.
        pub capacity: u32,
        /// Levels of the depth pyramid.
        pub levels: u32,
        pub width: u32,
        pub height: u32,
        /// Chunks of up to 64 clusters of one visible object: the workgroups.
        pub chunk_count: u32,
        pub pad: u32,
        /// First entry of each pyramid level (level k: `[k / 4][k % 4]`).
        pub level_offsets: [glam::UVec4; 4],
    }
}

/// [`GpuCullParams::flags`]: test normal cones (the scene culls back faces).
pub const CULL_CONE: u32 = 1;
/// [`GpuCullParams::flags`]: two-pass occlusion.
pub const CULL_OCCLUSION: u32 = 2;

gpu_struct! {
    /// One level's dispatch of `hiz.wgsl` (`HizLevel`).
    pub struct GpuHizLevel as "HizLevel" {
        pub src_offset: u32,
        pub src_width: u32,
        pub src_height: u32,
        pub dst_offset: u32,
        pub dst_width: u32,
        pub dst_height: u32,
        /// 1: the source is the pixels.
        pub from_pixels: u32,
        /// Entries of the 64-bit buffer per pixel: its samples.
        pub samples: u32,
    }
}

gpu_struct! {
    /// Which cluster list a `raster_clusters` dispatch reads (`ListParams`).
    pub struct GpuListParams as "ListParams" {
        /// Its length's entry in the cull counts (0 early, 1 late).
        pub index: u32,
        /// Its first entry in the lists' buffer.
        pub base: u32,
    }
}

/// What `cull.wgsl` counts per frame (its `counts` array, in this order;
/// read back with `--count-visibility`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CullCount {
    /// Clusters drawn by the early pass.
    DrawnEarly,
    /// Clusters drawn by the late pass (newly visible).
    DrawnLate,
    /// Clusters of the visible objects (each tested once a frame).
    Tested,
    /// Skipped: outside the frustum.
    Frustum,
    /// Skipped: every triangle faces away (normal cone).
    Cone,
    /// Skipped: behind the depth pyramid (and not drawn early).
    Occlusion,
}

impl CullCount {
    pub const ALL: [Self; 6] =
        [Self::DrawnEarly, Self::DrawnLate, Self::Tested, Self::Frustum, Self::Cone, Self::Occlusion];

    /// Its name among the frame counters.
    pub fn name(self) -> &'static str {
        match self {
            Self::DrawnEarly => "cull_drawn_early",
            Self::DrawnLate => "cull_drawn_late",
            Self::Tested => "cull_tested",
            Self::Frustum => "cull_frustum",
            Self::Cone => "cull_cone",
            Self::Occlusion => "cull_occlusion",
        }
    }
}

const CULL_COUNTS_BYTES: u64 = CullCount::ALL.len() as u64 * 4;

gpu_struct! {
    /// Settings of `resolve.wgsl` (`ResolveParams`).
    pub struct GpuResolveParams as "ResolveParams" {
        pub width: u32,
        pub height: u32,
        /// Visible objects (entries of the range list).
        pub range_count: u32,
        /// Samples per pixel (1 without MSAA).
        pub samples: u32,
    }
}

/// What the counting variant of `raster.wgsl` counts per frame (its
/// `counts` array, in this order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterCount {
    /// Triangles rasterized by their own thread (box of at most
    /// [`SceneGpu::vis_small_area`] pixels).
    SmallTriangles,
    /// Pixels those threads tested (their boxes).
    SmallPixelsTested,
    /// Triangles set up once and queued as 32x32 tiles.
    BigTriangles,
    /// Their queued tiles.
    BigTiles,
    /// 8x8 squares of those tiles that passed the edge test.
    BigSquaresPassed,
    /// Pixels the tile workgroups tested (in squares that passed).
    BigPixelsTested,
    /// 64-bit atomicMax issued: covered pixels inside the depth range that
    /// the depth test before the atomic did not reject.
    PixelsWritten,
    /// Big triangles (partly) rasterized by one thread because a queue was full.
    OverflowTriangles,
    /// Writes by triangles that face away (clockwise on screen): what
    /// back-face culling would save on closed meshes.
    BackFacingWrites,
    /// Covered pixels inside the depth range whose load found a value at
    /// least as large, so no atomicMax was issued
    /// ([`SceneGpu::vis_depth_test`], and alpha-masked triangles always).
    DepthRejects,
}

impl RasterCount {
    pub const ALL: [Self; 10] = [
        Self::SmallTriangles,
        Self::SmallPixelsTested,
        Self::BigTriangles,
        Self::BigTiles,
        Self::BigSquaresPassed,
        Self::BigPixelsTested,
        Self::PixelsWritten,
        Self::OverflowTriangles,
        Self::BackFacingWrites,
        Self::DepthRejects,
    ];

    /// Its name among the frame counters.
    pub fn name(self) -> &'static str {
        match self {
            Self::SmallTriangles => "vis_small_triangles",
            Self::SmallPixelsTested => "vis_small_pixels_tested",
            Self::BigTriangles => "vis_big_triangles",
            Self::BigTiles => "vis_big_tiles",
            Self::BigSquaresPassed => "vis_big_squares_passed",
            Self::BigPixelsTested => "vis_big_pixels_tested",
            Self::PixelsWritten => "vis_pixels_written",
            Self::OverflowTriangles => "vis_overflow_triangles",
            Self::BackFacingWrites => "vis_back_facing_writes",
            Self::DepthRejects => "vis_depth_rejects",
        }
    }
}

/// The counting variant's buffer and its read-back, and the read-back of
/// the cull counts.
struct RasterCounting {
    counts: wgpu::Buffer,
    readback: ReadbackRing<u64>,
    cull: ReadbackRing<u64>,
}

/// Cluster culling's pipelines and buffers (`cull.wgsl`, `hiz.wgsl`).
struct Cull {
    early: wgpu::ComputePipeline,
    late: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    raster: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// `raster.wgsl`'s group 1 reading the early list (also the group of
    /// the unculled path) and the late list.
    raster_groups: [wgpu::BindGroup; 2],
    pyramid: DepthPyramid,
    /// The lists' lengths and the counters (cleared every frame).
    counts: wgpu::Buffer,
    /// Indirect dispatch sizes of both lists.
    dispatch: wgpu::Buffer,
    capacity: u32,
    /// This frame's chunks (visible object, first cluster) of up to
    /// [`CULL_CHUNK`] clusters: the cull passes' workgroups.
    chunks: wgpu::Buffer,
    /// Bytes of its buffers (lists, history, pyramid).
    bytes: u64,
}

const COUNTS_BYTES: u64 = RasterCount::ALL.len() as u64 * 4;

#[derive(Debug, thiserror::Error)]
pub enum ComputeVisibilityError {
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error(
        "compute visibility needs 64-bit atomics (SHADER_INT64, SHADER_INT64_ATOMIC_MIN_MAX), which this adapter lacks"
    )]
    NoInt64Atomics,
    #[error(
        "compute visibility at {width}x{height} with {samples} samples per pixel needs a {needed} MiB buffer; this adapter binds at most {max} MiB (take fewer samples or --visibility raster)"
    )]
    TooLarge { width: u32, height: u32, samples: u32, needed: u64, max: u64 },
}

/// The compute rasterizer's pipelines, buffers and bind groups, for one
/// resolution and one output buffer.
pub struct ComputeVisibility {
    /// `clear.wgsl` over the 64-bit buffer (its group and workgroups).
    clear: wgpu::ComputePipeline,
    clear_group: wgpu::BindGroup,
    clear_groups: (u32, u32),
    raster: wgpu::ComputePipeline,
    queue_big: wgpu::ComputePipeline,
    raster_big: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    raster_params: wgpu::Buffer,
    resolve_params: wgpu::Buffer,
    /// Per visible object: (object, first triangle in the frame's list).
    ranges: wgpu::Buffer,
    /// Entries of the big-tile queue and of the setups (cleared every frame).
    big_count: wgpu::Buffer,
    big_capacity: u32,
    setup_capacity: u32,
    /// Bytes of the big-triangle setups.
    setup_bytes: u64,
    cull: Cull,
    resolve_group: wgpu::BindGroup,
    /// Group 1 of passes that import `shadespace::visibility_read`: the ids
    /// and the 64-bit buffer.
    pub read_layout: wgpu::BindGroupLayout,
    pub read_group: wgpu::BindGroup,
    width: u32,
    height: u32,
    /// Per pixel: entries of the 64-bit buffer, layers of the output.
    samples: u32,
    counting: Option<RasterCounting>,
}

impl ComputeVisibility {
    /// Fails where the device lacks [`FEATURES`]. `counting`: the variant
    /// that counts its work ([`RasterCount`], see [`Self::collect_counts`]).
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        out: &VisibilityBuffer,
        counting: bool,
    ) -> Result<Self, ComputeVisibilityError> {
        if !device.features().contains(FEATURES) {
            return Err(ComputeVisibilityError::NoInt64Atomics);
        }
        let (width, height) = (targets.width, targets.height);
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        use wgpu::BufferUsages as U;
        let raster_params = buffer("vis raster params", size_of::<GpuRasterParams>() as u64, U::UNIFORM | U::COPY_DST);
        let resolve_params =
            buffer("vis resolve params", size_of::<GpuResolveParams>() as u64, U::UNIFORM | U::COPY_DST);
        let ranges = buffer("vis ranges", (scene.draws.len().max(1) * 16) as u64, U::STORAGE | U::COPY_DST);
        let samples = targets.samples;
        let depth_bytes = width as u64 * height as u64 * u64::from(samples) * 8;
        let limits = device.limits();
        let max = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        if depth_bytes > max {
            let (needed, max) = (depth_bytes.div_ceil(1 << 20), max >> 20);
            return Err(ComputeVisibilityError::TooLarge { width, height, samples, needed, max });
        }
        // A whole number of 16 bytes: the clear writes 16 at a time.
        let depth_ids = buffer("vis depth and ids", depth_bytes.next_multiple_of(16), U::STORAGE);
        // Room for big triangles' tiles covering every pixel 128 times over (a
        // tile holds up to 1024 pixels; boxes of thin triangles and hidden
        // layers count too: on the H100, Sponza at 1080p overflowed a
        // 16-times queue and the overflow, rasterized by single threads, took
        // 250 ms); past it, threads still rasterize alone.
        let big_capacity = ((width as u64 * height as u64 / 8).max(1 << 16) as u32).min(1 << 22);
        let big_tiles = buffer("vis big tiles", big_capacity as u64 * 8, U::STORAGE);
        let big_count = buffer("vis big count", 8, U::STORAGE | U::COPY_DST);
        // One setup per triangle whose box exceeds 256 pixels: a few thousand
        // on Sponza's path at 1080p; past the capacity threads rasterize
        // their big triangles alone.
        let triangles: u64 = scene.draws.iter().map(|d| d.index_count as u64 / 3).sum();
        let setup_capacity = triangles.clamp(1, 1 << 16) as u32;
        let setup_size =
            crate::shaders::struct_size(&shaders.compose(RASTER)?, "Setup").expect("raster.wgsl declares struct Setup");
        let setup_bytes = setup_capacity as u64 * setup_size;
        let big_setups = buffer("vis big setups", setup_bytes, U::STORAGE);

        let read = Binding::Storage { read_only: true };
        let rw = Binding::Storage { read_only: false };
        let counting = counting.then(|| RasterCounting {
            counts: buffer("vis raster counts", COUNTS_BYTES, U::STORAGE | U::COPY_DST | U::COPY_SRC),
            readback: ReadbackRing::new("vis raster counts", COUNTS_BYTES),
            cull: ReadbackRing::new("vis cull counts", CULL_COUNTS_BYTES),
        });
        // Cluster culling: two lists of up to every cluster of every object.
        let capacity = scene.instance_clusters.max(1).next_multiple_of(32);
        let lists = buffer("vis cluster lists", 2 * capacity as u64 * 8, U::STORAGE);
        let history = buffer("vis cluster history", capacity as u64 * 4, U::STORAGE);
        let object_clusters = {
            let data: Vec<[u32; 4]> =
                if scene.object_clusters.is_empty() { vec![[0; 4]] } else { scene.object_clusters.clone() };
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("vis object clusters"),
                    contents: bytemuck::cast_slice(&data),
                    usage: U::STORAGE,
                },
            )
        };
        let cull_counts = buffer("vis cull counts", CULL_COUNTS_BYTES, U::STORAGE | U::COPY_DST | U::COPY_SRC);
        let dispatch = buffer("vis cull dispatch", 24, U::STORAGE | U::INDIRECT);
        // Chunks of up to CULL_CHUNK clusters: at most one partial chunk per object.
        let chunks_capacity = scene.draws.len() as u64 + u64::from(capacity) / CULL_CHUNK as u64 + 1;
        let chunks = buffer("vis cull chunks", chunks_capacity * 8, U::STORAGE | U::COPY_DST);
        let list_params = |index: u32| {
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("vis cluster list"),
                    contents: bytemuck::bytes_of(&GpuListParams { index, base: index * capacity }),
                    usage: U::UNIFORM,
                },
            )
        };
        let list_params = [list_params(0), list_params(1)];
        let cull_params = buffer("vis cull params", size_of::<GpuCullParams>() as u64, U::UNIFORM | U::COPY_DST);

        let mut raster_bindings =
            vec![Binding::Uniform, read, rw, rw, rw, rw, read, read, read, read, Binding::Uniform];
        if counting.is_some() {
            raster_bindings.push(rw);
        }
        let raster_layout = bind_group_layout(device, "vis raster", &raster_bindings);
        let dimension = if samples > 1 { wgpu::TextureViewDimension::D2Array } else { wgpu::TextureViewDimension::D2 };
        let out_binding = Binding::StorageTexture { format: super::FORMAT, dimension };
        let resolve_layout = bind_group_layout(device, "vis resolve", &[Binding::Uniform, read, read, out_binding]);
        let raster_group = |list: &wgpu::Buffer| {
            let mut resources = vec![
                raster_params.as_entire_binding(),
                ranges.as_entire_binding(),
                depth_ids.as_entire_binding(),
                big_tiles.as_entire_binding(),
                big_count.as_entire_binding(),
                big_setups.as_entire_binding(),
                scene.clusters.as_entire_binding(),
                scene.cluster_triangles.as_entire_binding(),
                lists.as_entire_binding(),
                cull_counts.as_entire_binding(),
                list.as_entire_binding(),
            ];
            if let Some(c) = &counting {
                resources.push(c.counts.as_entire_binding());
            }
            bind_group(device, "vis raster", &raster_layout, &resources)
        };
        let raster_groups = [raster_group(&list_params[0]), raster_group(&list_params[1])];
        let pyramid = DepthPyramid::new(
            device,
            shaders,
            "vis depth pyramid",
            (width, height, samples),
            HIZ,
            read,
            depth_ids.as_entire_binding(),
        )?;
        let (cull_layout, cull_group) = cull_group(
            device,
            "vis cull",
            [
                &cull_params,
                &ranges,
                &scene.clusters,
                &object_clusters,
                &history,
                &lists,
                &cull_counts,
                &pyramid.texels,
                &dispatch,
                &chunks,
            ],
        );
        let resolve_group = bind_group(
            device,
            "vis resolve",
            &resolve_layout,
            &[
                resolve_params.as_entire_binding(),
                ranges.as_entire_binding(),
                depth_ids.as_entire_binding(),
                wgpu::BindingResource::TextureView(&out.view),
            ],
        );
        let clear_layout = bind_group_layout(device, "vis clear", &[rw]);
        let clear_group = bind_group(device, "vis clear", &clear_layout, &[depth_ids.as_entire_binding()]);
        let clear = compute_pipeline(device, shaders, CLEAR, "clear", &[&clear_layout])?;
        let clear_groups = split((depth_ids.size() / 16).div_ceil(CLEAR_WORKGROUP) as u32);
        let uint = wgpu::TextureSampleType::Uint;
        let read_layout = bind_group_layout(
            device,
            "visibility read",
            &[Binding::Texture { sample: uint, dimension }, Binding::Storage { read_only: true }],
        );
        let read_group = bind_group(
            device,
            "visibility read",
            &read_layout,
            &[wgpu::BindingResource::TextureView(&out.view), depth_ids.as_entire_binding()],
        );
        let raster_layouts = [&scene.layout, &raster_layout];
        let raster_shader = match (scene.has_single_sided(), counting.is_some()) {
            (false, false) => RASTER,
            (false, true) => RASTER_COUNTING,
            (true, false) => RASTER_CULLING,
            (true, true) => RASTER_CULLING_COUNTING,
        };
        // Alpha testing is compiled in only for scenes that need it.
        let defs: &[&str] = if scene.has_alpha_masks() { &[ALPHA_MASK] } else { &[] };
        let mut raster = |entry| compute_pipeline_with(device, shaders, raster_shader, defs, entry, &raster_layouts);
        let (plain, big, clustered) = (raster("raster")?, raster("raster_big")?, raster("raster_clusters")?);
        let queue_big = raster("queue_big")?;
        let cull_layouts = [&scene.layout, &cull_layout];
        let cull = Cull {
            early: compute_pipeline(device, shaders, CULL, "cull_early", &cull_layouts)?,
            late: compute_pipeline(device, shaders, CULL, "cull_late", &cull_layouts)?,
            finish: compute_pipeline(device, shaders, CULL, "finish", &cull_layouts)?,
            raster: clustered,
            params: cull_params,
            group: cull_group,
            raster_groups,
            bytes: lists.size() + history.size() + pyramid.texels.size() + object_clusters.size() + chunks.size(),
            pyramid,
            counts: cull_counts,
            chunks,
            dispatch,
            capacity,
        };
        Ok(Self {
            clear,
            clear_group,
            clear_groups,
            raster: plain,
            queue_big,
            raster_big: big,
            cull,
            resolve: compute_pipeline(device, shaders, RESOLVE, "resolve", &[&resolve_layout])?,
            raster_params,
            resolve_params,
            ranges,
            big_count,
            big_capacity,
            setup_capacity,
            setup_bytes,
            resolve_group,
            read_layout,
            read_group,
            width,
            height,
            samples,
            counting,
        })
    }
}

impl ComputeVisibility {
    /// Starts the read-back of the frame's counts (counting variant). Call
    /// right after the frame's submit.
    pub fn after_submit(&mut self) {
        if let Some(c) = &mut self.counting {
            c.readback.after_submit();
            c.cull.after_submit();
        }
    }

    /// The counting variant's counts of finished frames, by frame number,
    /// with four ratios: `vis_atomics_per_pixel` (writes per screen pixel),
    /// `vis_tests_per_write` (pixels tested per write) and
    /// `vis_small_pixels_per_triangle`, and `vis_covered_per_pixel` (writes
    /// plus depth rejects: the atomics without the depth test); with culling,
    /// the [`CullCount`]s and `cull_drawn` (clusters drawn by both passes).
    /// None without counting.
    pub fn collect_counts(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        let Some(c) = &mut self.counting else { return Vec::new() };
        let pixels = self.width as f64 * self.height as f64;
        let mut culls: std::collections::BTreeMap<u64, Counters> = c
            .cull
            .collect(device, wait)
            .into_iter()
            .map(|(frame, bytes)| {
                let raw: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
                let mut counters: Counters =
                    CullCount::ALL.iter().map(|&k| (k.name().to_string(), raw[k as usize] as f64)).collect();
                let drawn = raw[CullCount::DrawnEarly as usize] as f64 + raw[CullCount::DrawnLate as usize] as f64;
                counters.insert("cull_drawn".into(), drawn);
                (frame, counters)
            })
            .collect();
        c.readback
            .collect(device, wait)
            .into_iter()
            .map(|(frame, bytes)| {
                let raw: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
                let get = |k: RasterCount| raw[k as usize] as f64;
                let mut counters: Counters = RasterCount::ALL.iter().map(|&k| (k.name().to_string(), get(k))).collect();
                let written = get(RasterCount::PixelsWritten);
                let tested = get(RasterCount::SmallPixelsTested) + get(RasterCount::BigPixelsTested);
                counters.insert("vis_atomics_per_pixel".into(), written / pixels);
                // What every covered pixel cost without the test: the atomics before it.
                counters.insert("vis_covered_per_pixel".into(), (written + get(RasterCount::DepthRejects)) / pixels);
                counters.insert("vis_tests_per_write".into(), tested / written.max(1.0));
                counters.insert(
                    "vis_small_pixels_per_triangle".into(),
                    get(RasterCount::SmallPixelsTested) / get(RasterCount::SmallTriangles).max(1.0),
                );
                counters.extend(culls.remove(&frame).unwrap_or_default());
                (frame, counters)
            })
            .collect()
    }

    /// Bytes of its buffers (the 64-bit one, the big-tile queue and setups,
    /// the ranges, and culling's cluster lists, history and depth pyramid).
    pub fn bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * u64::from(self.samples) * 8
            + self.big_capacity as u64 * 8
            + self.setup_bytes
            + self.ranges.size()
            + self.cull.bytes
    }
}

/// The depth pyramid's levels at `width` x `height` (each half the last,
/// rounded up, down to 1x1; level 0 from the pixels' `samples`) and its texels.
pub(crate) fn hiz_levels(width: u32, height: u32, samples: u32) -> (Vec<GpuHizLevel>, u64) {
    let mut levels = Vec::new();
    let (mut src, mut src_offset, mut offset) = ((width, height), 0, 0u32);
    loop {
        let dst = (src.0.div_ceil(2), src.1.div_ceil(2));
        levels.push(GpuHizLevel {
            src_offset,
            src_width: src.0,
            src_height: src.1,
            dst_offset: offset,
            dst_width: dst.0,
            dst_height: dst.1,
            from_pixels: u32::from(levels.is_empty()),
            samples,
        });
        src_offset = offset;
        offset += dst.0 * dst.1;
        src = dst;
        if dst == (1, 1) {
            break;
        }
    }
    assert!(levels.len() <= 16, "a {width}x{height} pyramid has more levels than cull.wgsl holds");
    (levels, offset as u64)
}

/// `cull.wgsl`'s group 1 and its layout, over its buffers in binding order:
/// parameters, object cluster ranges, the scene's clusters, per-object
/// cluster tables, the history, the lists, the counts, the depth pyramid's
/// texels, the dispatch sizes and the chunks.
pub(crate) fn cull_group(
    device: &wgpu::Device,
    label: &str,
    buffers: [&wgpu::Buffer; 10],
) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let (read, rw) = (Binding::Storage { read_only: true }, Binding::Storage { read_only: false });
    let layout = bind_group_layout(device, label, &[Binding::Uniform, read, read, read, rw, rw, rw, read, rw, read]);
    let resources: Vec<wgpu::BindingResource> = buffers.iter().map(|b| b.as_entire_binding()).collect();
    let group = bind_group(device, label, &layout, &resources);
    (layout, group)
}

/// The depth pyramid of two-pass occlusion culling (`hiz.wgsl`), shared by
/// the compute rasterizer and the raster pipelines' culling: its levels
/// ([`hiz_levels`]), each at a dynamic offset of one uniform buffer, its
/// texels (`cull.wgsl` reads them), and the pass that reduces level 0 from
/// `source` and every level from the one before.
pub(crate) struct DepthPyramid {
    /// Per level: its sizes, and its entry's offset in the dynamic uniform.
    levels: Vec<(GpuHizLevel, u32)>,
    /// Every level's texels, one `f32` each.
    pub(crate) texels: wgpu::Buffer,
    group: wgpu::BindGroup,
    reduce: wgpu::ComputePipeline,
}

impl DepthPyramid {
    /// The pyramid over `width` x `height` pixels of `samples` each, reduced
    /// by `shader` from `source` (bound as `source_binding`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        label: &str,
        (width, height, samples): (u32, u32, u32),
        shader: ShaderSource,
        source_binding: Binding,
        source: wgpu::BindingResource,
    ) -> Result<Self, ShaderError> {
        let (levels, texel_count) = hiz_levels(width, height, samples);
        let texels = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: texel_count.max(1) * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let entry = size_of::<GpuHizLevel>() as u32;
        let align = device.limits().min_uniform_buffer_offset_alignment.max(entry);
        let levels: Vec<(GpuHizLevel, u32)> =
            levels.into_iter().enumerate().map(|(i, l)| (l, i as u32 * align)).collect();
        let mut level_bytes = vec![0u8; levels.len().max(1) * align as usize];
        for (l, offset) in &levels {
            let at = *offset as usize;
            level_bytes[at..at + entry as usize].copy_from_slice(bytemuck::bytes_of(l));
        }
        let level_buffer = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &level_bytes,
                usage: wgpu::BufferUsages::UNIFORM,
            },
        );
        let rw = Binding::Storage { read_only: false };
        let layout =
            bind_group_layout(device, label, &[Binding::DynamicUniform { size: entry as u64 }, source_binding, rw]);
        let group = bind_group(
            device,
            label,
            &layout,
            &[
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &level_buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(entry as u64),
                }),
                source,
                texels.as_entire_binding(),
            ],
        );
        let reduce = compute_pipeline(device, shaders, shader, "reduce", &[&layout])?;
        Ok(Self { levels, texels, group, reduce })
    }

    /// Its level count and each level's first texel (`GpuCullParams`).
    pub(crate) fn level_offsets(&self) -> (u32, [glam::UVec4; 4]) {
        let mut offsets = [glam::UVec4::ZERO; 4];
        for (k, (l, _)) in self.levels.iter().enumerate() {
            offsets[k / 4][k % 4] = l.dst_offset;
        }
        (self.levels.len() as u32, offsets)
    }

    /// Builds every level, in one compute pass named `name`.
    pub(crate) fn encode(&self, frame: &mut Frame, name: &str) {
        let mut cp = frame.compute_pass(name);
        cp.set_pipeline(&self.reduce);
        for (l, offset) in &self.levels {
            cp.set_bind_group(0, &self.group, &[*offset]);
            cp.dispatch_workgroups(l.dst_width.div_ceil(8), l.dst_height.div_ceil(8), 1);
        }
    }
}

/// This frame's ranges of the visible objects, (object, first triangle in
/// the frame's list, first triangle in the scene's numbering, 0), and the
/// number of visible triangles.
pub fn visible_ranges(scene: &SceneGpu, visible: &[bool]) -> (Vec<[u32; 4]>, u32) {
    let mut ranges = Vec::new();
    let mut total = 0u32;
    for (object, d) in scene.draws.iter().enumerate().filter(|(i, _)| visible[*i]) {
        ranges.push([object as u32, total, scene.object_clusters[object][3], 0]);
        total += d.index_count / 3;
    }
    (ranges, total)
}

/// A 2D dispatch of `groups` workgroups (at most [`MAX_GROUPS_X`] along x).
pub(crate) fn split(groups: u32) -> (u32, u32) {
    let x = groups.clamp(1, MAX_GROUPS_X);
    (x, groups.div_ceil(x))
}

/// Reads: the scene and the frame's visible objects. Writes: `pass`'s output
/// visibility buffer (every pixel). The depth target is left untouched.
pub fn compute_visibility(frame: &mut Frame, pass: &mut ComputeVisibility) {
    let (ranges, triangles) = visible_ranges(frame.scene, frame.visible);
    let range_count = ranges.len() as u32;
    if !ranges.is_empty() {
        frame.queue.write_buffer(&pass.ranges, 0, bytemuck::cast_slice(&ranges));
    }
    let raster = GpuRasterParams {
        range_count,
        triangle_count: triangles,
        big_capacity: pass.big_capacity,
        setup_capacity: pass.setup_capacity,
        samples: pass.samples,
        depth_test: u32::from(frame.scene.vis_depth_test),
        small_area: frame.scene.vis_small_area,
        pad_c: 0,
    };
    frame.queue.write_buffer(&pass.raster_params, 0, bytemuck::bytes_of(&raster));
    let resolve = GpuResolveParams { width: pass.width, height: pass.height, range_count, samples: pass.samples };
    frame.queue.write_buffer(&pass.resolve_params, 0, bytemuck::bytes_of(&resolve));
    let culling = frame.scene.culling;
    let mut chunks: Vec<[u32; 2]> = Vec::new();
    if culling != Culling::None {
        for (r, range) in ranges.iter().enumerate() {
            let clusters = frame.scene.object_clusters[range[0] as usize][1];
            chunks.extend((0..clusters).step_by(CULL_CHUNK as usize).map(|first| [r as u32, first]));
        }
        if !chunks.is_empty() {
            frame.queue.write_buffer(&pass.cull.chunks, 0, bytemuck::cast_slice(&chunks));
        }
        let (levels, level_offsets) = pass.cull.pyramid.level_offsets();
        let flags = if frame.scene.has_single_sided() { CULL_CONE } else { 0 }
            | if culling == Culling::Occlusion { CULL_OCCLUSION } else { 0 };
        let params = GpuCullParams {
            range_count,
            flags,
            capacity: pass.cull.capacity,
            levels,
            width: pass.width,
            height: pass.height,
            chunk_count: chunks.len() as u32,
            pad: 0,
            level_offsets,
        };
        frame.queue.write_buffer(&pass.cull.params, 0, bytemuck::bytes_of(&params));
        frame.encoder.clear_buffer(&pass.cull.counts, 0, None);
    }
    frame.encoder.clear_buffer(&pass.big_count, 0, None);
    if let Some(c) = &pass.counting {
        frame.encoder.clear_buffer(&c.counts, 0, None);
    }

    let pixel_groups = (pass.width.div_ceil(8), pass.height.div_ceil(8));
    {
        let mut cp = frame.compute_pass("vis: clear");
        cp.set_pipeline(&pass.clear);
        cp.set_bind_group(0, &pass.clear_group, &[]);
        cp.dispatch_workgroups(pass.clear_groups.0, pass.clear_groups.1, 1);
    }
    if range_count > 0 && culling == Culling::None {
        let groups = split(triangles.div_ceil(RASTER_WORKGROUP));
        raster_passes(frame, pass, &pass.raster, None, groups, "");
    } else if range_count > 0 {
        let groups = split(chunks.len() as u32);
        cull_pass(frame, pass, &pass.cull.early, "vis: cull", groups);
        raster_passes(frame, pass, &pass.cull.raster, Some(0), groups, "");
        if culling == Culling::Occlusion {
            pass.cull.pyramid.encode(frame, "vis: hiz");
            cull_pass(frame, pass, &pass.cull.late, "vis: cull late", groups);
            frame.encoder.clear_buffer(&pass.big_count, 0, None);
            raster_passes(frame, pass, &pass.cull.raster, Some(1), groups, " late");
        }
    }
    {
        let mut cp = frame.compute_pass("vis: resolve");
        cp.set_pipeline(&pass.resolve);
        cp.set_bind_group(0, &pass.resolve_group, &[]);
        cp.dispatch_workgroups(pixel_groups.0, pixel_groups.1, 1);
    }
    if let Some(c) = &mut pass.counting {
        c.readback.copy(frame.device, frame.encoder, &c.counts, COUNTS_BYTES, frame.number);
        if culling != Culling::None {
            c.cull.copy(frame.device, frame.encoder, &pass.cull.counts, CULL_COUNTS_BYTES, frame.number);
        }
    }
}

/// `entry` of `cull.wgsl` over the visible objects (`groups`), then `finish`
/// sizing the lists' dispatches.
fn cull_pass(
    frame: &mut Frame,
    pass: &ComputeVisibility,
    entry: &wgpu::ComputePipeline,
    label: &str,
    groups: (u32, u32),
) {
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass(label);
    cp.set_bind_group(0, scene, &[]);
    cp.set_bind_group(1, &pass.cull.group, &[]);
    cp.set_pipeline(entry);
    cp.dispatch_workgroups(groups.0, groups.1, 1);
    cp.set_pipeline(&pass.cull.finish);
    cp.dispatch_workgroups(1, 1, 1);
}

/// `vis: raster{suffix}` with `entry` (`raster`: `groups` workgroups;
/// `raster_clusters`: indirect, over cluster list `list`), then `vis: raster
/// big{suffix}` over the tiles it queued.
fn raster_passes(
    frame: &mut Frame,
    pass: &ComputeVisibility,
    entry: &wgpu::ComputePipeline,
    list: Option<usize>,
    groups: (u32, u32),
    suffix: &str,
) {
    let scene = frame.scene_group;
    let group = &pass.cull.raster_groups[list.unwrap_or(0)];
    {
        let mut cp = frame.compute_pass(&format!("vis: raster{suffix}"));
        cp.set_pipeline(entry);
        cp.set_bind_group(0, scene, &[]);
        cp.set_bind_group(1, group, &[]);
        match list {
            Some(l) => cp.dispatch_workgroups_indirect(&pass.cull.dispatch, l as u64 * 12),
            None => cp.dispatch_workgroups(groups.0, groups.1, 1),
        }
    }
    let workgroups = frame.scene.vis_big_workgroups;
    let mut cp = frame.compute_pass(&format!("vis: raster big{suffix}"));
    cp.set_bind_group(0, scene, &[]);
    cp.set_bind_group(1, group, &[]);
    cp.set_pipeline(&pass.queue_big);
    cp.dispatch_workgroups(QUEUE_BIG_WORKGROUPS, 1, 1);
    cp.set_pipeline(&pass.raster_big);
    cp.dispatch_workgroups(workgroups, 1, 1);
}
