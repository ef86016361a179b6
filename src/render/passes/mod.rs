//! Passes that several pipelines call, one folder each (Rust beside its
//! WGSL), and the small helpers every pass uses: the scene raster pipeline,
//! the scene draw loop, the depth attachment, compute pipelines and
//! bind-group layouts.

pub mod background;
pub mod blended;
pub mod bloom;
pub mod cluster_draws;
pub mod depth_prepass;
pub mod environment;
pub mod exposure;
pub mod gbuffer;
pub mod light_grid;
pub mod shadows;
pub mod tonemap;
pub mod visibility;

use super::targets::{self, Targets};
use crate::render::scene_gpu::{DrawRange, SceneGpu};
use crate::shaders::{ALPHA_MASK, ShaderError, ShaderLibrary, ShaderSource};

/// Depth state of a scene raster pass (reversed Z: nearer is greater).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthMode {
    /// Test `Greater` and write: the first (or only) pass.
    Write,
    /// Test `Equal`, no write: after a depth pre-pass, one fragment per pixel.
    EqualAfterPrepass,
    /// Test `Greater`, no write: surfaces blended over the opaque frame.
    TestOnly,
}

impl DepthMode {
    pub fn after(prepass: bool) -> Self {
        if prepass { Self::EqualAfterPrepass } else { Self::Write }
    }
}

/// A scene raster pass's pipelines, one per kind of object the scene has. Opaque objects and, when the scene has alpha-masked ones, the
/// pass shader's [`ALPHA_MASK`] variant for those, which discards their
/// cut-away fragments: apart, so that opaque objects are drawn by a fragment
/// stage that never discards and keep their early depth test. A pass testing
/// `Equal` after a depth pre-pass needs the variant too: where a masked
/// triangle is cut away, another triangle of its object may have left the
/// same depth (coplanar ones), and the `Equal` test alone would let the cut
/// one through. Single-sided objects ([`SceneGpu::single_sided`]) and
/// double-sided ones apart too, by pipelines that cull back faces and that do
/// not (wgpu has no per-draw cull mode).
pub struct ScenePipeline {
    plain: Kinds,
    /// How they were built, for their cluster-draw variants (boxed, as
    /// is what follows: rarely used, and pass structs are held inline).
    recipe: Box<RasterRecipe>,
    /// The [`cluster_draws::CLUSTER_DRAW`] variants of `plain`
    /// ([`Self::add_cluster_draws`]).
    clustered: Option<Box<Kinds>>,
}

/// A pass's pipelines by kind of object, `[masked][single-sided]`: those of
/// the kinds the scene has ([`object_kind`]).
type Kinds = [[Option<wgpu::RenderPipeline>; 2]; 2];

/// Object `i`'s entry of [`Kinds`]: (alpha-masked, single-sided).
fn object_kind(scene: &SceneGpu, i: usize) -> (usize, usize) {
    (usize::from(scene.masked[i]), usize::from(scene.single_sided[i]))
}

/// The cull modes `scene`'s objects need: double-sided (false) and
/// single-sided (true), those it has.
fn sides(scene: &SceneGpu) -> Vec<bool> {
    [(false, scene.has_double_sided()), (true, scene.has_single_sided())]
        .into_iter()
        .filter(|p| p.1)
        .map(|p| p.0)
        .collect()
}

/// The pipelines of `kinds` with whether each is the alpha-masked and the
/// single-sided objects'.
fn kinds_iter(kinds: &Kinds) -> impl Iterator<Item = (&wgpu::RenderPipeline, bool, bool)> {
    kinds.iter().enumerate().flat_map(|(m, by_side)| {
        by_side.iter().enumerate().filter_map(move |(s, p)| p.as_ref().map(|p| (p, m == 1, s == 1)))
    })
}

/// A scene raster pass's pipelines by cull mode, `[single-sided]`
/// ([`ScenePipeline::for_every_object`]).
pub type SidedPipelines = [Option<wgpu::RenderPipeline>; 2];

