//! Shadow maps, shared by every pipeline: the [`crate::render::Renderer`]
//! renders them before the pipeline's passes, and the lighting model
//! (`shaders/shared/shadows.wgsl`) reads them, so every pipeline shades the
//! same shadows.
//!
//! Each shadowed light gets faces in one depth texture array, the shadow
//! atlas ([`ShadowAtlas`], bound in the scene bind group): a spot light one
//! perspective face over its cone, a point light (and a spot wider than
//! [`MAX_SPOT_HALF_ANGLE_DEG`]) six cube faces. Every layer is
//! [`FACE_SIZE`]² `Depth32Float`, reversed Z like the camera's depth (near
//! 1, far at the light's radius 0), whose float precision is then nearly
//! uniform over the range. The sun (the first directional light, when
//! [`SunView`] is given) gets cascades ([`cascades`]) in a second array of
//! [`cascades::CASCADE_SIZE`]² layers. Each face draws only its casters:
//! the objects whose bounds touch both the face's frustum and the light's
//! volume. With cluster culling ([`ShadowMaps::enable_culling`]) each face
//! draws only its casters' clusters inside its frustum ([`cull`]).

pub mod cascades;
pub mod cull;

use glam::{Mat4, Vec3};

use crate::render::frame::{Frame, scoped_render_pass};
use crate::render::scene_gpu::{GrowableBuffer, SceneGpu};
use crate::scene::{Aabb, Camera, Light, LightKind};
use crate::shaders::{ALPHA_MASK, ShaderError, ShaderLibrary, ShaderSource};
use cascades::{CASCADE_SIZE, CASCADES, cascade_view_projections};
use cull::ShadowCull;

use super::{Binding, bind_group, bind_group_layout_for};
use crate::render::culling::{Frustum, light_affects_aabb};

/// The depth-only raster shader of the shadow-map faces.
pub const SHADER: ShaderSource = ShaderSource::new("shadow_map.wgsl", include_str!("shadow_map.wgsl"));

/// Side of every shadow-map face, in texels. One texture array holds spot
/// and cube faces, so they share a size: 1024 keeps a 90-degree cube face
/// as sharp as a spot face of the same angle (512 would halve the point
/// lights' resolution for a quarter of their memory: 4 MiB per face here).
pub const FACE_SIZE: u32 = 1024;
/// Depth format of the atlas.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Spot lights whose cone is wider than this half-angle get six cube faces
/// (one perspective face would spread its texels too thin).
pub const MAX_SPOT_HALF_ANGLE_DEG: f32 = 60.0;
/// Texels every face reaches beyond its nominal edge, so that the 3x3
/// bilinear PCF kernel (2 texels) of a point near a cube face's edge, and a
/// lookup moved by the normal offset, stay inside the face.
const FACE_MARGIN_TEXELS: f32 = 3.0;
/// Bytes between two faces' view-projections in the pass's uniform buffer
/// (the largest `min_uniform_buffer_offset_alignment` wgpu allows).
const FACE_UNIFORM_STRIDE: u64 = 256;

/// When the shadow maps are rendered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShadowRefresh {
    /// A face again only when its view-projection changes (its light
    /// changed; for the sun's cascades, the camera moved): scene objects
    /// never move, so the other maps stay valid.
    #[default]
    OnChange,
    /// Every frame (what dynamic casters would need; the cost to measure).
    EveryFrame,
}

impl std::str::FromStr for ShadowRefresh {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "on-change" => Ok(Self::OnChange),
            "every-frame" => Ok(Self::EveryFrame),
            _ => Err(format!("'{s}' is not on-change or every-frame")),
        }
    }
}

/// Where a face is rendered: a layer of the atlas or of the sun's cascades.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceTarget {
    /// A layer of the atlas (spot and cube faces).
    Atlas(u32),
    /// A layer of the sun's cascades.
    Cascade(u32),
}

/// One shadow-map face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Face {
    /// Index of its light.
    pub light: u32,
    /// The light's view-projection (reversed Z).
    pub view_proj: Mat4,
    /// Where its map is rendered.
    pub target: FaceTarget,
}

