//! Cluster culling for the hardware raster pipelines (forward, clustered,
//! deferred, raster visibility): the compute rasterizer's culling pass
//! (`visibility/cull.wgsl`, the same shader and bindings) lists the
//! surviving clusters, and every scene raster pass draws them instead of
//! every triangle of every object in view, in one of two ways
//! ([`ClusterDraws`], `--cluster-draws`):
//!
//! - **indexed** (the default): `cull.wgsl` with [`INDEXED_DRAWS`] also
//!   writes, per run of consecutive surviving clusters of a chunk (one
//!   object's), a `draw_indexed_indirect` entry of its range of the scene's
//!   cluster-ordered index buffer (`SceneGpu::cluster_indices`: the meshes'
//!   triangles in cluster order, so that each cluster, and each run of a
//!   mesh's consecutive clusters, is one range; the meshes themselves keep
//!   their order, so triangle ids, charts and triangle maps are those of
//!   the plain draws), its first instance the run's first list entry (the
//!   vertex shader reads the object there), and counts the draws; each pass
//!   draws them with one `multi_draw_indexed_indirect_count` per list and
//!   pipeline state. Vertices are shared within a run, as in the plain draws.
//!   Needs `INDIRECT_FIRST_INSTANCE` and `MULTI_DRAW_INDIRECT_COUNT` (the
//!   H100, the H200 and lavapipe have both); without them, or where the
//!   draws would not fit one storage binding, the renderer logs why and
//!   draws lists ([`draws_for`]).
//! - **list**: one indirect instanced draw per list and pipeline state
//!   (`cluster_draws.wgsl`: an instance per cluster, three vertices per
//!   triangle slot, the unused slots zero-area). It needs neither feature,
//!   but runs the vertex shader three times a triangle: on the H200 the
//!   city's fly-over (89 % of its clusters drawn) took 1.9 times as long
//!   as without culling.
//!
//! Where: in the depth pre-pass ([`super::depth_prepass`]), so the passes
//! after it (testing `Equal`) draw what it drew. With `--culling occlusion`
//! it is two-pass: `cull` lists the clusters visible last frame, `depth
//! prepass` draws them, `cull hiz` builds the depth pyramid from the depth
//! target (`hiz.wgsl` with `DEPTH_TEXTURE`), `cull late` tests the rest and
//! `depth prepass late` draws what became visible. Pipelines run without a
//! pre-pass, and multisampled targets, draw every object as before.
//!
//! Why a second index buffer rather than meshes stored in cluster order:
//! the meshes' triangle order is what triangle ids, the chart cache's keys
//! (generated charts are keyed by the mesh's indices) and the CPU twins
//! use; the copy costs the index bytes again (Sponza 2.5 MB, the city's
//! meshes 1 MB) and the visibility pass one read per fragment
//! (`drawn_triangle`: the cluster's triangle list at the primitive index).
//!
//! The image is the same as without culling (tested) unless two triangles
//! of the scene write the same depth at a pixel: culling draws the clusters
//! in the order the culling pass listed them, so a different one of the two
//! may win the `Greater` test.

use crate::gpu::readback::ReadbackRing;
use crate::render::clusters::{CLUSTER_TRIANGLES, ClusterDraws, Culling};
use crate::render::frame::Frame;
use crate::render::passes::visibility::compute::{
    CULL, CULL_CHUNK, CULL_CONE, CULL_OCCLUSION, CullCount, DepthPyramid, GpuCullParams, HIZ, cull_group, split,
    visible_ranges,
};
use crate::render::passes::{
    Binding, bind_group, bind_group_layout, bind_group_layout_for, compute_pipeline, compute_pipeline_with,
};
use crate::render::report::Counters;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

