//! Bloom, in compute, on the HDR target before tone mapping: a chain of
//! half-size levels (13-tap down-sampling, Karis-weighted on the first
//! level), a 3x3-tent up-sampling chain adding each level into the one
//! above, and a composite back into the HDR target.
//!
//! The composite is a lerp, `hdr = mix(hdr, bloom, strength)` with `bloom`
//! the average of the levels' blurs, rather than `hdr += strength * bloom`:
//! it moves a fraction `strength` of the light into the glow instead of
//! adding light, so the image's mean brightness (and what an exposure means)
//! stays the same at any strength, and strength is a fraction in 0..=1.
//!
//! The up-sample and composite passes read and write their target in place
//! (`read_write` `Rgba16Float` storage), which saves a copy of the HDR
//! target; it needs `TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES` and an adapter
//! that offers it for that format ([`Bloom::supported`]; every Vulkan adapter
//! does).

use super::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::gpu::GpuContext;
use crate::render::frame::Frame;
use crate::render::targets::{HDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("bloom.wgsl", include_str!("bloom.wgsl"));

/// Levels of the chain at most: level 0 is half the image's size, level 5 a
/// 64th of it.
pub const MAX_LEVELS: u32 = 6;

/// The bloom chain and its passes, for one image size.
pub struct Bloom {
    down_first: wgpu::ComputePipeline,
    down: wgpu::ComputePipeline,
    up: wgpu::ComputePipeline,
    composite: wgpu::ComputePipeline,
    chain: wgpu::Texture,
    params: wgpu::Buffer,
    /// Down-sampling into level i (from the HDR target for i = 0).
    down_groups: Vec<wgpu::BindGroup>,
    /// Up-sampling level i + 1 into level i.
    up_groups: Vec<wgpu::BindGroup>,
    /// Level 0 into the HDR target.
    composite_group: wgpu::BindGroup,
}

impl Bloom {
    /// Whether the adapter can run bloom (read-write `Rgba16Float` storage).
    pub fn supported(ctx: &GpuContext) -> bool {
        ctx.has(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
            && ctx
                .adapter
                .get_texture_format_features(HDR_FORMAT)
                .flags
                .contains(wgpu::TextureFormatFeatureFlags::STORAGE_READ_WRITE)
    }

    /// A bloom chain for `targets` (as many levels as the size allows, up to
    /// [`MAX_LEVELS`]).
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, targets: &Targets) -> Result<Self, ShaderError> {
        let d2 = wgpu::TextureViewDimension::D2;
        let layout = bind_group_layout(
            device,
            "bloom",
            &[
                Binding::Texture { sample: wgpu::TextureSampleType::Float { filterable: true }, dimension: d2 },
                Binding::Sampler,
                Binding::StorageTextureReadWrite { format: HDR_FORMAT, dimension: d2 },
                Binding::Uniform,
            ],
        );
        let mut pipeline = |entry| compute_pipeline(device, shaders, SHADER, entry, &[&layout]);
        let (down_first, down, up, composite) =
            (pipeline("down_first")?, pipeline("down")?, pipeline("up")?, pipeline("composite")?);
        let levels = chain_levels(targets.width, targets.height);
        let chain = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("bloom chain"),
            size: wgpu::Extent3d {
                width: (targets.width / 2).max(1),
                height: (targets.height / 2).max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING,
            view_formats: &[],
        });
        let level: Vec<wgpu::TextureView> = (0..levels)
            .map(|i| {
                chain.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: i,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bloom params"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("bloom"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let group = |src: &wgpu::TextureView, dst: &wgpu::TextureView| {
            use wgpu::BindingResource as R;
            let resources =
                [R::TextureView(src), R::Sampler(&sampler), R::TextureView(dst), params.as_entire_binding()];
            bind_group(device, "bloom", &layout, &resources)
        };
        let down_groups = (0..levels as usize)
            .map(|i| group(if i == 0 { &targets.hdr_view } else { &level[i - 1] }, &level[i]))
            .collect();
        let up_groups = (0..levels as usize - 1).map(|i| group(&level[i + 1], &level[i])).collect();
        let composite_group = group(&level[0], &targets.hdr_view);
        Ok(Self { down_first, down, up, composite, chain, params, down_groups, up_groups, composite_group })
    }

    /// Levels in the chain.
    pub fn levels(&self) -> u32 {
        self.chain.mip_level_count()
    }

    /// Bytes the chain holds.
    pub fn memory(&self) -> u64 {
        let (w, h) = (self.chain.width() as u64, self.chain.height() as u64);
        (0..self.levels()).map(|i| (w >> i).max(1) * (h >> i).max(1) * 8).sum()
    }
}

/// Levels for a `width` x `height` image: halving until the smaller side
/// would drop below 1 texel, at least 1, at most [`MAX_LEVELS`].
fn chain_levels(width: u32, height: u32) -> u32 {
    width.min(height).max(1).ilog2().clamp(1, MAX_LEVELS)
}

/// Reads: `targets.hdr`. Writes: the chain, then `targets.hdr` =
/// lerp(`targets.hdr`, bloom, `strength`).
pub fn bloom(frame: &mut Frame, pass: &Bloom, strength: f32) {
    let levels = pass.levels();
    frame.queue.write_buffer(&pass.params, 0, bytemuck::cast_slice(&[strength, 1.0 / levels as f32, 0.0, 0.0]));
    let (w, h) = (pass.chain.width(), pass.chain.height());
    let groups = |i: u32| ((w >> i).max(1).div_ceil(8), (h >> i).max(1).div_ceil(8));
    let (image_w, image_h) = (frame.targets.width, frame.targets.height);
    let mut cp = frame.compute_pass("bloom");
    for (i, group) in pass.down_groups.iter().enumerate() {
        cp.set_pipeline(if i == 0 { &pass.down_first } else { &pass.down });
        cp.set_bind_group(0, group, &[]);
        let (x, y) = groups(i as u32);
        cp.dispatch_workgroups(x, y, 1);
    }
    cp.set_pipeline(&pass.up);
    for (i, group) in pass.up_groups.iter().enumerate().rev() {
        cp.set_bind_group(0, group, &[]);
        let (x, y) = groups(i as u32);
        cp.dispatch_workgroups(x, y, 1);
    }
    cp.set_pipeline(&pass.composite);
    cp.set_bind_group(0, &pass.composite_group, &[]);
    cp.dispatch_workgroups(image_w.div_ceil(8), image_h.div_ceil(8), 1);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_levels_follow_the_smaller_side() {
        assert_eq!(chain_levels(1920, 1080), MAX_LEVELS);
        assert_eq!(chain_levels(320, 180), MAX_LEVELS);
        assert_eq!(chain_levels(64, 40), 5);
        assert_eq!(chain_levels(32, 2), 1);
        assert_eq!(chain_levels(1, 1), 1);
    }
}
