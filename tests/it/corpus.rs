//! The real-file corpus (`tests/data/corpus/`; sources and licences in its
//! `LICENSES.md`): 40 files holding 30 distinct models (the Khronos box is
//! in eight files, a cube from tinyobjloader's tests in three and the
//! Cornell box in two; see [`MODELS`]). Every model renders with no option
//! besides the image size, in forward and in object space, through the
//! library as `shadespace render` sets it up ([`shadespace::Stage`], in this
//! process, so that the device's compiled pipelines serve every model and no
//! process starts per model; [`IN_PROCESS_CHECKED`] is drawn through the
//! command line too, in both pipelines, and the images agree), to
//! an image that shows the whole model framed and lit: its
//! bounding rectangle covers 30-90 % of the frame without touching its edges
//! (a long or flat model, which cannot cover 30 % of a 16:9 frame uncut,
//! spans at least 60 % of the frame along its longer side instead), its
//! pixels are neither black nor blown out; the loaders warn about what they
//! ignore (skins, morph targets, animations, extensions, missing material
//! files, absent texture coordinates), and a file that requires an
//! unsupported extension (a custom one, Draco compression) is refused with
//! an error naming the file and the extension, never a panic.
//!
//! Object space agrees with forward on every model within [`MAX_FLIP`]
//! (textured files included: the Cesium logo box, the voxel knight, the
//! duck, the fox).
//!
//! No model shows a coloured spot its materials do not have ([`spots`]): with
//! no `--lights`, a model is lit by the neutral studio set. The random
//! coloured point lights of `--lights small:32`, the default before, fail
//! that check on grey models ([`coloured_lights_leave_spots_the_check_finds`]).
//!
//! The test writes each render, a contact sheet and a table of the measures
//! to `target/tmp/corpus/`.

use std::fmt::Write as _;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use image::RgbaImage;
use shadespace::metrics;

/// A corpus file and the warnings its loading must print.
struct Model {
    file: &'static str,
    warns: &'static [&'static str],
    /// Least span in place of [`MIN_SPAN`]: a row of objects or a long,
    /// low model, whose turntable distance is fitted to its end-on view
    /// (where the nearest object or end looms), so that frame 0's broadside
    /// view spans less.
    min_span: f32,
    /// Seen through the file's own camera (glTF cameras come first), which
    /// frames it as its author chose: not held to the framing bounds.
    own_camera: bool,
}