/// A [`SceneRaster`] with owned parts.
struct RasterRecipe {
    shader: ShaderSource,
    vertex_entry: String,
    fragment: Option<(String, Vec<wgpu::TextureFormat>)>,
    depth: DepthMode,
    groups: Vec<Option<wgpu::BindGroupLayout>>,
    blend: Option<wgpu::BlendState>,
    samples: u32,
}

impl ScenePipeline {
    /// The pipelines of every object by cull mode, for a pass with a draw
    /// loop of its own that tests `Equal` after a depth pre-pass: in scenes
    /// with masks the [`ALPHA_MASK`] variants (they cut only the masked
    /// objects, and with no depth writes a fragment stage that may discard
    /// keeps its early depth test), else the plain ones.
    pub fn for_every_object(self) -> SidedPipelines {
        let [opaque, masked] = self.plain;
        if masked.iter().any(Option::is_some) { masked } else { opaque }
    }

    /// Whether it has its cluster-draw variants ([`Self::add_cluster_draws`]).
    pub fn draws_clusters(&self) -> bool {
        self.clustered.is_some()
    }

    /// The cluster-draw variants (none before [`Self::add_cluster_draws`]),
    /// each with whether it is the alpha-masked objects' (each draws every
    /// list: it skips the other kinds' objects).
    pub fn clustered_pipelines(&self) -> impl Iterator<Item = (&wgpu::RenderPipeline, bool)> {
        self.clustered.iter().flat_map(|c| kinds_iter(c).map(|(p, masked, _)| (p, masked)))
    }

    /// Builds the variants that draw cluster lists
    /// ([`cluster_draws::ClusterCull::draw_list`]) if not built yet, drawn
    /// as `scene.cluster_draws` says. A pass using group
    /// [`cluster_draws::CLUSTER_DRAW_GROUP`] itself has none.
    pub fn add_cluster_draws(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
    ) -> Result<(), ShaderError> {
        let r = &self.recipe;
        let group = cluster_draws::CLUSTER_DRAW_GROUP as usize;
        if self.clustered.is_some() || r.groups.get(group - 1).is_some_and(Option::is_some) {
            return Ok(());
        }
        let layout = cluster_draws::draw_layout(device);
        let mut groups: Vec<Option<&wgpu::BindGroupLayout>> = r.groups.iter().map(Option::as_ref).collect();
        groups.resize(groups.len().max(group), None);
        groups[group - 1] = Some(&layout);
        let fragment = r.fragment.as_ref().map(|(entry, formats)| (entry.as_str(), formats.as_slice()));
        let raster = SceneRaster {
            shader: r.shader,
            vertex_entry: &r.vertex_entry,
            fragment,
            depth: r.depth,
            groups: &groups,
            blend: r.blend,
            samples: r.samples,
        };
        let indexed = scene.cluster_draws == crate::render::clusters::ClusterDraws::Indexed;
        let draw: &[&str] = if indexed {
            &[cluster_draws::CLUSTER_DRAW, cluster_draws::INDEXED_DRAWS]
        } else {
            &[cluster_draws::CLUSTER_DRAW]
        };
        // Where the scene has both cull modes, every list is drawn once with
        // each, and each skips the other's objects (`cluster_draws.wgsl`).
        let mixed = scene.has_single_sided() && scene.has_double_sided();
        let mut clustered: Kinds = Default::default();
        for (m, by_side) in self.plain.iter().enumerate() {
            for (single, _) in by_side.iter().enumerate().filter(|(_, p)| p.is_some()) {
                let fragment = if m == 1 { raster.fragment.or(Some(("fs_alpha_mask", &[]))) } else { raster.fragment };
                let mut defs: Vec<&str> = draw.to_vec();
                if m == 1 {
                    defs.push(ALPHA_MASK);
                }
                if mixed {
                    defs.push(if single == 1 {
                        cluster_draws::SINGLE_SIDED_DRAW
                    } else {
                        cluster_draws::DOUBLE_SIDED_DRAW
                    });
                }
                let raster = SceneRaster { fragment, ..raster };
                clustered[m][single] = Some(raster_pipeline_with(device, shaders, scene, &raster, &defs, single == 1)?);
            }
        }
        self.clustered = Some(Box::new(clustered));
        Ok(())
    }
}