/// The shadow faces of a frame's lights. A face's index is also its
/// view-projection's index in the faces buffer the lighting model reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadowPlan {
    /// Per light (in the given order): its first face and its number of
    /// faces (0 for lights that cast no shadow).
    pub lights: Vec<(u32, u32)>,
    /// Every face, lights' faces contiguous, in light order.
    pub faces: Vec<Face>,
    /// Layers used in the atlas and in the cascades.
    pub atlas_layers: u32,
    pub cascade_layers: u32,
    /// Shadow-casting lights left without shadows: the atlas was full.
    pub unshadowed: u32,
}

/// What the sun's cascades are fitted to: the camera and the scene's bounds.
#[derive(Clone, Copy, Debug)]
pub struct SunView<'a> {
    pub camera: &'a Camera,
    /// Width over height of the image.
    pub aspect: f32,
    /// Bounds of every object (the casters the cascades' depth must hold).
    pub scene: Aabb,
}

/// Which faces each shadow-casting light gets, and their view-projections:
/// point and spot lights marked `casts_shadows`, and with `sun`, the first
/// directional light (cascades). Ambient lights get none. The atlas holds
/// at most `max_layers` faces (the device's array-layer limit): lights
/// beyond it cast no shadow, and are counted in `unshadowed`.
pub fn plan(lights: &[Light], sun: Option<&SunView>, max_layers: u32) -> ShadowPlan {
    let mut plan = ShadowPlan::default();
    let sun_light = sun.and_then(|_| lights.iter().position(|l| l.kind == LightKind::Directional));
    for (i, l) in lights.iter().enumerate() {
        let first = plan.faces.len() as u32;
        let light = i as u32;
        let local = l.casts_shadows && matches!(l.kind, LightKind::Point | LightKind::Spot) && l.radius > 0.0;
        if local {
            let spot_half = l.cos_outer.clamp(-1.0, 1.0).acos();
            let views: Vec<Mat4> = if l.kind == LightKind::Spot && spot_half <= MAX_SPOT_HALF_ANGLE_DEG.to_radians() {
                vec![face_view_proj(l, l.direction, spot_half.tan())]
            } else {
                CUBE_DIRECTIONS.iter().map(|d| face_view_proj(l, *d, 1.0)).collect()
            };
            if plan.atlas_layers + views.len() as u32 > max_layers {
                plan.unshadowed += 1;
            } else {
                for view_proj in views {
                    plan.faces.push(Face { light, view_proj, target: FaceTarget::Atlas(plan.atlas_layers) });
                    plan.atlas_layers += 1;
                }
            }
        }
        if let Some(view) = sun.filter(|_| sun_light == Some(i)) {
            let cascades = cascade_view_projections(l.direction, view.camera, view.aspect, &view.scene);
            for (c, view_proj) in cascades.into_iter().enumerate() {
                plan.faces.push(Face { light, view_proj, target: FaceTarget::Cascade(c as u32) });
            }
            plan.cascade_layers = CASCADES as u32;
        }
        plan.lights.push((first, plan.faces.len() as u32 - first));
    }
    plan
}

/// Cube face directions, in the order `shadows.wgsl`'s `cube_face` numbers them.
const CUBE_DIRECTIONS: [Vec3; 6] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];

/// The view-projection of a square face looking along `direction` from the
/// light, whose half-width is `tan_half` at unit distance before the margin,
/// reversed Z from `radius / 1000` to the light's radius.
fn face_view_proj(light: &Light, direction: Vec3, tan_half: f32) -> Mat4 {
    let dir = direction.normalize_or(Vec3::NEG_Y);
    let up = if dir.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
    let view = Mat4::look_to_rh(light.position, dir, up);
    let size = FACE_SIZE as f32;
    let tan_half = tan_half * size / (size - 2.0 * FACE_MARGIN_TEXELS);
    let far = light.radius;
    // Swapping near and far gives reversed Z (near -> 1, far -> 0).
    let projection = Mat4::perspective_rh(2.0 * tan_half.atan(), 1.0, far, far * 1e-3);
    projection * view
}

