//! A camera path built in code: a crane move that rises over a model while
//! closing in, rendered frame by frame in object space, whose shades are
//! reused between frames. Writes every frame and prints how many tiles each
//! frame shaded and reused, and its GPU time.
//!
//! `cargo run --example camera_path -- [SCENE] [FRAMES] [OUT_PREFIX]`

use glam::Vec3;
use shadespace::render::ObjectSpaceConfig;
use shadespace::{Camera, CameraPath, GpuContext, GpuOptions, LightSpec, PipelineConfig, SceneCameras, Stage};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args.next().unwrap_or_else(|| "tests/data/corpus/spot.obj".into());
    let frames: u32 = args.next().map_or(Ok(8), |n| n.parse())?;
    let prefix = args.next().unwrap_or_else(|| "camera_path".into());
    let stage = Stage::load(&scene, 480, 270)?;
    let bounds = stage.scene.bounds();
    let (centre, radius) = (bounds.center(), 0.5 * bounds.extent().length());

    // Frame k: a quarter turn around the model, from eye level to 60 degrees
    // above it, from 3 to 2 radii away.
    let camera = |k: u32| {
        let t = k as f32 / frames.max(2) as f32;
        let (turn, rise) = (t * std::f32::consts::FRAC_PI_2, t * 60f32.to_radians());
        let distance = radius * (3.0 - t);
        let eye = centre + distance * Vec3::new(turn.sin() * rise.cos(), rise.sin(), turn.cos() * rise.cos());
        Camera {
            position: eye,
            forward: (centre - eye).normalize(),
            up: Vec3::Y,
            fov_y: 50f32.to_radians(),
            near: 0.1 * radius,
            far: distance + 2.0 * radius,
        }
    };
    // Studio lights placed for the first frame's camera (a scene's own path,
    // `stage.cameras.path`, would place them for its frame 0 instead).
    let first =
        Stage { cameras: SceneCameras { path: CameraPath::Fixed(camera(0)), ..stage.cameras.clone() }, ..stage };
    let lights = first.lights(&LightSpec::Studio, 1)?;

    let ctx = GpuContext::new(&GpuOptions::default())?;
    let reuse = ObjectSpaceConfig { reuse: 2, ..Default::default() };
    let mut renderer = first.renderer(&ctx, PipelineConfig::ObjectSpace(reuse))?;
    for k in 0..frames {
        renderer.render(&ctx, &camera(k), &lights, k as u64)?;
        renderer.read_image(&ctx)?.save(format!("{prefix}-{k:02}.png"))?;
    }
    let counters = renderer.collect_counters(&ctx, true);
    for ((k, c), t) in counters.iter().zip(renderer.collect_timings(&ctx, true)) {
        let tiles = |name: &str| c.get(name).copied().unwrap_or(0.0);
        println!(
            "frame {k}: {} tiles shaded, {} reused, {:.3} ms GPU",
            tiles("shaded_tiles"),
            tiles("reused_tiles"),
            t.total_ms
        );
    }
    Ok(())
}
