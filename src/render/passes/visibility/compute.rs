//! Compute visibility: a software rasterizer that fills the same
//! [`VisibilityBuffer`] as the raster pass, with no vertex or fragment work
//! (the H100 runs those on a few of its SMs only).
//!
//! Passes, each timed under its name: `vis: clear` (the 64-bit buffer to
//! background), `vis: raster` (one thread per visible triangle: near-plane
//! clipped bounds, homogeneous edge functions with the top-left rule, and one
//! 64-bit `atomicMax(depth << 32 | payload)` per covered pixel; triangles
//! whose bounds exceed 256 pixels are set up once into a buffer and queued as
//! 32x32 tiles), `vis: raster big` (one workgroup per queued tile: its 8x8
//! squares are tested against the triangle's edges, then every pixel of the
//! squares that pass) and `vis: resolve` (payload to (object + 1, triangle)).
//! For scenes with alpha-masked materials the raster passes are compiled
//! with `ALPHA_MASK`: a masked triangle keeps a pixel only where its base
//! colour alpha passes the cutoff (the other scenes run the same code as
//! without masks).
//!
//! Payload: the complement of the triangle's index in this frame's list of
//! visible triangles, object by object (at equal depth the first drawn wins,
//! as in the raster path; 0 stays background). The same per-frame list of (object, first
//! index) ranges drives the dispatch (a thread finds its object by binary
//! search), so culled objects cost nothing and the 32 bits hold any mix of
//! object and triangle counts up to 2^32 - 1 visible triangles, where packing
//! fixed bit fields would have to cap one of them.
//!
//! The depth target is not written: the consumers are all compute passes
//! (object space's, tiled deferred's), which read depth, where they need it,
//! from the rasterizer's own 64-bit buffer (`visibility_read.wgsl`); a
//! full-screen depth write would be a fragment pass, the slow kind on the H100.

use super::VisibilityBuffer;
use crate::gpu::readback::ReadbackRing;
use crate::render::frame::Frame;
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline, compute_pipeline_with};
use crate::render::report::Counters;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ALPHA_MASK, ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const RASTER: ShaderSource = ShaderSource::new("raster.wgsl", include_str!("raster.wgsl"));
/// `raster.wgsl` culling back faces ([`crate::scene::Scene::cull_back_faces`]),
/// counting its work ([`RasterCount`]), or both.
pub const RASTER_CULLING: ShaderSource = RASTER.with_defs(&["CULL_BACK"]);
pub const RASTER_COUNTING: ShaderSource = RASTER.with_defs(&["COUNT"]);
pub const RASTER_CULLING_COUNTING: ShaderSource = RASTER.with_defs(&["CULL_BACK", "COUNT"]);
pub const RESOLVE: ShaderSource = ShaderSource::new("resolve.wgsl", include_str!("resolve.wgsl"));
/// The module lighting passes import to read the output as a G-buffer
/// (`shadespace::visibility_read`, group 1: [`ComputeVisibility::read_layout`]).
pub const SHARED_WGSL: ShaderSource = ShaderSource::new("visibility_read.wgsl", include_str!("visibility_read.wgsl"));

/// Threads per workgroup of `raster` (`RASTER_WORKGROUP` in `raster.wgsl`).
const RASTER_WORKGROUP: u32 = 64;
/// Workgroups of `raster_big`, which loop over the queued tiles
/// (`BIG_WORKGROUPS` in `raster.wgsl`).
const BIG_WORKGROUPS: u32 = 1024;
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
    }
}

gpu_struct! {
    /// Settings of `resolve.wgsl` (`ResolveParams`).
    pub struct GpuResolveParams as "ResolveParams" {
        pub width: u32,
        pub height: u32,
        /// Visible objects (entries of the range list).
        pub range_count: u32,
        pub pad: u32,
    }
}

