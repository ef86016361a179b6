//! Light volumes: the meshes (a sphere enclosing a point light's range, a
//! cone enclosing a spot light's), the per-frame lists that sort the lights
//! into four instanced indirect draws (`classify.wgsl`), and the raster
//! pipelines that draw them (`volumes.wgsl`).

use std::collections::HashMap;

use glam::{Vec3, Vec4};
use wgpu::util::{DeviceExt, DrawIndexedIndirectArgs};

use crate::gpu::{GpuContext, GpuError, readback};
use crate::render::culling::Frustum;
use crate::render::frame::Frame;
use crate::render::gpu_types::GpuView;
use crate::render::passes::gbuffer::{GBuffer, GpuUnproject};
use crate::render::passes::{
    Binding, bind_group, bind_group_layout, bind_group_layout_for, compute_pipeline, depth_attachment_read_only,
};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{DEPTH_FORMAT, HDR_FORMAT};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const CLASSIFY_SHADER: ShaderSource = ShaderSource::new("classify.wgsl", include_str!("classify.wgsl"));
pub const VOLUMES_SHADER: ShaderSource = ShaderSource::new("volumes.wgsl", include_str!("volumes.wgsl"));

/// Subdivisions of the icosahedron: 80 triangles, whose vertices are within
/// 8 % of the sphere they enclose (so the enclosing mesh covers little more than the light).
pub const SPHERE_SUBDIVISIONS: u32 = 1;
/// Sides of the cone's base polygon.
pub const CONE_SEGMENTS: u32 = 12;
/// Spot lights wider than about 63 degrees (`cos_outer` at most this) are
/// drawn as spheres: beyond it the enclosing cone (`tan²` of the angle times
/// a third of the range cubed, times pi) is larger than the range's sphere.
pub const CONE_MIN_COS: f32 = 0.45;

/// The four volume lists (and indirect draws), in their order in the list
/// and draw buffers; exported to WGSL as `VOLUME_*`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeList {
    /// Point lights (and wide spot lights) seen from outside their sphere.
    PointOutside = 0,
    /// Point lights whose sphere holds the eye or cuts the near plane.
    PointInside = 1,
    /// Spot lights seen from outside their cone.
    SpotOutside = 2,
    /// Spot lights whose cone holds the eye or cuts the near plane.
    SpotInside = 3,
}

impl VolumeList {
    pub const ALL: [Self; 4] = [Self::PointOutside, Self::PointInside, Self::SpotOutside, Self::SpotInside];

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::PointOutside => "VOLUME_POINT_OUTSIDE",
            Self::PointInside => "VOLUME_POINT_INSIDE",
            Self::SpotOutside => "VOLUME_SPOT_OUTSIDE",
            Self::SpotInside => "VOLUME_SPOT_INSIDE",
        }
    }

    fn inside(self) -> bool {
        matches!(self, Self::PointInside | Self::SpotInside)
    }

    fn vertex_entry(self) -> &'static str {
        match self {
            Self::PointOutside => "vs_point_outside",
            Self::PointInside => "vs_point_inside",
            Self::SpotOutside => "vs_spot_outside",
            Self::SpotInside => "vs_spot_inside",
        }
    }
}

/// A closed, convex triangle mesh wound counter-clockwise seen from outside.
#[derive(Clone, Debug, Default)]
pub struct VolumeMesh {
    pub positions: Vec<Vec3>,
    /// Three per triangle, into `positions`.
    pub indices: Vec<u32>,
}

impl VolumeMesh {
    /// Triangles as (a, b, c) corner positions.
    pub fn triangles(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        self.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]].map(|i| self.positions[i as usize]))
    }

    /// Smallest and largest distance from `center` to the mesh: to its
    /// nearest face plane (the inscribed sphere's radius) and its farthest
    /// vertex.
    pub fn radii(&self, center: Vec3) -> (f32, f32) {
        let inner = self
            .triangles()
            .map(|[a, b, c]| (b - a).cross(c - a).normalize().dot(a - center))
            .fold(f32::INFINITY, f32::min);
        let outer = self.positions.iter().map(|p| p.distance(center)).fold(0.0, f32::max);
        (inner, outer)
    }

    /// Turns every triangle to face away from `interior`, a point inside.
    fn orient_outwards(mut self, interior: Vec3) -> Self {
        for t in self.indices.chunks_exact_mut(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| self.positions[i as usize]);
            if (b - a).cross(c - a).dot(a - interior) < 0.0 {
                t.swap(1, 2);
            }
        }
        self
    }
}