const fn model(file: &'static str, warns: &'static [&'static str]) -> Model {
    Model { file, warns, min_span: MIN_SPAN, own_camera: false }
}

/// The corpus, 40 files of 30 distinct models. Re-encodings of one model:
/// the Khronos box (`box.glb`, `box-gltf/`, `box-embedded.gltf`,
/// `box-textured/`, `box-specgloss/`, `box-vertex-colors.glb`,
/// `box-interleaved.glb`, `box-textured-npot.glb`), the Cornell box
/// (`cornell-box/`, `missing-material-file.obj`) and tinyobjloader's cube
/// (`cube-vertex-colors.obj`, `smoothing-normal.obj`, `smoothing-group.obj`).
/// Eight of the other models render as boxes too (`box01.glb`,
/// `two-cubes.glb`, `cube-textransform/`, `cube-uri-spaces/`,
/// `sparse-morph-cube.glb`, `unassigned-skeleton.gltf`,
/// `extensions-overwrite/`, and `cornellbox-suzanne.obj` seen from outside):
/// counting all eleven boxes as one, 20 different shapes.
const MODELS: &[Model] = &[
    model("box.glb", &["no TEXCOORD_0"]),
    model("box-gltf/Box.gltf", &[]),
    model("box-embedded.gltf", &[]),
    model("box-textured/BoxTextured.gltf", &[]),
    model("box-specgloss/BoxTextured.gltf", &["extensions ignored: KHR_materials_pbrSpecularGlossiness"]),
    model("box-vertex-colors.glb", &[]),
    model("box01.glb", &[]),
    model("two-cubes.glb", &[]),
    Model { min_span: 0.45, ..model("shape-collection.glb", &[]) },
    model("knight.glb", &[]),
    model("cube-textransform/Cube-textransform.gltf", &[]),
    model("cube-uri-spaces/CubeImageUriSpaces.gltf", &[]),
    model("unicode/Unicode ❤♻ Test.gltf", &[]),
    model("sparse-morph-cube.glb", &["morph targets"]),
    model("unassigned-skeleton.gltf", &["skins ignored"]),
    Model {
        own_camera: true,
        ..model("extensions-overwrite/issue-261.gltf", &["extensions ignored: NV_MDL, NV_Iray"])
    },
    model("spot.obj", &[]),
    model("teapot.obj", &["no texture coordinates"]),
    model("cornell-box/cornell_box.obj", &[]),
    model("cornellbox-suzanne.obj", &["cornellbox_suzanne.mtl cannot be read"]),
    model("cube-vertex-colors.obj", &["cube.mtl cannot be read"]),
    model("missing-material-file.obj", &[]),
    model("smoothing-normal.obj", &[]),
    model("smoothing-group.obj", &[]),
    // The Khronos box again: positions and normals interleaved in one
    // buffer view; a 211x211 (not a power of two), repeating texture.
    model("box-interleaved.glb", &["no TEXCOORD_0"]),
    model("box-textured-npot.glb", &[]),
    // Its own camera shows it small (5 % of the frame), as its author chose.
    Model { own_camera: true, ..model("duck.glb", &[]) },
    // Long and low (measured span 0.594).
    Model { min_span: 0.55, ..model("fox.glb", &["skins ignored", "3 animations ignored"]) },
    model("rigged-simple.glb", &["skins ignored", "animations ignored", "no TEXCOORD_0"]),
    model("rigged-figure.glb", &["skins ignored", "animations ignored", "no TEXCOORD_0"]),
    model("morph-sphere.glb", &["morph targets", "animations ignored", "no TEXCOORD_0"]),
    model("alien.glb", &[]),
    model("cake.glb", &["extensions ignored: KHR_materials_unlit"]),
    // Long and flat (measured span 0.600, on the bound).
    Model { min_span: 0.55, ..model("speeder/craft_speederD.gltf", &["extensions ignored: KHR_materials_unlit"]) },
    model("suzanne.obj", &["no texture coordinates"]),
    model("fish.obj", &["no texture coordinates"]),
    model("penguin.obj", &["no texture coordinates"]),
    model("goathead.obj", &["no texture coordinates"]),
    model("wingnut.obj", &["no texture coordinates"]),
    model("koala.obj", &["no texture coordinates"]),
];

/// Files that must be refused (exit status 2), and what the error names.
const REFUSED: &[(&str, &str)] =
    &[("acme-box/ACMEBox.gltf", "ACME_gizmo"), ("dense-sphere.glb", "KHR_draco_mesh_compression")];

/// Untextured models that `--lights small:32` leaves spotted
/// ([`coloured_lights_leave_spots_the_check_finds`]).
const SPOTTED: [&str; 3] = ["missing-material-file.obj", "unassigned-skeleton.gltf", "shape-collection.glb"];

const PIPELINES: [&str; 2] = ["forward", "objectspace"];
const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
/// Share of the frame the model's bounding rectangle must cover.
const COVERAGE: RangeInclusive<f32> = 0.30..=0.90;
/// Least span (the larger of the rectangle's width and height shares) of a
/// model whose proportions keep its rectangle under [`COVERAGE`].
const MIN_SPAN: f32 = 0.60;
/// Least mean luma (0-1, of the sRGB values) of the model's pixels: lit, not
/// black.
const MIN_LUMA: f32 = 0.06;
/// Most of the model's pixels that may be white in every channel.
const MAX_BLOWN: f32 = 0.05;
/// Most mean FLIP of object space against forward on a corpus model at
/// 320x180 (measured: 0.012 or less, and 0.040 on `sparse-morph-cube.glb`,
/// whose checker lines object space blurs: the default texel density gives
/// this cube fewer shading texels than pixels).
const MAX_FLIP: f32 = 0.05;
/// A pixel brighter than this in some channel belongs to the model (the
/// background is black; the ambient light keeps every surface above it).
const MODEL_THRESHOLD: u8 = 2;

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus")
}

fn out_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("corpus");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Least value (max of R, G, B, 0-255) of a pixel whose colour [`spots`]
/// judges: in darker pixels 8-bit rounding and sRGB's linear toe move the
/// saturation too much.
const SPOT_MIN_VALUE: u8 = 64;
/// How far a pixel's saturation may exceed the model's [`palette_bound`]
/// before it is a spot pixel (8-bit rounding moves it by at most 0.016 at
/// [`SPOT_MIN_VALUE`]; the GPU's rounding may differ from the CPU's by one).
const SPOT_MARGIN: f32 = 0.05;
/// Most of the model's pixels that may be spot pixels.
const MAX_SPOT_SHARE: f32 = 0.01;

