//! The scene on the GPU: vertices, indices, objects, material textures, view,
//! lights and the shadow atlas, bound as group 0 by every pipeline.

use std::sync::Arc;

use glam::{Mat4, Vec4};
use image::imageops::FilterType;
use wgpu::util::DeviceExt;

use super::clusters::{ClusterDraws, Culling, GpuCluster};
use super::culling::LightLists;
use super::gpu_types::{GpuLight, GpuObject, GpuVertex, GpuView, NO_TEXTURE};
use super::mesh_memo;
use super::passes::environment::{self, EnvironmentMaps};
use super::passes::shadows::{ShadowAtlas, ShadowPlan};
use super::passes::{Binding, bind_group_layout_for};
use crate::hash::Fnv1a;
use crate::materials::{GpuLayer, LayerKind};
use crate::memo::Memo;
use crate::scene::{Aabb, Camera, Light, Scene};

/// Largest side of a layer of the albedo array; bigger textures are resized.
pub const MAX_ALBEDO_SIZE: u32 = 1024;
/// [`SceneGpu::vis_small_area`]'s default: a 16x16 box. On the H200 at
/// 1920x1080 128 and 512 pixels were slower on Sponza's path (BENCHMARKS.md,
/// "Compute visibility without its serial tail").
pub const DEFAULT_SMALL_AREA: u32 = 256;
/// [`SceneGpu::vis_big_workgroups`]'s default. Each workgroup's loop over
/// its tiles is a chain of dependent loads and barriers, so more of them
/// run faster: on the H200, Sponza's `vis: raster big` took 0.222 ms with
/// 1024, 0.179 with 4096, 0.161 with 32768 and 0.165 with 65535 at
/// 1920x1080 (0.803, 0.650, 0.583, 0.580 at 3840x2160; BENCHMARKS.md;
/// measured before the tiles walked only their squares that pass).
pub const DEFAULT_BIG_WORKGROUPS: u32 = 32768;
/// [`big_workgroups_for`] on a CPU driver, which runs workgroups a few at a
/// time and pays for each: on lavapipe 32768 made Sponza's `vis: raster
/// big` take 318 ms at 1280x720 where 1024 took 198.
pub const CPU_BIG_WORKGROUPS: u32 = 1024;

/// The big-triangle pass's workgroups for an adapter of `device_type`:
/// [`DEFAULT_BIG_WORKGROUPS`] on GPUs, [`CPU_BIG_WORKGROUPS`] on CPU drivers.
pub fn big_workgroups_for(device_type: wgpu::DeviceType) -> u32 {
    if device_type == wgpu::DeviceType::Cpu { CPU_BIG_WORKGROUPS } else { DEFAULT_BIG_WORKGROUPS }
}

/// Where one object's triangles are in the shared buffers (the same range
/// for every instance of a mesh).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawRange {
    pub first_index: u32,
    pub index_count: u32,
    pub base_vertex: u32,
}

/// A storage buffer that grows (and is then re-created) when written past its size.
pub(crate) struct GrowableBuffer {
    pub(crate) buffer: wgpu::Buffer,
    label: &'static str,
}

impl GrowableBuffer {
    pub(crate) fn new(device: &wgpu::Device, label: &'static str, size: u64) -> Self {
        Self { buffer: Self::create(device, label, size), label }
    }

    fn create(device: &wgpu::Device, label: &'static str, size: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(256).next_power_of_two(),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Writes `data`; returns true when the buffer had to be re-created.
    pub(crate) fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) -> bool {
        let grew = data.len() as u64 > self.buffer.size();
        if grew {
            self.buffer = Self::create(device, self.label, data.len() as u64);
        }
        if !data.is_empty() {
            queue.write_buffer(&self.buffer, 0, data);
        }
        grew
    }
}