/// An icosahedron subdivided `levels` times (vertices on the unit sphere),
/// then scaled so that every face is at least 1 from the centre: it encloses
/// the unit ball.
pub fn icosphere(levels: u32) -> VolumeMesh {
    let phi = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut indices: Vec<u32> = vec![
        0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3,
        4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1,
    ];
    for _ in 0..levels {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut finer = Vec::with_capacity(indices.len() * 4);
        for t in indices.chunks_exact(3) {
            let (a, b, c) = (t[0], t[1], t[2]);
            let (ab, bc, ca) =
                (midpoint(a, b, &mut positions), midpoint(b, c, &mut positions), midpoint(c, a, &mut positions));
            finer.extend_from_slice(&[a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca]);
        }
        indices = finer;
    }
    let mesh = VolumeMesh { positions, indices }.orient_outwards(Vec3::ZERO);
    let (inner, _) = mesh.radii(Vec3::ZERO);
    VolumeMesh { positions: mesh.positions.iter().map(|p| *p / inner).collect(), indices: mesh.indices }
}

/// A cone with its apex at the origin, its axis along +z and its base at
/// z = 1: a polygon of `segments` sides around the unit circle (so the cone
/// encloses the round cone of half-angle 45 degrees and height 1).
pub fn cone(segments: u32) -> VolumeMesh {
    let ring = 1.0 / (std::f32::consts::PI / segments as f32).cos();
    let mut positions = vec![Vec3::ZERO, Vec3::Z];
    positions.extend((0..segments).map(|i| {
        let a = std::f32::consts::TAU * i as f32 / segments as f32;
        Vec3::new(ring * a.cos(), ring * a.sin(), 1.0)
    }));
    let mut indices = Vec::new();
    for i in 0..segments {
        let (p, q) = (2 + i, 2 + (i + 1) % segments);
        indices.extend_from_slice(&[0, p, q, 1, q, p]);
    }
    VolumeMesh { positions, indices }.orient_outwards(Vec3::new(0.0, 0.0, 0.5))
}

gpu_struct! {
    /// Per-frame settings of the light-volume passes (`VolumeParams` in
    /// `deferred.wgsl`).
    pub struct GpuVolumeParams as "VolumeParams" {
        /// The view frustum's planes (world space, unit normals, inside >= 0).
        pub frustum: [Vec4; 6],
        /// Distance from the eye to the near plane's corners.
        pub near_reach: f32,
        /// Places per list.
        pub capacity: u32,
        pub cone_min_cos: f32,
        /// Farthest vertex of the sphere mesh from its centre.
        pub sphere_reach: f32,
        /// Circumradius of the cone mesh's base polygon.
        pub cone_ring: f32,
        pub pad_a: u32,
        pub pad_b: u32,
        pub pad_c: u32,
    }
}

/// Distance from the eye to the farthest corner of the near plane.
pub fn near_reach(view: &GpuView) -> f32 {
    let unproject = GpuUnproject::new(view);
    let eye = view.camera_position.truncate();
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(x, y)| unproject.world(x, y, 1.0).distance(eye))
        .fold(0.0, f32::max)
}

/// The meshes, lists, indirect draws and pipelines of the light volumes.
pub struct LightVolumes {
    mesh_vertices: wgpu::Buffer,
    mesh_indices: wgpu::Buffer,
    params: wgpu::Buffer,
    /// Four lists of `capacity` light indices each.
    lists: wgpu::Buffer,
    capacity: u32,
    /// Four `DrawIndexedIndirectArgs`, in [`VolumeList`] order.
    draws: wgpu::Buffer,
    sphere_reach: f32,
    cone_ring: f32,
    classify_layout: wgpu::BindGroupLayout,
    classify_group: wgpu::BindGroup,
    classify: wgpu::ComputePipeline,
    draw_layout: wgpu::BindGroupLayout,
    draw_group: wgpu::BindGroup,
    /// One raster pipeline per list, in [`VolumeList`] order.
    pipelines: Vec<wgpu::RenderPipeline>,
}

