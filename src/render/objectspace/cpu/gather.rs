//! CPU twin of shade gathering (`gather/gather.wgsl`): for a pixel of the
//! visibility buffer, the levels marking chose (one, or two blended), the
//! filter's taps in each (bilinear, or the cubic B-spline's 4x4 with
//! `--os-filter bspline`), their weights, the taps kept (those in the pixel's
//! chart island) and the colour filtered from the shades the GPU holds
//! ([`LevelTexels`]), in `f32` and in the WGSL's order; with `--os-aniso`,
//! the same at each anisotropic tap ([`AnisoTaps`]), averaged.
//!
//! As for marking, the GPU may round a near-boundary decision the other way;
//! [`gather_pixel`] returns every outcome (level within [`LOD_TOLERANCE`], 10
//! times more with `--os-aniso`, of a rounding boundary or a blend band's
//! edge, bilinear coordinate within [`TEXEL_TOLERANCE`] of an integer, tap
//! count and axis within [`ANISO_TOLERANCE`] of a decision), each with how
//! far its colour may be from the GPU's.
//!
//! [`LOD_TOLERANCE`]: super::LOD_TOLERANCE
//! [`ANISO_TOLERANCE`]: super::ANISO_TOLERANCE

use glam::{IVec2, UVec2, Vec2, Vec3};

use crate::render::objectspace::GatherFilter;

use super::{
    AnisoTaps, LevelPair, LevelTexels, MarkInputs, PixelSample, TEXEL_TOLERANCE, aniso_choices, bilinear_taps,
    chart_footprint, floor_candidates, level_choices, level_of_detail, lod_tolerance, sample_pixel_at,
    variable_rate_bias,
};

/// Bound on a gathered colour channel besides the weights' error, in
/// units in the last place of `Rgba16Float` at the twin's value
/// ([`super::f16_ulp`]): the HDR target stores 11 significant bits
/// (lavapipe rounds towards zero: up to one unit), and the GPU's `f32`
/// rounding of the weights and the sum may carry a value across a rounding
/// step. On lavapipe the largest difference in `tests/it/stage_twins.rs` is
/// 1.0 unit.
pub const COLOR_ULPS: f32 = 2.0;

/// One way the GPU may gather a pixel: one outcome of its near-boundary
/// decisions.
#[derive(Clone, Debug, PartialEq)]
pub struct GatherTaps {
    pub level: u32,
    /// Level-local texels of the taps, clamped into the level: bilinear's
    /// top-left, right, lower, lower right (`taps` in `gather.wgsl`), or the
    /// B-spline's 4x4 row by row ([`level_taps`]).
    pub taps: Vec<IVec2>,
    /// The filter's weights of the taps, before island filtering.
    pub weights: Vec<f32>,
    /// Which taps lie in the pixel's chart island (their triangle map names
    /// a triangle of its island).
    pub kept: Vec<bool>,
    /// The filtered colour; `None` when a tap's page has no physical page
    /// (the GPU shades the pixel forward then).
    pub color: Option<Vec3>,
    /// How far (per channel) the GPU's colour may be from `color` through
    /// the error of its bilinear coordinate (up to [`TEXEL_TOLERANCE`] of
    /// the level's side) moving the weights; [`COLOR_ULPS`] come on top.
    pub weight_tolerance: f32,
    /// The kept taps' weights sum to so little that the GPU's rounding may
    /// change which of them count: the colour is not checked.
    pub fragile: bool,
}

impl GatherTaps {
    /// Whether the GPU's colour `gpu` is what this outcome filters, within
    /// the bounds. Fragile outcomes and those with no colour match nothing.
    pub fn matches(&self, gpu: Vec3) -> bool {
        self.bound_used(gpu) <= 1.0
    }

    /// The largest share of its bound that a channel of the GPU's colour
    /// `gpu` uses (1: at the bound); infinite for fragile outcomes and
    /// those with no colour.
    pub fn bound_used(&self, gpu: Vec3) -> f32 {
        let Some(c) = self.color.filter(|_| !self.fragile) else { return f32::INFINITY };
        (0..3)
            .map(|i| (gpu[i] - c[i]).abs() / (COLOR_ULPS * super::f16_ulp(c[i]) + self.weight_tolerance))
            .fold(0.0, f32::max)
    }
}

