//! The real-file corpus (`tests/data/corpus/`; sources and licences in its
//! `LICENSES.md`): 40 files holding 30 distinct models (the Khronos box is
//! in eight files, a cube from tinyobjloader's tests in three and the
//! Cornell box in two; see [`MODELS`]). Every model renders through the
//! command line with no option besides the image size, in forward and in
//! object space, to an image that shows the whole model framed and lit: its
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

fn render(file: &Path, pipeline: &str, out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shadespace"))
        .args(["render", "--size", &format!("{WIDTH}x{HEIGHT}"), "--pipeline", pipeline, "--scene"])
        .arg(file)
        .arg("--out")
        .arg(out)
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
    let mut table = String::from("model\tpipeline\tsilhouette\textent\tspan\tluma\tblown\tflip_vs_forward\n");
    let mut failures = Vec::new();
    let mut sheets: [Vec<RgbaImage>; 2] = Default::default();
    for m in MODELS {
        let mut forward: Option<RgbaImage> = None;
        for (p, pipeline) in PIPELINES.iter().enumerate() {
            let name = format!("{}-{pipeline}.png", m.file.replace(['/', ' '], "_"));
            let png = out.join(&name);
            let run = render(&corpus().join(m.file), pipeline, &png);
            let stderr = String::from_utf8_lossy(&run.stderr);
            assert!(!stderr.contains("panicked"), "{}, {pipeline}: panicked:\n{stderr}", m.file);
            assert!(run.status.success(), "{}, {pipeline}: exit {:?}:\n{stderr}", m.file, run.status.code());
            for warning in m.warns {
                assert!(stderr.contains(warning), "{}: no warning '{warning}' in:\n{stderr}", m.file);
            }
            let image = image::open(&png).unwrap().to_rgba8();
            let shot = measure(&image);
            let flip = forward.as_ref().map_or(0.0, |f| metrics::compare(f, &image).0.flip_mean);
            writeln!(
                table,
                "{}\t{pipeline}\t{:.3}\t{:.3}\t{:.3}\t{:.3}\t{:.4}\t{flip:.4}",
                m.file, shot.silhouette, shot.extent, shot.span, shot.luma, shot.blown
            )
            .unwrap();
            if !(m.own_camera || shot.framed(m.min_span))
                || shot.luma < MIN_LUMA
                || shot.blown > MAX_BLOWN
                || flip > MAX_FLIP
            {
                failures.push(format!("{} ({pipeline}): {shot:?}", m.file));
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
        "not framed ({COVERAGE:?} of the frame, or a span of {MIN_SPAN}, uncut), black (luma < {MIN_LUMA}), blown out (> {MAX_BLOWN} white) or object space off forward (FLIP > {MAX_FLIP}):\n{}",
        failures.join("\n")
    );
}

#[test]
fn files_requiring_unsupported_extensions_are_refused_clearly() {
    for (file, named) in REFUSED {
        let run = render(&corpus().join(file), "forward", &out_dir().join("refused.png"));
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
