//! Shade gathering (`gather.wgsl`): per pixel of the visibility buffer, the
//! same mip level as marking chose, filtered bilinearly from the atlas into
//! the HDR target (objects outside the atlas, and taps on pages the atlas
//! could not back, are shaded per pixel with the world grid's lights: by a
//! dispatch of their own after the record gather, [`FORWARD_LIST`], else in
//! the gather).

use super::mark::PIXEL_RECORD;
use super::resources::Resources;
use super::{DebugView, GatherFilter};
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
/// Defined with [`PIXEL_RECORD`] for the shaded image: the gather lists the
/// pixels to shade forward and `shade_forward_pixels` shades them
/// (a forward list), so that the lighting model is not compiled into it.
pub const FORWARD_LIST: &str = "FORWARD_LIST";
/// Defined with [`FORWARD_LIST`] where the gather filters bilinearly: the
/// cubic filters are not compiled into it either.
pub const BILINEAR_ONLY: &str = "BILINEAR_ONLY";
/// Defined where every chart island has a code of its own in the atlas's
/// alpha ([`ISLAND_CODES`]): the island filter reads a tap's island with its
/// shade (one load a tap), not from the triangle map (two, and the
/// triangle's island where it is not the pixel's triangle).
pub const ISLAND_IN_ALPHA: &str = "ISLAND_IN_ALPHA";
/// Chart islands a mesh may number that `island_code` (`objectspace.wgsl`)
/// tells apart: the normal half floats from bit pattern 1024 up.
pub const ISLAND_CODES: u32 = 0x7c00 - 1024;

/// The record gather's pixels to shade forward (objects outside the atlas,
/// taps on pages the atlas could not back): the gather lists them and
/// raises the dispatch of `shade_forward_pixels`, which shades them after it.
struct ForwardList {
    pipeline: wgpu::ComputePipeline,
    /// Their count, then each pixel (x | y << 16), room for every pixel.
    pixels: wgpu::Buffer,
    /// The forward dispatch (x, 1, 1), x raised by the gather.
    dispatch: wgpu::Buffer,
    /// Bound in its place for the forward dispatch, which reads `dispatch`
    /// as INDIRECT and so may not bind it as storage.
    stand_in: wgpu::Buffer,
}

pub struct GatherPass {
    pipeline: wgpu::ComputePipeline,
    io_layout: wgpu::BindGroupLayout,
    /// Per view: the atlas and triangle maps (read) and its HDR target (written).
    io: Vec<wgpu::BindGroup>,
    /// Per view: its HDR target, to bind the atlas again after a resize.
    outputs: Vec<wgpu::TextureView>,
    /// With [`super::GatherInput::Record`]: marking's pixel records.
    records: Option<wgpu::Buffer>,
    /// With the records, for the shaded image ([`FORWARD_LIST`]).
    forward: Option<ForwardList>,
    /// The forward dispatch's group 2 (view 0's, the stand-in bound).
    forward_io: Option<wgpu::BindGroup>,
}

