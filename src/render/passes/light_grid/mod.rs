//! Light grids built on the GPU from the light buffer: for each
//! cell of a grid, the list of point and spot lights that may reach it, with
//! no cap on lights per cell and no CPU round trip. Ambient and directional
//! lights (the first `view.global_light_count`) reach everywhere and are
//! applied by `light_globals`, so the grids list only the others.
//!
//! Two grids share this machinery ([`LightGrid`]) and differ in their cells:
//! [`clusters`] (view space: screen tiles times logarithmic depth slices, for
//! clustered forward) and [`world`] (uniform world-space cells over the scene,
//! Oxide's "light matrix", for object space).
//!
//! A build ([`LightGrid::build`]), timed as `<grid>: count`, `<grid>: scan`
//! and `<grid>: fill`:
//! 1. *count*: one group of 32 threads per light (per slice of a light whose
//!    bounds hold many cells: [`CELLS_PER_ITEM`]) walks the cells its bounds
//!    cover and counts the hits (atomics); the per-cell test is conservative
//!    (sphere against the cell's box, and for spots the cone against the box's
//!    bounding sphere), so no light that reaches a point of a cell is missed;
//! 2. *scan*: exclusive prefix sum of the counts, a workgroup scan per 1024
//!    cells, a scan of the block totals, and the block offsets added back
//!    (any cell count; one block-total chunk per Mi cells);
//! 3. *fill*: the same walk writes each light into its cell's slots, then
//!    *finish* fixes each cell's (first, count) and zeroes the counts.
//!
//! List size: the total is only known on the GPU. It is copied out every
//! frame and read a few frames later without waiting; when it exceeds the
//! list, the list grows (to 1.25 times the total, as a power of two) and the
//! next builds fit. Until then, nothing is written out of bounds and nothing is
//! dropped silently: `fill` skips slots past the capacity, and a reader whose
//! cell range passes the capacity loops over all lights instead (correct,
//! slower). A grid kind may also reserve a CPU bound before its build (the
//! world grid does: its bound is cheap and exact per light).
//!
//! The order of the lights within a cell follows the atomics, so it may vary
//! between runs; the sum over them may then differ in the last bits.

pub mod clusters;
pub mod world;

use glam::{Mat4, UVec3, Vec2, Vec3};

use super::{Binding, bind_group, bind_group_layout, bind_group_layout_for, compute_pipeline};
use crate::gpu::readback::{self, ReadbackRing};
use crate::gpu::{GpuContext, GpuError};
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::scene::Light;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

/// The composable WGSL modules: reading a grid (`shadespace::light_grid`) and
/// the bindings and tests its build passes share (`shadespace::light_grid_build`).
pub const SHARED_WGSL: [ShaderSource; 2] = [
    ShaderSource::new("light_grid/grid.wgsl", include_str!("grid.wgsl")),
    ShaderSource::new("light_grid/build.wgsl", include_str!("build.wgsl")),
];
/// The per-cell passes (scan, finish), shared by both grids.
pub const CELLS_SHADER: ShaderSource = ShaderSource::new("light_grid/cells.wgsl", include_str!("cells.wgsl"));
/// Every light-grid pass shader, for the test that validates them all.
pub const PASS_SHADERS: [ShaderSource; 3] = [CELLS_SHADER, clusters::SHADER, world::SHADER];

/// Bind group index of a grid in the passes that read it.
pub const READ_GROUP: u32 = 3;
/// Cells per block of the scan (`SCAN_BLOCK` in `cells.wgsl`).
const SCAN_BLOCK: u32 = 1024;
/// Threads per workgroup of the per-cell passes.
const CELL_THREADS: u32 = 256;
/// Work items per workgroup of `count` and `fill` (`ITEMS_PER_GROUP` in `build.wgsl`).
const ITEMS_PER_GROUP: u32 = 2;
/// Most cells one work item of `count` and `fill` walks (16 per thread): a
/// light whose bounds hold more is dealt to several items, so that a light
/// covering the whole grid does not leave 32 threads walking it alone (on
/// the H100, four such lights took 0.36 ms of the world grid's build).
pub const CELLS_PER_ITEM: u64 = 512;
/// Work items the work buffer holds at first.
const MIN_WORK_ITEMS: u64 = 1024;
/// Smallest index list, in entries (4 MiB).
const MIN_CAPACITY: u64 = 1 << 20;