/// What the counting variant of `raster.wgsl` counts per frame (its
/// `counts` array, in this order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterCount {
    /// Triangles rasterized by their own thread (box of at most 256 pixels).
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
    /// 64-bit atomics issued: covered pixels inside the depth range.
    PixelsWritten,
    /// Big triangles (partly) rasterized by one thread because a queue was full.
    OverflowTriangles,
    /// Writes by triangles that face away (clockwise on screen): what
    /// back-face culling would save on closed meshes.
    BackFacingWrites,
}

impl RasterCount {
    pub const ALL: [Self; 9] = [
        Self::SmallTriangles,
        Self::SmallPixelsTested,
        Self::BigTriangles,
        Self::BigTiles,
        Self::BigSquaresPassed,
        Self::BigPixelsTested,
        Self::PixelsWritten,
        Self::OverflowTriangles,
        Self::BackFacingWrites,
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
        }
    }
}

/// The counting variant's buffer and its read-back.
struct RasterCounting {
    counts: wgpu::Buffer,
    readback: ReadbackRing<u64>,
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
}

/// The compute rasterizer's pipelines, buffers and bind groups, for one
/// resolution and one output buffer.
pub struct ComputeVisibility {
    clear: wgpu::ComputePipeline,
    raster: wgpu::ComputePipeline,
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
    raster_group: wgpu::BindGroup,
    resolve_group: wgpu::BindGroup,
    /// Group 1 of passes that import `shadespace::visibility_read`: the ids
    /// and the 64-bit buffer.
    pub read_layout: wgpu::BindGroupLayout,
    pub read_group: wgpu::BindGroup,
    width: u32,
    height: u32,
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
        let ranges = buffer("vis ranges", (scene.draws.len().max(1) * 8) as u64, U::STORAGE | U::COPY_DST);
        let depth_ids = buffer("vis depth and ids", width as u64 * height as u64 * 8, U::STORAGE);
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
        });
        let mut raster_bindings = vec![Binding::Uniform, read, rw, rw, rw, rw];
        if counting.is_some() {
            raster_bindings.push(rw);
        }
        let raster_layout = bind_group_layout(device, "vis raster", &raster_bindings);
        let dimension = wgpu::TextureViewDimension::D2;
        let out_binding = Binding::StorageTexture { format: super::FORMAT, dimension };
        let resolve_layout = bind_group_layout(device, "vis resolve", &[Binding::Uniform, read, rw, out_binding]);
        let mut raster_resources = vec![
            raster_params.as_entire_binding(),
            ranges.as_entire_binding(),
            depth_ids.as_entire_binding(),
            big_tiles.as_entire_binding(),
            big_count.as_entire_binding(),
            big_setups.as_entire_binding(),
        ];
        if let Some(c) = &counting {
            raster_resources.push(c.counts.as_entire_binding());
        }
        let raster_group = bind_group(device, "vis raster", &raster_layout, &raster_resources);
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
        let raster_groups = [&scene.layout, &raster_layout];
        let raster_shader = match (scene.cull_back_faces, counting.is_some()) {
            (false, false) => RASTER,
            (false, true) => RASTER_COUNTING,
            (true, false) => RASTER_CULLING,
            (true, true) => RASTER_CULLING_COUNTING,
        };
        // Alpha testing is compiled in only for scenes that need it.
        let defs: &[&str] = if scene.has_alpha_masks() { &[ALPHA_MASK] } else { &[] };
        let mut raster = |entry| compute_pipeline_with(device, shaders, raster_shader, defs, entry, &raster_groups);
        Ok(Self {
            raster: raster("raster")?,
            raster_big: raster("raster_big")?,
            clear: compute_pipeline(device, shaders, RESOLVE, "clear", &[&resolve_layout])?,
            resolve: compute_pipeline(device, shaders, RESOLVE, "resolve", &[&resolve_layout])?,
            raster_params,
            resolve_params,
            ranges,
            big_count,
            big_capacity,
            setup_capacity,
            setup_bytes,
            raster_group,
            resolve_group,
            read_layout,
            read_group,
            width,
            height,
            counting,
        })
    }
}

