//! Automatic exposure, in compute: the HDR frame's log-average luminance
//! (over the pixels any light reached) mapped to mid-grey, 0.18 (Reinhard's
//! key). Two dispatches, timed as one pass `exposure`: per 64x64 tile a sum
//! of log2 luminance and a pixel count, then one workgroup adds the tiles
//! and writes the exposure into the buffer the tone mapper reads. The frame
//! never waits for it on the CPU.

use super::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::frame::Frame;
use crate::render::targets::Targets;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("exposure.wgsl", include_str!("exposure.wgsl"));

/// Pixels per tile side (as in `exposure.wgsl`).
const TILE: u32 = 64;

/// The log-average luminance the exposure maps to (as in `exposure.wgsl`).
pub const KEY: f32 = 0.18;

/// How the HDR frame is scaled before tone mapping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exposure {
    /// A fixed multiplier (positive, finite).
    Fixed(f32),
    /// From the frame itself: its log-average luminance mapped to [`KEY`].
    Auto,
}

impl Default for Exposure {
    /// A fixed multiplier of 1 (the goldens' and the benchmarks').
    fn default() -> Self {
        Exposure::Fixed(1.0)
    }
}

/// The auto-exposure pipelines and the per-tile sums of one image size.
pub struct AutoExposure {
    sum_tiles: wgpu::ComputePipeline,
    average: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    groups: (u32, u32),
}

impl AutoExposure {
    /// A pass reading `targets.hdr` and writing its result into `exposure`,
    /// the tone mapper's exposure buffer (16 bytes, `STORAGE` usage).
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        targets: &Targets,
        exposure: &wgpu::Buffer,
    ) -> Result<Self, ShaderError> {
        let d2 = wgpu::TextureViewDimension::D2;
        let layout = bind_group_layout(
            device,
            "exposure",
            &[
                Binding::Texture { sample: wgpu::TextureSampleType::Float { filterable: false }, dimension: d2 },
                Binding::Storage { read_only: false },
                Binding::Storage { read_only: false },
            ],
        );
        let sum_tiles = compute_pipeline(device, shaders, SHADER, "sum_tiles", &[&layout])?;
        let average = compute_pipeline(device, shaders, SHADER, "average", &[&layout])?;
        let groups = (targets.width.div_ceil(TILE), targets.height.div_ceil(TILE));
        let tiles = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("exposure tiles"),
            size: (groups.0 * groups.1) as u64 * 8,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let bind_group = bind_group(
            device,
            "exposure",
            &layout,
            &[
                wgpu::BindingResource::TextureView(&targets.hdr_view),
                tiles.as_entire_binding(),
                exposure.as_entire_binding(),
            ],
        );
        Ok(Self { sum_tiles, average, bind_group, groups })
    }
}

/// Reads: `targets.hdr`. Writes: the tone mapper's exposure.
pub fn auto_exposure(frame: &mut Frame, pass: &AutoExposure) {
    let mut cp = frame.compute_pass("exposure");
    cp.set_bind_group(0, &pass.bind_group, &[]);
    cp.set_pipeline(&pass.sum_tiles);
    cp.dispatch_workgroups(pass.groups.0, pass.groups.1, 1);
    cp.set_pipeline(&pass.average);
    cp.dispatch_workgroups(1, 1, 1);
}