impl LightVolumes {
    /// The meshes, buffers and pipelines; the lists start small and grow
    /// with the light count.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        gbuffer: &GBuffer,
    ) -> Result<Self, ShaderError> {
        let (sphere, cone) = (icosphere(SPHERE_SUBDIVISIONS), cone(CONE_SEGMENTS));
        let (_, sphere_reach) = sphere.radii(Vec3::ZERO);
        let cone_ring = cone.positions[2].truncate().length();
        let vertices: Vec<Vec4> = sphere.positions.iter().chain(&cone.positions).map(|p| p.extend(0.0)).collect();
        let indices: Vec<u32> = sphere.indices.iter().chain(&cone.indices).copied().collect();
        let draw = |mesh: &VolumeMesh, first_index: usize, base_vertex: usize| DrawIndexedIndirectArgs {
            index_count: mesh.indices.len() as u32,
            instance_count: 0,
            first_index: first_index as u32,
            base_vertex: base_vertex as i32,
            first_instance: 0,
        };
        let (sphere_draw, cone_draw) = (draw(&sphere, 0, 0), draw(&cone, sphere.indices.len(), sphere.positions.len()));
        let draws: Vec<u8> = VolumeList::ALL
            .iter()
            .flat_map(|l| match l {
                VolumeList::PointOutside | VolumeList::PointInside => sphere_draw.as_bytes().to_vec(),
                VolumeList::SpotOutside | VolumeList::SpotInside => cone_draw.as_bytes().to_vec(),
            })
            .collect();
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        use wgpu::BufferUsages as U;
        let mesh_vertices = init("light volume vertices", bytemuck::cast_slice(&vertices), U::STORAGE);
        let mesh_indices = init("light volume indices", bytemuck::cast_slice(&indices), U::INDEX);
        let draws = init("light volume draws", &draws, U::STORAGE | U::INDIRECT | U::COPY_SRC);
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light volume params"),
            size: size_of::<GpuVolumeParams>() as u64,
            usage: U::UNIFORM | U::COPY_DST,
            mapped_at_creation: false,
        });
        let capacity = 1;
        let lists = Self::create_lists(device, capacity);
        let storage = |read_only| Binding::Storage { read_only };
        let classify_layout =
            bind_group_layout(device, "light volume classify", &[Binding::Uniform, storage(false), storage(false)]);
        let draw_layout = bind_group_layout_for(
            device,
            "light volume draw",
            wgpu::ShaderStages::VERTEX,
            &[Binding::Uniform, storage(true), storage(true)],
        );
        let classify =
            compute_pipeline(device, shaders, CLASSIFY_SHADER, "classify", &[&scene.layout, &classify_layout])?;
        let module = shaders.module(device, VOLUMES_SHADER)?;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("light volumes"),
            bind_group_layouts: &[Some(&scene.layout), Some(&gbuffer.read_layout), Some(&draw_layout)],
            immediate_size: 0,
        });
        let samples = gbuffer.normal.sample_count();
        let pipelines =
            VolumeList::ALL.iter().map(|l| volume_pipeline(device, &module, &layout, *l, samples)).collect();
        let (classify_group, draw_group) =
            Self::bind_groups(device, [&classify_layout, &draw_layout], [&params, &lists, &draws, &mesh_vertices]);
        Ok(Self {
            mesh_vertices,
            mesh_indices,
            params,
            lists,
            capacity,
            draws,
            sphere_reach,
            cone_ring,
            classify_layout,
            classify_group,
            classify,
            draw_layout,
            draw_group,
            pipelines,
        })
    }

    fn create_lists(device: &wgpu::Device, capacity: u32) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light volume lists"),
            size: VolumeList::ALL.len() as u64 * capacity as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        })
    }

    /// Buffers: params, lists, draws, mesh vertices.
    fn bind_groups(
        device: &wgpu::Device,
        [classify, draw]: [&wgpu::BindGroupLayout; 2],
        [params, lists, draws, vertices]: [&wgpu::Buffer; 4],
    ) -> (wgpu::BindGroup, wgpu::BindGroup) {
        let classify = bind_group(
            device,
            "light volume classify",
            classify,
            &[params.as_entire_binding(), lists.as_entire_binding(), draws.as_entire_binding()],
        );
        let draw = bind_group(
            device,
            "light volume draw",
            draw,
            &[params.as_entire_binding(), vertices.as_entire_binding(), lists.as_entire_binding()],
        );
        (classify, draw)
    }

    /// Grows the lists to hold `lights` lights each (re-created only when
    /// the light count grows past every earlier one).
    fn reserve(&mut self, device: &wgpu::Device, lights: u32) {
        if lights <= self.capacity {
            return;
        }
        self.capacity = lights.next_power_of_two();
        self.lists = Self::create_lists(device, self.capacity);
        (self.classify_group, self.draw_group) = Self::bind_groups(
            device,
            [&self.classify_layout, &self.draw_layout],
            [&self.params, &self.lists, &self.draws, &self.mesh_vertices],
        );
    }

    /// GPU memory: meshes, lists and draws.
    pub fn bytes(&self) -> u64 {
        self.mesh_vertices.size() + self.mesh_indices.size() + self.lists.size() + self.draws.size()
    }

    /// Instances the last finished frame drew from each list, in
    /// [`VolumeList`] order (waits for the GPU; for tests and debugging).
    pub fn read_counts(&self, ctx: &GpuContext) -> Result<[u32; 4], GpuError> {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_whole_buffer(ctx, &self.draws)?);
        let stride = size_of::<DrawIndexedIndirectArgs>() / 4;
        Ok(VolumeList::ALL.map(|l| words[l as usize * stride + 1]))
    }

    /// Triangles of the sphere and of the cone mesh.
    pub fn triangles() -> (u64, u64) {
        (icosphere(SPHERE_SUBDIVISIONS).indices.len() as u64 / 3, cone(CONE_SEGMENTS).indices.len() as u64 / 3)
    }
}