impl ComputeVisibility {
    /// Bytes of its buffers (the 64-bit one, the big-tile queue and setups,
    /// the ranges).
    /// Starts the read-back of the frame's counts (counting variant). Call
    /// right after the frame's submit.
    pub fn after_submit(&mut self) {
        if let Some(c) = &mut self.counting {
            c.readback.after_submit();
        }
    }

    /// The counting variant's counts of finished frames, by frame number,
    /// with three ratios: `vis_atomics_per_pixel` (writes per screen pixel),
    /// `vis_tests_per_write` (pixels tested per write) and
    /// `vis_small_pixels_per_triangle`. None without counting.
    pub fn collect_counts(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        let Some(c) = &mut self.counting else { return Vec::new() };
        let pixels = self.width as f64 * self.height as f64;
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
                counters.insert("vis_tests_per_write".into(), tested / written.max(1.0));
                counters.insert(
                    "vis_small_pixels_per_triangle".into(),
                    get(RasterCount::SmallPixelsTested) / get(RasterCount::SmallTriangles).max(1.0),
                );
                (frame, counters)
            })
            .collect()
    }

    pub fn bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * 8
            + self.big_capacity as u64 * 8
            + self.setup_bytes
            + self.ranges.size()
    }
}

/// This frame's (object, first triangle) ranges of the visible objects, and
/// the number of visible triangles.
pub fn visible_ranges(scene: &SceneGpu, visible: &[bool]) -> (Vec<[u32; 2]>, u32) {
    let mut ranges = Vec::new();
    let mut total = 0u32;
    for (object, d) in scene.draws.iter().enumerate().filter(|(i, _)| visible[*i]) {
        ranges.push([object as u32, total]);
        total += d.index_count / 3;
    }
    (ranges, total)
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
    };
    frame.queue.write_buffer(&pass.raster_params, 0, bytemuck::bytes_of(&raster));
    let resolve = GpuResolveParams { width: pass.width, height: pass.height, range_count, pad: 0 };
    frame.queue.write_buffer(&pass.resolve_params, 0, bytemuck::bytes_of(&resolve));
    frame.encoder.clear_buffer(&pass.big_count, 0, None);
    if let Some(c) = &pass.counting {
        frame.encoder.clear_buffer(&c.counts, 0, None);
    }

    let pixel_groups = (pass.width.div_ceil(8), pass.height.div_ceil(8));
    {
        let mut cp = frame.compute_pass("vis: clear");
        cp.set_pipeline(&pass.clear);
        cp.set_bind_group(0, &pass.resolve_group, &[]);
        cp.dispatch_workgroups(pixel_groups.0, pixel_groups.1, 1);
    }
    if triangles > 0 {
        let scene = frame.scene_group;
        let groups = triangles.div_ceil(RASTER_WORKGROUP);
        let groups_x = groups.min(MAX_GROUPS_X);
        {
            let mut cp = frame.compute_pass("vis: raster");
            cp.set_pipeline(&pass.raster);
            cp.set_bind_group(0, scene, &[]);
            cp.set_bind_group(1, &pass.raster_group, &[]);
            cp.dispatch_workgroups(groups_x, groups.div_ceil(groups_x), 1);
        }
        let mut cp = frame.compute_pass("vis: raster big");
        cp.set_pipeline(&pass.raster_big);
        cp.set_bind_group(0, scene, &[]);
        cp.set_bind_group(1, &pass.raster_group, &[]);
        cp.dispatch_workgroups(BIG_WORKGROUPS, 1, 1);
    }
    {
        let mut cp = frame.compute_pass("vis: resolve");
        cp.set_pipeline(&pass.resolve);
        cp.set_bind_group(0, &pass.resolve_group, &[]);
        cp.dispatch_workgroups(pixel_groups.0, pixel_groups.1, 1);
    }
    if let Some(c) = &mut pass.counting {
        c.readback.copy(frame.device, frame.encoder, &c.counts, COUNTS_BYTES, frame.number);
    }
}