impl GatherPass {
    /// The gather of `targets`' view (more with [`Self::add_view`]): with
    /// marking's pixel `records` it reads them; with them and the shaded
    /// image (`view`) it lists its forward pixels ([`FORWARD_LIST`]), and
    /// with `filter` bilinear compiles no cubic filter.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        targets: &Targets,
        grid: &LightGrid,
        (records, view, filter): (Option<&wgpu::Buffer>, DebugView, GatherFilter),
    ) -> Result<Self, ShaderError> {
        let mut bindings = vec![
            Binding::Texture {
                sample: wgpu::TextureSampleType::Float { filterable: false },
                dimension: wgpu::TextureViewDimension::D2Array,
            },
            Binding::StorageTexture { format: HDR_FORMAT, dimension: wgpu::TextureViewDimension::D2 },
            Binding::Texture { sample: wgpu::TextureSampleType::Uint, dimension: wgpu::TextureViewDimension::D2Array },
        ];
        let mut defs = Vec::new();
        if scene.island_numbers <= ISLAND_CODES {
            defs.push(ISLAND_IN_ALPHA);
        }
        if records.is_some() {
            bindings.push(Binding::Storage { read_only: true });
            defs.push(PIXEL_RECORD);
        }
        let listed = records.is_some() && view == DebugView::Shade;
        if listed {
            bindings.extend([Binding::Storage { read_only: false }, Binding::Storage { read_only: false }]);
            defs.push(FORWARD_LIST);
            if filter == GatherFilter::Bilinear {
                defs.push(BILINEAR_ONLY);
            }
        }
        let layout = bind_group_layout(device, "gather io", &bindings);
        let groups = [&scene.layout, &res.layout, &layout, &grid.layout];
        let pipeline = compute_pipeline_with(device, shaders, SHADER, &defs, "gather", &groups)?;
        let forward = if listed {
            let pipeline = compute_pipeline_with(device, shaders, SHADER, &defs, "shade_forward_pixels", &groups)?;
            let buffer = |label, size, usage| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage,
                    mapped_at_creation: false,
                })
            };
            let pixels = u64::from(targets.width) * u64::from(targets.height);
            let storage = wgpu::BufferUsages::STORAGE;
            let copy = wgpu::BufferUsages::COPY_DST;
            Some(ForwardList {
                pipeline,
                pixels: buffer("forward pixels", 4 * (1 + pixels), storage | copy),
                dispatch: buffer("forward dispatch", 12, storage | copy | wgpu::BufferUsages::INDIRECT),
                stand_in: buffer("forward dispatch stand-in", 12, storage),
            })
        } else {
            None
        };
        let records = records.cloned();
        let mut pass = Self {
            pipeline,
            io_layout: layout,
            io: Vec::new(),
            outputs: Vec::new(),
            records,
            forward,
            forward_io: None,
        };
        pass.add_view(device, res, &targets.hdr_view);
        Ok(pass)
    }

    /// Empties the forward list for a new frame (before the frame's commands).
    pub fn begin_frame(&self, queue: &wgpu::Queue) {
        if let Some(f) = &self.forward {
            queue.write_buffer(&f.pixels, 0, bytemuck::bytes_of(&0u32));
            queue.write_buffer(&f.dispatch, 0, bytemuck::cast_slice(&[0u32, 1, 1]));
        }
    }

    /// Adds the output of the next view: its HDR target.
    pub fn add_view(&mut self, device: &wgpu::Device, res: &Resources, hdr: &wgpu::TextureView) {
        self.io.push(self.io_group(device, res, hdr, false));
        if self.io.len() == 1 && self.forward.is_some() {
            self.forward_io = Some(self.io_group(device, res, hdr, true));
        }
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
        self.io = self.outputs.iter().map(|hdr| self.io_group(device, res, hdr, false)).collect();
        if self.forward.is_some() {
            self.forward_io = Some(self.io_group(device, res, &self.outputs[0], true));
        }
    }

    /// Group 2 of the gather writing `hdr` (`for_forward`: of the forward
    /// dispatch, the stand-in bound for its dispatch arguments).
    fn io_group(
        &self,
        device: &wgpu::Device,
        res: &Resources,
        hdr: &wgpu::TextureView,
        for_forward: bool,
    ) -> wgpu::BindGroup {
        let mut resources = vec![
            wgpu::BindingResource::TextureView(&res.physical.atlas_array),
            wgpu::BindingResource::TextureView(hdr),
            wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
        ];
        if let Some(records) = &self.records {
            resources.push(records.as_entire_binding());
        }
        if let Some(f) = &self.forward {
            let dispatch = if for_forward { &f.stand_in } else { &f.dispatch };
            resources.extend([f.pixels.as_entire_binding(), dispatch.as_entire_binding()]);
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
    if let (0, Some(f), Some(io)) = (view, &pass.forward, &pass.forward_io) {
        // Mostly no workgroup: a page the atlas could not back, an object outside it.
        cp.set_pipeline(&f.pipeline);
        cp.set_bind_group(2, io, &[]);
        cp.dispatch_workgroups_indirect(&f.dispatch, 0);
    }
}