/// The raster pipeline of one list: additive blending, no depth writes;
/// from outside, front faces tested `GreaterEqual` (the volume's surface in
/// front of the scene's, reversed Z); from inside, back faces untested.
/// Under MSAA (`samples` > 1: the G-buffer's depth is multisampled, the HDR
/// target not) no depth attachment: the fragment tests each sample itself.
fn volume_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    list: VolumeList,
    samples: u32,
) -> wgpu::RenderPipeline {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let keep = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let target = wgpu::ColorTargetState {
        format: HDR_FORMAT,
        blend: Some(wgpu::BlendState { color: add, alpha: keep }),
        write_mask: wgpu::ColorWrites::ALL,
    };
    let (cull, compare) = if list.inside() {
        (wgpu::Face::Front, wgpu::CompareFunction::Always)
    } else {
        (wgpu::Face::Back, wgpu::CompareFunction::GreaterEqual)
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(list.vertex_entry()),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(list.vertex_entry()),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(if samples > 1 && list.inside() { "fs_light_inside" } else { "fs_light" }),
            compilation_options: Default::default(),
            targets: &[Some(target)],
        }),
        primitive: wgpu::PrimitiveState { cull_mode: Some(cull), ..Default::default() },
        depth_stencil: (samples == 1).then_some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    })
}

/// Reads: the view and the lights. Writes: the volume lists and the
/// instance counts of the four indirect draws (growing the lists first when
/// the light count grew).
pub fn classify_volumes(frame: &mut Frame, volumes: &mut LightVolumes) {
    let view = frame.view;
    volumes.reserve(frame.device, view.light_count.saturating_sub(view.global_light_count).max(1));
    let params = GpuVolumeParams {
        frustum: Frustum::from_view_projection(view.view_proj).planes,
        near_reach: near_reach(view),
        capacity: volumes.capacity,
        cone_min_cos: CONE_MIN_COS,
        sphere_reach: volumes.sphere_reach,
        cone_ring: volumes.cone_ring,
        ..Default::default()
    };
    frame.queue.write_buffer(&volumes.params, 0, bytemuck::bytes_of(&params));
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("light volumes");
    cp.set_pipeline(&volumes.classify);
    cp.set_bind_group(0, scene, &[]);
    cp.set_bind_group(1, &volumes.classify_group, &[]);
    cp.dispatch_workgroups(1, 1, 1);
}

