//! The atlas page view (`atlas_view.wgsl`, `--view atlas-pages`): one mip
//! level of one object's virtual shading texture drawn over the frame after
//! the gather, each texel looked up through the two-level page table. Backed
//! pages show their shades, pages with no physical page a dark checker: what
//! the frame's marking and paging left in the atlas, live, with no read-back.

use super::atlas::AtlasLayout;
use super::resources::Resources;
use crate::render::frame::Frame;
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{HDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const SHADER: ShaderSource = ShaderSource::new("atlas_view.wgsl", include_str!("atlas_view.wgsl"));

/// Which object's shading texture the view shows, and which mip level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct AtlasPages {
    /// Scene object index (as `shadespace charts` lists them).
    pub object: usize,
    /// Mip level, 0 the finest.
    pub level: usize,
}

/// Why an object's level cannot be shown.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AtlasPagesError {
    #[error("--atlas-object {object}: the scene has {count} objects (0 to {})", count.saturating_sub(1))]
    NoObject { object: usize, count: usize },
    #[error("--atlas-object {0}: the object is shaded forward and has no shading texture")]
    ForwardOnly(usize),
    #[error("--atlas-level {level}: object {object}'s shading texture has {levels} levels (0 to {})", levels - 1)]
    NoLevel { object: usize, level: usize, levels: usize },
}

impl AtlasPages {
    /// `Ok` when `layout` has this object's level.
    pub fn check(&self, layout: &AtlasLayout) -> Result<(), AtlasPagesError> {
        let Some(entry) = layout.objects.get(self.object) else {
            return Err(AtlasPagesError::NoObject { object: self.object, count: layout.objects.len() });
        };
        let Some(atlas) = entry else { return Err(AtlasPagesError::ForwardOnly(self.object)) };
        if self.level >= atlas.levels.len() {
            return Err(AtlasPagesError::NoLevel {
                object: self.object,
                level: self.level,
                levels: atlas.levels.len(),
            });
        }
        Ok(())
    }
}

gpu_struct! {
    /// The object and level shown (`AtlasPages` in `atlas_view.wgsl`).
    pub struct GpuAtlasPages as "AtlasPages" {
        pub object: u32,
        pub level: u32,
        pub pad_a: u32,
        pub pad_b: u32,
    }
}

pub struct AtlasViewPass {
    pipeline: wgpu::ComputePipeline,
    /// The object and level, rewritten every frame (16 bytes).
    shown: wgpu::Buffer,
    io_layout: wgpu::BindGroupLayout,
    /// The HDR target, to bind the atlas again after a resize.
    output: wgpu::TextureView,
    /// The atlas (read), the HDR target (written) and `shown`.
    io: wgpu::BindGroup,
}

impl AtlasViewPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        targets: &Targets,
    ) -> Result<Self, ShaderError> {
        let layout = bind_group_layout(
            device,
            "atlas view io",
            &[
                Binding::Texture {
                    sample: wgpu::TextureSampleType::Float { filterable: false },
                    dimension: wgpu::TextureViewDimension::D2Array,
                },
                Binding::StorageTexture { format: HDR_FORMAT, dimension: wgpu::TextureViewDimension::D2 },
                Binding::Storage { read_only: true },
            ],
        );
        // Storage rather than uniform, like the view slot: lavapipe crashed
        // on a second uniform buffer beside the params (objectspace.wgsl).
        let shown = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("atlas view object and level"),
            size: size_of::<GpuAtlasPages>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipeline = compute_pipeline(device, shaders, SHADER, "atlas_view", &[&scene.layout, &res.layout, &layout])?;
        let output = targets.hdr_view.clone();
        let io = Self::io(device, &layout, res, &output, &shown);
        Ok(Self { pipeline, shown, io_layout: layout, output, io })
    }

    /// Binds the atlas again after a resize.
    pub fn rebind(&mut self, device: &wgpu::Device, res: &Resources) {
        self.io = Self::io(device, &self.io_layout, res, &self.output, &self.shown);
    }

    fn io(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        res: &Resources,
        output: &wgpu::TextureView,
        shown: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        bind_group(
            device,
            "atlas view io",
            layout,
            &[
                wgpu::BindingResource::TextureView(&res.physical.atlas_array),
                wgpu::BindingResource::TextureView(output),
                shown.as_entire_binding(),
            ],
        )
    }
}

/// Reads: the atlas, its table and the page table (as this frame's paging
/// left them). Writes: all of `targets.hdr`, `pages`'s level over the frame.
pub fn draw_atlas_pages(frame: &mut Frame, pass: &AtlasViewPass, res: &Resources, pages: AtlasPages) {
    let shown = GpuAtlasPages { object: pages.object as u32, level: pages.level as u32, pad_a: 0, pad_b: 0 };
    frame.queue.write_buffer(&pass.shown, 0, bytemuck::bytes_of(&shown));
    let (w, h) = (frame.targets.width.div_ceil(8), frame.targets.height.div_ceil(8));
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("atlas view");
    cp.set_pipeline(&pass.pipeline);
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &pass.io, &[]);
    cp.dispatch_workgroups(w, h, 1);
}
