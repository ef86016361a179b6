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
//! uniform over the range. Each face draws only its casters: the objects
//! whose bounds touch both the face's frustum and the light's volume.

use glam::{Mat4, Vec3};

use crate::render::frame::Frame;
use crate::render::scene_gpu::{GrowableBuffer, SceneGpu};
use crate::scene::{Light, LightKind};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

use super::{Binding, bind_group, bind_group_layout_for};
use crate::render::culling::{Frustum, light_affects_aabb};

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
    /// Once, and again only when the lights change: scene objects never move,
    /// so maps of unchanged lights stay valid.
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

/// The shadow faces of a frame's lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadowPlan {
    /// Per light (in the given order): its first face and its number of
    /// faces (0 for lights that cast no shadow).
    pub lights: Vec<(u32, u32)>,
    /// Per face: its light's index and its view-projection.
    pub faces: Vec<(u32, Mat4)>,
}

/// Which faces each shadow-casting light gets, and their view-projections.
/// Directional and ambient lights get none.
pub fn plan(lights: &[Light]) -> ShadowPlan {
    let mut plan = ShadowPlan::default();
    for (i, l) in lights.iter().enumerate() {
        let first = plan.faces.len() as u32;
        let shadowed = l.casts_shadows && matches!(l.kind, LightKind::Point | LightKind::Spot) && l.radius > 0.0;
        if shadowed {
            let spot_half = l.cos_outer.clamp(-1.0, 1.0).acos();
            if l.kind == LightKind::Spot && spot_half <= MAX_SPOT_HALF_ANGLE_DEG.to_radians() {
                plan.faces.push((i as u32, face_view_proj(l, l.direction, spot_half.tan())));
            } else {
                plan.faces.extend(CUBE_DIRECTIONS.iter().map(|d| (i as u32, face_view_proj(l, *d, 1.0))));
            }
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

/// The shadow atlas and what the lighting model reads with it: one
/// `Depth32Float` layer per face, a comparison sampler and the faces'
/// view-projections. Part of the scene bind group (bindings 8-10).
pub struct ShadowAtlas {
    texture: wgpu::Texture,
    /// All layers, for sampling.
    pub view: wgpu::TextureView,
    /// One view per layer, for rendering.
    layers: Vec<wgpu::TextureView>,
    pub sampler: wgpu::Sampler,
    faces: GrowableBuffer,
}

impl ShadowAtlas {
    /// An atlas holding no face yet: one 1x1 layer, so the bind group is valid.
    pub fn new(device: &wgpu::Device) -> Self {
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow atlas"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::GreaterEqual),
            ..Default::default()
        });
        let texture = Self::texture(device, 1, 1);
        Self {
            view: Self::array_view(&texture),
            texture,
            layers: Vec::new(),
            sampler,
            faces: GrowableBuffer::new(device, "shadow faces", 256),
        }
    }

    fn texture(device: &wgpu::Device, size: u32, layers: u32) -> wgpu::Texture {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow atlas"),
            size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: layers },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
    }

    fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
        super::view_as(texture, wgpu::TextureViewDimension::D2Array)
    }

    /// Uploads the faces' view-projections, growing the atlas to hold them
    /// (it never shrinks). Returns true when a resource was re-created, so
    /// that the scene bind group must be too.
    pub fn update(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, faces: &[Mat4]) -> bool {
        let needed = faces.len() as u32;
        let grow = needed > self.layers.len() as u32;
        if grow {
            self.texture = Self::texture(device, FACE_SIZE, needed);
            self.view = Self::array_view(&self.texture);
            self.layers = (0..needed)
                .map(|layer| {
                    self.texture.create_view(&wgpu::TextureViewDescriptor {
                        dimension: Some(wgpu::TextureViewDimension::D2),
                        base_array_layer: layer,
                        array_layer_count: Some(1),
                        ..Default::default()
                    })
                })
                .collect();
        }
        let grew_faces = self.faces.write(device, queue, bytemuck::cast_slice(faces));
        grow || grew_faces
    }

    /// The faces' view-projections (storage, one `mat4x4f` per face).
    pub fn faces_buffer(&self) -> &wgpu::Buffer {
        &self.faces.buffer
    }

    /// GPU bytes held: the depth layers and the face matrices.
    pub fn bytes(&self) -> u64 {
        let s = self.texture.size();
        s.width as u64 * s.height as u64 * s.depth_or_array_layers as u64 * 4 + self.faces.buffer.size()
    }
}

