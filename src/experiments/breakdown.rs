//! The quality experiment's error breakdown (`experiment quality
//! --breakdown`): each measured frame's FLIP, squared error and flicker
//! against its reference, split by pixel classes that test where object
//! space's extra error could come from. Each factor is a partition of the
//! frame's pixels (every pixel in one class):
//!
//! - `coverage`: background, interior, MSAA edge (samples on different surfaces);
//! - `level`: the atlas level the gather read;
//! - `interior level`: the same for interior pixels only (edges apart, so
//!   that a level's error is not its edges');
//! - `texels per pixel`: that level's texels per pixel (below 1: magnified);
//! - `anisotropy`: texels per pixel along the footprint's longer axis over
//!   those along its shorter (at a grazing angle a texel, sized for the
//!   longer axis, spans several pixels along the shorter);
//! - `island taps`: the filter's taps all in the pixel's chart island, some
//!   outside (near a chart border: renormalized), none inside (a sliver);
//! - `shade age`: the pixel's tile shaded this frame or reused;
//! - `reference gradient`: the reference's luma gradient (8-bit steps per
//!   pixel): flat, moderate, sharp (highlights, texture detail, edges).
//!
//! Object space's classes come from its own gather, read back after each
//! measured frame ([`crate::render::Renderer::read_pixel_classes`]); the
//! conventional pipelines' from the plain object-space configuration's run
//! of the same cell (same frames, lights and samples), so that for each
//! class both pipelines' error is over the same pixels and the classes
//! carrying object space's extra error can be named.

use image::RgbaImage;
use serde::{Deserialize, Serialize};

use super::report::{Section, Table};
use crate::metrics::breakdown::{ClassSums, LabelError, accumulate, frame_sums, pair_sums, total};
use crate::render::objectspace::debug::{Coverage, IslandTaps, PixelClass, ShadeSource};

/// A partition of the pixels: its name and its classes' names.
#[derive(Clone, Copy, Debug)]
pub struct Factor {
    pub name: &'static str,
    pub classes: &'static [&'static str],
}

/// Pixels shaded outside the atlas (an object shaded forward, or a page the
/// full atlas could not back): the last class of the factors that describe
/// the atlas read.
const FORWARD: &str = "shaded forward";

/// The factors, in the order of the report.
pub const FACTORS: [Factor; 8] = [
    Factor { name: "coverage", classes: &["background", "interior", "edge"] },
    Factor { name: "level", classes: &["background", "level 0", "level 1", "level 2", "level 3+", FORWARD] },
    Factor {
        name: "interior level",
        classes: &["background", "edge", "level 0", "level 1", "level 2", "level 3+", FORWARD],
    },
    Factor { name: "texels per pixel", classes: &["background", "< 0.5", "0.5-1", "1-2", ">= 2", FORWARD] },
    Factor { name: "anisotropy", classes: &["background", "< 2", "2-4", ">= 4", FORWARD] },
    Factor { name: "island taps", classes: &["background", "all in island", "some outside", "none inside", FORWARD] },
    Factor {
        name: "shade age",
        classes: &["background", "shaded this frame", "1 frame old", "2+ frames old", FORWARD],
    },
    Factor { name: "reference gradient", classes: &["background", "< 2", "2-8", ">= 8"] },
];

/// The reference's luma gradient at each pixel, in 8-bit steps per pixel:
/// the larger of the central differences across and down (one-sided at the
/// image's border).
pub fn luma_gradient(reference: &RgbaImage) -> Vec<f32> {
    let (w, h) = reference.dimensions();
    let luma: Vec<f32> = reference
        .pixels()
        .map(|p| 0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2]))
        .collect();
    let at = |x: u32, y: u32| luma[(y * w + x) as usize];
    let diff = |a: f32, b: f32, span: u32| (a - b).abs() / span.max(1) as f32;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (x0, x1, y0, y1) = (x.saturating_sub(1), (x + 1).min(w - 1), y.saturating_sub(1), (y + 1).min(h - 1));
            diff(at(x1, y), at(x0, y), x1 - x0).max(diff(at(x, y1), at(x, y0), y1 - y0))
        })
        .collect()
}