/// A `Depth32Float` array of square layers: all layers for sampling, one
/// view per layer for rendering.
struct DepthArray {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    layers: Vec<wgpu::TextureView>,
}

impl DepthArray {
    /// One 1x1 layer that nothing renders: a valid binding before any face.
    fn placeholder(device: &wgpu::Device, label: &str) -> Self {
        let texture = ShadowAtlas::texture(device, label, 1, 1);
        Self { view: ShadowAtlas::array_view(&texture), texture, layers: Vec::new() }
    }

    fn new(device: &wgpu::Device, label: &str, size: u32, layers: u32) -> Self {
        let texture = ShadowAtlas::texture(device, label, size, layers);
        let layers = (0..layers)
            .map(|layer| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        Self { view: ShadowAtlas::array_view(&texture), texture, layers }
    }

    fn bytes(&self) -> u64 {
        let s = self.texture.size();
        s.width as u64 * s.height as u64 * s.depth_or_array_layers as u64 * 4
    }
}

/// The shadow maps and what the lighting model reads with them: the atlas
/// (one `Depth32Float` layer per spot or cube face), the sun's cascades, a
/// comparison sampler and the faces' view-projections. Part of the scene
/// bind group (bindings 8-11).
pub struct ShadowAtlas {
    atlas: DepthArray,
    cascades: DepthArray,
    /// The comparison sampler (`GreaterEqual`, bilinear).
    pub sampler: wgpu::Sampler,
    faces: GrowableBuffer,
    /// Counts re-creations of the textures (their contents are then lost).
    generation: u64,
}

impl ShadowAtlas {
    /// An atlas holding no face yet (1x1 placeholders: a valid bind group).
    pub fn new(device: &wgpu::Device) -> Self {
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow atlas"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::GreaterEqual),
            ..Default::default()
        });
        Self {
            atlas: DepthArray::placeholder(device, "shadow atlas"),
            cascades: DepthArray::placeholder(device, "sun cascades"),
            sampler,
            faces: GrowableBuffer::new(device, "shadow faces", 256),
            generation: 0,
        }
    }

    fn texture(device: &wgpu::Device, label: &str, size: u32, layers: u32) -> wgpu::Texture {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: layers },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            // Copied from by tests comparing maps.
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    }

    fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
        super::view_as(texture, wgpu::TextureViewDimension::D2Array)
    }

    /// Uploads the plan's view-projections, growing the arrays to hold its
    /// faces (they never shrink). Returns true when a resource was
    /// re-created, so that the scene bind group must be too.
    pub fn update(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, plan: &ShadowPlan) -> bool {
        let grow_atlas = plan.atlas_layers > self.atlas.layers.len() as u32;
        if grow_atlas {
            self.atlas = DepthArray::new(device, "shadow atlas", FACE_SIZE, plan.atlas_layers);
        }
        let grow_cascades = plan.cascade_layers > self.cascades.layers.len() as u32;
        if grow_cascades {
            self.cascades = DepthArray::new(device, "sun cascades", CASCADE_SIZE, plan.cascade_layers);
        }
        if grow_atlas || grow_cascades {
            self.generation += 1;
        }
        let matrices: Vec<Mat4> = plan.faces.iter().map(|f| f.view_proj).collect();
        let grew_faces = self.faces.write(device, queue, bytemuck::cast_slice(&matrices));
        grow_atlas || grow_cascades || grew_faces
    }

    /// The atlas's texture (one layer per spot or cube face), to read back.
    pub fn atlas_texture(&self) -> &wgpu::Texture {
        &self.atlas.texture
    }

    /// The atlas's layers, for sampling.
    pub fn atlas_view(&self) -> &wgpu::TextureView {
        &self.atlas.view
    }

    /// The sun's cascades, for sampling.
    pub fn cascades_view(&self) -> &wgpu::TextureView {
        &self.cascades.view
    }

    fn layer(&self, target: FaceTarget) -> &wgpu::TextureView {
        match target {
            FaceTarget::Atlas(layer) => &self.atlas.layers[layer as usize],
            FaceTarget::Cascade(layer) => &self.cascades.layers[layer as usize],
        }
    }

    /// The faces' view-projections (storage, one `mat4x4f` per face).
    pub fn faces_buffer(&self) -> &wgpu::Buffer {
        &self.faces.buffer
    }

    /// GPU bytes held: the depth layers and the face matrices.
    pub fn bytes(&self) -> u64 {
        self.atlas.bytes() + self.cascades.bytes() + self.faces.buffer.size()
    }
}