/// One way the GPU may gather a pixel from its levels: the finer level's
/// filter where `pair.t < 1`, the coarser's where `pair.t > 0`, each at the
/// pixel's anisotropic taps (`filter_taps` in `gather.wgsl`: one with
/// `--os-aniso 1`) and averaged, blended `(1 - t) fine + t coarse`.
#[derive(Clone, Debug, PartialEq)]
pub struct GatherOutcome {
    pub pair: LevelPair,
    /// The taps read (`taps.count` points; a single one with `--os-aniso 1`).
    pub taps: AnisoTaps,
    /// The finer level's filter at each tap, in order; empty where it is not read.
    pub fine: Vec<GatherTaps>,
    /// The coarser level's filter at each tap; empty where it is not read.
    pub coarse: Vec<GatherTaps>,
    /// How far `t` may be from the GPU's: the level's rounding
    /// ([`super::lod_tolerance`]) over the blend band's width, inside the band.
    pub blend_tolerance: f32,
}

/// The mean colour of a level's filters at the taps (`filter_taps`);
/// `Some(None)` when a tap has no physical page, `None` when the level is
/// not read.
fn taps_color(taps: &[GatherTaps]) -> Option<Option<Vec3>> {
    if taps.is_empty() {
        return None;
    }
    Some(taps.iter().map(|g| g.color).sum::<Option<Vec3>>().map(|c| c / taps.len() as f32))
}

/// The mean weight tolerance of a level's filters at the taps (0 where not read).
fn taps_tolerance(taps: &[GatherTaps]) -> f32 {
    if taps.is_empty() { 0.0 } else { taps.iter().map(|g| g.weight_tolerance).sum::<f32>() / taps.len() as f32 }
}

impl GatherOutcome {
    /// The levels' filters that this outcome reads, every tap's.
    pub fn taps(&self) -> impl Iterator<Item = &GatherTaps> {
        self.fine.iter().chain(&self.coarse)
    }

    /// The blended colour; `None` when a level's tap has no physical page.
    pub fn color(&self) -> Option<Vec3> {
        let t = self.pair.t;
        let fine = taps_color(&self.fine).map_or(Some(Vec3::ZERO), |c| c.map(|c| c * (1.0 - t)))?;
        let coarse = taps_color(&self.coarse).map_or(Some(Vec3::ZERO), |c| c.map(|c| c * t))?;
        Some(fine + coarse)
    }

    /// A level's kept taps weigh too little to check (see [`GatherTaps::fragile`]).
    pub fn fragile(&self) -> bool {
        self.taps().any(|g| g.fragile)
    }

    /// Whether the GPU's colour `gpu` is what this outcome gathers, within
    /// the bounds. Fragile outcomes and those with no colour match nothing.
    pub fn matches(&self, gpu: Vec3) -> bool {
        self.bound_used(gpu) <= 1.0
    }

    /// The largest share of its bound that a channel of the GPU's colour
    /// `gpu` uses (1: at the bound); infinite for fragile outcomes and
    /// those with no colour. The levels' weight tolerances count by their
    /// weights, and the two levels' difference by how far `t` may move.
    pub fn bound_used(&self, gpu: Vec3) -> f32 {
        let (Some(c), Some(bound)) = (self.color(), self.bound()) else { return f32::INFINITY };
        (0..3).map(|i| (gpu[i] - c[i]).abs() / bound[i]).fold(0.0, f32::max)
    }

    /// How far (per channel) the GPU's colour may be from [`Self::color`]:
    /// [`COLOR_ULPS`], the levels' weight tolerances by their weights, and
    /// the two levels' difference by how far `t` may move. `None` for
    /// fragile outcomes and those with no colour.
    pub fn bound(&self) -> Option<Vec3> {
        let c = self.color().filter(|_| !self.fragile())?;
        let t = self.pair.t;
        let weights = taps_tolerance(&self.fine) * (1.0 - t) + taps_tolerance(&self.coarse) * t;
        let spread = match (taps_color(&self.fine), taps_color(&self.coarse)) {
            (Some(f), Some(g)) => (f.expect("checked") - g.expect("checked")).abs(),
            _ => Vec3::ZERO,
        };
        Some(Vec3::from_array(std::array::from_fn(|i| {
            COLOR_ULPS * super::f16_ulp(c[i]) + weights + spread[i] * self.blend_tolerance
        })))
    }
}

/// What the gather writes for a pixel.
#[derive(Clone, Debug, PartialEq)]
pub enum PixelGather {
    /// Background: black.
    Background,
    /// An object outside the atlas, shaded forward in the gather (not twinned).
    Forward,
    /// Filtered from the atlas: every outcome the GPU may take.
    Atlas(Vec<GatherOutcome>),
}