/// The class of a pixel in factor `factor` ([`FACTORS`]), from what object
/// space's gather read for it and the reference's gradient there.
pub fn class_of(factor: usize, c: &PixelClass, gradient: f32) -> u8 {
    if c.coverage == Coverage::Background {
        return 0;
    }
    if factor == 0 {
        return if c.coverage == Coverage::Edge { 2 } else { 1 };
    }
    if factor == 7 {
        return if gradient < 2.0 {
            1
        } else if gradient < 8.0 {
            2
        } else {
            3
        };
    }
    if factor == 2 && c.coverage == Coverage::Edge {
        return 1;
    }
    if c.source != Some(ShadeSource::Atlas) {
        return FACTORS[factor].classes.len() as u8 - 1;
    }
    match factor {
        1 => 1 + c.level.min(3) as u8,
        2 => 2 + c.level.min(3) as u8,
        3 => match c.texels_per_pixel {
            t if t < 0.5 => 1,
            t if t < 1.0 => 2,
            t if t < 2.0 => 3,
            _ => 4,
        },
        4 => match c.texels_per_pixel / c.texels_per_pixel_minor.max(f32::MIN_POSITIVE) {
            a if a < 2.0 => 1,
            a if a < 4.0 => 2,
            _ => 3,
        },
        5 => match c.taps {
            IslandTaps::All => 1,
            IslandTaps::Some => 2,
            IslandTaps::None => 3,
        },
        _ => 1 + c.age.min(2) as u8,
    }
}

/// Per factor, each pixel's class (row-major).
pub fn labels(classes: &[PixelClass], reference: &RgbaImage) -> Vec<Vec<u8>> {
    let gradient = luma_gradient(reference);
    assert_eq!(classes.len(), gradient.len(), "one class per pixel of the reference");
    (0..FACTORS.len()).map(|f| classes.iter().zip(&gradient).map(|(c, &g)| class_of(f, c, g)).collect()).collect()
}

/// Per factor, per class: a path's sums, from its frames, their references,
/// each frame's labels ([`labels`]) and FLIP map.
pub struct PathSums {
    pub factors: Vec<Vec<ClassSums>>,
}

impl PathSums {
    pub fn new() -> Self {
        Self { factors: FACTORS.iter().map(|f| vec![ClassSums::default(); f.classes.len()]).collect() }
    }

    /// Adds frame `t`'s error (`flip`: its FLIP map) and, from the second
    /// frame on, the flicker of the pair (t-1, t), each by `labels` (frame t's).
    pub fn add_frame(
        &mut self,
        labels: &[Vec<u8>],
        (frames, references): (&[RgbaImage], &[RgbaImage]),
        t: usize,
        flip: &[f32],
    ) -> Result<(), LabelError> {
        for (f, sums) in self.factors.iter_mut().enumerate() {
            let n = sums.len();
            accumulate(sums, &frame_sums(&labels[f], n, &references[t], &frames[t], flip)?);
            if t > 0 {
                let pair =
                    pair_sums(&labels[f], n, (&frames[t - 1], &frames[t]), (&references[t - 1], &references[t]))?;
                accumulate(sums, &pair);
            }
        }
        Ok(())
    }
}

impl PathSums {
    /// Adds `other`'s sums (another frame's) to these.
    pub fn merge(&mut self, other: &PathSums) {
        for (a, b) in self.factors.iter_mut().zip(&other.factors) {
            accumulate(a, b);
        }
    }
}

impl Default for PathSums {
    fn default() -> Self {
        Self::new()
    }
}

/// A row of `breakdown.csv`: one class of one factor in one cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BreakdownRow {
    /// The cell's index in the grid (as `data.csv`'s `cell`).
    pub cell: usize,
    pub textures: String,
    pub gloss: String,
    pub lights_spec: String,
    pub msaa: u32,
    pub config: String,
    /// Whose gather the classes come from: `own` (object space's), or
    /// `objectspace` (the plain object-space run's, for the conventional pipelines).
    pub classes_from: String,
    pub factor: String,
    pub class: String,
    /// Pixels of the class over the measured frames.
    pub pixels: u64,
    /// Sum of their FLIP values.
    pub flip_sum: f64,
    /// Sum over their RGB channels of the squared 8-bit error.
    pub squared_sum: f64,
    /// Pixels of the class in the later frame of each frame pair, summed.
    pub pair_pixels: u64,
    /// Sum over them and their channels of |change - reference change|.
    pub flicker_sum: f64,
}

