//! Object space's flicker and error against the 4x4 supersampled reference
//! along consecutive path frames, per configuration: the measurements behind
//! `--level-blend` (BENCHMARKS.md, "Object space's flicker"). Unlike
//! `shadespace experiment quality` it takes the lighting model and any
//! object-space options, and prints the tiles each configuration shades.
//!
//! `cargo run --release --example flicker -- SCENE WxH FIRST FRAMES default|high phong|pbr file|detailed CONFIG...`
//!
//! Lights `small:8` (seed 1), placed as the quality experiment places them;
//! path frames FIRST..FIRST+FRAMES measured after one warm-up frame (FIRST
//! at least 1). CONFIG: `forward`, `deferred-compute`, or `os` with options
//! `os:blend=W,reuse=N,hz=N,vr=V,bias=B,filter=bilinear|bspline|mitchell,texel=1|4`
//! (`hz=N`: reuse N spread over the frames, as `--shade-hz`; `filter`:
//! `--os-filter`; `texel`: `--os-texel-samples`).
//! Prints per configuration: mean FLIP and PSNR,
//! mean flicker (8-bit steps a channel), and per frame the shaded and visible
//! tiles, shaded texels and the share of atlas pixels whose level holds
//! fewer than one texel per pixel (`under_shaded_share`).

