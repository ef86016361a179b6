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
//!
//! Alpha-blended objects follow in a render pass of their own, object by
//! object back to front (`passes::blended::back_to_front`): each one's
//! emission pair (every blended object has one) composites its emission
//! times its opacity "over" the frame, scaling what is behind by one minus
//! the opacity, and then each of its light pairs adds its light times the
//! opacity: the same sum as one forward fragment, one light at a time.

use std::collections::VecDeque;

use serde::Serialize;

use super::culling;
use super::frame::Frame;
use super::passes::background::{Background, Coverage, background};
use super::passes::blended::{OVER, back_to_front, blended_pipeline, over_frame_attachment};
use super::passes::depth_prepass::{DepthPrepass, depth_prepass};
use super::passes::{
    Binding, DepthMode, SceneRaster, SidedPipelines, bind_group, bind_group_layout_for, depth_attachment,
    depth_attachment_read_only, hdr_attachment_then, scene_raster_pipeline_from,
};
use super::report::{Counters, PipelineReport};
use super::scene_gpu::{GrowableBuffer, SceneGpu};
use super::targets::{HDR_FORMAT, Targets};
use super::{Pipeline, PipelineConfig, RenderError};
use glam::{Mat4, Vec2, Vec3};

use crate::scene::{Aabb, Light, LightKind};
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
    shade: SidedPipelines,
    pairs_layout: wgpu::BindGroupLayout,
    pairs_buffer: GrowableBuffer,
    pairs_group: wgpu::BindGroup,
    builder: PairBuilder,
    /// Per object: whether it emits light (it gets an emission pair).
    emissive: Vec<bool>,
    /// Draws per recorded frame, until collected as counters.
    draws: VecDeque<(u64, usize)>,
    /// For scenes with an environment: drawn where the opaque objects leave background.
    background: Option<Background>,
    /// For scenes with alpha-blended objects: the pipelines of their pairs.
    blended: Option<BlendedPipelines>,
}

/// The pipelines drawing an alpha-blended object's pairs: its emission
/// pair composited [`OVER`] the frame, then its light pairs added.
struct BlendedPipelines {
    over: wgpu::RenderPipeline,
    add: wgpu::RenderPipeline,
}