/// The shadow-map pass: its pipeline, the faces' view-projections as dynamic
/// uniforms, and each face's casters.
pub struct ShadowMaps {
    pipeline: wgpu::RenderPipeline,
    /// For the alpha-masked casters, when the scene has some.
    masked_pipeline: Option<wgpu::RenderPipeline>,
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
    uniforms: wgpu::Buffer,
    /// The faces of the last plan, and per face the objects it draws.
    faces: Vec<Face>,
    casters: Vec<Vec<u32>>,
    /// Faces whose map is out of date (new view-projection, or new texture).
    stale: Vec<bool>,
    /// The atlas generation the maps were rendered into.
    generation: u64,
    /// The faces' cluster culling and the pipelines drawing what it keeps
    /// (opaque, alpha-masked), once enabled (boxed: rarely built).
    cull: Option<Box<(ShadowCull, wgpu::RenderPipeline, Option<wgpu::RenderPipeline>)>>,
}

impl ShadowMaps {
    /// The pass's pipeline and bind group (over the scene's objects and
    /// vertices); no faces until [`ShadowMaps::set_plan`].
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, scene: &SceneGpu) -> Result<Self, ShaderError> {
        let stages = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let bindings = [
            Binding::Storage { read_only: true },
            Binding::Storage { read_only: true },
            Binding::DynamicUniform { size: size_of::<Mat4>() as u64 },
            // The base colour textures, for alpha-masked casters.
            Binding::Texture {
                sample: wgpu::TextureSampleType::Float { filterable: true },
                dimension: wgpu::TextureViewDimension::D2Array,
            },
            Binding::Sampler,
        ];
        let layout = bind_group_layout_for(device, "shadow maps", stages, &bindings);
        let pipeline = shadow_pipeline(device, shaders, &[&layout], false)?;
        // Alpha-masked casters get a fragment stage that cuts their depth
        // (kept apart: opaque casters draw with no fragment stage at all).
        let masked_pipeline =
            if scene.has_alpha_masks() { Some(shadow_pipeline(device, shaders, &[&layout], true)?) } else { None };
        let uniforms = Self::uniforms(device, 1);
        let group = Self::group(device, &layout, scene, &uniforms);
        Ok(Self {
            pipeline,
            masked_pipeline,
            layout,
            group,
            uniforms,
            faces: Vec::new(),
            casters: Vec::new(),
            stale: Vec::new(),
            generation: 0,
            cull: None,
        })
    }

    /// Culls the faces' casters by cluster from now on, in frames whose
    /// `scene.culling` is not none ([`cull`]); `scene` must draw its
    /// clusters indexed ([`crate::render::ClusterDraws::Indexed`]).
    pub fn enable_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
    ) -> Result<(), ShaderError> {
        if self.cull.is_some() {
            return Ok(());
        }
        let cull = ShadowCull::new(device, shaders, scene)?;
        let layouts = [&self.layout, &cull.draw_layout];
        let opaque = shadow_pipeline(device, shaders, &layouts, false)?;
        let masked =
            if self.masked_pipeline.is_some() { Some(shadow_pipeline(device, shaders, &layouts, true)?) } else { None };
        self.cull = Some(Box::new((cull, opaque, masked)));
        Ok(())
    }

    /// Whether the faces are culled by cluster ([`Self::enable_culling`]).
    pub fn culls(&self) -> bool {
        self.cull.is_some()
    }

    /// GPU bytes of the culling's buffers (0 without culling).
    pub fn cull_bytes(&self) -> u64 {
        self.cull.as_ref().map_or(0, |c| c.0.bytes())
    }

    /// Starts the read-back of the frame's cull counts. Call right after the submit.
    pub fn after_submit(&mut self) {
        if let Some(c) = &mut self.cull {
            c.0.after_submit();
        }
    }

    /// The cull counts of finished frames ([`ShadowCull::collect_counts`]).
    pub fn collect_counts(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, crate::render::Counters)> {
        self.cull.as_mut().map(|c| c.0.collect_counts(device, wait)).unwrap_or_default()
    }

    fn uniforms(device: &wgpu::Device, faces: usize) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadow face uniforms"),
            size: faces.max(1) as u64 * FACE_UNIFORM_STRIDE,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        scene: &SceneGpu,
        uniforms: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let face = wgpu::BufferBinding { buffer: uniforms, offset: 0, size: wgpu::BufferSize::new(64) };
        bind_group(
            device,
            "shadow maps",
            layout,
            &[
                scene.objects.as_entire_binding(),
                scene.vertices.as_entire_binding(),
                wgpu::BindingResource::Buffer(face),
                wgpu::BindingResource::TextureView(&scene.albedo_view),
                wgpu::BindingResource::Sampler(&scene.sampler),
            ],
        )
    }

    /// Takes this frame's plan: uploads its faces to the scene's atlas and to
    /// the pass's uniforms, and finds the casters of the faces that changed
    /// (objects never move, so a face whose view-projection is unchanged
    /// keeps its map).
    pub fn set_plan(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &mut SceneGpu,
        lights: &[Light],
        plan: &ShadowPlan,
    ) {
        if plan.faces == self.faces {
            return;
        }
        scene.update_shadows(device, queue, plan);
        let count = plan.faces.len();
        if count as u64 * FACE_UNIFORM_STRIDE > self.uniforms.size() {
            self.uniforms = Self::uniforms(device, count);
            self.group = Self::group(device, &self.layout, scene, &self.uniforms);
        }
        let mut bytes = vec![0u8; count * FACE_UNIFORM_STRIDE as usize];
        for (slot, face) in bytes.chunks_exact_mut(FACE_UNIFORM_STRIDE as usize).zip(&plan.faces) {
            slot[..64].copy_from_slice(bytemuck::bytes_of(&face.view_proj));
        }
        if !bytes.is_empty() {
            queue.write_buffer(&self.uniforms, 0, &bytes);
        }
        let new_textures = scene.shadow_atlas.generation != self.generation;
        self.generation = scene.shadow_atlas.generation;
        self.casters.resize(count, Vec::new());
        self.stale.resize(count, true);
        for (i, face) in plan.faces.iter().enumerate() {
            if new_textures || self.faces.get(i) != Some(face) {
                self.stale[i] = true;
                self.casters[i] = casters(face, &lights[face.light as usize], &scene.object_bounds);
            }
        }
        self.faces = plan.faces.clone();
    }

    /// Number of faces of the last plan.
    pub fn faces(&self) -> usize {
        self.faces.len()
    }
}