/// The levels (object, level) [`gather_pixel`] may read for a pixel
/// (none for background and forward-shaded objects).
pub fn pixel_levels(inputs: &MarkInputs, pixel: UVec2, ids: [u32; 2]) -> Vec<(usize, u32)> {
    pixel_levels_at(inputs, pixel, Vec2::splat(0.5), ids)
}

/// [`pixel_levels`] for the point `at` of the pixel (a [`super::SampleGroup`]'s).
pub fn pixel_levels_at(inputs: &MarkInputs, pixel: UVec2, at: Vec2, ids: [u32; 2]) -> Vec<(usize, u32)> {
    if ids[0] == 0 {
        return Vec::new();
    }
    let p = sample_pixel_at(inputs.scene, inputs.view, pixel, at, ids);
    let e = &inputs.entries[p.object];
    if e.size == 0 {
        return Vec::new();
    }
    let tolerance = lod_tolerance(&inputs.params);
    let mut levels: Vec<u32> =
        level_choices(pixel_lod(inputs, &p), e.level_count, inputs.params.level_blend, tolerance)
            .iter()
            .flat_map(LevelPair::levels)
            .collect();
    levels.sort_unstable();
    levels.dedup();
    levels.into_iter().map(|l| (p.object, l)).collect()
}

/// The unrounded level of the point `p` (as marking computes it).
fn pixel_lod(inputs: &MarkInputs, p: &PixelSample) -> f32 {
    let f = chart_footprint(inputs.scene, p);
    let normals = &inputs.scene.meshes[inputs.scene.objects[p.object].mesh].normals;
    let bias = variable_rate_bias(inputs.params.variable_rate, p.tri.map(|v| normals[v]));
    level_of_detail(&inputs.entries[p.object], &inputs.params, &f, bias)
}

/// The bilinear weights of `gather.wgsl` for the fractions `w` of the
/// right and lower taps.
pub fn tap_weights(w: Vec2) -> [f32; 4] {
    [(1.0 - w.x) * (1.0 - w.y), w.x * (1.0 - w.y), (1.0 - w.x) * w.y, w.x * w.y]
}

/// The cubic B-spline weights of `bspline_weights` in `gather.wgsl`: the
/// four texels around a point at fraction `f` past the second one's centre.
pub fn bspline_weights(f: f32) -> [f32; 4] {
    let g = 1.0 - f;
    let (f2, f3) = (f * f, f * f * f);
    [g * g * g, 3.0 * f3 - 6.0 * f2 + 4.0, -3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0, f3].map(|w| w / 6.0)
}

/// The Mitchell-Netravali cubic (B = C = 1/3) at distance `x` (0 to 2), as
/// `mitchell` in `gather.wgsl`.
fn mitchell(x: f32) -> f32 {
    if x < 1.0 {
        ((7.0 * x - 12.0) * x * x + 16.0 / 3.0) / 6.0
    } else {
        (((-7.0 / 3.0 * x + 12.0) * x - 20.0) * x + 32.0 / 3.0) / 6.0
    }
}

/// The weights of `cubic_weights` in `gather.wgsl` for `filter` (a cubic).
pub fn cubic_weights(filter: GatherFilter, f: f32) -> [f32; 4] {
    match filter {
        GatherFilter::Mitchell => [mitchell(1.0 + f), mitchell(f), mitchell(1.0 - f), mitchell(2.0 - f)],
        _ => bspline_weights(f),
    }
}

/// The taps and weights `gather.wgsl` reads in a level of side `size` for
/// the unclamped top-left bilinear texel `base` and fractions `w`: bilinear's
/// four, or a cubic's 4x4 from `base - 1`, row by row
/// (`filter_level_cubic`); clamped into the level.
pub fn level_taps(filter: GatherFilter, size: u32, base: IVec2, w: Vec2) -> (Vec<IVec2>, Vec<f32>) {
    if filter == GatherFilter::Bilinear {
        let (lo, hi) = bilinear_taps(size, base);
        return (vec![lo, IVec2::new(hi.x, lo.y), IVec2::new(lo.x, hi.y), hi], tap_weights(w).to_vec());
    }
    let high = IVec2::splat(size as i32 - 1);
    let (wx, wy) = (cubic_weights(filter, w.x), cubic_weights(filter, w.y));
    let mut taps = Vec::with_capacity(16);
    let mut weights = Vec::with_capacity(16);
    for (j, wy) in wy.iter().enumerate() {
        for (i, wx) in wx.iter().enumerate() {
            taps.push((base + IVec2::new(i as i32 - 1, j as i32 - 1)).clamp(IVec2::ZERO, high));
            weights.push(wx * wy);
        }
    }
    (taps, weights)
}