/// The module scene raster passes import (`shadespace::cluster_draws`).
pub const SHARED_WGSL: ShaderSource = ShaderSource::new("cluster_draws.wgsl", include_str!("cluster_draws.wgsl"));
/// The compute shader that sizes the lists' draws.
pub const ARGS: ShaderSource = ShaderSource::new("draw_args.wgsl", include_str!("draw_args.wgsl"));
/// `hiz.wgsl` reading the depth target.
pub const HIZ_DEPTH: ShaderSource = HIZ.with_defs(&["DEPTH_TEXTURE"]);
/// Defined in the scene raster passes' variant that draws cluster lists.
pub const CLUSTER_DRAW: &str = "CLUSTER_DRAW";
/// Defined, besides [`CLUSTER_DRAW`], in the scene raster passes' variant
/// that draws clusters with indexed draws, and in `cull.wgsl`'s variant
/// that writes them.
pub const INDEXED_DRAWS: &str = "INDEXED_DRAWS";
/// Defined, besides [`CLUSTER_DRAW`], in the variant that draws the
/// single-sided objects of lists that hold double-sided ones too (it skips
/// those: `cluster_draws.wgsl`'s `other_sides`).
pub const SINGLE_SIDED_DRAW: &str = "SINGLE_SIDED_DRAW";
/// [`SINGLE_SIDED_DRAW`]'s twin for the double-sided objects.
pub const DOUBLE_SIDED_DRAW: &str = "DOUBLE_SIDED_DRAW";
/// The features the indexed cluster draws need: a draw's first instance
/// carries its cluster, and the draws are counted on the GPU.
pub const INDEXED_FEATURES: wgpu::Features =
    wgpu::Features::INDIRECT_FIRST_INSTANCE.union(wgpu::Features::MULTI_DRAW_INDIRECT_COUNT);
/// `cull.wgsl`'s flag for a frame drawn the plain way: with occlusion, the
/// early pass lists nothing and the late pass lists every cluster it sees
/// (against the pyramid of the whole depth), so the lists count what
/// culling would draw next frame; no indexed draws are written.
pub const CULL_PLAIN: u32 = 4;
/// Bytes of one `draw_indexed_indirect` entry (`cull.wgsl`'s `DrawIndexedArgs`).
const DRAW_INDEXED_BYTES: u64 = 20;
/// The bind group of the cluster draws (`cluster_draws.wgsl`'s group 2):
/// one that none of the passes that cull uses (clustered shading's light
/// grid is group 3, the others have none but the scene's).
pub const CLUSTER_DRAW_GROUP: u32 = 2;
/// Vertices per listed cluster (`cluster_draws.wgsl`).
const _: () = assert!(CLUSTER_TRIANGLES == 64, "cluster_draws.wgsl and draw_args.wgsl draw 64 triangles a cluster");

const CULL_COUNTS_BYTES: u64 = CullCount::ALL.len() as u64 * 4;
/// The indexed draws' four counts (list 0 opaque, list 0 masked, list 1 ...).
const DRAW_COUNTS_BYTES: u64 = 16;
/// Read back each frame: the [`CullCount`]s, then the indexed draws' counts
/// (copied after them; zero with list draws).
const READBACK_BYTES: u64 = CULL_COUNTS_BYTES + DRAW_COUNTS_BYTES;

/// Entries of each cluster list (and of each list's indexed draws) for `scene`.
fn list_capacity(scene: &SceneGpu) -> u32 {
    scene.instance_clusters.max(1).next_multiple_of(32)
}

/// The cluster draws the raster passes can use for `wanted` on `device`:
/// [`ClusterDraws::List`] where it lacks [`INDEXED_FEATURES`] or where the
/// indexed draws of `scene`'s clusters would not fit one storage binding;
/// says why in a log line when it falls back.
pub fn draws_for(wanted: ClusterDraws, device: &wgpu::Device, scene: &SceneGpu) -> ClusterDraws {
    if wanted == ClusterDraws::List {
        return wanted;
    }
    let missing = INDEXED_FEATURES - device.features();
    if !missing.is_empty() {
        tracing::warn!("the adapter lacks {missing:?}: cluster culling draws lists (--cluster-draws list)");
        return ClusterDraws::List;
    }
    let bytes = 2 * u64::from(list_capacity(scene)) * DRAW_INDEXED_BYTES;
    let limits = device.limits();
    if bytes > limits.max_storage_buffer_binding_size.min(limits.max_buffer_size) {
        tracing::warn!(
            "the indexed draws of {} clusters need {} MiB, past the adapter's storage binding: cluster culling draws lists",
            scene.instance_clusters,
            bytes >> 20
        );
        return ClusterDraws::List;
    }
    wanted
}