/// Reads: the G-buffer (with depth), the lights, the volume lists and
/// draws of `lists`. Writes: `targets.hdr`, adding each listed light where
/// its volume covers a pixel. Timed as `label`.
pub fn draw_volumes(frame: &mut Frame, volumes: &LightVolumes, gbuffer: &GBuffer, lists: [VolumeList; 2], label: &str) {
    let (scene, targets) = (frame.scene, frame.targets);
    let color = [Some(wgpu::RenderPassColorAttachment {
        view: &targets.hdr_view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
    })];
    // Under MSAA the shader tests the multisampled depth itself.
    let depth = (targets.samples == 1).then(|| depth_attachment_read_only(targets));
    let mut rp = frame.render_pass(label, &color, depth);
    rp.set_bind_group(0, scene.bind_group(), &[]);
    rp.set_bind_group(1, &gbuffer.read_group, &[]);
    rp.set_bind_group(2, &volumes.draw_group, &[]);
    rp.set_index_buffer(volumes.mesh_indices.slice(..), wgpu::IndexFormat::Uint32);
    let stride = size_of::<DrawIndexedIndirectArgs>() as u64;
    for list in lists {
        rp.set_pipeline(&volumes.pipelines[list as usize]);
        rp.draw_indexed_indirect(&volumes.draws, list as u64 * stride);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_closed_convex_outward(mesh: &VolumeMesh, interior: Vec3) {
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in mesh.indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((a, b)).or_default() += 1;
            }
        }
        // Closed and consistently wound: every directed edge once, its
        // opposite once.
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} used {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no opposite");
        }
        for [a, b, c] in mesh.triangles() {
            let n = (b - a).cross(c - a);
            assert!(n.dot(a - interior) > 0.0, "face {a} {b} {c} faces inwards");
            // Convex: every vertex on the inner side of every face.
            for p in &mesh.positions {
                assert!(n.normalize().dot(*p - a) <= 1e-5, "vertex {p} outside face {a} {b} {c}");
            }
        }
    }

    /// Whether `p` is inside (or on) the convex mesh.
    fn contains(mesh: &VolumeMesh, p: Vec3) -> bool {
        mesh.triangles().all(|[a, b, c]| (b - a).cross(c - a).normalize().dot(p - a) <= 1e-5)
    }

    #[test]
    fn icosphere_encloses_the_unit_ball() {
        let mesh = icosphere(SPHERE_SUBDIVISIONS);
        assert_eq!(mesh.indices.len() / 3, 80);
        assert_eq!(mesh.positions.len(), 42);
        assert_closed_convex_outward(&mesh, Vec3::ZERO);
        let (inner, outer) = mesh.radii(Vec3::ZERO);
        assert!((inner - 1.0).abs() < 1e-5, "inscribed radius {inner}");
        assert!(outer < 1.08, "the mesh is {outer} wide, little more than the ball");
    }

    #[test]
    fn cone_encloses_the_unit_cone() {
        let mesh = cone(CONE_SEGMENTS);
        assert_closed_convex_outward(&mesh, Vec3::new(0.0, 0.0, 0.5));
        for i in 0..360 {
            let a = (i as f32).to_radians();
            assert!(contains(&mesh, Vec3::new(a.cos(), a.sin(), 1.0)), "rim at {i} degrees is outside");
        }
    }

    /// Points of a spot light's lit region (its outer cone cut at its range),
    /// mapped as `spot_volume` in `volumes.wgsl` maps the mesh, are inside it.
    #[test]
    fn cone_volume_encloses_the_spot_lights_sector() {
        let mesh = cone(CONE_SEGMENTS);
        for cos_outer in [CONE_MIN_COS + 0.001, 0.6, 0.8, 0.95, 0.999] {
            let tan = (1.0 - cos_outer * cos_outer).sqrt() / cos_outer;
            let sin = (1.0 - cos_outer * cos_outer).sqrt();
            // In the light's frame (axis +z, unit range), mesh space is that
            // frame with x and y divided by tan.
            for i in 0..64 {
                let a = std::f32::consts::TAU * i as f32 / 64.0;
                for (r, s) in [(1.0, 1.0), (1.0, 0.5), (0.5, 1.0), (1.0, 0.0)] {
                    let lateral = r * sin * s;
                    let along = (r * r - lateral * lateral).sqrt();
                    let p = Vec3::new(lateral * a.cos() / tan, lateral * a.sin() / tan, along);
                    assert!(contains(&mesh, p), "cos_outer {cos_outer}: sector point {p} outside");
                }
            }
        }
    }

    #[test]
    fn near_reach_is_the_near_plane_corner_distance() {
        let camera = crate::scene::Camera {
            position: Vec3::new(1.0, 2.0, 3.0),
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: 90f32.to_radians(),
            near: 0.5,
            far: 100.0,
        };
        let view = crate::render::scene_gpu::gpu_view(&camera, 200, 100);
        // Half extents at the near plane: 0.5 high, 1.0 wide.
        let expected = (0.5f32 * 0.5 + 0.5 * 0.5 + 1.0 * 1.0).sqrt();
        assert!((near_reach(&view) - expected).abs() < 1e-4, "{} != {expected}", near_reach(&view));
    }
}
