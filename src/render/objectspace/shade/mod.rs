//! Shade evaluation (`shade.wgsl`): one workgroup per queued tile, through
//! an indirect dispatch over the shade list (marking appends to it; the queue
//! is kept per physical tile: `objectspace.wgsl`); each texel finds its triangle in the triangle-index
//! map and runs the shared lighting model with the global lights and the
//! lights of its world-grid cell.

use super::resources::{ATLAS_FORMAT, Resources, SHADE_ARGS};
use crate::render::frame::{TimedComputePass, stage};
use crate::render::passes::light_grid::{LightGrid, READ_GROUP};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline_with};
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("shade.wgsl", include_str!("shade.wgsl"));
/// Defined for tiles of 8x8 texels with one point a texel (the default):
/// each workgroup lists the lights that reach its tile and its texels loop
/// over that list (`shade.wgsl`).
pub const TILE_LIGHTS: &str = "TILE_LIGHTS";

pub struct ShadePass {
    pipeline: wgpu::ComputePipeline,
    io_layout: wgpu::BindGroupLayout,
    /// The atlas as a storage texture, the triangle maps to read.
    outputs: wgpu::BindGroup,
}

impl ShadePass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        grid: &LightGrid,
        tile_lights: bool,
    ) -> Result<Self, ShaderError> {
        let dimension = wgpu::TextureViewDimension::D2Array;
        let layout = bind_group_layout(
            device,
            "shade io",
            &[
                Binding::StorageTexture { format: ATLAS_FORMAT, dimension },
                Binding::Texture { sample: wgpu::TextureSampleType::Uint, dimension },
            ],
        );
        let groups = [&scene.layout, &res.layout, &layout, &grid.layout];
        let defs: &[&str] = if tile_lights { &[TILE_LIGHTS] } else { &[] };
        let pipeline = compute_pipeline_with(device, shaders, SHADER, defs, "shade", &groups)?;
        let outputs = Self::outputs(device, &layout, res);
        Ok(Self { pipeline, io_layout: layout, outputs })
    }

    /// Binds the atlas again after a resize.
    pub fn rebind(&mut self, device: &wgpu::Device, res: &Resources) {
        self.outputs = Self::outputs(device, &self.io_layout, res);
    }

    fn outputs(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, res: &Resources) -> wgpu::BindGroup {
        bind_group(
            device,
            "shade io",
            layout,
            &[
                wgpu::BindingResource::TextureView(&res.physical.atlas_array),
                wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
            ],
        )
    }
}

/// Reads: the packed shade queue and its count, the triangle-index maps,
/// the scene, its lights and the world grid. Writes: the queued tiles of
/// the atlas.
pub fn shade_tiles(
    cp: &mut TimedComputePass,
    pass: &ShadePass,
    res: &Resources,
    scene: &wgpu::BindGroup,
    grid: &LightGrid,
) {
    let mut cp = stage(cp, "shade");
    cp.set_pipeline(&pass.pipeline);
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &pass.outputs, &[]);
    cp.set_bind_group(READ_GROUP, grid.bind_group(), &[]);
    cp.dispatch_workgroups_indirect(&res.dispatch, SHADE_ARGS);
}