/// The objects whose bounds touch both the face's frustum and the light's
/// volume (only those can shadow a point the light reaches; the sun reaches
/// everything, and its cascades' depth range holds the whole scene).
fn casters(face: &Face, light: &Light, bounds: &[Aabb]) -> Vec<u32> {
    let frustum = Frustum::from_view_projection(face.view_proj);
    let touches = |b: &Aabb| frustum.intersects_aabb(b) && light_affects_aabb(light, b);
    bounds.iter().enumerate().filter(|(_, b)| touches(b)).map(|(i, _)| i as u32).collect()
}

/// One draw per caster, with the bound pipeline.
fn draw_casters<'a>(rp: &mut wgpu::RenderPass, scene: &SceneGpu, casters: impl Iterator<Item = &'a u32>) {
    for &object in casters {
        let d = scene.draws[object as usize];
        rp.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, object..object + 1);
    }
}

/// The shadow-map pipeline over `layouts`: depth only, or with the
/// [`ALPHA_MASK`] fragment stage that cuts alpha-masked casters; with a
/// second layout, the [`cull::CLUSTER_DRAW`] variant drawing culled clusters.
fn shadow_pipeline(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    layouts: &[&wgpu::BindGroupLayout],
    alpha_mask: bool,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    let mut defs: Vec<&str> = Vec::new();
    if alpha_mask {
        defs.push(ALPHA_MASK);
    }
    if layouts.len() > 1 {
        defs.push(cull::CLUSTER_DRAW);
    }
    let module = shaders.module_with(device, SHADER, &defs)?;
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("shadow maps"),
        bind_group_layouts: &groups,
        immediate_size: 0,
    });
    let fragment = alpha_mask.then(|| wgpu::FragmentState {
        module: &module,
        entry_point: Some("fs_alpha_mask"),
        compilation_options: Default::default(),
        targets: &[],
    });
    Ok(device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(if alpha_mask { "shadow maps (alpha mask)" } else { "shadow maps" }),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_shadow"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment,
        // Both sides cast: scenes hold open meshes and single quads.
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            // The lighting model biases its lookups (shadows.wgsl).
            bias: Default::default(),
        }),
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    }))
}