pub struct SceneGpu {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub objects: wgpu::Buffer,
    pub view: wgpu::Buffer,
    pub albedo: wgpu::Texture,
    pub draws: Vec<DrawRange>,
    /// World-space bounds per object (for culling).
    pub object_bounds: Vec<Aabb>,
    /// CPU copy of the object table; light ranges are rewritten per frame.
    pub object_data: Vec<GpuObject>,
    pub triangle_count: u64,
    /// Per triangle of the index buffer: its chart island in its mesh's
    /// chart UVs ([`triangle_islands`](crate::charts::islands::triangle_islands); object space filters within it).
    pub triangle_charts: wgpu::Buffer,
    /// One more than the largest chart island number of any mesh (islands
    /// are numbered per mesh from 0).
    pub island_numbers: u32,
    /// Per object: whether its material is single-sided (not
    /// [`crate::scene::Material::double_sided`]): every pipeline culls its
    /// back faces.
    pub single_sided: Vec<bool>,
    /// Every mesh's clusters ([`clusters::build`](super::clusters::build)), mesh after mesh.
    pub clusters: wgpu::Buffer,
    /// The clusters' triangles (indices of their mesh's triangles), cluster
    /// after cluster.
    pub cluster_triangles: wgpu::Buffer,
    /// The index buffer in cluster order: entry `k` of `cluster_triangles`
    /// is the triangle at indices `3k..3k + 3` (mesh-local vertex indices, as
    /// in `indices`), so each cluster is one range of it, drawn by the
    /// indexed cluster draws ([`ClusterDraws::Indexed`]). The meshes keep
    /// their triangle order: triangle ids, charts and triangle maps do not
    /// change with culling.
    pub cluster_indices: wgpu::Buffer,
    /// Per object: its mesh's first cluster and cluster count, its first slot
    /// in per-instance cluster state (slots are numbered object after
    /// object), and its first triangle in the scene's numbering (objects'
    /// triangles back to back: the compute rasterizer's payload).
    pub object_clusters: Vec<[u32; 4]>,
    /// Clusters of all objects (instances count once each).
    pub instance_clusters: u32,
    /// How the compute rasterizer culls clusters this frame (the renderer
    /// sets it from [`super::Renderer::culling`]).
    pub culling: Culling,
    /// Whether the compute rasterizer reads a pixel before its 64-bit
    /// atomicMax and skips the atomic where it would not win (the renderer
    /// sets it from [`super::Renderer::vis_depth_test`]; the ids are the same
    /// either way).
    pub vis_depth_test: bool,
    /// Most pixels of a triangle's bounds that the compute rasterizer draws
    /// in the triangle's own thread; bigger triangles are drawn by
    /// workgroups (the renderer sets it from [`super::Renderer::vis_small_area`];
    /// the ids are the same whatever it is).
    pub vis_small_area: u32,
    /// Workgroups of the compute rasterizer's pass over big triangles' tiles,
    /// which loop over them (the renderer sets it from
    /// [`super::Renderer::vis_big_workgroups`]; the ids are the same whatever it is).
    pub vis_big_workgroups: u32,
    /// How the raster passes draw culled clusters: the renderer sets it from
    /// [`super::Renderer::cluster_draws`] where the adapter can
    /// ([`super::passes::cluster_draws::draws_for`]) before culling is built.
    pub cluster_draws: ClusterDraws,
    /// The raster passes draw the plain way (every object in view) in a
    /// frame after one whose culling kept more than this share of the
    /// clusters it tested (the renderer sets it from
    /// [`super::Renderer::cull_plain_above`]; 1 or more: never).
    pub cull_plain_above: f32,
    /// Per object: whether its material is alpha-masked
    /// ([`crate::scene::Material::alpha_cutoff`]).
    pub masked: Vec<bool>,
    /// Per object: whether its material is alpha-blended
    /// ([`crate::scene::Material::blend`]; drawn by [`super::passes::blended`]).
    pub blended: Vec<bool>,
    /// Per object: whether it emits light, through its material's emissive
    /// factor or an emissive layer (multi-pass forward gives it an emission
    /// pass).
    pub emits: Vec<bool>,
    /// Some object has an emissive, metallic-roughness or occlusion texture
    /// (the shaders are composed with [`crate::shaders::MATERIAL_TEXTURES`]).
    pub material_textures: bool,
    /// Some material has layers (the shaders are composed with
    /// [`crate::shaders::LAYERS`]).
    pub layers: bool,
    /// The layer table of every material ([`crate::materials::GpuLayer`],
    /// binding 13; one unused entry when no material has layers).
    layers_buffer: wgpu::Buffer,
    /// Shadow maps of the shadowed lights (bindings 8-11).
    pub shadow_atlas: ShadowAtlas,
    /// The environment's prefiltered maps (bindings 14-17; black until
    /// [`Self::set_environment`]).
    pub environment: EnvironmentMaps,
    environment_sampler: wgpu::Sampler,
    lights: GrowableBuffer,
    light_indices: GrowableBuffer,
    /// The colour textures as one array (binding 5).
    pub albedo_view: wgpu::TextureView,
    linear_maps_view: wgpu::TextureView,
    /// The linear maps' array (kept for its size).
    linear_maps: wgpu::Texture,
    /// Trilinear, isotropic: the scene group's samples at an explicit level
    /// (binding 18) and the shadow-map passes' alpha tests (a caster's
    /// coverage from the light does not need a sharper filter).
    pub sampler: wgpu::Sampler,
    /// The sampler of the material textures in the scene group (binding 6):
    /// trilinear with up to [`Self::anisotropy`] anisotropic taps.
    material_sampler: wgpu::Sampler,
    anisotropy: u16,
    pub layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
}

