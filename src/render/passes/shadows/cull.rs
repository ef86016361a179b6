//! The shadow maps culled by cluster (`--culling` frustum or occlusion,
//! with the indexed cluster draws): before the faces are drawn, one pass of
//! `cull.wgsl` (its [`SHADOW_FACES`] variant) tests every cluster of every
//! face's casters against that face's frustum (no cone: the shadow pass
//! culls no faces; no occlusion: a face has no depth of its own before it
//! is drawn) and writes an indexed draw per run of consecutive clusters
//! kept, each face's in a part of its own of one draw buffer, counted per
//! face; each face then draws its part with one
//! `multi_draw_indexed_indirect_count` per pipeline (opaque casters,
//! alpha-masked ones), with `shadow_map.wgsl`'s `CLUSTER_DRAW` variant.
//!
//! Every cluster a face drops lies wholly outside one of its clip planes, so
//! its triangles could not have written a texel: the maps are the same
//! (depth only, and the largest depth wins whichever order the triangles
//! come in). As the camera's culling does ([`super::super::cluster_draws`]),
//! the faces draw the plain way (one draw per caster) after a culling that
//! kept more than `cull_plain_above` of the clusters it tested, and the
//! culling pass then runs only to count.

use crate::gpu::readback::ReadbackRing;
use crate::render::clusters::Culling;
use crate::render::frame::Frame;
use crate::render::passes::cluster_draws::{CULL_PLAIN, INDEXED_DRAWS};
use crate::render::passes::visibility::compute::{CULL, CULL_CHUNK, CullCount, GpuCullParams, split};
use crate::render::passes::{Binding, bind_group, bind_group_layout, bind_group_layout_for, compute_pipeline_with};
use crate::render::report::Counters;
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary};

/// Defined, with [`INDEXED_DRAWS`], in `cull.wgsl`'s variant that culls for
/// the shadow faces.
pub const SHADOW_FACES: &str = "SHADOW_FACES";
/// Defined in `shadow_map.wgsl`'s variant that draws culled clusters.
pub const CLUSTER_DRAW: &str = "CLUSTER_DRAW";
/// Bytes of one `draw_indexed_indirect` entry.
const DRAW_INDEXED_BYTES: u64 = 20;
const CULL_COUNTS_BYTES: u64 = CullCount::ALL.len() as u64 * 4;
/// Read back: the [`CullCount`]s, then the draws of every face.
const READBACK_BYTES: u64 = CULL_COUNTS_BYTES + 4;
/// Frames' counters held for [`ShadowCull::collect_counts`] at most.
const MAX_RESULTS: usize = 1024;

/// One face's culled draws this frame.
#[derive(Clone, Copy, Debug)]
pub struct FaceDraws {
    /// Its index in the plan (its counts' place in the count buffer).
    face: u32,
    /// First draw entry and most draws of its opaque casters, then of its
    /// alpha-masked casters.
    opaque: (u32, u32),
    masked: (u32, u32),
}

/// The buffers sized for a frame's casters (grown when a frame needs more).
struct Sized {
    /// Cluster list entries (and draws): the clusters of every face's casters.
    capacity: u32,
    /// Entries of `ranges`: every face's casters.
    ranges_capacity: u32,
    chunks_capacity: u32,
    /// Faces `face_draws` and the counts hold.
    faces_capacity: u32,
    ranges: wgpu::Buffer,
    chunks: wgpu::Buffer,
    face_draws: wgpu::Buffer,
    draws: wgpu::Buffer,
    /// Every face's draws, a pad, then per face opaque and masked draws.
    draw_counts: wgpu::Buffer,
    /// `cull.wgsl`'s groups 1 and 2.
    cull_group: wgpu::BindGroup,
    draws_group: wgpu::BindGroup,
    /// `shadow_map.wgsl`'s group 1: the ranges and the list.
    draw_group: wgpu::BindGroup,
    bytes: u64,
}