/// What the indexed cluster draws add to [`ClusterCull`].
struct IndexedDraws {
    early: wgpu::ComputePipeline,
    late: wgpu::ComputePipeline,
    /// `cull.wgsl`'s group 2: the split, the draws and their counts.
    group: wgpu::BindGroup,
    /// Per list, `capacity` entries: the opaque objects' draws, then from
    /// `masked_first` the alpha-masked objects'.
    draws: wgpu::Buffer,
    /// Draws per list and kind (list 0 opaque, list 0 masked, list 1 ...).
    counts: wgpu::Buffer,
    /// The first entry of the masked objects' draws in each list's entries:
    /// the clusters of every opaque object.
    masked_first: u32,
    /// The scene's index buffer in cluster order.
    indices: wgpu::Buffer,
}

/// The layout of [`CLUSTER_DRAW_GROUP`].
pub fn draw_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let read = Binding::Storage { read_only: true };
    let stages = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
    bind_group_layout_for(device, "cluster draws", stages, &[Binding::Uniform, read, read, read, read])
}

/// Culling's pipelines and buffers for one depth target, and the lists'
/// draws.
pub struct ClusterCull {
    early: wgpu::ComputePipeline,
    late: wgpu::ComputePipeline,
    args: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    ranges: wgpu::Buffer,
    chunks: wgpu::Buffer,
    counts: wgpu::Buffer,
    draw_args: wgpu::Buffer,
    group: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    /// [`CLUSTER_DRAW_GROUP`] drawing list 0 and list 1.
    draw_groups: [wgpu::BindGroup; 2],
    /// With [`ClusterDraws::Indexed`] (boxed: held inline by every pre-pass).
    indexed: Option<Box<IndexedDraws>>,
    pyramid: DepthPyramid,
    capacity: u32,
    width: u32,
    height: u32,
    /// Tagged with the frame's number, culling, whether it drew plain and
    /// the draws a pass drawing plain issues ([`super::plain_draws`]).
    readback: ReadbackRing<(u64, Culling, bool, u32)>,
    /// Counters read back and not yet handed out ([`Self::collect_counts`]).
    results: Vec<(u64, Counters)>,
    /// The last frame read back that tested clusters (frames come back in
    /// the order they were submitted): its culling and the share of the
    /// tested clusters culling kept.
    kept: Option<(Culling, f64)>,
    /// Whether this frame's pre-pass culled (the passes after it draw the lists).
    active: bool,
    bytes: u64,
}

/// Frames' counters held for [`ClusterCull::collect_counts`] at most (the
/// oldest go first when nobody collects them).
const MAX_RESULTS: usize = 1024;