/// The colour of one outcome: `gather.wgsl`'s island filter and weighted
/// sum over the taps' shades.
pub fn filter_taps(
    level: &LevelTexels,
    own_island: u32,
    islands: &[u32],
    level_index: u32,
    taps: &[IVec2],
    weights: &[f32],
) -> GatherTaps {
    let texels: Vec<usize> = taps.iter().map(|&t| level.index(t)).collect();
    let shades: Vec<Option<[f32; 4]>> = texels.iter().map(|&i| level.shades[i]).collect();
    let kept: Vec<bool> = texels
        .iter()
        .map(|&i| level.triangles[i].is_some_and(|id| id != 0 && islands[id as usize - 1] == own_island))
        .collect();
    let kept_weight: f32 = weights.iter().zip(&kept).map(|(w, &k)| w * f32::from(k)).sum();
    let w: Vec<f32> = if kept_weight > 0.0 {
        weights.iter().zip(&kept).map(|(w, &k)| w * f32::from(k) / kept_weight).collect()
    } else {
        weights.to_vec()
    };
    let rgb = |s: &Option<[f32; 4]>| Vec3::from_slice(&s.expect("checked")[..3]);
    let color = shades.iter().all(Option::is_some).then(|| shades.iter().zip(&w).map(|(s, &w)| rgb(s) * w).sum());
    // The colour moves by at most the spread of the taps' shades per texel
    // the filter's coordinate moves, along each axis (the weights' slopes
    // sum to at most 2 along an axis, bilinear's; the B-spline's to 1.5),
    // divided by the kept weight it is renormalized by.
    let delta = level.size as f32 * TEXEL_TOLERANCE;
    let spread = color.map_or(0.0, |_| {
        let s: Vec<Vec3> = shades.iter().map(rgb).collect();
        (s.iter().copied().fold(Vec3::MIN, Vec3::max) - s.iter().copied().fold(Vec3::MAX, Vec3::min)).max_element()
    });
    let any_kept = kept.iter().any(|&k| k);
    let norm = if kept_weight > 0.0 { kept_weight } else { 1.0 };
    GatherTaps {
        level: level_index,
        taps: taps.to_vec(),
        weights: weights.to_vec(),
        kept,
        color,
        weight_tolerance: 4.0 * delta * spread / norm,
        fragile: any_kept && kept_weight < 4.0 * delta,
    }
}

/// Mirrors `gather` for pixel `pixel` whose visibility ids are `ids`:
/// every outcome of its near-boundary decisions. `islands` holds the chart
/// island of each triangle of each object's mesh (`triangle_charts`);
/// `level(object, level)` the texels of the levels [`pixel_levels`] names.
pub fn gather_pixel<'a>(
    inputs: &MarkInputs,
    islands: &[Vec<u32>],
    pixel: UVec2,
    ids: [u32; 2],
    level: impl Fn(usize, u32) -> &'a LevelTexels,
) -> PixelGather {
    gather_pixel_at(inputs, islands, pixel, Vec2::splat(0.5), ids, level)
}

