//! Multi-pass forward shading, the classic study's baseline: a depth
//! pre-pass, then one additive pass per light over the objects its volume
//! reaches (point lights by sphere-box, spot lights by cone-box, ambient and
//! directional lights over every visible object), each fragment shading its
//! one light with the shared lighting model.
//!
//! All the light passes are recorded as one render pass with one draw per
//! (object, light) pair: the pairs are culled on the CPU into a storage
//! buffer, and each draw's `first_instance` is its pair's index, so the
//! shaders find their object and light with no per-draw uniform writes or
//! bind-group switches. Emission is one more "light" of each emissive object.

use std::collections::VecDeque;

use serde::Serialize;

use super::culling;
use super::frame::Frame;
use super::passes::depth_prepass::{DepthPrepass, depth_prepass};
use super::passes::{
    Binding, DepthMode, SceneRaster, bind_group, bind_group_layout_for, color_attachment, depth_attachment,
    scene_raster_pipeline_from,
};
use super::report::{Counters, PipelineReport};
use super::scene_gpu::{GrowableBuffer, SceneGpu};
use super::targets::HDR_FORMAT;
use super::{Pipeline, PipelineConfig, RenderError};
use crate::scene::{Aabb, Light};
use crate::shaders::{ShaderLibrary, ShaderSource, gpu_struct};

pub const SHADER: ShaderSource = ShaderSource::new("forward_multipass.wgsl", include_str!("forward_multipass.wgsl"));

/// `LightPair.light` of the pair that adds an object's emission (exported
/// to WGSL as `PAIR_EMISSION`).
pub const EMISSION: u32 = u32::MAX;

/// Settings of the multi-pass forward pipeline (none yet: the depth
/// pre-pass is part of the technique).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ForwardMultipassConfig {}

gpu_struct! {
    /// One draw of the light passes: an object lit by one light (or its
    /// emission when `light` is [`EMISSION`]).
    pub struct LightPair as "LightPair" {
        pub object: u32,
        /// Index into the frame's (GPU-ordered) lights, or [`EMISSION`].
        pub light: u32,
    }
}

pub struct ForwardMultipass {
    config: ForwardMultipassConfig,
    prepass: DepthPrepass,
    shade: wgpu::RenderPipeline,
    pairs_layout: wgpu::BindGroupLayout,
    pairs_buffer: GrowableBuffer,
    pairs_group: wgpu::BindGroup,
    builder: PairBuilder,
    /// Per object: whether it emits light (it gets an emission pair).
    emissive: Vec<bool>,
    /// Draws per recorded frame, until collected as counters.
    draws: VecDeque<(u64, usize)>,
}

impl ForwardMultipass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        config: ForwardMultipassConfig,
    ) -> Result<Self, RenderError> {
        let prepass = DepthPrepass::new(device, shaders, scene)?;
        let pairs_layout = bind_group_layout_for(
            device,
            "light pairs",
            wgpu::ShaderStages::VERTEX_FRAGMENT,
            &[Binding::Storage { read_only: true }],
        );
        let additive = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let raster = SceneRaster {
            shader: SHADER,
            vertex_entry: "vs_main",
            fragment: Some(("fs_main", HDR_FORMAT)),
            depth: DepthMode::EqualAfterPrepass,
            groups: &[Some(&pairs_layout)],
            blend: Some(wgpu::BlendState { color: additive, alpha: wgpu::BlendComponent::REPLACE }),
        };
        let shade = scene_raster_pipeline_from(device, shaders, scene, &raster)?;
        let pairs_buffer = GrowableBuffer::new(device, "light pairs", 64 * 1024);
        let pairs_group = bind_group(device, "light pairs", &pairs_layout, &[pairs_buffer.buffer.as_entire_binding()]);
        let emissive = scene.object_data.iter().map(|o| o.emissive.max_element() > 0.0).collect();
        Ok(Self {
            config,
            prepass,
            shade,
            pairs_layout,
            pairs_buffer,
            pairs_group,
            builder: PairBuilder::default(),
            emissive,
            draws: VecDeque::new(),
        })
    }
}

impl Pipeline for ForwardMultipass {
    fn encode(&mut self, frame: &mut Frame) {
        depth_prepass(frame, &self.prepass);
        let pairs = self.builder.build(frame.lights, &frame.scene.object_bounds, frame.visible, &self.emissive);
        if self.pairs_buffer.write(frame.device, frame.queue, bytemuck::cast_slice(pairs)) {
            self.pairs_group = bind_group(
                frame.device,
                "light pairs",
                &self.pairs_layout,
                &[self.pairs_buffer.buffer.as_entire_binding()],
            );
        }
        self.draws.push_back((frame.number, pairs.len()));
        light_passes(frame, &self.shade, &self.pairs_group, pairs);
    }

    fn uses_object_light_lists(&self) -> bool {
        false
    }

    fn collect_counters(&mut self, _device: &wgpu::Device, _wait: bool) -> Vec<(u64, Counters)> {
        self.draws.drain(..).map(|(frame, draws)| (frame, [("light_draws".to_string(), draws as f64)].into())).collect()
    }

    fn report(&self) -> PipelineReport {
        PipelineReport::new(PipelineConfig::ForwardMultipass(self.config))
            .memory("light pairs", self.pairs_buffer.buffer.size())
    }
}