/// What one cell's breakdown rows repeat: the cell and its group.
pub struct CellKey<'a> {
    pub cell: usize,
    pub textures: &'a str,
    pub gloss: &'a str,
    pub lights_spec: &'a str,
    pub msaa: u32,
    pub config: &'a str,
    pub classes_from: &'a str,
}

impl PathSums {
    /// The cell's rows, one per factor and class.
    pub fn rows(&self, key: &CellKey) -> Vec<BreakdownRow> {
        let mut out = Vec::new();
        for (factor, sums) in FACTORS.iter().zip(&self.factors) {
            for (class, s) in factor.classes.iter().zip(sums) {
                out.push(BreakdownRow {
                    cell: key.cell,
                    textures: key.textures.into(),
                    gloss: key.gloss.into(),
                    lights_spec: key.lights_spec.into(),
                    msaa: key.msaa,
                    config: key.config.into(),
                    classes_from: key.classes_from.into(),
                    factor: factor.name.into(),
                    class: class.to_string(),
                    pixels: s.pixels,
                    flip_sum: s.flip,
                    squared_sum: s.squared,
                    pair_pixels: s.pair_pixels,
                    flicker_sum: s.flicker,
                });
            }
        }
        out
    }
}

fn sums(r: &BreakdownRow) -> ClassSums {
    ClassSums {
        pixels: r.pixels,
        flip: r.flip_sum,
        squared: r.squared_sum,
        pair_pixels: r.pair_pixels,
        flicker: r.flicker_sum,
    }
}

/// The pipeline the extra error is counted against.
pub const BASELINE: &str = "deferred-compute";
/// The configuration whose extra error is split: it shares its classes with
/// the conventional pipelines (theirs are its run's).
pub const SUBJECT: &str = "objectspace";

/// One class in one group: pixel share, and per configuration its mean and share of FLIP and flicker.
fn percent(part: f64, whole: f64) -> String {
    if whole == 0.0 { "-".into() } else { format!("{:.0} %", 100.0 * part / whole) }
}