impl SceneGpu {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) -> Self {
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        let mut mesh_ranges = Vec::with_capacity(scene.meshes.len());
        let SceneClusters {
            gpu: gpu_clusters,
            triangles: cluster_triangles,
            indices: cluster_indices,
            ranges: mesh_clusters,
        } = upload_clusters(scene);
        for mesh in &scene.meshes {
            let charts = mesh.uv1.as_ref().unwrap_or(&mesh.uv0);
            mesh_ranges.push(DrawRange {
                first_index: indices.len() as u32,
                index_count: mesh.indices.len() as u32,
                base_vertex: vertices.len() as u32,
            });
            vertices.extend((0..mesh.positions.len()).map(|i| GpuVertex {
                position: mesh.positions[i],
                uv0_x: mesh.uv0[i].x,
                normal: mesh.normals[i],
                uv0_y: mesh.uv0[i].y,
                tangent: mesh.tangents[i],
                chart_uv: charts[i],
                ..Default::default()
            }));
            indices.extend_from_slice(&mesh.indices);
        }
        let (albedo, white_layer, linear_maps, linear_layers) = upload_textures(device, queue, scene);
        let linear_layer = |t: Option<usize>| t.and_then(|t| linear_layers[t]).unwrap_or(NO_TEXTURE);
        let draws: Vec<DrawRange> = scene.objects.iter().map(|o| mesh_ranges[o.mesh]).collect();
        // The layer table: each material's layers in order; per material its range.
        let mut layer_table = Vec::new();
        let mut layer_ranges = Vec::with_capacity(scene.materials.len());
        for m in &scene.materials {
            layer_ranges.push((layer_table.len() as u32, m.layers.len() as u32));
            let color = |t: usize| t as u32;
            layer_table.extend(m.layers.iter().map(|l| GpuLayer::new(l, m, color, |t| linear_layer(Some(t)))));
        }
        let layers = !layer_table.is_empty();
        if layer_table.is_empty() {
            layer_table.push(GpuLayer::default());
        }
        let object_data: Vec<GpuObject> = scene
            .objects
            .iter()
            .zip(&draws)
            .map(|(o, d)| {
                let m = &scene.materials[o.material];
                GpuObject {
                    model: o.transform,
                    normal_model: o.transform.inverse().transpose(),
                    base_color: m.base_color,
                    emissive: m.emissive,
                    albedo_layer: m.base_color_texture.map_or(white_layer, |t| t as u32),
                    light_offset: 0,
                    light_count: 0,
                    first_index: d.first_index,
                    base_vertex: d.base_vertex,
                    specular: m.specular,
                    shininess: m.shininess,
                    metallic: m.metallic,
                    roughness: m.roughness,
                    normal_layer: linear_layer(m.normal_texture),
                    emissive_layer: m.emissive_texture.map_or(NO_TEXTURE, |t| t as u32),
                    metal_rough_layer: linear_layer(m.metallic_roughness_texture),
                    occlusion_layer: linear_layer(m.occlusion_texture),
                    occlusion_strength: m.occlusion_strength,
                    alpha_cutoff: m.alpha_cutoff.unwrap_or(0.0),
                    layer_first: layer_ranges[o.material].0,
                    layer_count: layer_ranges[o.material].1,
                    cull_back: u32::from(!m.double_sided),
                    ..Default::default()
                }
            })
            .collect();
        let material_textures = object_data
            .iter()
            .any(|o| [o.emissive_layer, o.metal_rough_layer, o.occlusion_layer].iter().any(|&l| l != NO_TEXTURE));
        let storage = |label, contents: &[u8], extra| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
            })
        };
        let vertices_buf = storage("vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::empty());
        let indices_buf = storage("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX);
        // Chart island of every triangle, in index-buffer order (at least one
        // entry: empty buffers cannot be bound).
        let mut islands: Vec<u32> = Vec::new();
        for m in &scene.meshes {
            islands.extend_from_slice(&mesh_memo::islands(&m.indices, m.uv1.as_ref().unwrap_or(&m.uv0)));
        }
        if islands.is_empty() {
            islands.push(0);
        }
        let island_numbers = islands.iter().max().map_or(0, |&i| i.saturating_add(1));
        let triangle_charts = storage("triangle charts", bytemuck::cast_slice(&islands), wgpu::BufferUsages::empty());
        let objects = storage("objects", bytemuck::cast_slice(&object_data), wgpu::BufferUsages::empty());
        let layers_buf = storage("material layers", bytemuck::cast_slice(&layer_table), wgpu::BufferUsages::empty());
        let view = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view"),
            size: size_of::<GpuView>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let lights = GrowableBuffer::new(device, "lights", 64 * 1024);
        let light_indices = GrowableBuffer::new(device, "light indices", 64 * 1024);
        let array_view = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let albedo_view = array_view(&albedo);
        let linear_maps_view = array_view(&linear_maps);
        let sampler = material_sampler(device, 1);
        let layout = bind_group_layout(device);
        let shadow_atlas = ShadowAtlas::new(device);
        let environment = EnvironmentMaps::black(device);
        let environment_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("environment"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let bind_group = make_bind_group(
            device,
            &layout,
            [&view, &objects, &vertices_buf, &lights.buffer, &light_indices.buffer, &indices_buf, &layers_buf],
            [&albedo_view, &linear_maps_view],
            [&sampler, &sampler],
            &shadow_atlas,
            (&environment, &environment_sampler),
        );
        let object_bounds = scene.all_object_bounds();
        let (mut slots, mut triangles) = (0u32, 0u32);
        let object_clusters: Vec<[u32; 4]> = scene
            .objects
            .iter()
            .map(|o| {
                let (first, count) = mesh_clusters[o.mesh];
                let entry = [first, count, slots, triangles];
                slots += count;
                triangles = triangles.saturating_add(scene.meshes[o.mesh].triangle_count() as u32);
                entry
            })
            .collect();
        let clusters_buf = storage("clusters", bytemuck::cast_slice(&gpu_clusters), wgpu::BufferUsages::empty());
        let cluster_triangles =
            storage("cluster triangles", bytemuck::cast_slice(&cluster_triangles), wgpu::BufferUsages::empty());
        let cluster_indices =
            storage("cluster indices", bytemuck::cast_slice(&cluster_indices), wgpu::BufferUsages::INDEX);
        Self {
            vertices: vertices_buf,
            indices: indices_buf,
            objects,
            view,
            albedo,
            draws,
            object_bounds,
            object_data,
            triangle_count: scene.triangle_count() as u64,
            single_sided: (0..scene.objects.len()).map(|i| scene.single_sided(i)).collect(),
            clusters: clusters_buf,
            cluster_triangles,
            cluster_indices,
            object_clusters,
            instance_clusters: slots,
            culling: Culling::default(),
            vis_depth_test: false,
            vis_small_area: DEFAULT_SMALL_AREA,
            vis_big_workgroups: DEFAULT_BIG_WORKGROUPS,
            cluster_draws: ClusterDraws::default(),
            cull_plain_above: super::clusters::CULL_PLAIN_ABOVE,
            masked: scene.objects.iter().map(|o| scene.materials[o.material].alpha_cutoff.is_some()).collect(),
            blended: scene.objects.iter().map(|o| scene.materials[o.material].blend).collect(),
            emits: scene
                .objects
                .iter()
                .map(|o| {
                    let m = &scene.materials[o.material];
                    m.emissive.max_element() > 0.0
                        || m.layers.iter().any(
                            |l| matches!(l.kind, LayerKind::Emissive { emission, .. } if emission.max_element() > 0.0),
                        )
                })
                .collect(),
            material_textures,
            layers,
            layers_buffer: layers_buf,
            triangle_charts,
            island_numbers,
            shadow_atlas,
            environment,
            environment_sampler,
            lights,
            light_indices,
            albedo_view,
            linear_maps_view,
            linear_maps,
            material_sampler: sampler.clone(),
            sampler,
            anisotropy: 1,
            layout,
            bind_group,
        }
    }

    /// The most anisotropic taps the material sampler takes (1: isotropic).
    pub fn anisotropy(&self) -> u16 {
        self.anisotropy
    }

    /// Gives the material textures' sampler (the scene group's binding 6)
    /// up to `anisotropy` taps (1, 2, 4, 8 or 16; 1 is trilinear alone) and
    /// rebuilds the group. Samples taken with gradients (implicit or
    /// `textureSampleGrad`) filter anisotropically; those at an explicit
    /// level (object space's texels, layer masks) use the isotropic
    /// [`Self::sampler`], having no footprint. An adapter without
    /// `DownlevelFlags::ANISOTROPIC_FILTERING` gets an isotropic sampler from
    /// wgpu, silently ([`super::Renderer::texture_anisotropy`] warns).
    pub fn set_anisotropy(&mut self, device: &wgpu::Device, anisotropy: u16) {
        if anisotropy != self.anisotropy {
            self.anisotropy = anisotropy;
            self.material_sampler = material_sampler(device, anisotropy);
            self.rebuild_bind_group(device);
        }
    }

    /// Bytes of the scene's GPU data, by kind: `scene_vertex_bytes` and
    /// `scene_index_bytes` (one range per mesh, however many instances
    /// draw it), `scene_triangle_chart_bytes` (per mesh triangle too),
    /// `scene_object_bytes` (the per-instance table: transform and material)
    /// `scene_texture_bytes` (the colour and linear arrays, mips included)
    /// and `scene_cluster_bytes` (clusters, their triangle lists and the
    /// cluster-ordered index buffer, per mesh).
    pub fn memory(&self) -> [(&'static str, u64); 6] {
        let texture = |t: &wgpu::Texture| -> u64 {
            let layers = u64::from(t.depth_or_array_layers());
            let block = u64::from(t.format().block_copy_size(None).unwrap_or(4));
            (0..t.mip_level_count())
                .map(|m| u64::from((t.width() >> m).max(1)) * u64::from((t.height() >> m).max(1)) * layers * block)
                .sum()
        };
        [
            ("scene_vertex_bytes", self.vertices.size()),
            ("scene_index_bytes", self.indices.size()),
            ("scene_triangle_chart_bytes", self.triangle_charts.size()),
            ("scene_object_bytes", self.objects.size()),
            ("scene_texture_bytes", texture(&self.albedo) + texture(&self.linear_maps)),
            ("scene_cluster_bytes", self.clusters.size() + self.cluster_triangles.size() + self.cluster_indices.size()),
        ]
    }

    /// Whether some object is alpha-masked.
    pub fn has_alpha_masks(&self) -> bool {
        self.masked.contains(&true)
    }

    /// Whether some object is single-sided (its back faces culled).
    pub fn has_single_sided(&self) -> bool {
        self.single_sided.contains(&true)
    }

    /// Whether some object is double-sided (both faces drawn).
    pub fn has_double_sided(&self) -> bool {
        self.single_sided.contains(&false)
    }

    /// Whether some object is alpha-blended.
    pub fn has_blended(&self) -> bool {
        self.blended.contains(&true)
    }

    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// Uploads this frame's view and per-object light lists, and the lights
    /// when they changed (`None`: same as last frame).
    pub fn update_frame(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        view: &GpuView,
        changed_lights: Option<&[GpuLight]>,
        lists: &LightLists,
    ) {
        queue.write_buffer(&self.view, 0, bytemuck::bytes_of(view));
        for (i, o) in self.object_data.iter_mut().enumerate() {
            o.light_offset = lists.offsets[i];
            o.light_count = lists.counts[i];
        }
        queue.write_buffer(&self.objects, 0, bytemuck::cast_slice(&self.object_data));
        let mut grew = changed_lights.is_some_and(|l| self.lights.write(device, queue, bytemuck::cast_slice(l)));
        grew |= self.light_indices.write(device, queue, bytemuck::cast_slice(&lists.indices));
        if grew {
            self.rebuild_bind_group(device);
        }
    }

    /// Binds the environment's prefiltered maps (lights of kind
    /// `LightKind::Environment` read them).
    pub fn set_environment(&mut self, device: &wgpu::Device, maps: EnvironmentMaps) {
        self.environment = maps;
        self.rebuild_bind_group(device);
    }

    /// Uploads the shadow faces' view-projections, growing the atlas to hold them.
    pub fn update_shadows(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, plan: &ShadowPlan) {
        if self.shadow_atlas.update(device, queue, plan) {
            self.rebuild_bind_group(device);
        }
    }

    /// The scene bind group with another view uniform (`view`, a buffer of
    /// one [`GpuView`]): for passes that render the scene from a second
    /// camera in the same frame. Built anew each frame (the scene's own
    /// group is rebuilt when its buffers grow).
    pub fn bind_group_with_view(&self, device: &wgpu::Device, view: &wgpu::Buffer) -> wgpu::BindGroup {
        make_bind_group(
            device,
            &self.layout,
            [
                view,
                &self.objects,
                &self.vertices,
                &self.lights.buffer,
                &self.light_indices.buffer,
                &self.indices,
                &self.layers_buffer,
            ],
            [&self.albedo_view, &self.linear_maps_view],
            [&self.material_sampler, &self.sampler],
            &self.shadow_atlas,
            (&self.environment, &self.environment_sampler),
        )
    }

    fn rebuild_bind_group(&mut self, device: &wgpu::Device) {
        self.bind_group = make_bind_group(
            device,
            &self.layout,
            [
                &self.view,
                &self.objects,
                &self.vertices,
                &self.lights.buffer,
                &self.light_indices.buffer,
                &self.indices,
                &self.layers_buffer,
            ],
            [&self.albedo_view, &self.linear_maps_view],
            [&self.material_sampler, &self.sampler],
            &self.shadow_atlas,
            (&self.environment, &self.environment_sampler),
        );
    }
}

/// The material textures' sampler: repeating, trilinear, with up to
/// `anisotropy` anisotropic taps (wgpu asks every filter to be linear for
/// them, as here).
fn material_sampler(device: &wgpu::Device, anisotropy: u16) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(if anisotropy > 1 { "material textures (anisotropic)" } else { "material textures" }),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        anisotropy_clamp: anisotropy,
        ..Default::default()
    })
}