/// The shadow-map pass: its pipeline, the faces' view-projections as dynamic
/// uniforms, and each face's casters.
pub struct ShadowMaps {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
    uniforms: wgpu::Buffer,
    /// Per face: the objects it draws.
    casters: Vec<Vec<u32>>,
}

impl ShadowMaps {
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, scene: &SceneGpu) -> Result<Self, ShaderError> {
        let stages = wgpu::ShaderStages::VERTEX;
        let bindings = [
            Binding::Storage { read_only: true },
            Binding::Storage { read_only: true },
            Binding::DynamicUniform { size: size_of::<Mat4>() as u64 },
        ];
        let layout = bind_group_layout_for(device, "shadow maps", stages, &bindings);
        let module = shaders.module(device, SHADER)?;
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow maps"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow maps"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_shadow"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: None,
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
        });
        let uniforms = Self::uniforms(device, 1);
        let group = Self::group(device, &layout, scene, &uniforms);
        Ok(Self { pipeline, layout, group, uniforms, casters: Vec::new() })
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
            ],
        )
    }

    /// Takes a new plan (the lights changed): uploads its faces to the scene's
    /// atlas and to the pass's uniforms, and finds each face's casters.
    pub fn set_plan(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &mut SceneGpu,
        lights: &[Light],
        plan: &ShadowPlan,
    ) {
        let matrices: Vec<Mat4> = plan.faces.iter().map(|(_, m)| *m).collect();
        scene.update_shadows(device, queue, &matrices);
        if matrices.len() as u64 * FACE_UNIFORM_STRIDE > self.uniforms.size() {
            self.uniforms = Self::uniforms(device, matrices.len());
            self.group = Self::group(device, &self.layout, scene, &self.uniforms);
        }
        let mut bytes = vec![0u8; matrices.len() * FACE_UNIFORM_STRIDE as usize];
        for (slot, m) in bytes.chunks_exact_mut(FACE_UNIFORM_STRIDE as usize).zip(&matrices) {
            slot[..64].copy_from_slice(bytemuck::bytes_of(m));
        }
        if !bytes.is_empty() {
            queue.write_buffer(&self.uniforms, 0, &bytes);
        }
        self.casters = plan
            .faces
            .iter()
            .map(|(light, m)| {
                let frustum = Frustum::from_view_projection(*m);
                let light = &lights[*light as usize];
                let bounds = scene.object_bounds.iter().enumerate();
                bounds
                    .filter(|(_, b)| frustum.intersects_aabb(b) && light_affects_aabb(light, b))
                    .map(|(i, _)| i as u32)
                    .collect()
            })
            .collect();
    }

    /// Number of faces the pass renders.
    pub fn faces(&self) -> usize {
        self.casters.len()
    }
}

/// Reads: the casters' vertices and transforms. Writes: every face's layer
/// of the shadow atlas (cleared to the far plane first). Timed as
/// `shadow maps`, each face as `shadow maps/face N`.
pub fn shadow_maps(frame: &mut Frame, maps: &ShadowMaps) {
    if maps.casters.is_empty() {
        return;
    }
    let scene = frame.scene;
    let mut scope = frame.scope("shadow maps");
    for (face, casters) in maps.casters.iter().enumerate() {
        let depth = wgpu::RenderPassDepthStencilAttachment {
            view: &scene.shadow_atlas.layers[face],
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        };
        let descriptor = wgpu::RenderPassDescriptor { depth_stencil_attachment: Some(depth), ..Default::default() };
        let mut rp = scope.scoped_render_pass(format!("face {face}"), descriptor);
        rp.set_pipeline(&maps.pipeline);
        rp.set_bind_group(0, &maps.group, &[(face as u64 * FACE_UNIFORM_STRIDE) as u32]);
        rp.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
        for &object in casters {
            let d = scene.draws[object as usize];
            rp.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, object..object + 1);
        }
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
        let p = plan(&lights);
        assert_eq!(p.lights, vec![(0, 0), (0, 6), (6, 1), (7, 0), (7, 6)]);
        assert_eq!(p.faces.len(), 13);
        assert!(p.faces[..6].iter().all(|(l, _)| *l == 1));
        assert_eq!(p.faces[6].0, 2);
    }

    /// A point on a cube face's axis projects to the face's centre, reversed
    /// Z: near the light is near 1, the light's radius is 0; every direction
    /// lands inside the face `cube_face` would pick, with the margin.
    #[test]
    fn faces_cover_their_directions_in_reversed_z() {
        let l = light(LightKind::Point, 0.8);
        let p = plan(&[l]);
        for (face, (_, m)) in p.faces.iter().enumerate() {
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