/// The pass shaders with [`ALPHA_MASK`] variants (those drawn through
/// [`ScenePipeline`]s, the shadow maps and the compute rasterizer), which
/// must compose too (checked in `shaders`' tests).
pub fn alpha_masked_shaders() -> Vec<ShaderSource> {
    use crate::render::{clustered, forward_multipass};
    vec![
        clustered::SHADER,
        forward_multipass::SHADER,
        depth_prepass::SHADER,
        visibility::SHADER,
        gbuffer::SHADER,
        crate::render::forward::SHADER,
        shadows::SHADER,
        visibility::compute::RASTER,
        visibility::compute::RASTER_CULLING_COUNTING,
    ]
}

/// A raster pipeline over the scene bind group (group 0): vertices pulled
/// from storage (no vertex buffers), back faces culled for single-sided
/// objects only ([`ScenePipeline`]), a reversed-Z depth test, and a fragment stage writing its
/// colour targets (several: a G-buffer; none: depth only), with bind groups
/// after the scene's, blending, and multisampling.
#[derive(Clone, Copy)]
pub struct SceneRaster<'a> {
    pub shader: ShaderSource,
    pub vertex_entry: &'a str,
    /// Fragment entry point and colour target formats (none: depth only).
    pub fragment: Option<(&'a str, &'a [wgpu::TextureFormat])>,
    pub depth: DepthMode,
    /// Layouts of groups 1, 2, ... (group 0 is the scene's; `None` leaves a
    /// group unused).
    pub groups: &'a [Option<&'a wgpu::BindGroupLayout>],
    /// Blending into every colour target (none: replace).
    pub blend: Option<wgpu::BlendState>,
    /// Samples per pixel of the targets it draws into ([`Targets::samples`]).
    pub samples: u32,
}

/// The raster pipelines `raster` describes ([`SceneRaster`]), one per kind
/// of object `scene` has ([`ScenePipeline`]).
pub fn scene_raster_pipeline_from(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    raster: &SceneRaster,
) -> Result<ScenePipeline, ShaderError> {
    let mut plain: Kinds = Default::default();
    for single in sides(scene) {
        plain[0][usize::from(single)] = Some(raster_pipeline_with(device, shaders, scene, raster, &[], single)?);
        if scene.has_alpha_masks() {
            // A depth-only pass discards in a fragment stage of its own.
            let fragment = raster.fragment.or(Some(("fs_alpha_mask", &[])));
            let masked = SceneRaster { fragment, ..*raster };
            plain[1][usize::from(single)] =
                Some(raster_pipeline_with(device, shaders, scene, &masked, &[ALPHA_MASK], single)?);
        }
    }
    let recipe = Box::new(RasterRecipe {
        shader: raster.shader,
        vertex_entry: raster.vertex_entry.to_string(),
        fragment: raster.fragment.map(|(entry, formats)| (entry.to_string(), formats.to_vec())),
        depth: raster.depth,
        groups: raster.groups.iter().map(|g| g.cloned()).collect(),
        blend: raster.blend,
        samples: raster.samples,
    });
    Ok(ScenePipeline { plain, recipe, clustered: None })
}

/// One pipeline of [`scene_raster_pipeline_from`] drawing both faces: the
/// shader's [`ALPHA_MASK`] variant when `alpha_mask` (the blended passes,
/// which draw every face of their surfaces).
pub(crate) fn raster_pipeline(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    raster: &SceneRaster,
    alpha_mask: bool,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    raster_pipeline_with(device, shaders, scene, raster, if alpha_mask { &[ALPHA_MASK] } else { &[] }, false)
}

/// [`raster_pipeline`] with `defs` defined, culling back faces when `cull_back`.
fn raster_pipeline_with(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    raster: &SceneRaster,
    defs: &[&str],
    cull_back: bool,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    let shader = raster.shader;
    let state = (
        (raster.vertex_entry, raster.fragment, raster.depth, raster.groups.len()),
        (raster.blend, raster.samples, cull_back),
    );
    shaders
        .pipeline(shader, defs, state, |shaders| build_raster_pipeline(device, shaders, scene, raster, defs, cull_back))
}