/// The model whose images are drawn both ways, in this process and through
/// the command line ([`MAX_IN_PROCESS_FLIP`]), whose warnings the command
/// line prints too: textured, skinned and animated.
const IN_PROCESS_CHECKED: &str = "fox.glb";
/// Most mean FLIP between the two: the same frame drawn by the same code.
const MAX_IN_PROCESS_FLIP: f32 = 0.01;

/// A `std::io::Write` into a buffer the test reads afterwards.
#[derive(Clone, Default)]
struct Log(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);

impl std::io::Write for Log {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// `pipeline`'s image of `file` as `shadespace render` draws it with no
/// option besides the size, drawn through the library on `ctx`, and the
/// warnings it logged on the way (as `RUST_LOG=warn` prints them).
fn render_in_process(ctx: &shadespace::GpuContext, file: &Path, pipeline: &str) -> (RgbaImage, String) {
    use shadespace::{LightSpec, PipelineConfig, Stage};
    let log = Log::default();
    let writer = log.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_max_level(tracing::Level::WARN)
        .with_ansi(false)
        .with_writer(move || writer.clone())
        .finish();
    let image = tracing::subscriber::with_default(subscriber, || {
        let stage = Stage::load(file.to_str().unwrap(), WIDTH, HEIGHT).unwrap();
        let lights = stage.lights(&LightSpec::Auto, 1).unwrap();
        let mut renderer = stage.renderer(ctx, PipelineConfig::from_name(pipeline).unwrap()).unwrap();
        renderer.render(ctx, &stage.camera(0), &lights, 0).unwrap();
        renderer.read_image(ctx).unwrap()
    });
    ctx.check_errors().unwrap();
    let warnings = String::from_utf8(log.0.lock().unwrap().clone()).unwrap();
    (image, warnings)
}

fn render(file: &Path, pipeline: &str, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shadespace"))
        .args(["render", "--size", &format!("{WIDTH}x{HEIGHT}"), "--pipeline", pipeline, "--scene"])
        .arg(file)
        .arg("--out")
        .arg(out)
        .args(extra)
        .env("SHADESPACE_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("corpus-charts"))
        .env("RUST_LOG", "warn")
        .output()
        .expect("run shadespace")
}

/// What the image shows of the model.
#[derive(Debug)]
struct Shot {
    /// Share of the frame the model's pixels cover.
    silhouette: f32,
    /// Share of the frame their bounding rectangle covers.
    extent: f32,
    /// The larger of the rectangle's width and height shares.
    span: f32,
    /// Whether the rectangle touches the frame's edge (the model is cut off).
    cut: bool,
    /// Mean luma of the model's pixels, 0-1.
    luma: f32,
    /// Share of the model's pixels that are white.
    blown: f32,
}

impl Shot {
    /// Whole and large enough: see [`COVERAGE`] and [`MIN_SPAN`].
    fn framed(&self, min_span: f32) -> bool {
        let large = COVERAGE.contains(&self.extent) || (self.extent < *COVERAGE.end() && self.span >= min_span);
        large && !self.cut
    }
}

fn measure(image: &RgbaImage) -> Shot {
    let (mut count, mut luma, mut blown) = (0usize, 0.0f64, 0usize);
    let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
    for (x, y, p) in image.enumerate_pixels() {
        if p[0].max(p[1]).max(p[2]) <= MODEL_THRESHOLD {
            continue;
        }
        count += 1;
        luma += (0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64) / 255.0;
        blown += usize::from(p[0].min(p[1]).min(p[2]) >= 250);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let frame = (image.width() * image.height()) as f32;
    if count == 0 {
        return Shot { silhouette: 0.0, extent: 0.0, span: 0.0, cut: false, luma: 0.0, blown: 0.0 };
    }
    Shot {
        silhouette: count as f32 / frame,
        extent: ((x1 - x0 + 1) * (y1 - y0 + 1)) as f32 / frame,
        span: ((x1 - x0 + 1) as f32 / image.width() as f32).max((y1 - y0 + 1) as f32 / image.height() as f32),
        cut: x0 == 0 || y0 == 0 || x1 + 1 == image.width() || y1 + 1 == image.height(),
        luma: (luma / count as f64) as f32,
        blown: blown as f32 / count as f32,
    }
}

/// Saturation `(max - min) / max` of an RGB colour (0 for black).
fn saturation(c: [f32; 3]) -> f32 {
    let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
    if hi > 0.0 { (hi - lo) / hi } else { 0.0 }
}

/// The most saturated pixel, of value at least [`SPOT_MIN_VALUE`], that the
/// model's materials can give under white light.
///
/// Its palette is every object's base colour factor times each texel of its
/// base colour texture (or alone), and its emissive colour times each
/// emissive texel, in linear RGB; `r` is the least `min / max` of those
/// colours. Under white lights a pixel is, in linear RGB, a positive mix of
/// these colours and of white (specular, Fresnel; textures and object-space
/// shades are filtered in linear RGB), so its `min / max` is at least `r`;
/// the exposure scales it, per-channel Reinhard only raises it. The sRGB
/// encoding then lowers it most where the pixel is darkest: the bound is the
/// largest saturation of the 8-bit sRGB encoding of `(r M, M)` over the
/// linear values M the brightest channel can have (from [`SPOT_MIN_VALUE`]
/// to 1). A pixel more saturated than that shows a light's colour.
fn palette_bound(file: &Path) -> f32 {
    let scene = shadespace::scene::load(file.to_str().unwrap()).unwrap();
    let linear = shadespace::color::srgb8_to_linear;
    let mut least = 1.0f32;
    let mut add = |c: [f32; 3]| least = least.min(1.0 - saturation(c));
    for object in &scene.objects {
        let m = &scene.materials[object.material];
        for (factor, texture) in [(m.base_color.truncate(), m.base_color_texture), (m.emissive, m.emissive_texture)] {
            match texture {
                None => add(factor.to_array()),
                Some(t) => {
                    for texel in scene.textures[t].rgba8.chunks_exact(4) {
                        add([0, 1, 2].map(|k| factor[k] * linear(texel[k])));
                    }
                }
            }
        }
    }
    let lowest = linear(SPOT_MIN_VALUE);
    let srgb = |v: f32| shadespace::color::linear_to_srgb8(v) as f32;
    (0..=256)
        .map(|k| lowest + (1.0 - lowest) * k as f32 / 256.0)
        .map(|m| saturation([srgb(least * m), srgb(m), srgb(m)]))
        .fold(0.0, f32::max)
}

/// Share of the model's pixels (any channel above [`MODEL_THRESHOLD`])
/// that are spot pixels: at least [`SPOT_MIN_VALUE`] bright and more
/// saturated than `bound` (the model's [`palette_bound`]) by more than
/// [`SPOT_MARGIN`]. A model with coloured spots its materials do not have
/// has more than [`MAX_SPOT_SHARE`].
fn spots(image: &RgbaImage, bound: f32) -> f32 {
    let (mut model, mut spot) = (0usize, 0usize);
    for p in image.pixels() {
        let hi = p[0].max(p[1]).max(p[2]);
        if hi <= MODEL_THRESHOLD {
            continue;
        }
        model += 1;
        let c = [p[0], p[1], p[2]].map(|c| c as f32);
        spot += usize::from(hi >= SPOT_MIN_VALUE && saturation(c) > bound + SPOT_MARGIN);
    }
    spot as f32 / model.max(1) as f32
}

/// Tiles the images into rows of five.
fn contact_sheet(images: &[RgbaImage]) -> RgbaImage {
    let columns = 5;
    let rows = images.len().div_ceil(columns) as u32;
    let mut sheet = RgbaImage::new(WIDTH * columns as u32, HEIGHT * rows);
    for (k, image) in images.iter().enumerate() {
        let (x, y) = ((k % columns) as u32 * WIDTH, (k / columns) as u32 * HEIGHT);
        image::imageops::replace(&mut sheet, image, x as i64, y as i64);
    }
    sheet
}

#[test]
fn every_corpus_model_renders_framed_and_lit_in_forward_and_object_space() {
    let out = out_dir();
    let mut table =
        String::from("model\tpipeline\tsilhouette\textent\tspan\tluma\tblown\tflip_vs_forward\tpalette\tspots\n");
    let mut failures = Vec::new();
    let mut sheets: [Vec<RgbaImage>; 2] = Default::default();
    let ctx = crate::common::gpu();
    for m in MODELS {
        let mut forward: Option<RgbaImage> = None;
        let palette = palette_bound(&corpus().join(m.file));
        for (p, pipeline) in PIPELINES.iter().enumerate() {
            let name = format!("{}-{pipeline}.png", m.file.replace(['/', ' '], "_"));
            let png = out.join(&name);
            let (image, warnings) = render_in_process(&ctx, &corpus().join(m.file), pipeline);
            image.save(&png).unwrap();
            for warning in m.warns {
                assert!(warnings.contains(warning), "{}, {pipeline}: no warning '{warning}' in:\n{warnings}", m.file);
            }
            if m.file == IN_PROCESS_CHECKED {
                let cli = out.join(format!("{name}-cli.png"));
                let run = render(&corpus().join(m.file), pipeline, &cli, &[]);
                let stderr = String::from_utf8_lossy(&run.stderr);
                assert!(run.status.success() && !stderr.contains("panicked"), "{}: {stderr}", m.file);
                for warning in m.warns {
                    assert!(stderr.contains(warning), "{}: the command line printed no '{warning}':\n{stderr}", m.file);
                }
                let flip = metrics::compare(&image::open(&cli).unwrap().to_rgba8(), &image).0.flip_mean;
                eprintln!("{}, {pipeline}: in this process against the command line: FLIP {flip:.4}", m.file);
                assert!(flip <= MAX_IN_PROCESS_FLIP, "{}: in-process image off the command line's: {flip}", m.file);
            }
            let shot = measure(&image);
            let flip = forward.as_ref().map_or(0.0, |f| metrics::compare(f, &image).0.flip_mean);
            let spots = spots(&image, palette);
            writeln!(
                table,
                "{}\t{pipeline}\t{:.3}\t{:.3}\t{:.3}\t{:.3}\t{:.4}\t{flip:.4}\t{palette:.3}\t{spots:.4}",
                m.file, shot.silhouette, shot.extent, shot.span, shot.luma, shot.blown
            )
            .unwrap();
            if !(m.own_camera || shot.framed(m.min_span))
                || shot.luma < MIN_LUMA
                || shot.blown > MAX_BLOWN
                || flip > MAX_FLIP
                || spots > MAX_SPOT_SHARE
            {
                failures.push(format!("{} ({pipeline}): {shot:?}, flip {flip:.4}, spots {spots:.4}", m.file));
            }
            if p == 0 {
                forward = Some(image.clone());
            }
            sheets[p].push(image);
        }
    }
    std::fs::write(out.join("corpus.tsv"), &table).unwrap();
    for (pipeline, images) in PIPELINES.iter().zip(&sheets) {
        contact_sheet(images).save(out.join(format!("corpus-{pipeline}.png"))).unwrap();
    }
    println!("{table}");
    assert!(
        failures.is_empty(),
        "not framed ({COVERAGE:?} of the frame, or a span of {MIN_SPAN}, uncut), black (luma < {MIN_LUMA}), blown out (> {MAX_BLOWN} white), object space off forward (FLIP > {MAX_FLIP}) or coloured spots (> {MAX_SPOT_SHARE} of the model):\n{}",
        failures.join("\n")
    );
}

/// Untextured models (the loader gives them a pale checker) under
/// `--lights small:32`, the default before the studio set: the spot check
/// finds the lights' colours on each, where the default lighting leaves none.
#[test]
fn coloured_lights_leave_spots_the_check_finds() {
    for file in SPOTTED {
        let path = corpus().join(file);
        let png = out_dir().join(format!("{}-small32.png", file.replace(['/', ' '], "_")));
        let run = render(&path, "forward", &png, &["--lights", "small:32"]);
        assert!(run.status.success(), "{file}: {}", String::from_utf8_lossy(&run.stderr));
        let share = spots(&image::open(&png).unwrap().to_rgba8(), palette_bound(&path));
        assert!(share > MAX_SPOT_SHARE, "{file}: small:32 leaves spots on only {share:.4} of the model");
    }
}

#[test]
fn files_requiring_unsupported_extensions_are_refused_clearly() {
    for (file, named) in REFUSED {
        let run = render(&corpus().join(file), "forward", &out_dir().join("refused.png"), &[]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{file}: {stderr}");
        let file_name = Path::new(file).file_name().unwrap().to_str().unwrap();
        assert!(
            stderr.contains(file_name) && stderr.contains(named),
            "{file}: error does not name the file and '{named}':\n{stderr}"
        );
        assert!(!stderr.contains("panicked"), "{file}: {stderr}");
    }
}