/// Every mesh's clusters, mesh after mesh.
struct SceneClusters {
    /// The GPU clusters (their triangle ranges into `triangles`).
    gpu: Vec<GpuCluster>,
    /// Their triangles (mesh-local triangle indices).
    triangles: Vec<u32>,
    /// The meshes' indices in that order (three per entry of `triangles`).
    indices: Vec<u32>,
    /// Per mesh its (first cluster, cluster count).
    ranges: Vec<(u32, u32)>,
}

/// Every mesh's clusters ([`SceneClusters`]). The lists hold at least one entry
/// (empty buffers cannot be bound). Built on the calling thread, not with
/// rayon: renderers are built inside rayon jobs whose pool may be blocked
/// waiting for them (the speedup experiment's `par_bridge` deadlocked so);
/// Sponza's 208,221 triangles take a few tens of milliseconds.
fn upload_clusters(scene: &Scene) -> SceneClusters {
    let (mut gpu, mut triangles, mut indices, mut ranges) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for mesh in &scene.meshes {
        let mc = mesh_memo::clusters(&mesh.positions, &mesh.indices);
        ranges.push((gpu.len() as u32, mc.clusters.len() as u32));
        let base = triangles.len() as u32;
        gpu.extend(mc.clusters.iter().map(|c| GpuCluster::new(c, base + c.first)));
        triangles.extend_from_slice(&mc.triangles);
        indices.extend(mc.triangles.iter().flat_map(|&t| &mesh.indices[3 * t as usize..3 * t as usize + 3]));
    }
    if gpu.is_empty() {
        gpu.push(GpuCluster::default());
    }
    if triangles.is_empty() {
        triangles.push(0);
    }
    if indices.is_empty() {
        indices.resize(3, 0);
    }
    SceneClusters { gpu, triangles, indices, ranges }
}