/// [`raster_pipeline`] as it is built when not built before.
fn build_raster_pipeline(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    raster: &SceneRaster,
    defs: &[&str],
    cull_back: bool,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    let shader = raster.shader;
    let module = shaders.module_with(device, shader, defs)?;
    let groups: Vec<Option<&wgpu::BindGroupLayout>> =
        std::iter::once(Some(&scene.layout)).chain(raster.groups.iter().copied()).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(shader.file),
        bind_group_layouts: &groups,
        immediate_size: 0,
    });
    let targets: Option<Vec<Option<wgpu::ColorTargetState>>> = raster.fragment.map(|(_, formats)| {
        let target =
            |format| Some(wgpu::ColorTargetState { format, blend: raster.blend, write_mask: wgpu::ColorWrites::ALL });
        formats.iter().map(|f| target(*f)).collect()
    });
    let (depth_write, compare) = match raster.depth {
        DepthMode::Write => (true, wgpu::CompareFunction::Greater),
        DepthMode::EqualAfterPrepass => (false, wgpu::CompareFunction::Equal),
        DepthMode::TestOnly => (false, wgpu::CompareFunction::Greater),
    };
    Ok(device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(shader.file),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(raster.vertex_entry),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: raster.fragment.zip(targets.as_ref()).map(|((entry, _), targets)| wgpu::FragmentState {
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets: targets.as_slice(),
        }),
        primitive: wgpu::PrimitiveState { cull_mode: cull_back.then_some(wgpu::Face::Back), ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: targets::DEPTH_FORMAT,
            depth_write_enabled: Some(depth_write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        // The standard sample positions (the only ones wgpu offers).
        multisample: wgpu::MultisampleState { count: raster.samples, ..Default::default() },
        multiview_mask: None,
        cache: None,
    }))
}

/// Draws the scene with `pipeline`: the cluster lists of `cull` where this
/// frame's depth pre-pass culled with it and the pipeline has its
/// cluster-draw variants, else every visible object ([`draw_objects`]).
pub fn draw_scene(
    pass: &mut wgpu::RenderPass,
    scene: &SceneGpu,
    visible: &[bool],
    pipeline: &ScenePipeline,
    cull: Option<&cluster_draws::ClusterCull>,
) {
    match (cull.filter(|c| c.active()), &pipeline.clustered) {
        (Some(cull), Some(_)) => {
            pass.set_bind_group(0, scene.bind_group(), &[]);
            for (p, masked) in pipeline.clustered_pipelines() {
                pass.set_pipeline(p);
                cull.draw_list(pass, 0, masked);
                cull.draw_list(pass, 1, masked);
            }
        }
        _ => draw_objects(pass, scene, visible, pipeline),
    }
}

/// Draws every visible object with `pipeline`: one instanced draw per object,
/// the instance index being the object (the shaders read its table entry);
/// each kind of object ([`ScenePipeline`]) with its pipeline.
pub fn draw_objects(pass: &mut wgpu::RenderPass, scene: &SceneGpu, visible: &[bool], pipeline: &ScenePipeline) {
    pass.set_bind_group(0, scene.bind_group(), &[]);
    pass.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
    for (p, masked, single) in kinds_iter(&pipeline.plain) {
        pass.set_pipeline(p);
        draw_visible(pass, scene, |i| {
            visible[i] && object_kind(scene, i) == (usize::from(masked), usize::from(single))
        });
    }
}

/// Draws every object `i` for which `draw(i)` with the bound pipeline: one
/// instanced draw per run of consecutive such objects of one mesh (the
/// city's instances come mesh by mesh), else one per object.
fn draw_visible(pass: &mut wgpu::RenderPass, scene: &SceneGpu, draw: impl Fn(usize) -> bool) {
    for (d, first, end) in visible_runs(scene, draw) {
        pass.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, first..end);
    }
}