impl ForwardMultipass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        config: ForwardMultipassConfig,
    ) -> Result<Self, RenderError> {
        let samples = targets.samples;
        let prepass = DepthPrepass::new(device, shaders, scene, samples)?;
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
            fragment: Some(("fs_main", &[HDR_FORMAT])),
            depth: DepthMode::EqualAfterPrepass,
            groups: &[Some(&pairs_layout)],
            blend: Some(wgpu::BlendState { color: additive, alpha: wgpu::BlendComponent::REPLACE }),
            samples,
        };
        let shade = scene_raster_pipeline_from(device, shaders, scene, &raster)?.for_every_object();
        let pairs_buffer = GrowableBuffer::new(device, "light pairs", 64 * 1024);
        let pairs_group = bind_group(device, "light pairs", &pairs_layout, &[pairs_buffer.buffer.as_entire_binding()]);
        let emissive = scene.emits.clone();
        let blended = if scene.has_blended() {
            let groups = [Some(&pairs_layout)];
            // Light pairs add their premultiplied colour and keep the alpha.
            let keep = wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            };
            let add = wgpu::BlendState { color: additive, alpha: keep };
            Some(BlendedPipelines {
                over: blended_pipeline(device, shaders, scene, targets, SHADER, &groups, OVER)?,
                add: blended_pipeline(device, shaders, scene, targets, SHADER, &groups, add)?,
            })
        } else {
            None
        };
        let background = Background::new(device, shaders, scene, targets, Coverage::Depth, blended.is_some())?;
        Ok(Self {
            background,
            blended,
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
        let opaque = self.builder.build(frame.lights, &frame.scene.object_bounds, frame.visible, &self.emissive).len();
        let order = match self.blended {
            Some(_) => back_to_front(frame.scene, frame.camera, frame.view.view_proj),
            None => Vec::new(),
        };
        let pairs = self.builder.add_blended(frame.lights, &frame.scene.object_bounds, &order);
        if self.pairs_buffer.write(frame.device, frame.queue, bytemuck::cast_slice(pairs)) {
            self.pairs_group = bind_group(
                frame.device,
                "light pairs",
                &self.pairs_layout,
                &[self.pairs_buffer.buffer.as_entire_binding()],
            );
        }
        self.draws.push_back((frame.number, pairs.len()));
        light_passes(frame, &self.shade, &self.pairs_group, &pairs[..opaque], self.blended.is_some());
        if let Some(pass) = &self.background {
            background(frame, pass);
        }
        if let Some(blended) = &self.blended {
            blended_light_passes(frame, blended, &self.pairs_group, pairs, opaque);
        }
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
/// `targets.hdr`, cleared, then one additive draw per pair, each light's
/// draws scissored to the screen rectangle its volume covers (under MSAA
/// into the samples, which the one pass resolves at its end, or with
/// `blended_after` leaves for the blended pass to resolve).
fn light_passes(
    frame: &mut Frame,
    pipelines: &SidedPipelines,
    pairs_group: &wgpu::BindGroup,
    pairs: &[LightPair],
    blended_after: bool,
) {
    let (scene, targets, lights) = (frame.scene, frame.targets, frame.lights);
    let size = (targets.width, targets.height);
    let view_proj = frame.view.view_proj;
    let color = [hdr_attachment_then(targets, blended_after)];
    let mut rp = frame.render_pass("light passes", &color, Some(depth_attachment(targets, false)));
    rp.set_bind_group(0, scene.bind_group(), &[]);
    rp.set_bind_group(1, pairs_group, &[]);
    rp.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
    let mut current = None;
    let mut rect = None;
    let mut sided = None;
    for (i, pair) in pairs.iter().enumerate() {
        if current != Some(pair.light) {
            current = Some(pair.light);
            rect = match lights.get(pair.light as usize) {
                Some(l) if matches!(l.kind, LightKind::Point | LightKind::Spot) => {
                    light_scissor(l.position, l.radius, view_proj, size)
                }
                _ => Some(ScissorRect { x: 0, y: 0, width: size.0, height: size.1 }),
            };
            if let Some(r) = rect {
                rp.set_scissor_rect(r.x, r.y, r.width, r.height);
            }
        }
        if rect.is_none() {
            continue; // the light's volume is off screen
        }
        // Single- and double-sided objects by pipelines of their cull modes.
        let single = scene.single_sided[pair.object as usize];
        if sided != Some(single) {
            sided = Some(single);
            if let Some(p) = &pipelines[usize::from(single)] {
                rp.set_pipeline(p);
            }
        }
        let d = scene.draws[pair.object as usize];
        let i = i as u32;
        rp.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, i..i + 1);
    }
}

/// Reads: the opaque frame and its depth, the scene and its lights, and
/// `pairs` (uploaded to the buffer of `pairs_group`), whose pairs from
/// `first` on are the blended objects', object by object (each object's
/// emission pair first). Writes: those pairs over the frame, each emission
/// pair composited over it and each light pair added (under MSAA into the
/// samples, resolved at the end of the pass).
fn blended_light_passes(
    frame: &mut Frame,
    pipelines: &BlendedPipelines,
    pairs_group: &wgpu::BindGroup,
    pairs: &[LightPair],
    first: usize,
) {
    let (scene, targets) = (frame.scene, frame.targets);
    if pairs.len() == first && targets.hdr_msaa_view.is_none() {
        return;
    }
    let color = [over_frame_attachment(targets)];
    let mut rp = frame.render_pass("blended light passes", &color, Some(depth_attachment_read_only(targets)));
    rp.set_bind_group(0, scene.bind_group(), &[]);
    rp.set_bind_group(1, pairs_group, &[]);
    rp.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
    let mut over = None;
    for (i, pair) in pairs.iter().enumerate().skip(first) {
        let emission = pair.light == EMISSION;
        if over != Some(emission) {
            over = Some(emission);
            rp.set_pipeline(if emission { &pipelines.over } else { &pipelines.add });
        }
        let d = scene.draws[pair.object as usize];
        let i = i as u32;
        rp.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, i..i + 1);
    }
}

/// A rectangle of the target, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct ScissorRect {
    x: u32,
    y: u32,
    width: u32,
    height: u32,
}