/// The view uniform for a camera and a target size (its light counts are
/// filled in by [`order_lights`]'s caller).
pub fn gpu_view(camera: &Camera, width: u32, height: u32) -> GpuView {
    let view_proj: Mat4 = camera.view_projection(width as f32 / height as f32);
    GpuView {
        view_proj,
        camera_position: camera.position.extend(1.0),
        viewport: Vec4::new(width as f32, height as f32, 1.0 / width as f32, 1.0 / height as f32),
        ..Default::default()
    }
}

/// The lights in the order the GPU holds them: ambient, directional and
/// environment lights first (every pipeline applies them everywhere), then
/// point and spot lights, each group in the given order. Returns them and
/// the number of global lights.
pub fn order_lights(lights: &[Light]) -> (Vec<Light>, u32) {
    let global = |l: &&Light| l.kind.is_global();
    let mut ordered: Vec<Light> = lights.iter().filter(global).cloned().collect();
    let globals = ordered.len() as u32;
    ordered.extend(lights.iter().filter(|l| !global(l)).cloned());
    (ordered, globals)
}

/// Group 0 of every pipeline (`scene_bindings.wgsl`, `shadows.wgsl`), seen
/// by every stage.
fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let stages = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let read = Binding::Storage { read_only: true };
    let array = wgpu::TextureViewDimension::D2Array;
    let albedo = Binding::Texture { sample: wgpu::TextureSampleType::Float { filterable: true }, dimension: array };
    let depth = Binding::Texture { sample: wgpu::TextureSampleType::Depth, dimension: array };
    // Bindings 0-7: view, objects, vertices, lights, light indices, albedo,
    // its sampler, indices; 8-11: shadow atlas, comparison sampler, shadow
    // faces, sun cascades; 12: linear maps (normal, metallic-roughness, occlusion);
    // 13: material layers; 14-17: the environment's specular and irradiance
    // maps, their sampler and the BRDF lookup table; 18: the isotropic
    // sampler of explicit-level samples.
    let bindings = [Binding::Uniform, read, read, read, read, albedo, Binding::Sampler, read];
    let shadows = [depth, Binding::ComparisonSampler, read, depth];
    let maps = [albedo, read];
    let env = environment::scene_bindings();
    let texel = [Binding::Sampler];
    bind_group_layout_for(device, "scene", stages, &[bindings.as_slice(), &shadows, &maps, &env, &texel].concat())
}