gpu_struct! {
    /// A grid's geometry and list capacity (`LightGridParams` in `grid.wgsl`).
    pub struct GpuLightGridParams as "LightGridParams" {
        /// World to grid space: the view matrix (clusters) or identity (world grid).
        pub to_grid: Mat4,
        /// Cells per axis.
        pub dims: UVec3,
        pub cell_count: u32,
        /// World grid: the min corner.
        pub origin: Vec3,
        /// World grid: the side of a cell.
        pub cell_size: f32,
        /// Clusters: `(aspect * tan(fov/2), tan(fov/2))`.
        pub tan_half: Vec2,
        /// Clusters: view depth of the first slice's near side.
        pub near: f32,
        /// Clusters: view depth of the last slice's far side.
        pub far: f32,
        /// Clusters: `slices / ln(far / near)`.
        pub slices_per_log: f32,
        /// Entries the index list holds.
        pub capacity: u32,
        /// Work items of `count` and `fill` ([`LightGrid::build`]).
        pub work_count: u32,
        pub pad_b: u32,
    }
}

/// One grid's GPU state: the per-cell counts and ranges, the index list and
/// the build pipelines. The geometry comes per frame from its kind.
pub struct LightGrid {
    label: &'static str,
    max_cells: u32,
    params: wgpu::Buffer,
    counts: wgpu::Buffer,
    cells: wgpu::Buffer,
    list: wgpu::Buffer,
    block_sums: wgpu::Buffer,
    status: wgpu::Buffer,
    /// Per work item of `count` and `fill`: (light among the grid's lights,
    /// slice | slices << 16).
    work: wgpu::Buffer,
    work_capacity: u64,
    /// Work items for the current lights; `None` before the first build.
    work_count: Option<u32>,
    capacity: u64,
    max_capacity: u64,
    build_layout: wgpu::BindGroupLayout,
    build_group: wgpu::BindGroup,
    /// Layout of the group readers bind at [`READ_GROUP`].
    pub layout: wgpu::BindGroupLayout,
    read_group: wgpu::BindGroup,
    count: wgpu::ComputePipeline,
    fill: wgpu::ComputePipeline,
    scan_blocks: wgpu::ComputePipeline,
    scan_sums: wgpu::ComputePipeline,
    scan_add: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    totals: ReadbackRing<()>,
    /// This frame's geometry (as uploaded).
    last: GpuLightGridParams,
    /// Largest total entries seen (read back).
    peak_entries: u64,
    /// Builds recorded so far.
    builds: u64,
}

/// A grid read back to the CPU (tests).
#[derive(Clone, Debug)]
pub struct GridContents {
    pub params: GpuLightGridParams,
    /// Per cell: (first entry, entry count).
    pub cells: Vec<[u32; 2]>,
    pub list: Vec<u32>,
    /// Entries of all cells as the scan summed them.
    pub total: u32,
}

impl GridContents {
    /// Whether cell `cell`'s list was fully written (else readers fall back to all lights).
    pub fn fits(&self, cell: usize) -> bool {
        let [first, count] = self.cells[cell];
        first as u64 + count as u64 <= self.params.capacity as u64
    }

    /// The lights of cell `cell` (only meaningful when it [`fits`](Self::fits)).
    pub fn lights_of(&self, cell: usize) -> &[u32] {
        let [first, count] = self.cells[cell];
        &self.list[first as usize..(first + count) as usize]
    }
}