use anyhow::{Context, bail};
use shadespace::charts::ChartCache;
use shadespace::experiments::census::StudyScene;
use shadespace::metrics::temporal::path_quality;
use shadespace::reference::{ReferenceCache, ReferenceSettings, ReferenceView, References};
use shadespace::render::objectspace::GatherFilter;
use shadespace::render::{
    DeferredComputeConfig, Exposure, ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer,
    ShadingModel, VisibilityMethod,
};
use shadespace::scene::gloss::{self, Gloss};
use shadespace::scene::lights::build_lights;
use shadespace::scene::path::cameras_for_scene;
use shadespace::{GpuContext, GpuOptions};

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 8 {
        bail!("usage: flicker SCENE WxH FIRST FRAMES default|high phong|pbr file|detailed CONFIG...");
    }
    let spec = &a[0];
    let (w, h) = a[1].split_once('x').context("size: WxH")?;
    let (width, height): (u32, u32) = (w.parse()?, h.parse()?);
    let first: u32 = a[2].parse().context("FIRST: a path frame")?;
    anyhow::ensure!(first >= 1, "FIRST must be at least 1 (one warm-up frame comes before it)");
    let frames: u32 = a[3].parse().context("FRAMES: a frame count")?;
    let g = match a[4].as_str() {
        "default" => Gloss::Default,
        "high" => Gloss::High,
        other => bail!("gloss '{other}' is not default or high"),
    };
    let shading = match a[5].as_str() {
        "phong" => ShadingModel::Phong,
        "pbr" => ShadingModel::Pbr,
        other => bail!("shading '{other}' is not phong or pbr"),
    };
    let detailed = match a[6].as_str() {
        "file" => false,
        "detailed" => true,
        other => bail!("textures '{other}' are not file or detailed"),
    };
    let ctx = GpuContext::new(&GpuOptions::default())?;
    let study = StudyScene::load(spec, &[], 256.0, &ChartCache::from_env())?;
    let prepare = |s: &shadespace::scene::Scene| {
        let mut s = s.clone();
        if detailed {
            shadespace::scene::detail::add_detailed_textures(&mut s);
        }
        gloss::apply(&mut s, g);
        s
    };
    let render_scene = prepare(&study.render);
    let charted = prepare(study.charted());
    let aspect = width as f32 / height as f32;
    let cameras = cameras_for_scene(spec, &render_scene, aspect)?;
    let region = cameras.light_region(&render_scene.bounds());
    let path = &cameras.path;
    let spec_l: shadespace::LightSpec = "small:8".parse()?;
    let lights = build_lights(&spec_l, &region, &path.camera_at(0), aspect, 1)?;
    let settings = ReferenceSettings { width, height, shading, sun_shadow: false, exposure: Exposure::default() };
    let mut refs = References::new(&ctx, &render_scene, settings, ReferenceCache::from_env());
    let mut reference = Vec::new();
    for f in first..first + frames {
        let camera = path.camera_at(f);
        reference.push(refs.get(&ReferenceView { camera: &camera, lights: &lights, samples: 4 })?.0.image());
    }
    println!("config\tflip\tpsnr\tflicker\tshaded_tiles\tvisible_tiles\tshaded_texels\tunder_shaded");
    for c in &a[7..] {
        let mut os = ObjectSpaceConfig { texture_sizes: study.density_sizes.clone(), ..Default::default() };
        let pipeline = match c.as_str() {
            "forward" => PipelineConfig::Forward(ForwardConfig { depth_prepass: true }),
            "deferred-compute" => PipelineConfig::DeferredCompute(DeferredComputeConfig {
                depth_prepass: true,
                visibility: VisibilityMethod::preferred(ctx.device.features()),
                count_visibility: false,
                ..Default::default()
            }),
            other => {
                let Some(opts) = other.strip_prefix("os") else {
                    bail!("configuration '{other}' is not forward, deferred-compute or os[:...]")
                };
                let opts = opts.trim_start_matches(':');
                os.visibility = VisibilityMethod::preferred(ctx.device.features());
                for kv in opts.split(',').filter(|s| !s.is_empty()) {
                    let (k, v) = kv.split_once('=').with_context(|| format!("'{kv}' is not KEY=VALUE"))?;
                    match k {
                        "blend" => os.level_blend = v.parse()?,
                        "reuse" => os.reuse = v.parse()?,
                        "hz" => {
                            os.reuse = v.parse()?;
                            os.spread_reshading = true
                        }
                        "vr" => os.variable_rate = v.parse()?,
                        "bias" => os.mip_bias = v.parse()?,
                        "filter" => {
                            os.gather_filter = match v {
                                "bilinear" => GatherFilter::Bilinear,
                                "bspline" => GatherFilter::Bspline,
                                "mitchell" => GatherFilter::Mitchell,
                                _ => bail!("filter '{v}' is not bilinear, bspline or mitchell"),
                            }
                        }
                        "texel" => os.texel_samples = v.parse()?,
                        _ => bail!("'{k}' is not blend, reuse, hz, vr, bias, filter or texel"),
                    }
                }
                PipelineConfig::ObjectSpace(os)
            }
        };
        let is_os = matches!(pipeline, PipelineConfig::ObjectSpace(_));
        let scene = if is_os { &charted } else { &render_scene };
        let mut r = Renderer::new(&ctx, scene, &RenderOptions::new(width, height, pipeline))?;
        r.shading = shading;
        let mut images = Vec::new();
        // One warm-up frame before the first measured one (FIRST >= 1).
        for (i, f) in (first - 1..first + frames).enumerate() {
            r.render(&ctx, &path.camera_at(f), &lights, i as u64)?;
            if f >= first {
                images.push(r.read_image(&ctx)?);
            }
        }
        let counters = r.collect_counters(&ctx, true);
        let n = counters.len().max(1) as f64;
        let mean = |k: &str| counters.iter().map(|(_, c)| c.get(k).copied().unwrap_or(0.0)).sum::<f64>() / n;
        let q = path_quality(&images, &reference);
        println!(
            "{c}\t{:.5}\t{:.3}\t{:.4}\t{:.0}\t{:.0}\t{:.0}\t{:.3}",
            q.flip_mean,
            q.psnr_db,
            q.flicker.mean,
            mean("shaded_tiles"),
            mean("visible_tiles"),
            mean("shaded_texels"),
            mean("under_shaded_share")
        );
    }
    Ok(())
}