/// Buffers in binding order 0, 1, 2, 3, 4, 7, 13; the shadow maps are 8-11;
/// textures: albedo (5) and linear maps (12); the environment 14-17.
fn make_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffers: [&wgpu::Buffer; 7],
    textures: [&wgpu::TextureView; 2],
    [sampler, texel_sampler]: [&wgpu::Sampler; 2],
    shadows: &ShadowAtlas,
    (env, env_sampler): (&EnvironmentMaps, &wgpu::Sampler),
) -> wgpu::BindGroup {
    let [view, objects, vertices, lights, light_indices, indices, layers] = buffers;
    let [albedo, linear_maps] = textures;
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("scene"),
        layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: view.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: objects.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: vertices.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: lights.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: light_indices.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(albedo) },
            wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::Sampler(sampler) },
            wgpu::BindGroupEntry { binding: 7, resource: indices.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::TextureView(shadows.atlas_view()) },
            wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::Sampler(&shadows.sampler) },
            wgpu::BindGroupEntry { binding: 10, resource: shadows.faces_buffer().as_entire_binding() },
            wgpu::BindGroupEntry { binding: 11, resource: wgpu::BindingResource::TextureView(shadows.cascades_view()) },
            wgpu::BindGroupEntry { binding: 12, resource: wgpu::BindingResource::TextureView(linear_maps) },
            wgpu::BindGroupEntry { binding: 13, resource: layers.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 14, resource: wgpu::BindingResource::TextureView(env.specular_view()) },
            wgpu::BindGroupEntry { binding: 15, resource: wgpu::BindingResource::TextureView(env.irradiance_view()) },
            wgpu::BindGroupEntry { binding: 16, resource: wgpu::BindingResource::Sampler(env_sampler) },
            wgpu::BindGroupEntry { binding: 17, resource: wgpu::BindingResource::TextureView(env.brdf_lut_view()) },
            wgpu::BindGroupEntry { binding: 18, resource: wgpu::BindingResource::Sampler(texel_sampler) },
        ],
    })
}