/// [`gather_pixel`] at the point `at` of the pixel (a [`super::SampleGroup`]'s,
/// under MSAA). A point outside its triangle widens the bilinear
/// coordinate's tolerance by the square of its [`super::extrapolation`], as
/// marking's twin does.
pub fn gather_pixel_at<'a>(
    inputs: &MarkInputs,
    islands: &[Vec<u32>],
    pixel: UVec2,
    at: Vec2,
    ids: [u32; 2],
    level: impl Fn(usize, u32) -> &'a LevelTexels,
) -> PixelGather {
    if ids[0] == 0 {
        return PixelGather::Background;
    }
    let p = sample_pixel_at(inputs.scene, inputs.view, pixel, at, ids);
    let reach = super::extrapolation(p.b).powi(2);
    let e = &inputs.entries[p.object];
    if e.size == 0 {
        return PixelGather::Forward;
    }
    let f = chart_footprint(inputs.scene, &p);
    let islands = &islands[p.object];
    let own = islands[p.triangle];
    // Every outcome of one level's filter at chart point `uv` (its bilinear
    // coordinate floored both ways when near an integer).
    // `slack`: the tap's position error beyond the chart point's (`AnisoTaps::slack`).
    let filters = |level_index: u32, uv: Vec2, slack: f32| -> Vec<GatherTaps> {
        let texels = level(p.object, level_index);
        let size = e.levels[level_index as usize].size;
        assert_eq!(texels.size, size, "object {} level {level_index}: texels of another size", p.object);
        let t = uv * size as f32 - 0.5;
        let tolerance = size as f32 * (TEXEL_TOLERANCE * reach + slack);
        let mut out = Vec::new();
        for x in floor_candidates(t.x, tolerance) {
            for y in floor_candidates(t.y, tolerance) {
                let base = IVec2::new(x, y);
                let (taps, weights) = level_taps(inputs.params.gather_filter, size, base, t - base.as_vec2());
                let mut g = filter_taps(texels, own, islands, level_index, &taps, &weights);
                // The weights move with the tap's wider error too.
                g.weight_tolerance *= reach + slack / TEXEL_TOLERANCE;
                out.push(g);
            }
        }
        out
    };
    // Every outcome of one level's filters at every tap of `taps`: each
    // tap's outcomes combined with the others'.
    let level_outcomes = |level_index: u32, taps: &AnisoTaps| -> Vec<Vec<GatherTaps>> {
        let mut combos: Vec<Vec<GatherTaps>> = vec![Vec::new()];
        for (i, uv) in taps.points().into_iter().enumerate() {
            let tap = filters(level_index, uv, taps.slack(i as u32));
            combos = combos
                .iter()
                .flat_map(|c| tap.iter().map(move |g| [c.as_slice(), std::slice::from_ref(g)].concat()))
                .collect();
        }
        combos
    };
    let blend = inputs.params.level_blend;
    let mut outcomes = Vec::new();
    for taps in aniso_choices(e.size, e.level_count, inputs.params.aniso, &f) {
        let tolerance = lod_tolerance(&inputs.params);
        for pair in level_choices(pixel_lod(inputs, &p), e.level_count, blend, tolerance) {
            let fine = if pair.t < 1.0 { level_outcomes(pair.lo, &taps) } else { vec![Vec::new()] };
            let coarse = if pair.t > 0.0 { level_outcomes(pair.hi, &taps) } else { vec![Vec::new()] };
            let blend_tolerance = if pair.t > 0.0 && pair.t < 1.0 { tolerance / blend } else { 0.0 };
            for fine in &fine {
                for coarse in &coarse {
                    outcomes.push(GatherOutcome {
                        pair,
                        taps,
                        fine: fine.clone(),
                        coarse: coarse.clone(),
                        blend_tolerance,
                    });
                }
            }
        }
    }
    PixelGather::Atlas(outcomes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4x4 level: shades are x + 10 y in red; triangle 1 (island 0) on
    /// columns 0-1, triangle 2 (island 5) on columns 2-3, row 3 empty.
    fn level() -> LevelTexels {
        let texel = |i: u32| IVec2::new(i as i32 % 4, i as i32 / 4);
        LevelTexels {
            size: 4,
            shades: (0..16).map(texel).map(|t| Some([(t.x + 10 * t.y) as f32, 0.0, 0.0, 1.0])).collect(),
            triangles: (0..16)
                .map(texel)
                .map(|t| {
                    Some(if t.y == 3 {
                        0
                    } else if t.x < 2 {
                        1
                    } else {
                        2
                    })
                })
                .collect(),
        }
    }

    const ISLANDS: [u32; 2] = [0, 5];

    fn taps(x: i32, y: i32) -> [IVec2; 4] {
        [IVec2::new(x, y), IVec2::new(x + 1, y), IVec2::new(x, y + 1), IVec2::new(x + 1, y + 1)]
    }

    #[test]
    fn weights_interpolate_along_each_axis() {
        assert_eq!(tap_weights(Vec2::new(0.25, 0.5)), [0.375, 0.125, 0.375, 0.125]);
        // Inside one island: the bilinear interpolation of x + 10 y.
        let g = filter_taps(&level(), 0, &ISLANDS, 0, &taps(0, 0), &tap_weights(Vec2::new(0.25, 0.5)));
        assert_eq!(g.kept, [true; 4]);
        assert_eq!(g.color, Some(Vec3::new(0.25 + 5.0, 0.0, 0.0)));
        // Swapping the right and lower taps' weights is a different colour.
        let swapped = GatherTaps { color: Some(Vec3::new(0.5 + 2.5, 0.0, 0.0)), ..g.clone() };
        assert!(g.matches(g.color.unwrap()) && !swapped.matches(g.color.unwrap()));
    }

    #[test]
    fn taps_outside_the_island_are_left_out() {
        // Columns 1-2 straddle the islands: the pixel of island 0 keeps column 1 only.
        let g = filter_taps(&level(), 0, &ISLANDS, 0, &taps(1, 0), &tap_weights(Vec2::new(0.5, 0.5)));
        assert_eq!(g.kept, [true, false, true, false]);
        assert_eq!(g.color, Some(Vec3::new(1.0 + 5.0, 0.0, 0.0)));
        // Row 3 has no triangle: taps there are left out too.
        let g = filter_taps(&level(), 5, &ISLANDS, 0, &taps(2, 2), &tap_weights(Vec2::new(0.5, 0.25)));
        assert_eq!(g.kept, [true, true, false, false]);
        assert_eq!(g.color, Some(Vec3::new(22.5, 0.0, 0.0)));
        // No tap in the island: all four, unfiltered.
        let g = filter_taps(&level(), 7, &ISLANDS, 0, &taps(0, 0), &tap_weights(Vec2::new(0.5, 0.5)));
        assert_eq!((g.kept, g.color), (vec![false; 4], Some(Vec3::new(5.5, 0.0, 0.0))));
        // Kept taps of weight 0 only: the GPU's rounding decides, unchecked.
        let g = filter_taps(&level(), 5, &ISLANDS, 0, &taps(1, 0), &tap_weights(Vec2::new(0.0, 0.5)));
        assert!(g.fragile && !g.matches(g.color.unwrap()));
    }

    #[test]
    fn bspline_taps_reproduce_a_linear_ramp() {
        // One triangle over an 8x8 level of shades x + 10 y.
        let l = LevelTexels {
            size: 8,
            shades: (0..64).map(|i| Some([(i % 8 + 10 * (i / 8)) as f32, 0.0, 0.0, 1.0])).collect(),
            triangles: vec![Some(1); 64],
        };
        let w = bspline_weights(0.3);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6 && w.iter().all(|&w| w > 0.0), "{w:?}");
        // The point 3.25, 3.5 (base 3, 3): the 4x4 from texel 2, 2, and the
        // cubic B-spline reproduces a linear function exactly.
        let (taps, weights) = level_taps(GatherFilter::Bspline, 8, IVec2::new(3, 3), Vec2::new(0.25, 0.5));
        assert_eq!((taps.len(), taps[0], taps[15]), (16, IVec2::new(2, 2), IVec2::new(5, 5)));
        let g = filter_taps(&l, 0, &[0], 0, &taps, &weights);
        assert!((g.color.unwrap().x - 38.25).abs() < 1e-4, "{:?}", g.color);
        // At the level's corner the taps clamp into it (the ramp bends there).
        let (taps, _) = level_taps(GatherFilter::Bspline, 8, IVec2::new(-1, 7), Vec2::ZERO);
        assert_eq!((taps[0], taps[15]), (IVec2::new(0, 6), IVec2::new(1, 7)));
        // Mitchell's weights sum to 1 too, with small negative outer lobes.
        let m = cubic_weights(GatherFilter::Mitchell, 0.5);
        assert!((m.iter().sum::<f32>() - 1.0).abs() < 1e-6 && m[0] < 0.0 && m[3] < 0.0, "{m:?}");
        assert!((cubic_weights(GatherFilter::Mitchell, 0.0)[1] - 8.0 / 9.0).abs() < 1e-6);
        // Bilinear's four are unchanged.
        assert_eq!(
            level_taps(GatherFilter::Bilinear, 8, IVec2::new(3, 3), Vec2::new(0.25, 0.5)),
            (taps4(3, 3), tap_weights(Vec2::new(0.25, 0.5)).to_vec())
        );
    }

    fn taps4(x: i32, y: i32) -> Vec<IVec2> {
        taps(x, y).to_vec()
    }

    #[test]
    fn unbacked_taps_have_no_colour() {
        let mut l = level();
        l.shades[5] = None;
        assert_eq!(filter_taps(&l, 0, &ISLANDS, 0, &taps(0, 0), &tap_weights(Vec2::ZERO)).color, None);
    }
}