impl ClusterCull {
    /// Culling into `targets`' depth (one sample per pixel).
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
    ) -> Result<Self, ShaderError> {
        let (width, height) = (targets.width, targets.height);
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        let init = |label, contents: &[u8], usage| {
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage },
            )
        };
        use wgpu::BufferUsages as U;
        let capacity = list_capacity(scene);
        let lists = buffer("cull lists", 2 * capacity as u64 * 8, U::STORAGE);
        let history = buffer("cull history", capacity as u64 * 4, U::STORAGE);
        let object_clusters = {
            let data: Vec<[u32; 4]> =
                if scene.object_clusters.is_empty() { vec![[0; 4]] } else { scene.object_clusters.clone() };
            init("cull object clusters", bytemuck::cast_slice(&data), U::STORAGE)
        };
        let ranges = buffer("cull ranges", (scene.draws.len().max(1) * 16) as u64, U::STORAGE | U::COPY_DST);
        let counts = buffer("cull counts", READBACK_BYTES, U::STORAGE | U::COPY_DST | U::COPY_SRC);
        // `cull.wgsl`'s `finish` sizes dispatches for the compute rasterizer; unused here.
        let dispatch = buffer("cull dispatch", 24, U::STORAGE);
        let draw_args = buffer("cull draw args", 32, U::STORAGE | U::INDIRECT);
        let chunks_capacity = scene.draws.len() as u64 + u64::from(capacity) / CULL_CHUNK as u64 + 1;
        let chunks = buffer("cull chunks", chunks_capacity * 8, U::STORAGE | U::COPY_DST);
        let params = buffer("cull params", size_of::<GpuCullParams>() as u64, U::UNIFORM | U::COPY_DST);

        let read = Binding::Storage { read_only: true };
        let rw = Binding::Storage { read_only: false };
        let depth =
            Binding::Texture { sample: wgpu::TextureSampleType::Depth, dimension: wgpu::TextureViewDimension::D2 };
        let pyramid = DepthPyramid::new(
            device,
            shaders,
            "cull depth pyramid",
            (width, height, 1),
            HIZ_DEPTH,
            depth,
            wgpu::BindingResource::TextureView(&targets.depth_view),
        )?;
        // The compute rasterizer's group (`cull.wgsl`'s group 1).
        let (cull_layout, group) = cull_group(
            device,
            "cull",
            [
                &params,
                &ranges,
                &scene.clusters,
                &object_clusters,
                &history,
                &lists,
                &counts,
                &pyramid.texels,
                &dispatch,
                &chunks,
            ],
        );
        let args_layout = bind_group_layout(device, "cull draw args", &[read, rw]);
        let args_group = bind_group(
            device,
            "cull draw args",
            &args_layout,
            &[counts.as_entire_binding(), draw_args.as_entire_binding()],
        );
        let layout = draw_layout(device);
        let draw_group = |list: u32| {
            let base = init("cluster draw list", bytemuck::bytes_of(&[list * capacity, 0, 0, 0]), U::UNIFORM);
            bind_group(
                device,
                "cluster draws",
                &layout,
                &[
                    base.as_entire_binding(),
                    ranges.as_entire_binding(),
                    lists.as_entire_binding(),
                    scene.clusters.as_entire_binding(),
                    scene.cluster_triangles.as_entire_binding(),
                ],
            )
        };
        let cull_layouts = [&scene.layout, &cull_layout];
        let indexed = if scene.cluster_draws == ClusterDraws::Indexed {
            // The opaque objects' clusters: the masked ones' draws follow them.
            let masked_first: u32 = scene
                .object_data
                .iter()
                .zip(&scene.object_clusters)
                // As `cull.wgsl` tells them apart (`alpha_cutoff > 0`; NaN is opaque).
                .filter(|(o, _)| o.alpha_cutoff.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater))
                .map(|(_, c)| c[1])
                .sum();
            let split = init("cull draw split", bytemuck::bytes_of(&[masked_first, 0, 0, 0]), U::UNIFORM);
            let draws =
                buffer("cull indexed draws", 2 * u64::from(capacity) * DRAW_INDEXED_BYTES, U::STORAGE | U::INDIRECT);
            let counts = buffer(
                "cull indexed draw counts",
                DRAW_COUNTS_BYTES,
                U::STORAGE | U::INDIRECT | U::COPY_DST | U::COPY_SRC,
            );
            let layout = bind_group_layout(device, "cull indexed draws", &[Binding::Uniform, rw, rw]);
            let group = bind_group(
                device,
                "cull indexed draws",
                &layout,
                &[split.as_entire_binding(), draws.as_entire_binding(), counts.as_entire_binding()],
            );
            let layouts = [&scene.layout, &cull_layout, &layout];
            let mut variant = |entry| compute_pipeline_with(device, shaders, CULL, &[INDEXED_DRAWS], entry, &layouts);
            Some(Box::new(IndexedDraws {
                early: variant("cull_early")?,
                late: variant("cull_late")?,
                group,
                draws,
                counts,
                masked_first,
                indices: scene.cluster_indices.clone(),
            }))
        } else {
            None
        };
        let indexed_bytes = indexed.as_ref().map_or(0, |d| d.draws.size());
        Ok(Self {
            early: compute_pipeline(device, shaders, CULL, "cull_early", &cull_layouts)?,
            late: compute_pipeline(device, shaders, CULL, "cull_late", &cull_layouts)?,
            args: compute_pipeline(device, shaders, ARGS, "draw_args", &[&args_layout])?,
            draw_groups: [draw_group(0), draw_group(1)],
            indexed,
            bytes: lists.size()
                + indexed_bytes
                + history.size()
                + pyramid.texels.size()
                + object_clusters.size()
                + chunks.size()
                + ranges.size(),
            params,
            ranges,
            chunks,
            counts,
            draw_args,
            group,
            args_group,
            pyramid,
            capacity,
            width,
            height,
            readback: ReadbackRing::new("cull counts", READBACK_BYTES),
            results: Vec::new(),
            kept: None,
            active: false,
        })
    }

    /// Bytes of its buffers (lists, indexed draws, history, pyramid,
    /// per-object tables).
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Whether this frame's pre-pass culled: the passes after it draw the
    /// lists ([`Self::draw_list`]) instead of the objects.
    pub fn active(&self) -> bool {
        self.active
    }

    /// Culls the frame's visible objects' clusters with `frame.scene.culling`
    /// (none: nothing, and [`Self::active`] is false), drawing depth with
    /// `draw_depth(frame, self, Some(list), clear)`: list 0 (the clusters
    /// that pass the frustum and cone tests; with occlusion only those
    /// visible last frame), then with occlusion list 1 (those that became
    /// visible).
    ///
    /// Unless the last frame read back culled the same way and kept more
    /// than `frame.scene.cull_plain_above` of the clusters it tested: then
    /// the frame draws the plain way (`draw_depth(frame, self, None, true)`:
    /// every visible object; [`Self::active`] is false, so the passes after
    /// draw the objects too), and the culling passes only run to count, and
    /// with occlusion to keep each cluster's visibility, tested against the
    /// pyramid of the whole depth, for the frames after ([`CULL_PLAIN`]:
    /// the late list then holds every cluster seen, the early one none).
    /// Where most clusters are kept, the cluster draws cost more than they
    /// save (their many small draws against one instanced draw per run of a
    /// mesh's instances), and the culling passes cost little (0.06-0.13 ms
    /// on the H200 at 1920x1080).
    pub fn cull(&mut self, frame: &mut Frame, draw_depth: impl Fn(&mut Frame, &Self, Option<usize>, bool)) {
        let culling = frame.scene.culling;
        if culling == Culling::None {
            self.active = false;
            return;
        }
        self.gather(frame.device, false);
        let limit = f64::from(frame.scene.cull_plain_above);
        let plain = self.kept.is_some_and(|(mode, kept)| mode == culling && kept > limit);
        self.active = !plain;
        let (ranges, _) = visible_ranges(frame.scene, frame.visible);
        let mut chunks: Vec<[u32; 2]> = Vec::new();
        for (r, range) in ranges.iter().enumerate() {
            let clusters = frame.scene.object_clusters[range[0] as usize][1];
            chunks.extend((0..clusters).step_by(CULL_CHUNK as usize).map(|first| [r as u32, first]));
        }
        if !ranges.is_empty() {
            frame.queue.write_buffer(&self.ranges, 0, bytemuck::cast_slice(&ranges));
        }
        if !chunks.is_empty() {
            frame.queue.write_buffer(&self.chunks, 0, bytemuck::cast_slice(&chunks));
        }
        let (levels, level_offsets) = self.pyramid.level_offsets();
        let flags = if frame.scene.has_single_sided() { CULL_CONE } else { 0 }
            | if culling == Culling::Occlusion { CULL_OCCLUSION } else { 0 }
            | if plain { CULL_PLAIN } else { 0 };
        let params = GpuCullParams {
            range_count: ranges.len() as u32,
            flags,
            capacity: self.capacity,
            levels,
            width: self.width,
            height: self.height,
            chunk_count: chunks.len() as u32,
            pad: 0,
            level_offsets,
        };
        frame.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        frame.encoder.clear_buffer(&self.counts, 0, None);
        if let Some(d) = &self.indexed {
            frame.encoder.clear_buffer(&d.counts, 0, None);
        }
        let groups = split(chunks.len() as u32);
        let (early, late) = self.indexed.as_ref().map_or((&self.early, &self.late), |d| (&d.early, &d.late));
        self.cull_pass(frame, early, "cull", groups);
        draw_depth(frame, self, (!plain).then_some(0), true);
        if culling == Culling::Occlusion {
            self.pyramid.encode(frame, "cull hiz");
            self.cull_pass(frame, late, "cull late", groups);
            if !plain {
                draw_depth(frame, self, Some(1), false);
            }
        }
        if let Some(d) = &self.indexed {
            frame.encoder.copy_buffer_to_buffer(&d.counts, 0, &self.counts, CULL_COUNTS_BYTES, DRAW_COUNTS_BYTES);
        }
        let tag = (frame.number, culling, plain, super::plain_draws(frame.scene, frame.visible));
        self.readback.copy(frame.device, frame.encoder, &self.counts, READBACK_BYTES, tag);
    }

    /// `entry` of `cull.wgsl` over the chunks (`groups`), then the lists'
    /// draws (the indexed draws are written by `entry` itself).
    fn cull_pass(&self, frame: &mut Frame, entry: &wgpu::ComputePipeline, label: &str, groups: (u32, u32)) {
        let scene = frame.scene_group;
        let mut cp = frame.compute_pass(label);
        if groups.0 * groups.1 > 0 {
            cp.set_bind_group(0, scene, &[]);
            cp.set_bind_group(1, &self.group, &[]);
            if let Some(d) = &self.indexed {
                cp.set_bind_group(2, &d.group, &[]);
            }
            cp.set_pipeline(entry);
            cp.dispatch_workgroups(groups.0, groups.1, 1);
        }
        if self.indexed.is_none() {
            cp.set_pipeline(&self.args);
            cp.set_bind_group(0, &self.args_group, &[]);
            cp.dispatch_workgroups(1, 1, 1);
        }
    }

    /// Draws list `list` with the bound pipeline (a [`CLUSTER_DRAW`]
    /// variant, with [`INDEXED_DRAWS`] where culling draws indexed), the
    /// opaque objects' clusters, or with `masked` the alpha-masked ones'
    /// (list draws hold both: each pipeline's vertex shader skips the
    /// other's).
    pub fn draw_list(&self, pass: &mut wgpu::RenderPass, list: usize, masked: bool) {
        pass.set_bind_group(CLUSTER_DRAW_GROUP, &self.draw_groups[list], &[]);
        match &self.indexed {
            Some(d) => {
                let (first, max) =
                    if masked { (d.masked_first, self.capacity - d.masked_first) } else { (0, d.masked_first) };
                if max == 0 {
                    return;
                }
                pass.set_index_buffer(d.indices.slice(..), wgpu::IndexFormat::Uint32);
                let offset = (list as u64 * u64::from(self.capacity) + u64::from(first)) * DRAW_INDEXED_BYTES;
                let count = (2 * list as u64 + u64::from(masked)) * 4;
                pass.multi_draw_indexed_indirect_count(&d.draws, offset, &d.counts, count, max);
            }
            None => pass.draw_indirect(&self.draw_args, list as u64 * 16),
        }
    }

    /// Starts the read-back of the frame's counts. Call right after the submit.
    pub fn after_submit(&mut self) {
        self.readback.after_submit();
    }

    /// The [`CullCount`]s of finished frames that culled, with `cull_drawn`
    /// (clusters kept by both passes: drawn, or in a frame drawn the plain
    /// way those culling would have drawn), `cull_plain` (1 where the frame
    /// drew every object in view, [`Self::cull`]), `cull_plain_draws` (the
    /// draws a pass issues drawing the plain way: one per run of
    /// consecutive visible instances of a mesh) and, with indexed draws,
    /// `cull_draws` (the indexed draws of both passes: one per run of
    /// consecutive clusters; 0 in plain frames), by frame number.
    pub fn collect_counts(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        self.gather(device, wait);
        std::mem::take(&mut self.results)
    }

    /// Reads back the counts that have arrived (all with `wait`) into
    /// `results`, and the last frame's kept share into `kept`.
    fn gather(&mut self, device: &wgpu::Device, wait: bool) {
        let indexed = self.indexed.is_some();
        for ((frame, culling, plain, plain_draws), bytes) in self.readback.collect(device, wait) {
            let raw: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
            let mut counters: Counters =
                CullCount::ALL.iter().map(|&k| (k.name().to_string(), raw[k as usize] as f64)).collect();
            let drawn = raw[CullCount::DrawnEarly as usize] as f64 + raw[CullCount::DrawnLate as usize] as f64;
            counters.insert("cull_drawn".into(), drawn);
            counters.insert("cull_plain".into(), f64::from(u8::from(plain)));
            counters.insert("cull_plain_draws".into(), f64::from(plain_draws));
            if indexed {
                let draws: u32 = raw[CullCount::ALL.len()..].iter().sum();
                counters.insert("cull_draws".into(), f64::from(draws));
            }
            let tested = f64::from(raw[CullCount::Tested as usize]);
            if tested > 0.0 {
                self.kept = Some((culling, drawn / tested));
            }
            if self.results.len() == MAX_RESULTS {
                self.results.remove(0);
            }
            self.results.push((frame, counters));
        }
    }
}