/// Uploads the scene's textures as two 2D arrays of one size with full mip
/// chains (mips filtered on the CPU): colour (sRGB: every texture, plus a
/// white layer for untextured materials; base colour and emissive textures
/// are sampled from it at their texture's index) and linear maps (the
/// textures materials use as normal, metallic-roughness or occlusion maps,
/// once each even when a material packs occlusion, roughness and metallic
/// into one image). One size lets a pass sample all of them at one mip
/// level; one array each keeps the binding count constant in the number of
/// objects, which lavapipe (no binding arrays) requires.
/// Returns the colour array, its white layer, the linear array and each
/// texture's layer in it.
fn upload_textures(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
) -> (wgpu::Texture, u32, wgpu::Texture, Vec<Option<u32>>) {
    let size = scene
        .textures
        .iter()
        .map(|t| t.width.max(t.height))
        .max()
        .unwrap_or(1)
        .clamp(1, MAX_ALBEDO_SIZE)
        .next_power_of_two();
    let white = image::RgbaImage::from_pixel(size, size, image::Rgba([255; 4]));
    let colour: Vec<&crate::scene::Texture> = scene.textures.iter().collect();
    let albedo =
        upload_array(device, queue, "albedo array", wgpu::TextureFormat::Rgba8UnormSrgb, size, &colour, &white);
    let mut linear_layers = vec![None; scene.textures.len()];
    let mut linear: Vec<&crate::scene::Texture> = Vec::new();
    let used =
        scene.materials.iter().flat_map(|m| [m.normal_texture, m.metallic_roughness_texture, m.occlusion_texture]);
    for t in used.flatten() {
        if t < linear_layers.len() && linear_layers[t].is_none() {
            linear_layers[t] = Some(linear.len() as u32);
            linear.push(&scene.textures[t]);
        }
    }
    let flat = image::RgbaImage::from_pixel(size, size, image::Rgba([128, 128, 255, 255]));
    let linear_maps = upload_array(device, queue, "linear maps", wgpu::TextureFormat::Rgba8Unorm, size, &linear, &flat);
    (albedo, scene.textures.len() as u32, linear_maps, linear_layers)
}

