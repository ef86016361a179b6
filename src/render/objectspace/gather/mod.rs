//! Shade gathering (`gather.wgsl`): per pixel of the visibility buffer, the
//! same mip level as marking chose, filtered bilinearly from the atlas into
//! the HDR target (objects outside the atlas are shaded here per pixel, with
//! the world grid's lights).

use super::resources::Resources;
use crate::render::frame::Frame;
use crate::render::passes::light_grid::{LightGrid, READ_GROUP};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{HDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("gather.wgsl", include_str!("gather.wgsl"));

pub struct GatherPass {
    pipeline: wgpu::ComputePipeline,
    /// The atlas and triangle maps (read) and the HDR target (written).
    io: wgpu::BindGroup,
}

impl GatherPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        targets: &Targets,
        grid: &LightGrid,
    ) -> Result<Self, ShaderError> {
        let layout = bind_group_layout(
            device,
            "gather io",
            &[
                Binding::Texture {
                    sample: wgpu::TextureSampleType::Float { filterable: false },
                    dimension: wgpu::TextureViewDimension::D2Array,
                },
                Binding::StorageTexture { format: HDR_FORMAT, dimension: wgpu::TextureViewDimension::D2 },
                Binding::Texture {
                    sample: wgpu::TextureSampleType::Uint,
                    dimension: wgpu::TextureViewDimension::D2Array,
                },
            ],
        );
        let io = bind_group(
            device,
            "gather io",
            &layout,
            &[
                wgpu::BindingResource::TextureView(&res.atlas_array),
                wgpu::BindingResource::TextureView(&targets.hdr_view),
                wgpu::BindingResource::TextureView(&res.triangle_map_array),
            ],
        );
        let groups = [&scene.layout, &res.layout, &layout, &grid.layout];
        let pipeline = compute_pipeline(device, shaders, SHADER, "gather", &groups)?;
        Ok(Self { pipeline, io })
    }
}

/// Reads: the visibility buffer, the atlas and its table (and the tile
/// stamps for the debug views; the world grid for forward-only objects).
/// Writes: `targets.hdr`.
pub fn gather(frame: &mut Frame, pass: &GatherPass, res: &Resources, grid: &LightGrid) {
    let (w, h) = (frame.targets.width.div_ceil(8), frame.targets.height.div_ceil(8));
    let scene = frame.scene.bind_group();
    let mut cp = frame.compute_pass("gather");
    cp.set_pipeline(&pass.pipeline);
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &pass.io, &[]);
    cp.set_bind_group(READ_GROUP, grid.bind_group(), &[]);
    cp.dispatch_workgroups(w, h, 1);
}