/// The shadow faces' cluster culling: its pipeline and buffers.
pub struct ShadowCull {
    pipeline: wgpu::ComputePipeline,
    cull_layout: wgpu::BindGroupLayout,
    draws_layout: wgpu::BindGroupLayout,
    /// `shadow_map.wgsl`'s group 1 in its [`CLUSTER_DRAW`] variant.
    pub draw_layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    counts: wgpu::Buffer,
    object_clusters: wgpu::Buffer,
    /// Bound where `cull.wgsl` wants the history, the pyramid and the
    /// dispatch sizes, which culling by frustum alone never reads.
    unused: [wgpu::Buffer; 3],
    sized: Option<Sized>,
    /// The opaque objects' clusters come first in each face's part of the draws.
    masked: Vec<bool>,
    /// Tagged with the frame's number, whether the faces drew plain and the
    /// draws they issue drawing plain (one per face and caster).
    readback: ReadbackRing<(u64, bool, u32)>,
    results: Vec<(u64, Counters)>,
    /// The share of the tested clusters kept by the last culling read back
    /// that tested some (they come back in the order they were submitted).
    kept: Option<f64>,
}

impl ShadowCull {
    /// The pipeline over `scene` (whose cluster-ordered index buffer the
    /// faces draw); buffers come with the first faces.
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, scene: &SceneGpu) -> Result<Self, ShaderError> {
        let init = |label, contents: &[u8], usage| {
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage },
            )
        };
        use wgpu::BufferUsages as U;
        let (read, rw) = (Binding::Storage { read_only: true }, Binding::Storage { read_only: false });
        let cull_layout =
            bind_group_layout(device, "shadow cull", &[Binding::Uniform, read, read, read, rw, rw, rw, read, rw, read]);
        let draws_layout = bind_group_layout(device, "shadow cull draws", &[read, rw, rw]);
        let draw_layout =
            bind_group_layout_for(device, "shadow cluster draws", wgpu::ShaderStages::VERTEX, &[read, read]);
        let layouts = [&scene.layout, &cull_layout, &draws_layout];
        let pipeline =
            compute_pipeline_with(device, shaders, CULL, &[INDEXED_DRAWS, SHADOW_FACES], "cull_early", &layouts)?;
        let object_clusters = {
            let data: Vec<[u32; 4]> =
                if scene.object_clusters.is_empty() { vec![[0; 4]] } else { scene.object_clusters.clone() };
            init("shadow cull object clusters", bytemuck::cast_slice(&data), U::STORAGE)
        };
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        // As `cull.wgsl` tells them apart (`alpha_cutoff > 0`; NaN is opaque).
        let masked =
            scene.object_data.iter().map(|o| o.alpha_cutoff.partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater));
        Ok(Self {
            pipeline,
            cull_layout,
            draws_layout,
            draw_layout,
            params: buffer("shadow cull params", size_of::<GpuCullParams>() as u64, U::UNIFORM | U::COPY_DST),
            counts: buffer("shadow cull counts", READBACK_BYTES, U::STORAGE | U::COPY_DST | U::COPY_SRC),
            object_clusters,
            unused: ["history", "pyramid", "dispatch"].map(|_| buffer("shadow cull unused", 32, U::STORAGE)),
            sized: None,
            masked: masked.collect(),
            readback: ReadbackRing::new("shadow cull counts", READBACK_BYTES),
            results: Vec::new(),
            kept: None,
        })
    }

    /// Bytes of its buffers.
    pub fn bytes(&self) -> u64 {
        self.object_clusters.size() + self.sized.as_ref().map_or(0, |s| s.bytes)
    }

    /// Buffers for `capacity` clusters, `ranges` casters, `chunks` chunks
    /// and `faces` faces, re-created a quarter larger than asked when the
    /// present ones are too small.
    fn reserve(
        &mut self,
        device: &wgpu::Device,
        scene: &SceneGpu,
        capacity: u32,
        ranges: u32,
        chunks: u32,
        faces: u32,
    ) {
        if self.sized.as_ref().is_some_and(|s| {
            s.capacity >= capacity
                && s.ranges_capacity >= ranges
                && s.chunks_capacity >= chunks
                && s.faces_capacity >= faces
        }) {
            return;
        }
        let grow = |n: u32| (n.max(1) + n / 4).next_multiple_of(32);
        let (capacity, ranges_capacity, chunks_capacity, faces_capacity) =
            (grow(capacity), grow(ranges), grow(chunks), grow(faces));
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        use wgpu::BufferUsages as U;
        let ranges = buffer("shadow cull ranges", u64::from(ranges_capacity) * 16, U::STORAGE | U::COPY_DST);
        let chunks = buffer("shadow cull chunks", u64::from(chunks_capacity) * 8, U::STORAGE | U::COPY_DST);
        let face_draws = buffer("shadow cull face draws", u64::from(faces_capacity) * 8, U::STORAGE | U::COPY_DST);
        let lists = buffer("shadow cull list", u64::from(capacity) * 8, U::STORAGE);
        let draws = buffer("shadow cull draws", u64::from(capacity) * DRAW_INDEXED_BYTES, U::STORAGE | U::INDIRECT);
        let draw_counts = buffer(
            "shadow cull draw counts",
            (2 + 2 * u64::from(faces_capacity)) * 4,
            U::STORAGE | U::INDIRECT | U::COPY_DST | U::COPY_SRC,
        );
        let cull_group = bind_group(
            device,
            "shadow cull",
            &self.cull_layout,
            &[
                &self.params,
                &ranges,
                &scene.clusters,
                &self.object_clusters,
                &self.unused[0],
                &lists,
                &self.counts,
                &self.unused[1],
                &self.unused[2],
                &chunks,
            ]
            .map(|b| b.as_entire_binding()),
        );
        let draws_group = bind_group(
            device,
            "shadow cull draws",
            &self.draws_layout,
            &[face_draws.as_entire_binding(), draws.as_entire_binding(), draw_counts.as_entire_binding()],
        );
        let draw_group = bind_group(
            device,
            "shadow cluster draws",
            &self.draw_layout,
            &[ranges.as_entire_binding(), lists.as_entire_binding()],
        );
        let bytes = [&ranges, &chunks, &face_draws, &lists, &draws, &draw_counts].iter().map(|b| b.size()).sum();
        self.sized = Some(Sized {
            capacity,
            ranges_capacity,
            chunks_capacity,
            faces_capacity,
            ranges,
            chunks,
            face_draws,
            draws,
            draw_counts,
            cull_group,
            draws_group,
            draw_group,
            bytes,
        });
    }

    /// Culls the clusters of `casters[f]` against face `f`'s frustum for
    /// every face `f` of `faces` (indices of the plan's `face_count` faces),
    /// when `frame.scene.culling` is not none. Returns each face's draws, or
    /// none where the faces draw the plain way: culling is off, or the
    /// newest finished culling kept more than `cull_plain_above` of the
    /// clusters it tested (the pass then still runs, to count).
    pub fn cull(
        &mut self,
        frame: &mut Frame,
        casters: &[Vec<u32>],
        faces: &[usize],
        face_count: usize,
    ) -> Option<Vec<FaceDraws>> {
        let scene = frame.scene;
        if scene.culling == Culling::None || faces.is_empty() {
            return None;
        }
        self.gather(frame.device, false);
        let plain = self.kept.is_some_and(|kept| kept > f64::from(scene.cull_plain_above));
        let mut ranges: Vec<[u32; 4]> = Vec::new();
        let mut chunks: Vec<[u32; 2]> = Vec::new();
        let mut draws = Vec::with_capacity(faces.len());
        let mut first = 0u32;
        for &f in faces {
            let clusters = |masked: bool| -> u32 {
                let of = casters[f].iter().filter(|&&o| self.masked[o as usize] == masked);
                of.map(|&o| scene.object_clusters[o as usize][1]).sum()
            };
            let (opaque, masked) = (clusters(false), clusters(true));
            draws.push(FaceDraws { face: f as u32, opaque: (first, opaque), masked: (first + opaque, masked) });
            first += opaque + masked;
            for &object in &casters[f] {
                let r = ranges.len() as u32;
                let count = scene.object_clusters[object as usize][1];
                chunks.extend((0..count).step_by(CULL_CHUNK as usize).map(|c| [r, c]));
                ranges.push([object, 0, 0, f as u32]);
            }
        }
        self.reserve(frame.device, scene, first, ranges.len() as u32, chunks.len() as u32, face_count as u32);
        let sized = self.sized.as_ref().expect("reserved");
        let mut face_draws = vec![[0u32; 2]; face_count];
        for d in &draws {
            face_draws[d.face as usize] = [d.opaque.0, d.masked.0];
        }
        if !ranges.is_empty() {
            frame.queue.write_buffer(&sized.ranges, 0, bytemuck::cast_slice(&ranges));
        }
        if !chunks.is_empty() {
            frame.queue.write_buffer(&sized.chunks, 0, bytemuck::cast_slice(&chunks));
        }
        if face_count > 0 {
            frame.queue.write_buffer(&sized.face_draws, 0, bytemuck::cast_slice(&face_draws));
        }
        let params = GpuCullParams {
            range_count: ranges.len() as u32,
            // The frustum alone; no draws written where the faces draw plain.
            flags: if plain { CULL_PLAIN } else { 0 },
            capacity: sized.capacity,
            levels: 0,
            width: 1,
            height: 1,
            chunk_count: chunks.len() as u32,
            pad: 0,
            level_offsets: Default::default(),
        };
        frame.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        frame.encoder.clear_buffer(&self.counts, 0, None);
        frame.encoder.clear_buffer(&sized.draw_counts, 0, None);
        let groups = split(chunks.len() as u32);
        if !chunks.is_empty() {
            let scene_group = frame.scene_group;
            let mut cp = frame.compute_pass("shadow cull");
            cp.set_bind_group(0, scene_group, &[]);
            cp.set_bind_group(1, &sized.cull_group, &[]);
            cp.set_bind_group(2, &sized.draws_group, &[]);
            cp.set_pipeline(&self.pipeline);
            cp.dispatch_workgroups(groups.0, groups.1, 1);
        }
        frame.encoder.copy_buffer_to_buffer(&sized.draw_counts, 0, &self.counts, CULL_COUNTS_BYTES, 4);
        let tag = (frame.number, plain, ranges.len() as u32);
        self.readback.copy(frame.device, frame.encoder, &self.counts, READBACK_BYTES, tag);
        (!plain).then_some(draws)
    }

    /// Draws one face's kept clusters with the bound [`CLUSTER_DRAW`]
    /// pipeline: its opaque casters', or with `masked` its alpha-masked
    /// casters'.
    pub fn draw_face(&self, pass: &mut wgpu::RenderPass, scene: &SceneGpu, face: &FaceDraws, masked: bool) {
        let sized = self.sized.as_ref().expect("culled before drawing");
        let (first, max) = if masked { face.masked } else { face.opaque };
        if max == 0 {
            return;
        }
        pass.set_bind_group(1, &sized.draw_group, &[]);
        pass.set_index_buffer(scene.cluster_indices.slice(..), wgpu::IndexFormat::Uint32);
        let count = (2 + 2 * u64::from(face.face) + u64::from(masked)) * 4;
        pass.multi_draw_indexed_indirect_count(
            &sized.draws,
            u64::from(first) * DRAW_INDEXED_BYTES,
            &sized.draw_counts,
            count,
            max,
        );
    }

    /// Starts the read-back of the frame's counts. Call right after the submit.
    pub fn after_submit(&mut self) {
        self.readback.after_submit();
    }

    /// The counts of finished frames that culled the shadow faces, by frame
    /// number: `shadow_cull_tested` (the clusters of every culled face's
    /// casters), `shadow_cull_frustum` (outside their face's frustum),
    /// `shadow_cull_drawn` (kept: drawn, or in a frame drawn the plain way
    /// those culling would have drawn), `shadow_cull_draws` (indexed draws
    /// of every face; 0 when drawn the plain way), `shadow_cull_plain` and
    /// `shadow_cull_plain_draws` (the draws of the faces drawn the plain
    /// way: one per face and caster).
    pub fn collect_counts(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        self.gather(device, wait);
        std::mem::take(&mut self.results)
    }

    fn gather(&mut self, device: &wgpu::Device, wait: bool) {
        for ((frame, plain, plain_draws), bytes) in self.readback.collect(device, wait) {
            let raw: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
            let [tested, frustum, drawn] =
                [CullCount::Tested, CullCount::Frustum, CullCount::DrawnEarly].map(|k| f64::from(raw[k as usize]));
            let draws = f64::from(raw[CullCount::ALL.len()]);
            let counters: Counters = [
                ("shadow_cull_tested", tested),
                ("shadow_cull_frustum", frustum),
                ("shadow_cull_drawn", drawn),
                ("shadow_cull_draws", draws),
                ("shadow_cull_plain", f64::from(u8::from(plain))),
                ("shadow_cull_plain_draws", f64::from(plain_draws)),
            ]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
            if tested > 0.0 {
                self.kept = Some(drawn / tested);
            }
            if self.results.len() == MAX_RESULTS {
                self.results.remove(0);
            }
            self.results.push((frame, counters));
        }
    }
}
