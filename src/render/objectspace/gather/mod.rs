//! Shade gathering (`gather.wgsl`): per pixel of the visibility buffer, the
//! same mip level as marking chose, filtered bilinearly from the atlas into
//! the HDR target (objects outside the atlas are shaded here per pixel, with
//! the world grid's lights).

use super::mark::PIXEL_RECORD;
use super::resources::Resources;
use crate::render::frame::{TimedComputePass, stage};
use crate::render::passes::light_grid::{LightGrid, READ_GROUP};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline_with};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{HDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("gather.wgsl", include_str!("gather.wgsl"));
/// Defined for the debug entry `classify` (each pixel's class:
/// [`super::ObjectSpace::read_pixel_classes`]).
pub const PIXEL_CLASSES: &str = "PIXEL_CLASSES";

pub struct GatherPass {
    pipeline: wgpu::ComputePipeline,
    io_layout: wgpu::BindGroupLayout,
    /// Per view: the atlas and triangle maps (read) and its HDR target (written).
    io: Vec<wgpu::BindGroup>,
    /// Per view: its HDR target, to bind the atlas again after a resize.
    outputs: Vec<wgpu::TextureView>,
    /// With [`super::GatherInput::Record`]: marking's pixel records.
    records: Option<wgpu::Buffer>,
}

impl GatherPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        targets: &Targets,
        grid: &LightGrid,
        records: Option<&wgpu::Buffer>,
    ) -> Result<Self, ShaderError> {
        let mut bindings = vec![
            Binding::Texture {
                sample: wgpu::TextureSampleType::Float { filterable: false },
                dimension: wgpu::TextureViewDimension::D2Array,
            },
            Binding::StorageTexture { format: HDR_FORMAT, dimension: wgpu::TextureViewDimension::D2 },
            Binding::Texture { sample: wgpu::TextureSampleType::Uint, dimension: wgpu::TextureViewDimension::D2Array },
        ];
        let defs: &[&str] = if records.is_some() {
            bindings.push(Binding::Storage { read_only: true });
            &[PIXEL_RECORD]
        } else {
            &[]
        };
        let layout = bind_group_layout(device, "gather io", &bindings);
        let groups = [&scene.layout, &res.layout, &layout, &grid.layout];
        let pipeline = compute_pipeline_with(device, shaders, SHADER, defs, "gather", &groups)?;
        let records = records.cloned();
        let mut pass = Self { pipeline, io_layout: layout, io: Vec::new(), outputs: Vec::new(), records };
        pass.add_view(device, res, &targets.hdr_view);
        Ok(pass)
    }

    /// Adds the output of the next view: its HDR target.
    pub fn add_view(&mut self, device: &wgpu::Device, res: &Resources, hdr: &wgpu::TextureView) {
        self.io.push(self.io_group(device, res, hdr));
        self.outputs.push(hdr.clone());
    }

    /// The `classify` debug pass over view 0's pixels, writing into a
    /// buffer of `vec4u` per pixel.
    pub fn classify_pass(
        &self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        grid: &LightGrid,
        pixels: u64,
    ) -> Result<ClassifyPass, ShaderError> {
        let layout = bind_group_layout(
            device,
            "classify io",
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
                Binding::Storage { read_only: false },
            ],
        );
        let groups = [&scene.layout, &res.layout, &layout, &grid.layout];
        let pipeline = compute_pipeline_with(device, shaders, SHADER, &[PIXEL_CLASSES], "classify", &groups)?;
        let classes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pixel classes"),
            size: pixels * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Ok(ClassifyPass { pipeline, layout, classes, output: self.outputs[0].clone() })
    }

    /// Binds the atlas again after a resize.
    pub fn rebind(&mut self, device: &wgpu::Device, res: &Resources) {
        self.io = self.outputs.iter().map(|hdr| self.io_group(device, res, hdr)).collect();
    }

    fn io_group(&self, device: &wgpu::Device, res: &Resources, hdr: &wgpu::TextureView) -> wgpu::BindGroup {
        let mut resources = vec![
            wgpu::BindingResource::TextureView(&res.physical.atlas_array),
            wgpu::BindingResource::TextureView(hdr),
            wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
        ];
        if let Some(records) = &self.records {
            resources.push(records.as_entire_binding());
        }
        bind_group(device, "gather io", &self.io_layout, &resources)
    }
}

/// The `classify` debug pass (`gather.wgsl` with [`PIXEL_CLASSES`]).
pub struct ClassifyPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    /// Per pixel of view 0: `vec4u` ([`super::debug::PixelClass`]).
    pub classes: wgpu::Buffer,
    /// View 0's HDR target (bound, not written).
    output: wgpu::TextureView,
}

/// Records `classify` over view 0's pixels (`width` x `height`) into
/// `pass.classes`. Reads what the gather read, as the last frame left it;
/// writes nothing else. Bound afresh each time: the atlas may have been resized.
pub fn classify(
    encoder: &mut wgpu::CommandEncoder,
    device: &wgpu::Device,
    pass: &ClassifyPass,
    (res, scene, grid): (&Resources, &wgpu::BindGroup, &LightGrid),
    (width, height): (u32, u32),
) {
    let io = bind_group(
        device,
        "classify io",
        &pass.layout,
        &[
            wgpu::BindingResource::TextureView(&res.physical.atlas_array),
            wgpu::BindingResource::TextureView(&pass.output),
            wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
            pass.classes.as_entire_binding(),
        ],
    );
    let mut cp =
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("classify"), timestamp_writes: None });
    cp.set_pipeline(&pass.pipeline);
    res.bind_view(&mut cp, scene, 0);
    cp.set_bind_group(2, &io, &[]);
    cp.set_bind_group(READ_GROUP, grid.bind_group(), &[]);
    cp.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
}

/// Reads: the visibility buffer, the atlas and its table (and the tile
/// stamps for the debug views; the world grid for forward-only objects).
/// Writes: view `view`'s HDR target (`targets.hdr` for view 0). `scene`:
/// that view's scene group; `groups`: [`super::mark::pixel_groups`].
pub fn gather(
    cp: &mut TimedComputePass,
    pass: &GatherPass,
    (res, scene, grid): (&Resources, &wgpu::BindGroup, &LightGrid),
    view: usize,
    groups: [u32; 2],
) {
    let mut cp = stage(cp, if view == 0 { "gather" } else { "gather: other views" });
    cp.set_pipeline(&pass.pipeline);
    res.bind_view(&mut cp, scene, view);
    cp.set_bind_group(2, &pass.io[view], &[]);
    cp.set_bind_group(READ_GROUP, grid.bind_group(), &[]);
    cp.dispatch_workgroups(groups[0], groups[1], 1);
}