/// Reads: the casters' vertices and transforms. Writes: the layers of the
/// stale faces (all faces with `every_frame`), cleared to the far plane
/// first. Timed as `shadow maps`, each face as `shadow maps/face N` (N: its
/// index in the plan) or, for the sun, `shadow maps/cascade K`; with
/// cluster culling, the faces' culling pass before them as `shadow cull`.
pub fn shadow_maps(frame: &mut Frame, maps: &mut ShadowMaps, every_frame: bool) {
    let faces: Vec<usize> = (0..maps.faces.len()).filter(|i| every_frame || maps.stale[*i]).collect();
    if faces.is_empty() {
        return;
    }
    let culled = match &mut maps.cull {
        Some(c) => c.0.cull(frame, &maps.casters, &faces, maps.faces.len()),
        None => None,
    };
    let scene = frame.scene;
    let mut scope = frame.scope("shadow maps");
    for (k, &i) in faces.iter().enumerate() {
        let target = maps.faces[i].target;
        let depth = wgpu::RenderPassDepthStencilAttachment {
            view: scene.shadow_atlas.layer(target),
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        };
        let descriptor = wgpu::RenderPassDescriptor { depth_stencil_attachment: Some(depth), ..Default::default() };
        let label = match target {
            FaceTarget::Atlas(_) => format!("face {i}"),
            FaceTarget::Cascade(k) => format!("cascade {k}"),
        };
        let mut rp = scoped_render_pass(&mut scope, label, descriptor);
        rp.set_bind_group(0, &maps.group, &[(i as u64 * FACE_UNIFORM_STRIDE) as u32]);
        if let (Some(draws), Some(c)) = (&culled, &maps.cull) {
            let (cull, opaque, masked) = &**c;
            rp.set_pipeline(opaque);
            cull.draw_face(&mut rp, scene, &draws[k], false);
            if let Some(masked) = masked {
                rp.set_pipeline(masked);
                cull.draw_face(&mut rp, scene, &draws[k], true);
            }
            continue;
        }
        rp.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
        let casters = &maps.casters[i];
        let masked = maps.masked_pipeline.as_ref();
        rp.set_pipeline(&maps.pipeline);
        draw_casters(&mut rp, scene, casters.iter().filter(|&&o| masked.is_none() || !scene.masked[o as usize]));
        if let Some(masked) = masked {
            rp.set_pipeline(masked);
            draw_casters(&mut rp, scene, casters.iter().filter(|&&o| scene.masked[o as usize]));
        }
    }
    for i in faces {
        maps.stale[i] = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::lights::default_ambient;

    fn light(kind: LightKind, cos_outer: f32) -> Light {
        Light {
            kind,
            position: Vec3::new(1.0, 3.0, -2.0),
            direction: Vec3::new(0.2, -1.0, 0.1).normalize(),
            radius: 6.0,
            cos_outer,
            casts_shadows: true,
            ..default_ambient()
        }
    }

    /// Spots get one face, points and wide spots six, others none; faces of
    /// one light are contiguous.
    #[test]
    fn plan_gives_faces_per_light_kind() {
        let lights = [
            default_ambient(),
            light(LightKind::Point, 0.8),
            light(LightKind::Spot, 40f32.to_radians().cos()),
            Light { casts_shadows: false, ..light(LightKind::Point, 0.8) },
            light(LightKind::Spot, 80f32.to_radians().cos()),
        ];
        let p = plan(&lights, None, 2048);
        assert_eq!(p.lights, vec![(0, 0), (0, 6), (6, 1), (7, 0), (7, 6)]);
        assert_eq!((p.faces.len(), p.atlas_layers, p.cascade_layers), (13, 13, 0));
        assert!(p.faces[..6].iter().all(|f| f.light == 1));
        assert_eq!(p.faces[6].light, 2);
        assert_eq!(p.faces[12].target, FaceTarget::Atlas(12));
        // With room for 8 layers: the second cube no longer fits.
        let p = plan(&lights, None, 8);
        assert_eq!((p.lights[4], p.atlas_layers, p.unshadowed), ((7, 0), 7, 1));
    }

    /// With a sun view, the first directional light gets the cascades,
    /// after the faces of the lights before it.
    #[test]
    fn plan_gives_the_first_directional_light_cascades() {
        let sun = Light { kind: LightKind::Directional, ..default_ambient() };
        let lights = [sun, sun, light(LightKind::Spot, 0.8)];
        let camera = Camera {
            position: Vec3::new(0.0, 1.0, 5.0),
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: 1.0,
            near: 0.1,
            far: 50.0,
        };
        let view =
            SunView { camera: &camera, aspect: 1.0, scene: Aabb { min: Vec3::splat(-2.0), max: Vec3::splat(2.0) } };
        let p = plan(&lights, Some(&view), 2048);
        assert_eq!(p.lights, vec![(0, CASCADES as u32), (4, 0), (4, 1)]);
        assert_eq!((p.atlas_layers, p.cascade_layers), (1, CASCADES as u32));
        assert_eq!(p.faces[3].target, FaceTarget::Cascade(3));
        assert_eq!(p.faces[4].target, FaceTarget::Atlas(0));
        assert_eq!(plan(&lights, None, 2048).lights[0], (0, 0));
    }

    /// A point on a cube face's axis projects to the face's centre, reversed
    /// Z: near the light is near 1, the light's radius is 0; every direction
    /// lands inside the face `cube_face` would pick, with the margin.
    #[test]
    fn faces_cover_their_directions_in_reversed_z() {
        let l = light(LightKind::Point, 0.8);
        let p = plan(&[l], None, 2048);
        for (face, Face { view_proj: m, .. }) in p.faces.iter().enumerate() {
            let dir = CUBE_DIRECTIONS[face];
            let near = m.project_point3(l.position + dir * 0.01);
            let far = m.project_point3(l.position + dir * l.radius);
            assert!(near.x.abs() < 1e-4 && near.y.abs() < 1e-4, "{near}");
            assert!(near.z > 0.05 && near.z <= 1.0 && far.z.abs() < 1e-5, "{near} {far}");
            // The corner direction of the face (|x| = |y| = |z|) is inside, by the margin.
            let side = if dir.y.abs() > 0.9 { Vec3::X + Vec3::Z } else { Vec3::Y + dir.cross(Vec3::Y) };
            let corner = m.project_point3(l.position + (dir + side) * 2.0);
            let edge = 1.0 - 2.0 * FACE_MARGIN_TEXELS / FACE_SIZE as f32;
            assert!((corner.x.abs() - edge).abs() < 1e-3 && (corner.y.abs() - edge).abs() < 1e-3, "{corner}");
        }
    }

    #[test]
    fn refresh_parses() {
        assert_eq!("on-change".parse(), Ok(ShadowRefresh::OnChange));
        assert_eq!("every-frame".parse(), Ok(ShadowRefresh::EveryFrame));
        assert!("sometimes".parse::<ShadowRefresh>().is_err());
    }
}