/// The breakdown's report sections (a table of FLIP and one of flicker per
/// group of cells: textures, gloss, lights, samples) and results: per
/// group, factor and class, the pixel share, each configuration's mean and
/// share, and the share of [`SUBJECT`]'s extra error over [`BASELINE`] each
/// class carries.
pub fn summarize(rows: &[BreakdownRow]) -> (serde_json::Value, Vec<Section>) {
    type Key = (String, String, String, u32);
    let mut groups: Vec<(Key, Vec<&BreakdownRow>)> = Vec::new();
    for r in rows {
        let key = (r.textures.clone(), r.gloss.clone(), r.lights_spec.clone(), r.msaa);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, members)) => members.push(r),
            None => groups.push((key, vec![r])),
        }
    }
    let mut sections = Vec::new();
    let mut results = Vec::new();
    for ((textures, gloss, lights, msaa), members) in groups {
        let mut configs: Vec<&str> = Vec::new();
        for r in &members {
            if !configs.contains(&r.config.as_str()) {
                configs.push(&r.config);
            }
        }
        let find = |config: &str, factor: &str, class: &str| {
            members.iter().find(|r| r.config == config && r.factor == factor && r.class == class).map(|r| sums(r))
        };
        let config_total = |config: &str, factor: &str| {
            total(
                &members
                    .iter()
                    .filter(|r| r.config == config && r.factor == factor)
                    .map(|r| sums(r))
                    .collect::<Vec<_>>(),
            )
        };
        let extra = configs.contains(&BASELINE) && configs.contains(&SUBJECT);
        let mut head: Vec<String> = vec!["factor".into(), "class".into(), "pixels".into()];
        head.extend(configs.iter().map(|c| c.to_string()));
        if extra {
            head.push(format!("{SUBJECT} - {BASELINE}"));
        }
        let head: Vec<&str> = head.iter().map(String::as_str).collect();
        let (mut flip_table, mut flicker_table) = (Table::new(&head), Table::new(&head));
        let mut factors_json = Vec::new();
        for factor in FACTORS {
            let totals: Vec<ClassSums> = configs.iter().map(|c| config_total(c, factor.name)).collect();
            // The pixel shares of the classes the conventional pipelines share
            // with `SUBJECT`; a configuration classified by its own run (other
            // object-space options) notes its own share where it differs.
            let shown = configs.iter().position(|c| *c == SUBJECT).unwrap_or(0);
            let share = |s: &ClassSums, t: &ClassSums| s.pixels as f64 / t.pixels.max(1) as f64;
            let mut classes_json = Vec::new();
            for class in factor.classes {
                let per: Vec<Option<ClassSums>> = configs.iter().map(|c| find(c, factor.name, class)).collect();
                if per.iter().flatten().all(|s| s.pixels == 0) {
                    continue;
                }
                let pixel_share = per[shown].as_ref().map_or(0.0, |s| share(s, &totals[shown]));
                let mut flip_row =
                    vec![factor.name.to_string(), class.to_string(), format!("{:.0} %", 100.0 * pixel_share)];
                let mut flicker_row = flip_row.clone();
                let mut configs_json = serde_json::Map::new();
                for ((config, s), t) in configs.iter().zip(&per).zip(&totals) {
                    let Some(s) = s.as_ref().filter(|s| s.pixels > 0) else {
                        flip_row.push("-".into());
                        flicker_row.push("-".into());
                        continue;
                    };
                    let flip_mean = s.flip / s.pixels.max(1) as f64;
                    let flicker_mean = s.flicker / (3 * s.pair_pixels.max(1)) as f64;
                    let own = share(s, t);
                    let note = if (own - pixel_share).abs() >= 0.005 {
                        format!("; {:.0} % px", 100.0 * own)
                    } else {
                        String::new()
                    };
                    flip_row.push(format!("{flip_mean:.4} ({}{note})", percent(s.flip, t.flip)));
                    flicker_row.push(format!("{flicker_mean:.3} ({}{note})", percent(s.flicker, t.flicker)));
                    configs_json.insert(
                        config.to_string(),
                        serde_json::json!({
                            "pixel_share": own, "flip_mean": flip_mean, "flip_share": s.flip / t.flip.max(f64::MIN_POSITIVE),
                            "flicker_mean": flicker_mean, "flicker_share": s.flicker / t.flicker.max(f64::MIN_POSITIVE),
                        }),
                    );
                }
                let mut class_json = serde_json::json!({
                    "class": class, "pixel_share": pixel_share, "configs": configs_json,
                });
                if extra {
                    let at = |c: &str| configs.iter().position(|x| *x == c).expect("listed");
                    let (s, b) = (per[at(SUBJECT)], per[at(BASELINE)]);
                    let (ts, tb) = (&totals[at(SUBJECT)], &totals[at(BASELINE)]);
                    if let (Some(s), Some(b)) = (s.filter(|s| s.pixels > 0), b) {
                        let flip_extra = (s.flip - b.flip) / s.pixels.max(1) as f64;
                        let flicker_extra = (s.flicker - b.flicker) / (3 * s.pair_pixels.max(1)) as f64;
                        flip_row.push(format!("{flip_extra:+.4} ({})", percent(s.flip - b.flip, ts.flip - tb.flip)));
                        flicker_row.push(format!(
                            "{flicker_extra:+.3} ({})",
                            percent(s.flicker - b.flicker, ts.flicker - tb.flicker)
                        ));
                        class_json["extra_flip_share"] = serde_json::json!((s.flip - b.flip) / (ts.flip - tb.flip));
                        class_json["extra_flicker_share"] =
                            serde_json::json!((s.flicker - b.flicker) / (ts.flicker - tb.flicker));
                    } else {
                        flip_row.push("-".into());
                        flicker_row.push("-".into());
                    }
                }
                flip_table.rows.push(flip_row);
                flicker_table.rows.push(flicker_row);
                classes_json.push(class_json);
            }
            factors_json.push(serde_json::json!({ "factor": factor.name, "classes": classes_json }));
        }
        results.push(serde_json::json!({
            "textures": textures, "gloss": gloss, "lights_spec": lights, "msaa": msaa, "factors": factors_json,
        }));
        let what =
            format!("textures {textures}, gloss {gloss}, {lights}, {msaa} sample{}", if msaa == 1 { "" } else { "s" });
        sections.push(Section {
            heading: format!("Error by pixel class: {what}"),
            text: format!(
                "Each factor splits every measured frame's pixels into classes (its rows; `pixels`: the class's \
                 share of the pixels, in `{SUBJECT}`'s classes; a configuration classified by its own run notes its \
                 own share, `% px`, where it differs). Per configuration, the class's mean FLIP against the reference (first \
                 table) and mean flicker per channel in 8-bit steps (second), and in brackets the share of the \
                 configuration's total the class carries. The classes are what object space's gather read for \
                 the pixel (the conventional pipelines: the `{SUBJECT}` run's classes, so both are judged over \
                 the same pixels).{}",
                if extra {
                    format!(
                        " Last column: `{SUBJECT}`'s mean minus `{BASELINE}`'s over the class, and in brackets \
                         the share of `{SUBJECT}`'s extra total (over `{BASELINE}`'s) that the class carries."
                    )
                } else {
                    String::new()
                }
            ),
            tables: vec![("FLIP:".into(), flip_table), ("Flicker:".into(), flicker_table)],
            figures: Vec::new(),
        });
    }
    (serde_json::json!(results), sections)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn class(
        coverage: Coverage,
        source: ShadeSource,
        level: u32,
        texels: f32,
        taps: IslandTaps,
        age: u32,
    ) -> PixelClass {
        PixelClass {
            coverage,
            source: Some(source),
            level,
            texels_per_pixel: texels,
            texels_per_pixel_minor: texels / (1.0 + level as f32),
            taps,
            age,
            blended: false,
        }
    }

    /// Every pixel kind falls in exactly one class of each factor (a class
    /// index the factor has), background in the first.
    #[test]
    fn every_pixel_has_one_class_per_factor() {
        let background = PixelClass {
            coverage: Coverage::Background,
            source: None,
            level: 0,
            texels_per_pixel: 0.0,
            texels_per_pixel_minor: 0.0,
            taps: IslandTaps::All,
            age: 0,
            blended: false,
        };
        let kinds = [
            background,
            class(Coverage::Interior, ShadeSource::Atlas, 0, 0.3, IslandTaps::All, 0),
            class(Coverage::Edge, ShadeSource::Atlas, 5, 1.2, IslandTaps::Some, 1),
            class(Coverage::Interior, ShadeSource::Atlas, 2, 3.0, IslandTaps::None, 7),
            class(Coverage::Interior, ShadeSource::Forward, 0, 0.0, IslandTaps::All, 0),
            class(Coverage::Edge, ShadeSource::NotBacked, 1, 0.9, IslandTaps::All, 0),
        ];
        // Anisotropy 1 + level: 1, 6, 3.
        let expected: [[u8; 8]; 6] = [
            [0, 0, 0, 0, 0, 0, 0, 0],
            [1, 1, 2, 1, 1, 1, 1, 1],
            [2, 4, 1, 3, 3, 2, 2, 2],
            [1, 3, 4, 4, 2, 3, 3, 3],
            [1, 5, 6, 5, 4, 4, 4, 1],
            [2, 5, 1, 5, 4, 4, 4, 2],
        ];
        let gradients = [0.0, 0.5, 3.0, 9.0, 1.0, 5.0];
        for ((k, g), want) in kinds.iter().zip(gradients).zip(expected) {
            let got: Vec<u8> = (0..FACTORS.len()).map(|f| class_of(f, k, g)).collect();
            assert_eq!(got, want, "{k:?}");
            for (f, &c) in got.iter().enumerate() {
                assert!(usize::from(c) < FACTORS[f].classes.len());
            }
        }
    }

    #[test]
    fn the_gradient_is_the_steeper_central_difference() {
        let img = RgbaImage::from_fn(4, 3, |x, y| {
            let v = (x * 10 + y * 40) as u8;
            image::Rgba([v, v, v, 255])
        });
        let g = luma_gradient(&img);
        // Inside: across (20 over 2 pixels) = 10, down (80 over 2) = 40.
        assert!((g[4 + 1] - 40.0).abs() < 1e-3, "{g:?}");
        // Corner: one-sided, 10 across and 40 down.
        assert!((g[0] - 40.0).abs() < 1e-3, "{g:?}");
    }
}