/// The pixels a light's sphere (`center`, `radius`) may cover: the projected
/// corners of its bounding box, conservatively (the whole target when the
/// box crosses the eye plane); `None` when it is wholly behind the eye or
/// off screen. Classic multi-pass forward scissors each light this way, so
/// a small light shades only its own rectangle of each object it reaches.
fn light_scissor(center: Vec3, radius: f32, view_proj: Mat4, (w, h): (u32, u32)) -> Option<ScissorRect> {
    let full = ScissorRect { x: 0, y: 0, width: w, height: h };
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    let mut behind = 0u32;
    for i in 0..8 {
        let sign = Vec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        );
        let clip = view_proj * (center + sign * radius).extend(1.0);
        if clip.w <= 1e-5 {
            behind += 1;
            continue;
        }
        let ndc = clip.truncate().truncate() / clip.w;
        (lo, hi) = (lo.min(ndc), hi.max(ndc));
    }
    match behind {
        8 => return None,
        1.. => return Some(full),
        0 => {}
    }
    // NDC y points up, pixel y down.
    let x0 = ((lo.x * 0.5 + 0.5) * w as f32).floor().clamp(0.0, w as f32) as u32;
    let x1 = ((hi.x * 0.5 + 0.5) * w as f32).ceil().clamp(0.0, w as f32) as u32;
    let y0 = ((0.5 - hi.y * 0.5) * h as f32).floor().clamp(0.0, h as f32) as u32;
    let y1 = ((0.5 - lo.y * 0.5) * h as f32).ceil().clamp(0.0, h as f32) as u32;
    (x1 > x0 && y1 > y0).then_some(ScissorRect { x: x0, y: y0, width: x1 - x0, height: y1 - y0 })
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

    /// Appends the pairs of the blended objects `order` (back to front) to
    /// the last [`PairBuilder::build`]'s, object by object: each one's
    /// emission pair, then a pair per light reaching it (in light order);
    /// returns every pair.
    fn add_blended(&mut self, lights: &[Light], bounds: &[Aabb], order: &[u32]) -> &[LightPair] {
        if order.is_empty() {
            return &self.pairs;
        }
        self.bounds.clear();
        self.bounds.resize(bounds.len(), Aabb::EMPTY);
        for &o in order {
            self.bounds[o as usize] = bounds[o as usize];
        }
        let lists = culling::lights_per_object(lights, &self.bounds, None);
        for &object in order {
            self.pairs.push(LightPair { object, light: EMISSION });
            self.pairs.extend(lists.lights_of(object as usize).iter().map(|&light| LightPair { object, light }));
        }
        &self.pairs
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;

    /// A light in view gets a rectangle around its projected centre that
    /// shrinks with distance; one behind the eye or off to the side gets
    /// none; one around the eye gets the whole target.
    #[test]
    fn scissor_covers_the_light_and_culls_what_is_off_screen() {
        let camera = Camera {
            position: Vec3::ZERO,
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: 100.0,
        };
        let size = (320, 180);
        let vp = camera.view_projection(320.0 / 180.0);
        let near = light_scissor(Vec3::new(0.0, 0.0, -5.0), 1.0, vp, size).unwrap();
        let far = light_scissor(Vec3::new(0.0, 0.0, -20.0), 1.0, vp, size).unwrap();
        for r in [near, far] {
            assert!(r.x < 160 && r.x + r.width > 160 && r.y < 90 && r.y + r.height > 90, "{r:?}");
        }
        assert!(far.width < near.width && far.height < near.height, "{near:?} {far:?}");
        assert!(near.width < 320, "a small light does not cover the screen: {near:?}");
        assert_eq!(light_scissor(Vec3::new(0.0, 0.0, 5.0), 1.0, vp, size), None, "behind the eye");
        assert_eq!(light_scissor(Vec3::new(50.0, 0.0, -5.0), 1.0, vp, size), None, "off to the side");
        let around = light_scissor(Vec3::ZERO, 2.0, vp, size).unwrap();
        assert_eq!((around.width, around.height), size);
    }

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

    /// Blended objects' pairs follow the opaque ones in the order given,
    /// each object's emission pair first (emissive or not), then one per
    /// light reaching it, in light order.
    #[test]
    fn blended_pairs_follow_object_by_object() {
        let lights = vec![
            light(LightKind::Ambient, Vec3::ZERO, Vec3::NEG_Y, 0.0),
            light(LightKind::Point, Vec3::new(10.0, 0.0, 0.0), Vec3::NEG_Y, 1.0),
            light(LightKind::Point, Vec3::new(0.0, 0.0, 0.0), Vec3::NEG_Y, 2.0),
        ];
        let unit = |x: f32| Aabb { min: Vec3::new(x - 0.5, -0.5, -0.5), max: Vec3::new(x + 0.5, 0.5, 0.5) };
        let bounds = [unit(0.0), unit(10.0), unit(0.5)];
        // Object 0 is opaque; 1 and 2 are blended, drawn 2 then 1.
        let mut builder = PairBuilder::default();
        let opaque = builder.build(&lights, &bounds, &[true, false, false], &[false; 3]).len();
        let pairs = builder.add_blended(&lights, &bounds, &[2, 1]);
        let got: Vec<(u32, u32)> = pairs[opaque..].iter().map(|p| (p.object, p.light)).collect();
        assert_eq!(got, [(2, EMISSION), (2, 0), (2, 2), (1, EMISSION), (1, 0), (1, 1)]);
        assert!(pairs[..opaque].iter().all(|p| p.object == 0));
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