/// Reads: the depth target (from the pre-pass), the scene and its lights,
/// and `pairs` (already uploaded to the buffer of `pairs_group`). Writes:
/// `targets.hdr`, cleared, then one additive draw per pair.
fn light_passes(
    frame: &mut Frame,
    pipeline: &wgpu::RenderPipeline,
    pairs_group: &wgpu::BindGroup,
    pairs: &[LightPair],
) {
    let (scene, targets) = (frame.scene, frame.targets);
    let color = [color_attachment(&targets.hdr_view, wgpu::Color::BLACK)];
    let mut rp = frame.render_pass("light passes", &color, Some(depth_attachment(targets, false)));
    rp.set_pipeline(pipeline);
    rp.set_bind_group(0, scene.bind_group(), &[]);
    rp.set_bind_group(1, pairs_group, &[]);
    rp.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
    for (i, pair) in pairs.iter().enumerate() {
        let d = scene.draws[pair.object as usize];
        let i = i as u32;
        rp.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, i..i + 1);
    }
}

/// Builds a frame's pairs, reusing its allocations from frame to frame.
#[derive(Default)]
struct PairBuilder {
    /// Object bounds with the invisible objects emptied (so that culling skips them).
    bounds: Vec<Aabb>,
    /// Per light: where its pairs start in `pairs` (then: where the next goes).
    starts: Vec<u32>,
    pairs: Vec<LightPair>,
}

impl PairBuilder {
    /// The draws of a frame, light by light in light order (each light's
    /// objects in object order), after the emission pairs of the visible
    /// emissive objects: so every pixel sums the same terms in the same
    /// order as single-pass forward. `lights` in GPU order; `visible` and
    /// `emissive` per object.
    fn build(&mut self, lights: &[Light], bounds: &[Aabb], visible: &[bool], emissive: &[bool]) -> &[LightPair] {
        self.bounds.clear();
        self.bounds.extend(bounds.iter().zip(visible).map(|(b, v)| if *v { *b } else { Aabb::EMPTY }));
        // The vectorised per-object culling, transposed to per-light lists.
        let lists = culling::lights_per_object(lights, &self.bounds, None);
        self.pairs.clear();
        let visible_emissive = (0..bounds.len()).filter(|&o| visible[o] && emissive[o]);
        self.pairs.extend(visible_emissive.map(|o| LightPair { object: o as u32, light: EMISSION }));
        self.starts.clear();
        self.starts.resize(lights.len(), 0);
        for &l in &lists.indices {
            self.starts[l as usize] += 1;
        }
        let mut next = self.pairs.len() as u32;
        for s in &mut self.starts {
            (*s, next) = (next, next + *s);
        }
        self.pairs.resize(next as usize, LightPair::default());
        for object in 0..bounds.len() {
            for &l in lists.lights_of(object) {
                let slot = &mut self.starts[l as usize];
                self.pairs[*slot as usize] = LightPair { object: object as u32, light: l };
                *slot += 1;
            }
        }
        &self.pairs
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::scene::LightKind;

    fn light(kind: LightKind, position: Vec3, direction: Vec3, radius: f32) -> Light {
        Light {
            kind,
            color: Vec3::ONE,
            intensity: 1.0,
            position,
            direction,
            radius,
            cos_inner: 0.95,
            cos_outer: 0.9,
            casts_shadows: false,
        }
    }

    /// The pairs are exactly the emissive visible objects, then, light by
    /// light, the visible objects each light reaches (`light_affects_aabb`).
    #[test]
    fn pairs_match_brute_force_light_by_light() {
        let mut state = 3u32;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let mut lights = vec![
            light(LightKind::Ambient, Vec3::ZERO, Vec3::NEG_Y, 0.0),
            light(LightKind::Directional, Vec3::ZERO, Vec3::NEG_Y, 0.0),
        ];
        for i in 0..200 {
            let kind = if i % 3 == 0 { LightKind::Spot } else { LightKind::Point };
            let p = Vec3::new(rnd() * 40.0 - 20.0, rnd() * 10.0, rnd() * 40.0 - 20.0);
            let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            lights.push(light(kind, p, d, 0.5 + 5.0 * rnd()));
        }
        let bounds: Vec<Aabb> = (0..40)
            .map(|_| {
                let c = Vec3::new(rnd() * 40.0 - 20.0, rnd() * 10.0, rnd() * 40.0 - 20.0);
                let h = Vec3::new(0.2 + 2.0 * rnd(), 0.2 + 2.0 * rnd(), 0.2 + 2.0 * rnd());
                Aabb { min: c - h, max: c + h }
            })
            .collect();
        let visible: Vec<bool> = (0..bounds.len()).map(|o| o % 5 != 1).collect();
        let emissive: Vec<bool> = (0..bounds.len()).map(|o| o % 7 == 0).collect();

        let mut expected: Vec<(u32, u32)> =
            (0..bounds.len()).filter(|&o| visible[o] && emissive[o]).map(|o| (o as u32, EMISSION)).collect();
        for (l, light) in lights.iter().enumerate() {
            for (o, b) in bounds.iter().enumerate() {
                if visible[o] && culling::light_affects_aabb(light, b) {
                    expected.push((o as u32, l as u32));
                }
            }
        }
        let mut builder = PairBuilder::default();
        // Twice: the second build reuses the first one's allocations.
        for _ in 0..2 {
            let pairs = builder.build(&lights, &bounds, &visible, &emissive);
            let got: Vec<(u32, u32)> = pairs.iter().map(|p| (p.object, p.light)).collect();
            assert_eq!(got, expected);
        }
        // Globals reach every visible object; some point or spot light reaches none.
        let visible_count = visible.iter().filter(|v| **v).count();
        assert_eq!(expected.iter().filter(|p| p.1 == 0).count(), visible_count);
        assert!((2..lights.len() as u32).any(|l| !expected.iter().any(|p| p.1 == l)));
        assert!(expected.iter().filter(|p| p.1 >= 2).count() > 40, "too few local pairs to test anything");
    }
}