/// The runs of consecutive objects `i` of one mesh for which `draw(i)`, as
/// (the mesh's range, first object, end): [`draw_visible`]'s draws.
fn visible_runs(scene: &SceneGpu, draw: impl Fn(usize) -> bool) -> Vec<(DrawRange, u32, u32)> {
    let mut runs: Vec<(DrawRange, u32, u32)> = Vec::new();
    for (i, d) in scene.draws.iter().enumerate().filter(|(i, _)| draw(*i)) {
        let i = i as u32;
        match runs.last_mut() {
            Some((range, _, end)) if *range == *d && *end == i => *end = i + 1,
            _ => runs.push((*d, i, i + 1)),
        }
    }
    runs
}

/// The draws [`draw_objects`] issues for the `visible` objects with a
/// pipeline of `scene` (each kind of object apart): what a pass drawing the
/// plain way issues, beside what the cluster draws issue.
pub fn plain_draws(scene: &SceneGpu, visible: &[bool]) -> u32 {
    let mut n = 0;
    for masked in 0..2 {
        for single in 0..2 {
            n += visible_runs(scene, |i| visible[i] && object_kind(scene, i) == (masked, single)).len();
        }
    }
    n as u32
}

/// The depth target as an attachment: cleared (to far, 0 in reversed Z) or
/// loaded, and stored.
pub fn depth_attachment(targets: &Targets, clear: bool) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    let load = if clear { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load };
    wgpu::RenderPassDepthStencilAttachment {
        view: &targets.depth_view,
        depth_ops: Some(wgpu::Operations { load, store: wgpu::StoreOp::Store }),
        stencil_ops: None,
    }
}

/// The depth target as a read-only attachment: depth-tested against, and
/// sampled in the same pass (light volumes read it to rebuild positions).
pub fn depth_attachment_read_only(targets: &Targets) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment { view: &targets.depth_view, depth_ops: None, stencil_ops: None }
}

/// A colour attachment cleared to `clear` and stored.
pub fn color_attachment(view: &wgpu::TextureView, clear: wgpu::Color) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
    })
}

/// The HDR target as the colour attachment of a pipeline's one shading
/// pass, cleared to black. Under MSAA it is the multisampled colour,
/// resolved into `targets.hdr` at the end of the pass (the mean of the
/// samples, in linear HDR, before exposure, bloom and tone mapping) and
/// then discarded: the pass must be the pipeline's only one into it.
pub fn hdr_attachment(targets: &Targets) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    hdr_attachment_then(targets, false)
}

/// [`hdr_attachment`], or with `blended_after` for a shading pass that the
/// blended pass follows ([`blended`]): under MSAA the samples are then
/// stored, not resolved, and the blended pass resolves them.
pub fn hdr_attachment_then(targets: &Targets, blended_after: bool) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    let clear = wgpu::LoadOp::Clear(wgpu::Color::BLACK);
    Some(match &targets.hdr_msaa_view {
        None => wgpu::RenderPassColorAttachment {
            view: &targets.hdr_view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: clear, store: wgpu::StoreOp::Store },
        },
        Some(msaa) if blended_after => wgpu::RenderPassColorAttachment {
            view: msaa,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: clear, store: wgpu::StoreOp::Store },
        },
        Some(msaa) => wgpu::RenderPassColorAttachment {
            view: msaa,
            depth_slice: None,
            resolve_target: Some(&targets.hdr_view),
            ops: wgpu::Operations { load: clear, store: wgpu::StoreOp::Discard },
        },
    })
}

/// A compute pipeline for entry point `entry` of `shader` over bind groups `groups`.
pub fn compute_pipeline(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    shader: ShaderSource,
    entry: &str,
    groups: &[&wgpu::BindGroupLayout],
) -> Result<wgpu::ComputePipeline, ShaderError> {
    compute_pipeline_with(device, shaders, shader, &[], entry, groups)
}

/// [`compute_pipeline`] of `shader` composed with `extra` defined too.
pub fn compute_pipeline_with(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    shader: ShaderSource,
    extra: &[&str],
    entry: &str,
    groups: &[&wgpu::BindGroupLayout],
) -> Result<wgpu::ComputePipeline, ShaderError> {
    shaders.pipeline(shader, extra, (entry, groups.len()), |shaders| {
        let module = shaders.module_with(device, shader, extra)?;
        let groups: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().copied().map(Some).collect();
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(entry),
            bind_group_layouts: &groups,
            immediate_size: 0,
        });
        Ok(device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        }))
    })
}

