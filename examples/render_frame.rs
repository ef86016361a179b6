//! One frame of a scene through the library, as `shadespace render` draws it
//! when given only the scene (a model gets studio lighting and automatic
//! exposure): writes the image and prints each pass's GPU time.
//!
//! `cargo run --example render_frame -- [SCENE] [PIPELINE] [OUT.png] [WIDTHxHEIGHT]`

use shadespace::{GpuContext, GpuOptions, LightSpec, PipelineConfig, Stage};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    render_frame(&args)
}

/// The example with its arguments (a function, so that the tests run it too).
pub fn render_frame(args: &[String]) -> anyhow::Result<()> {
    let arg = |k: usize, default: &str| args.get(k).map_or(default, String::as_str).to_string();
    let (scene, name, out, size) =
        (arg(0, "tests/data/corpus/duck.glb"), arg(1, "forward"), arg(2, "render_frame.png"), arg(3, "640x360"));
    let pipeline = PipelineConfig::from_name(&name)
        .ok_or_else(|| anyhow::anyhow!("no pipeline '{name}' (one of {})", PipelineConfig::NAMES.join(", ")))?;
    let (w, h) = size.split_once('x').and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?))).unwrap_or((0, 0));
    anyhow::ensure!(w > 0 && h > 0, "size '{size}' is not WIDTHxHEIGHT");

    let stage = Stage::load(&scene, w, h)?;
    let lights = stage.lights(&LightSpec::Auto, 1)?;
    let ctx = GpuContext::new(&GpuOptions::default())?;
    let mut renderer = stage.renderer(&ctx, pipeline)?;
    let stats = renderer.render(&ctx, &stage.camera(0), &lights, 0)?;
    renderer.read_image(&ctx)?.save(&out)?;
    println!("{name}: {} lights, {} objects visible -> {out}", lights.len(), stats.visible_objects);
    for frame in renderer.collect_timings(&ctx, true) {
        for (pass, ms) in &frame.passes {
            println!("  {pass:<16} {ms:8.3} ms GPU");
        }
    }
    Ok(())
}