/// Texture mip chains remembered at most (bytes): Sponza with detailed
/// textures holds about 300 MiB of them.
const MIP_CHAIN_BUDGET: usize = 512 << 20;

static MIP_CHAINS: Memo<Vec<image::RgbaImage>> =
    Memo::new(MIP_CHAIN_BUDGET, |chain| chain.iter().map(|level| level.as_raw().len()).sum());

/// The image of `width` x `height` RGBA8 texels `rgba8` resized to `size`
/// x `size` and its mip chain down to 1 x 1, each level filtered from the
/// one above (triangle filter), remembered by content ([`crate::memo`]): a
/// renderer built again over the same scene filters nothing.
fn mip_chain(width: u32, height: u32, rgba8: &[u8], size: u32) -> Arc<Vec<image::RgbaImage>> {
    let mut h = Fnv1a::default();
    h.write_pod(&[size, width, height]);
    h.write_pod(rgba8);
    MIP_CHAINS.get(h.finish(), || {
        let image = image::RgbaImage::from_raw(width, height, rgba8.to_vec()).expect("4 bytes a texel");
        let mut level = if (width, height) == (size, size) {
            image
        } else {
            image::imageops::resize(&image, size, size, FilterType::Triangle)
        };
        let mut chain = Vec::with_capacity(size.ilog2() as usize + 1);
        for mip in 1..=size.ilog2() {
            let next = image::imageops::resize(&level, size >> mip, size >> mip, FilterType::Triangle);
            chain.push(std::mem::replace(&mut level, next));
        }
        chain.push(level);
        chain
    })
}

/// One layer per texture (resized to `size`), then `last`.
fn upload_array(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    format: wgpu::TextureFormat,
    size: u32,
    textures: &[&crate::scene::Texture],
    last: &image::RgbaImage,
) -> wgpu::Texture {
    let mip_count = size.ilog2() + 1;
    let layers = textures.len() as u32 + 1;
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: layers },
        mip_level_count: mip_count,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let chains = textures
        .iter()
        .map(|t| {
            if t.rgba8.len() == 4 * t.width as usize * t.height as usize {
                mip_chain(t.width, t.height, &t.rgba8, size)
            } else {
                mip_chain(last.width(), last.height(), last.as_raw(), size)
            }
        })
        .chain(std::iter::once(mip_chain(last.width(), last.height(), last.as_raw(), size)));
    for (layer, chain) in chains.enumerate() {
        for (mip, img) in chain.iter().enumerate() {
            let s = img.width();
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: mip as u32,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: layer as u32 },
                    aspect: wgpu::TextureAspect::All,
                },
                img.as_raw(),
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * s), rows_per_image: Some(s) },
                wgpu::Extent3d { width: s, height: s, depth_or_array_layers: 1 },
            );
        }
    }
    texture
}