impl LightGrid {
    /// A grid of at most `max_cells` cells whose count and fill passes are
    /// `count` and `fill` of `shader`.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        label: &'static str,
        shader: ShaderSource,
        max_cells: u32,
    ) -> Result<Self, ShaderError> {
        let limits = device.limits();
        let max_capacity = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size) / 4;
        let storage = |name: &str, size: u64, extra| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("{label} {name}")),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            })
        };
        let cells_n = max_cells.max(1) as u64;
        // Zero-initialised: the counts are zero between builds.
        let counts = storage("counts", cells_n * 4, wgpu::BufferUsages::empty());
        let cells = storage("cells", cells_n * 8, wgpu::BufferUsages::COPY_SRC);
        let block_sums = storage("block sums", cells_n.div_ceil(SCAN_BLOCK as u64) * 4, wgpu::BufferUsages::empty());
        let status = storage("status", 16, wgpu::BufferUsages::COPY_SRC);
        let work = Self::work_buffer(device, label, MIN_WORK_ITEMS);
        let capacity = MIN_CAPACITY.min(max_capacity);
        let list = Self::list_buffer(device, label, capacity);
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label} params")),
            size: size_of::<GpuLightGridParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let rw = Binding::Storage { read_only: false };
        let read = Binding::Storage { read_only: true };
        let build_layout =
            bind_group_layout(device, &format!("{label} build"), &[Binding::Uniform, rw, rw, rw, rw, rw, read]);
        let stages = wgpu::ShaderStages::COMPUTE | wgpu::ShaderStages::FRAGMENT;
        let layout = bind_group_layout_for(device, label, stages, &[Binding::Uniform, read, read]);
        let groups = [&scene.layout, &build_layout];
        let mut pipeline = |shader, entry| compute_pipeline(device, shaders, shader, entry, &groups);
        let (count, fill) = (pipeline(shader, "count")?, pipeline(shader, "fill")?);
        let scan_blocks = pipeline(CELLS_SHADER, "scan_blocks")?;
        let scan_sums = pipeline(CELLS_SHADER, "scan_sums")?;
        let scan_add = pipeline(CELLS_SHADER, "scan_add")?;
        let finish = pipeline(CELLS_SHADER, "finish")?;
        let (build_group, read_group) = Self::bind_groups(
            device,
            label,
            (&build_layout, &layout),
            [&params, &counts, &cells, &list, &block_sums, &status, &work],
        );
        Ok(Self {
            label,
            max_cells,
            params,
            counts,
            cells,
            list,
            block_sums,
            status,
            work,
            work_capacity: MIN_WORK_ITEMS,
            work_count: None,
            capacity,
            max_capacity,
            build_layout,
            build_group,
            layout,
            read_group,
            count,
            fill,
            scan_blocks,
            scan_sums,
            scan_add,
            finish,
            totals: ReadbackRing::new("light grid totals", 4),
            last: GpuLightGridParams::default(),
            peak_entries: 0,
            builds: 0,
        })
    }

    fn list_buffer(device: &wgpu::Device, label: &str, capacity: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label} list")),
            size: capacity.max(4) * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    fn work_buffer(device: &wgpu::Device, label: &str, items: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label} work")),
            size: items.max(1) * 8,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Build group (params, counts, cells, list, block sums, status, work)
    /// and read group (params, cells, list).
    fn bind_groups(
        device: &wgpu::Device,
        label: &str,
        (build, read): (&wgpu::BindGroupLayout, &wgpu::BindGroupLayout),
        buffers: [&wgpu::Buffer; 7],
    ) -> (wgpu::BindGroup, wgpu::BindGroup) {
        let all = buffers.map(|b| b.as_entire_binding());
        let build_group = bind_group(device, &format!("{label} build"), build, &all);
        let read_group = bind_group(device, label, read, &[all[0].clone(), all[2].clone(), all[3].clone()]);
        (build_group, read_group)
    }

    /// The group readers bind at [`READ_GROUP`] (re-created when the list grows).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.read_group
    }

    /// Entries the index list holds now.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// Most entries one build needed, of those read back so far.
    pub fn peak_entries(&self) -> u64 {
        self.peak_entries
    }

    /// Bytes of GPU memory the grid holds.
    pub fn bytes(&self) -> u64 {
        [&self.counts, &self.cells, &self.list, &self.block_sums, &self.status, &self.params, &self.work]
            .iter()
            .map(|b| b.size())
            .sum()
    }

    /// Grows the list to hold at least `entries` (up to the binding limit;
    /// beyond it, readers of the cells that do not fit loop over all lights).
    pub fn reserve(&mut self, device: &wgpu::Device, entries: u64) {
        if entries <= self.capacity || self.capacity >= self.max_capacity {
            return;
        }
        let wanted = (entries + entries / 4).next_power_of_two().min(self.max_capacity);
        tracing::debug!("{}: index list grows from {} to {wanted} entries", self.label, self.capacity);
        self.capacity = wanted;
        self.list = Self::list_buffer(device, self.label, wanted);
        self.rebind(device);
    }

    fn rebind(&mut self, device: &wgpu::Device) {
        (self.build_group, self.read_group) = Self::bind_groups(
            device,
            self.label,
            (&self.build_layout, &self.layout),
            [&self.params, &self.counts, &self.cells, &self.list, &self.block_sums, &self.status, &self.work],
        );
    }

    /// Deals the grid's lights (the point and spot lights of `lights`, in
    /// their order) to the work items of `count` and `fill`: light `l` gets
    /// one item per [`CELLS_PER_ITEM`] of its `cells(l)` cells (at least one).
    fn set_work(&mut self, frame: &Frame, cells: impl Fn(&Light) -> u64) {
        let mut items: Vec<[u32; 2]> = Vec::new();
        for (k, light) in frame.lights.iter().filter(|l| !is_global(l)).enumerate() {
            let slices = cells(light).div_ceil(CELLS_PER_ITEM).clamp(1, 0xffff) as u32;
            items.extend((0..slices).map(|s| [k as u32, s | slices << 16]));
        }
        if items.len() as u64 > self.work_capacity {
            self.work_capacity = (items.len() as u64).next_power_of_two();
            self.work = Self::work_buffer(frame.device, self.label, self.work_capacity);
            self.rebind(frame.device);
        }
        frame.queue.write_buffer(&self.work, 0, bytemuck::cast_slice(&items));
        self.work_count = Some(items.len() as u32);
    }

    /// Takes in the totals of earlier builds that came back, growing the
    /// list when one did not fit (the next build then fits).
    pub fn collect_totals(&mut self, device: &wgpu::Device) {
        let totals: Vec<u64> = self
            .totals
            .collect(device, false)
            .into_iter()
            .map(|(_, bytes)| u32::from_le_bytes(bytes[..4].try_into().expect("4 bytes")) as u64)
            .collect();
        if let Some(&peak) = totals.iter().max() {
            self.peak_entries = self.peak_entries.max(peak);
            self.reserve(device, peak);
        }
    }

    /// Builds recorded so far.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// Records this frame's build over `params` (its geometry; the capacity
    /// and work are filled in here); `cells(light)` bounds the cells a light's
    /// walk covers (how its work is split; 1 keeps one item per light).
    /// Reads: the scene's view and lights. Writes: the grid's cells and list,
    /// and its total for the read-back.
    pub fn build(&mut self, frame: &mut Frame, mut params: GpuLightGridParams, cells: impl Fn(&Light) -> u64) {
        assert!(
            params.cell_count <= self.max_cells,
            "{}: {} cells > {}",
            self.label,
            params.cell_count,
            self.max_cells
        );
        self.collect_totals(frame.device);
        if frame.lights_changed || self.work_count.is_none() {
            self.set_work(frame, cells);
        }
        let items = self.work_count.unwrap_or(0);
        params.capacity = self.capacity as u32;
        params.work_count = items;
        self.last = params;
        frame.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let light_groups = split(items.div_ceil(ITEMS_PER_GROUP));
        let cell_groups = split(params.cell_count.div_ceil(CELL_THREADS));
        let blocks = params.cell_count.div_ceil(SCAN_BLOCK);
        let scene = frame.scene_group;
        let run = |frame: &mut Frame, name: &str, steps: &[(&wgpu::ComputePipeline, (u32, u32))]| {
            let mut cp = frame.compute_pass(&format!("{}: {name}", self.label));
            cp.set_bind_group(0, scene, &[]);
            cp.set_bind_group(1, &self.build_group, &[]);
            for (pipeline, (x, y)) in steps {
                cp.set_pipeline(pipeline);
                cp.dispatch_workgroups(*x, *y, 1);
            }
        };
        run(frame, "count", &[(&self.count, light_groups)]);
        run(
            frame,
            "scan",
            &[(&self.scan_blocks, (blocks, 1)), (&self.scan_sums, (1, 1)), (&self.scan_add, cell_groups)],
        );
        run(frame, "fill", &[(&self.fill, light_groups), (&self.finish, cell_groups)]);
        self.totals.copy(frame.device, frame.encoder, &self.status, 4, ());
        self.builds += 1;
    }

    /// Starts the read-back of the frame's total; call after its submit.
    pub fn after_submit(&mut self) {
        self.totals.after_submit();
    }

    /// The last build's geometry as uploaded.
    pub fn params(&self) -> &GpuLightGridParams {
        &self.last
    }

    /// Reads the last build back (blocks; for tests and debugging).
    pub fn read_back(&self, ctx: &GpuContext) -> Result<GridContents, GpuError> {
        let n = self.last.cell_count as usize;
        let cells: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&readback::read_whole_buffer(ctx, &self.cells)?);
        let list: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_whole_buffer(ctx, &self.list)?);
        let status: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_whole_buffer(ctx, &self.status)?);
        Ok(GridContents { params: self.last, cells: cells[..n].to_vec(), list, total: status[0] })
    }
}

/// Whether a light reaches everywhere (applied by `light_globals`, in no grid).
fn is_global(l: &Light) -> bool {
    l.kind.is_global()
}

/// Workgroups `n` as (x, y) within the 65535-per-dimension limit; the
/// shaders index `y * groups.x + x` and skip the overshoot.
fn split(n: u32) -> (u32, u32) {
    const MAX: u32 = 65535;
    if n <= MAX { (n, 1) } else { (MAX, n.div_ceil(MAX)) }
}