/// What one binding of a bind group holds (its index is its place
/// in the list given to [`bind_group_layout`]).
#[derive(Clone, Copy, Debug)]
pub enum Binding {
    Uniform,
    /// A uniform bound at a dynamic offset, `size` bytes at a time.
    DynamicUniform {
        size: u64,
    },
    Storage {
        read_only: bool,
    },
    /// A sampled texture without a sampler (read with `textureLoad`).
    Texture {
        sample: wgpu::TextureSampleType,
        dimension: wgpu::TextureViewDimension,
    },
    /// A multisampled 2D texture (read with `textureLoad` per sample).
    MultisampledTexture {
        sample: wgpu::TextureSampleType,
    },
    /// A write-only storage texture.
    StorageTexture {
        format: wgpu::TextureFormat,
        dimension: wgpu::TextureViewDimension,
    },
    /// A read-write storage texture (formats other than r32 need
    /// `TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES`).
    StorageTextureReadWrite {
        format: wgpu::TextureFormat,
        dimension: wgpu::TextureViewDimension,
    },
    /// A filtering sampler.
    Sampler,
    /// A comparison sampler (shadow maps).
    ComparisonSampler,
}

/// A bind-group layout for compute passes; binding `i` is `bindings[i]`.
pub fn bind_group_layout(device: &wgpu::Device, label: &str, bindings: &[Binding]) -> wgpu::BindGroupLayout {
    bind_group_layout_for(device, label, wgpu::ShaderStages::COMPUTE, bindings)
}

/// A bind-group layout seen by `stages`; binding `i` is `bindings[i]`.
pub fn bind_group_layout_for(
    device: &wgpu::Device,
    label: &str,
    stages: wgpu::ShaderStages,
    bindings: &[Binding],
) -> wgpu::BindGroupLayout {
    let buffer = |ty, dynamic, size: Option<u64>| wgpu::BindingType::Buffer {
        ty,
        has_dynamic_offset: dynamic,
        min_binding_size: size.and_then(wgpu::BufferSize::new),
    };
    let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: stages,
            ty: match *b {
                Binding::Uniform => buffer(wgpu::BufferBindingType::Uniform, false, None),
                Binding::DynamicUniform { size } => buffer(wgpu::BufferBindingType::Uniform, true, Some(size)),
                Binding::Storage { read_only } => buffer(wgpu::BufferBindingType::Storage { read_only }, false, None),
                Binding::Texture { sample, dimension } => {
                    wgpu::BindingType::Texture { sample_type: sample, view_dimension: dimension, multisampled: false }
                }
                Binding::MultisampledTexture { sample } => wgpu::BindingType::Texture {
                    sample_type: sample,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: true,
                },
                Binding::StorageTexture { format, dimension } => wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format,
                    view_dimension: dimension,
                },
                Binding::StorageTextureReadWrite { format, dimension } => wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::ReadWrite,
                    format,
                    view_dimension: dimension,
                },
                Binding::Sampler => wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                Binding::ComparisonSampler => wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
            },
            count: None,
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries })
}

/// A bind group whose binding `i` is `resources[i]`.
pub fn bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| wgpu::BindGroupEntry { binding: i as u32, resource: r.clone() })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
}

/// The HDR target as a compute pass's output: a layout holding one
/// write-only storage texture and the bind group binding `targets.hdr` to it.
pub fn hdr_output(device: &wgpu::Device, targets: &Targets, label: &str) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let dimension = wgpu::TextureViewDimension::D2;
    let layout =
        bind_group_layout(device, label, &[Binding::StorageTexture { format: targets::HDR_FORMAT, dimension }]);
    let group = bind_group(device, label, &layout, &[wgpu::BindingResource::TextureView(&targets.hdr_view)]);
    (layout, group)
}

/// A view of `texture` as `dimension` (all layers).
pub fn view_as(texture: &wgpu::Texture, dimension: wgpu::TextureViewDimension) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor { dimension: Some(dimension), ..Default::default() })
}
