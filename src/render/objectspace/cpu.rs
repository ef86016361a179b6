//! CPU twin of tile marking: plain-Rust versions of the pixel reconstruction
//! in `objectspace.wgsl` and of the marking pass in
//! `mark/mark.wgsl`, to check the GPU's marking state against (as Vello
//! keeps CPU versions of its GPU stages).
//!
//! The functions use the WGSL's formulas in the same order, in `f32`. The GPU
//! may still round differently (fused multiply-adds, approximate `log2`,
//! `normalize` and `sqrt`), so a pixel close to a decision (its mip level
//! within [`LOD_TOLERANCE`] of a rounding boundary, or a bilinear coordinate
//! within [`TEXEL_TOLERANCE`] of a texel boundary) counts every outcome:
//! [`visible_tiles`] returns the tiles every outcome marks (`must`) and the
//! tiles some outcome marks (`may`), and the GPU's visible set must lie in
//! between.
//!
//! The stages after marking have twins of their own: [`shade`] (a texel's
//! triangle, barycentrics and Phong shade) and [`gather`] (a pixel's level,
//! bilinear taps, weights, kept taps and filtered colour).

pub mod gather;
pub mod shade;

use std::collections::{BTreeMap, BTreeSet};

use glam::{IVec2, Mat4, UVec2, Vec2, Vec3, Vec4, Vec4Swizzles};

use super::atlas::{GpuAtlasEntry, GpuAtlasLevel};
use super::{GatherFilter, MsaaGather};
use crate::render::gpu_types::GpuView;
use crate::scene::{Mesh, Scene};

/// How far (in levels) a pixel's unrounded mip level may be from a rounding
/// boundary (x.5) and still be rounded either way. The level is
/// `log2(rho) + biases`, so 1.5e-4 levels is a relative error of 1e-4 in the
/// footprint `rho`. On lavapipe no pixel of `tests/it/mark_twin.rs` rounds
/// differently even with no tolerance (the closest came within 4e-6 of x.5),
/// and the margin makes a few dozen pixels a frame ambiguous, a tile or two.
pub const LOD_TOLERANCE: f32 = 1.5e-4;

/// How far (as a fraction of the level's side) a bilinear coordinate
/// `t = uv * size - 0.5` may be from an integer and still be floored either
/// way. The chart UV's error is absolute (the barycentrics' rounding, from
/// cross products of clip coordinates tens of units large, times the UV
/// extent of the triangle), so the error of `t` grows with the side. On
/// lavapipe one atrium pixel of `tests/it/mark_twin.rs` has `t` 8.6e-7 of the
/// side from an integer (1.1e-4 texels at 128) and is floored the other way
/// on the GPU; 1e-5 leaves a tenfold margin.
pub const TEXEL_TOLERANCE: f32 = 1e-5;

/// The `Params` fields that marking reads (`objectspace::resources::GpuParams`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarkParams {
    /// This frame's stamp (frames rendered so far, this one included).
    pub stamp: u32,
    pub reuse: u32,
    /// Stamp of the first frame with this frame's view.
    pub view_since: u32,
    pub tile_size: u32,
    pub mip_bias: f32,
    pub variable_rate: f32,
    /// Width of the band over which a pixel blends two levels (0: none).
    pub level_blend: f32,
    /// How the gather filters a level: marking marks the tiles of the
    /// texels it reads ([`GatherFilter::margin`] beyond the bilinear pair).
    pub gather_filter: GatherFilter,
    /// Most gather taps along the footprint's longer axis (`--os-aniso`).
    pub aniso: u32,
}

/// Everything the marking pass reads besides the visibility buffer.
#[derive(Clone, Copy, Debug)]
pub struct MarkInputs<'a> {
    /// The scene as uploaded: positions, normals and chart UVs per mesh,
    /// indices, object transforms.
    pub scene: &'a Scene,
    /// The frame's view uniform (`scene_gpu::gpu_view`).
    pub view: &'a GpuView,
    /// The atlas table as the GPU holds it this frame (`valid_since` included).
    pub entries: &'a [GpuAtlasEntry],
    pub params: MarkParams,
}

/// The chart UVs the GPU shades through: `uv1`, or else `uv0` (as
/// `SceneGpu::new` uploads them).
pub fn chart_uvs(mesh: &Mesh) -> &[Vec2] {
    mesh.uv1.as_deref().unwrap_or(&mesh.uv0)
}

/// Mirrors `pixel_ndc`: the NDC point of a pixel's centre. `viewport` is
/// (width, height, 1/width, 1/height).
pub fn pixel_ndc(pixel: Vec2, viewport: Vec4) -> Vec2 {
    point_ndc(pixel + 0.5, viewport)
}

/// Mirrors `point_ndc`: the NDC point of screen point `xy` (in pixels).
pub fn point_ndc(xy: Vec2, viewport: Vec4) -> Vec2 {
    let uv = xy * viewport.zw();
    Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0)
}

/// Mirrors `standard_sample_position`: Vulkan's standard position of
/// sample `s` of `count` (0..1 from the pixel's top-left corner).
pub fn standard_sample_position(count: u32, s: u32) -> Vec2 {
    const SAMPLES_2: [[f32; 2]; 2] = [[0.75, 0.75], [0.25, 0.25]];
    const SAMPLES_4: [[f32; 2]; 4] = [[0.375, 0.125], [0.875, 0.375], [0.125, 0.625], [0.625, 0.875]];
    const SAMPLES_8: [[f32; 2]; 8] = [
        [0.5625, 0.3125],
        [0.4375, 0.6875],
        [0.8125, 0.5625],
        [0.3125, 0.1875],
        [0.1875, 0.8125],
        [0.0625, 0.4375],
        [0.6875, 0.9375],
        [0.9375, 0.0625],
    ];
    let table: &[[f32; 2]] = match count {
        2 => &SAMPLES_2,
        4 => &SAMPLES_4,
        8 => &SAMPLES_8,
        _ => return Vec2::splat(0.5),
    };
    Vec2::from(table[s as usize])
}

/// What the shade pass writes in the alpha of a texel whose triangle lies
/// in chart island `island` (`island_code` in `objectspace.wgsl`): the half
/// float of bit pattern 1024 + `island`, a normal number for islands below
/// [`super::gather::ISLAND_CODES`].
pub fn island_code(island: u32) -> f32 {
    let bits = 1024 + island;
    let mantissa = (bits & 1023) as f32 / 1024.0;
    (1.0 + mantissa) * 2f32.powi((bits >> 10) as i32 - 15)
}

/// Mirrors `same_chart_surface`: both background, or one object's
/// triangles in one chart island (`islands[object][triangle]`).
pub fn same_chart_surface(islands: &[Vec<u32>], a: [u32; 2], b: [u32; 2]) -> bool {
    if a[0] != b[0] {
        return false;
    }
    if a[0] == 0 || a[1] == b[1] {
        return true;
    }
    let object = &islands[a[0] as usize - 1];
    object[a[1] as usize] == object[b[1] as usize]
}

/// How far barycentrics `b` extrapolate their triangle: the sum of their
/// magnitudes (1 inside it). Their normalising sum then cancels by that
/// factor, and each is that much larger, so the chart point's rounding
/// error grows with its square, and [`TEXEL_TOLERANCE`] is widened by it.
/// Under MSAA a group's point may lie outside the triangle it is rebuilt
/// on (its first sample's; other triangles of the island cover it): on
/// lavapipe a pixel of the atrium at 4 samples (`tests/it/mark_twin.rs`,
/// barycentrics (1.29, -1.54, 1.26), a sum of 4.08, on a finely split
/// column seen edge-on) had its bilinear coordinate 4.3e-5 of the side
/// from the twin's.
pub fn extrapolation(b: Vec3) -> f32 {
    b.abs().element_sum().max(1.0)
}

/// Mirrors `SampleGroup`: samples of a pixel marked and gathered as one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleGroup {
    /// Its first sample's ids (`[0] == 0`: background).
    pub ids: [u32; 2],
    /// The point (0..1 in the pixel): its samples' centroid, or the
    /// pixel's centre where they are all of its samples.
    pub at: Vec2,
    /// Its samples.
    pub count: u32,
}

/// Mirrors the loop of `sample_group` that marking and the gather run over
/// a pixel whose samples' ids are `samples` (its sample count of them): its
/// groups, in their order.
pub fn sample_groups(islands: &[Vec<u32>], samples: &[[u32; 2]], mode: MsaaGather) -> Vec<SampleGroup> {
    let n = samples.len() as u32;
    let mut left: u32 = (1 << n) - 1;
    let mut out = Vec::new();
    while left != 0 {
        let first = left.trailing_zeros();
        let ids = samples[first as usize];
        let mut mask = 1u32 << first;
        if mode == MsaaGather::Pixel {
            for s in first + 1..n {
                if left & (1 << s) != 0 && same_chart_surface(islands, samples[s as usize], ids) {
                    mask |= 1 << s;
                }
            }
        }
        let count = mask.count_ones();
        let mut at = Vec2::splat(0.5);
        if count < n {
            // Summed in sample order, as the WGSL does.
            let sum = (first..n)
                .filter(|s| mask & (1 << s) != 0)
                .fold(Vec2::ZERO, |sum, s| sum + standard_sample_position(n, s));
            at = sum / count as f32;
        }
        out.push(SampleGroup { ids, at, count });
        left &= !mask;
    }
    out
}

/// Mirrors `barycentrics`: homogeneous, perspective-correct barycentrics of
/// NDC point `q` for clip-space vertices (x, y, w).
pub fn barycentrics(c0: Vec3, c1: Vec3, c2: Vec3, q: Vec2) -> Vec3 {
    let r = q.extend(1.0);
    let e = Vec3::new(c1.cross(c2).dot(r), c2.cross(c0).dot(r), c0.cross(c1).dot(r));
    e / (e.x + e.y + e.z)
}

/// Mirrors `PixelSample`: what a visibility-buffer pixel sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSample {
    pub object: usize,
    pub triangle: usize,
    /// The triangle's vertices, as indices into its mesh.
    pub tri: [usize; 3],
    /// Barycentrics at the pixel centre, one pixel right, one pixel down.
    pub b: Vec3,
    pub b_dx: Vec3,
    pub b_dy: Vec3,
}

/// Mirrors `sample_pixel`: rebuilds pixel `pixel` whose visibility ids are
/// `(object + 1, triangle)`, object non-zero. Panics on ids outside the scene.
pub fn sample_pixel(scene: &Scene, view: &GpuView, pixel: UVec2, ids: [u32; 2]) -> PixelSample {
    sample_pixel_at(scene, view, pixel, Vec2::splat(0.5), ids)
}

/// Mirrors `sample_pixel_at`: [`sample_pixel`] at point `at` of the pixel
/// (0..1 from its top-left corner), derivatives one pixel apart.
pub fn sample_pixel_at(scene: &Scene, view: &GpuView, pixel: UVec2, at: Vec2, ids: [u32; 2]) -> PixelSample {
    let object = ids[0] as usize - 1;
    let triangle = ids[1] as usize;
    let o = &scene.objects[object];
    let mesh = &scene.meshes[o.mesh];
    let tri = [0, 1, 2].map(|k| mesh.indices[3 * triangle + k] as usize);
    let mvp: Mat4 = view.view_proj * o.transform;
    let [c0, c1, c2] = tri.map(|v| (mvp * mesh.positions[v].extend(1.0)).xyw());
    let q = point_ndc(pixel.as_vec2() + at, view.viewport);
    let step = 2.0 * view.viewport.zw();
    PixelSample {
        object,
        triangle,
        tri,
        b: barycentrics(c0, c1, c2, q),
        b_dx: barycentrics(c0, c1, c2, q + Vec2::new(step.x, 0.0)),
        b_dy: barycentrics(c0, c1, c2, q - Vec2::new(0.0, step.y)),
    }
}

/// Mirrors `interpolate2`.
fn interpolate2(b: Vec3, a: Vec2, c: Vec2, d: Vec2) -> Vec2 {
    a * b.x + c * b.y + d * b.z
}

/// Mirrors `ChartFootprint`: chart UV of a pixel and its screen derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartFootprint {
    pub uv: Vec2,
    pub du_dx: Vec2,
    pub du_dy: Vec2,
}

/// Mirrors `chart_footprint`.
pub fn chart_footprint(scene: &Scene, p: &PixelSample) -> ChartFootprint {
    let charts = chart_uvs(&scene.meshes[scene.objects[p.object].mesh]);
    let [a, c, d] = p.tri.map(|v| charts[v]);
    let uv = interpolate2(p.b, a, c, d);
    ChartFootprint { uv, du_dx: interpolate2(p.b_dx, a, c, d) - uv, du_dy: interpolate2(p.b_dy, a, c, d) - uv }
}

/// Mirrors `variable_rate_bias`: up to `variable_rate` levels coarser where
/// the triangle's vertex normals agree, none where they diverge.
pub fn variable_rate_bias(variable_rate: f32, normals: [Vec3; 3]) -> f32 {
    if variable_rate <= 0.0 {
        return 0.0;
    }
    let [n0, n1, n2] = normals.map(Vec3::normalize);
    let min_dot = n0.dot(n1).min(n1.dot(n2).min(n0.dot(n2)));
    let curvature = ((1.0 - min_dot) * 8.0).clamp(0.0, 1.0);
    variable_rate * (1.0 - curvature)
}

/// The unrounded level of `select_level` (`footprint_level` plus the
/// biases): `log2(max(major / N, minor) * size) + biases`, major and minor
/// the lengths of the longer and shorter of dUV/dx and dUV/dy, N
/// [`MarkParams::aniso`].
pub fn level_of_detail(e: &GpuAtlasEntry, params: &MarkParams, f: &ChartFootprint, variable_rate_bias: f32) -> f32 {
    let size = e.size as f32;
    let (a, b) = (f.du_dx.length(), f.du_dy.length());
    let rho = (a.max(b) / params.aniso as f32).max(a.min(b)) * size;
    rho.max(1e-8).log2() + params.mip_bias + e.mip_bias + variable_rate_bias
}

/// How far (relative) the ratio of an anisotropic footprint's longer axis
/// to a tap's span, or its two axes' lengths, may be from a decision
/// (`ceil` to the tap count; which axis is the longer) and still go either
/// way on the GPU. The shorter axis is the difference of two close chart
/// UVs, whose absolute rounding error is a larger share of it than of the
/// longer axis: 10 times [`LOD_TOLERANCE`]'s relative error. With 1e-4 one
/// pixel of `tests/it/mark_twin.rs`'s atrium at `--os-aniso 8` (frame 1)
/// went the other way on lavapipe.
pub const ANISO_TOLERANCE: f32 = 1e-3;

/// The tolerance on a pixel's unrounded level ([`LOD_TOLERANCE`]): 10 times
/// wider with `--os-aniso` above 1, where the level follows the shorter
/// axis (see [`ANISO_TOLERANCE`]).
pub fn lod_tolerance(params: &MarkParams) -> f32 {
    if params.aniso > 1 { 10.0 * LOD_TOLERANCE } else { LOD_TOLERANCE }
}

/// The relative error of an anisotropic footprint's axis (`AnisoTaps::axis`)
/// on the GPU, for the position of its taps ([`AnisoTaps::slack`]): the
/// same as [`ANISO_TOLERANCE`]'s lengths.
pub const AXIS_TOLERANCE: f32 = 1e-3;

/// Mirrors `AnisoTaps`: the chart points the gather filters and averages
/// for a pixel (`--os-aniso`), `count` of them spread along `axis`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisoTaps {
    pub uv: Vec2,
    pub axis: Vec2,
    pub count: u32,
}

impl AnisoTaps {
    /// Mirrors `aniso_tap`: the chart point of tap `i`.
    pub fn tap(&self, i: u32) -> Vec2 {
        if self.count == 1 {
            return self.uv;
        }
        self.uv + self.axis * ((i as f32 + 0.5) / self.count as f32 - 0.5)
    }

    /// Every tap's chart point, in the gather's order.
    pub fn points(&self) -> Vec<Vec2> {
        (0..self.count).map(|i| self.tap(i)).collect()
    }

    /// How far (in chart UV) the GPU's tap `i` may be from [`Self::tap`]'s
    /// beyond the chart point's own error ([`TEXEL_TOLERANCE`]): the axis's
    /// error ([`AXIS_TOLERANCE`] of it, a difference of close chart UVs)
    /// times the tap's offset along it. A pixel at a silhouette may have an
    /// axis of most of the chart (its neighbour's barycentrics extrapolated
    /// far off the triangle): on lavapipe a far tap of one of the atrium at
    /// `--os-aniso 8` (axis 0.76 of the chart) floored the other way with
    /// no slack. One other there (pixel (77, 19) of path frame 12 at 128x72)
    /// is off by more than 3e-3 of its axis, which this twin does not cover.
    pub fn slack(&self, i: u32) -> f32 {
        if self.count == 1 {
            return 0.0;
        }
        self.axis.length() * ((i as f32 + 0.5) / self.count as f32 - 0.5).abs() * AXIS_TOLERANCE
    }
}

/// Mirrors `aniso_taps` for an object of level-0 side `size`, `level_count`
/// levels and at most `aniso` taps: every tap set the GPU may take (a tap
/// count near a `ceil` boundary both ways, and both axes where their
/// lengths nearly tie, see [`ANISO_TOLERANCE`]). Both axes are capped at
/// what the coarsest level resolves (the longer at `aniso` of its texels,
/// the shorter at one), so that a footprint extrapolated far off its
/// triangle (a silhouette) keeps its taps near the pixel's chart point.
pub fn aniso_choices(size: u32, level_count: u32, aniso: u32, f: &ChartFootprint) -> Vec<AnisoTaps> {
    let single = AnisoTaps { uv: f.uv, axis: Vec2::ZERO, count: 1 };
    if aniso <= 1 {
        return vec![single];
    }
    let (a, b) = (f.du_dx.length(), f.du_dy.length());
    let coarsest = (1u32 << (level_count - 1)) as f32;
    let longer = a.max(b) * size as f32;
    let major = longer.min(aniso as f32 * coarsest);
    let minor = (a.min(b) * size as f32).min(coarsest);
    let per_tap = (major / aniso as f32).max(minor).max(1.0);
    let ratio = major / per_tap;
    let mut counts: Vec<u32> = [ratio * (1.0 - ANISO_TOLERANCE), ratio, ratio * (1.0 + ANISO_TOLERANCE)]
        .iter()
        .map(|r| (r.ceil() as u32).clamp(1, aniso))
        .collect();
    counts.dedup();
    let mut axes = vec![if a >= b { f.du_dx } else { f.du_dy }];
    if (a - b).abs() <= ANISO_TOLERANCE * a.max(b) {
        axes = vec![f.du_dx, f.du_dy];
    }
    if longer > major {
        for axis in &mut axes {
            *axis *= major / longer;
        }
    }
    let mut out: Vec<AnisoTaps> = Vec::new();
    for &count in &counts {
        for &axis in &axes {
            let t = if count == 1 { single } else { AnisoTaps { uv: f.uv, axis, count } };
            if !out.contains(&t) {
                out.push(t);
            }
        }
    }
    out
}

/// The rest of `select_level`: WGSL `round` (ties to even), clamped to the
/// object's levels.
pub fn select_level(lod: f32, level_count: u32) -> u32 {
    lod.round_ties_even().clamp(0.0, (level_count - 1) as f32) as u32
}

/// Mirrors `LevelPair`: the levels a pixel reads, `lo` and `hi` (lo + 1,
/// or lo at the last level) with `hi`'s weight `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelPair {
    pub lo: u32,
    pub hi: u32,
    pub t: f32,
}

impl LevelPair {
    /// The levels marked and gathered: `lo` where t < 1, `hi` where t > 0.
    pub fn levels(&self) -> Vec<u32> {
        let mut out = Vec::new();
        if self.t < 1.0 {
            out.push(self.lo);
        }
        if self.t > 0.0 {
            out.push(self.hi);
        }
        out
    }
}

/// Mirrors `select_levels` for unrounded level `lod`: with `blend` 0 the
/// rounded level alone ([`select_level`]); else the coarser level's weight
/// rises from 0 to 1 over the `blend` levels around each x.5.
pub fn select_levels(lod: f32, level_count: u32, blend: f32) -> LevelPair {
    if blend <= 0.0 {
        let level = select_level(lod, level_count);
        return LevelPair { lo: level, hi: level, t: 0.0 };
    }
    let clamped = lod.clamp(0.0, (level_count - 1) as f32);
    let base = clamped.floor();
    let lo = base as u32;
    let hi = (lo + 1).min(level_count - 1);
    let t = if hi == lo { 0.0 } else { ((clamped - base - 0.5) / blend + 0.5).clamp(0.0, 1.0) };
    LevelPair { lo, hi, t }
}

/// Mirrors `Bilinear`: the footprint of a bilinear lookup in a level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bilinear {
    /// Top-left tap, level-local, clamped into the level.
    pub texel: IVec2,
    /// Bottom-right tap, clamped into the level.
    pub texel_hi: IVec2,
    /// Weight of the right and lower taps.
    pub weight: Vec2,
}

/// Mirrors `bilinear` for a level of side `size`.
pub fn bilinear(size: u32, uv: Vec2) -> Bilinear {
    let t = uv * size as f32 - 0.5;
    let base = t.floor();
    let (texel, texel_hi) = bilinear_taps(size, base.as_ivec2());
    Bilinear { texel, texel_hi, weight: t - base }
}

/// The clamped taps of `bilinear` for an unclamped top-left texel `base`.
pub fn bilinear_taps(size: u32, base: IVec2) -> (IVec2, IVec2) {
    let high = IVec2::splat(size as i32 - 1);
    (base.clamp(IVec2::ZERO, high), (base + 1).clamp(IVec2::ZERO, high))
}

/// Mirrors `mark_footprint`'s span: the first and last texels (clamped into
/// the level) that a filter reading `margin` texels beyond the bilinear pair
/// of top-left texel `base` reads.
pub fn filter_span(size: u32, base: IVec2, margin: u32) -> (IVec2, IVec2) {
    let high = IVec2::splat(size as i32 - 1);
    let m = margin as i32;
    ((base - m).clamp(IVec2::ZERO, high), (base + 1 + m).clamp(IVec2::ZERO, high))
}

/// Mirrors the tile index of `mark_tile`: the global tile holding a texel of a level.
pub fn tile_of(l: &GpuAtlasLevel, tile_size: u32, texel: IVec2) -> u32 {
    let tiles_per_row = l.size / tile_size;
    let t = texel.as_uvec2() / tile_size;
    l.tile_base + t.y * tiles_per_row + t.x
}

/// Mirrors the calls of `mark_tile` in `mark`: the tiles of a filter's
/// footprint from `texel` to `texel_hi` (at most 4 texels a side, so at
/// most two tiles along each axis: the top-left texel's, plus those the
/// others cross into).
pub fn footprint_tiles(l: &GpuAtlasLevel, tile_size: u32, texel: IVec2, texel_hi: IVec2) -> Vec<u32> {
    let lo = texel.as_uvec2() / tile_size;
    let hi = texel_hi.as_uvec2() / tile_size;
    let mut tiles = vec![tile_of(l, tile_size, texel)];
    if hi.x != lo.x {
        tiles.push(tile_of(l, tile_size, IVec2::new(texel_hi.x, texel.y)));
    }
    if hi.y != lo.y {
        tiles.push(tile_of(l, tile_size, IVec2::new(texel.x, texel_hi.y)));
    }
    if hi.x != lo.x && hi.y != lo.y {
        tiles.push(tile_of(l, tile_size, texel_hi));
    }
    tiles
}

/// The values `x` floors to when it may be off by up to `tolerance`.
pub fn floor_candidates(x: f32, tolerance: f32) -> impl Iterator<Item = i32> {
    let (low, high) = ((x - tolerance).floor() as i32, (x + tolerance).floor() as i32);
    low..=high
}

/// One level of an object's virtual texture as the GPU holds it
/// (`ObjectSpace::read_levels`), row-major, `size` texels a row: what the
/// twins of shade and gather read. `None` for texels of pages with no
/// physical page.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelTexels {
    pub size: u32,
    /// Shade (RGBA) per texel.
    pub shades: Vec<Option<[f32; 4]>>,
    /// Triangle + 1 covering the texel (0: none).
    pub triangles: Vec<Option<u32>>,
}

impl LevelTexels {
    /// Index of level-local texel `texel` (inside the level) in the rows.
    pub fn index(&self, texel: IVec2) -> usize {
        texel.y as usize * self.size as usize + texel.x as usize
    }
}

/// The spacing of `Rgba16Float` values (one unit in the last place) at
/// `x`, the unit of the shade and gather twins' bounds: 2^-10 of the
/// binade's base, 2^-24 among the subnormals.
pub fn f16_ulp(x: f32) -> f32 {
    let x = x.abs();
    if x < 2f32.powi(-14) { 2f32.powi(-24) } else { 2f32.powi(x.log2().floor() as i32 - 10) }
}

/// The level pairs a pixel of unrounded level `lod` may select on the GPU:
/// [`select_levels`] at `lod` and `tolerance` ([`lod_tolerance`]) either
/// side of it, each distinct set of levels read once (both sides of a
/// rounding boundary, or of a blend band's edge).
pub fn level_choices(lod: f32, level_count: u32, blend: f32, tolerance: f32) -> Vec<LevelPair> {
    let mut out: Vec<LevelPair> = Vec::new();
    for x in [lod - tolerance, lod, lod + tolerance] {
        let pair = select_levels(x, level_count, blend);
        if !out.iter().any(|p| p.levels() == pair.levels()) {
            out.push(pair);
        }
    }
    out
}

/// The tiles one pixel marks.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PixelTiles {
    /// Marked whichever way the GPU rounds.
    pub must: Vec<u32>,
    /// Marked by some way the GPU may round.
    pub may: Vec<u32>,
}

/// What `mark` marks for one pixel, over every outcome of its near-boundary
/// decisions (see [`LOD_TOLERANCE`], [`TEXEL_TOLERANCE`]). `None` for
/// objects outside the atlas (shaded forward).
pub fn pixel_tiles(inputs: &MarkInputs, pixel: UVec2, ids: [u32; 2]) -> Option<PixelTiles> {
    pixel_tiles_at(inputs, pixel, Vec2::splat(0.5), ids)
}

/// [`pixel_tiles`] for the point `at` of the pixel (a [`SampleGroup`]'s).
pub fn pixel_tiles_at(inputs: &MarkInputs, pixel: UVec2, at: Vec2, ids: [u32; 2]) -> Option<PixelTiles> {
    let p = sample_pixel_at(inputs.scene, inputs.view, pixel, at, ids);
    let reach = extrapolation(p.b).powi(2);
    let e = &inputs.entries[p.object];
    if e.size == 0 {
        return None;
    }
    let f = chart_footprint(inputs.scene, &p);
    let normals = &inputs.scene.meshes[inputs.scene.objects[p.object].mesh].normals;
    let bias = variable_rate_bias(inputs.params.variable_rate, p.tri.map(|v| normals[v]));
    let lod = level_of_detail(e, &inputs.params, &f, bias);
    let choices = level_choices(lod, e.level_count, inputs.params.level_blend, lod_tolerance(&inputs.params));
    let aniso = aniso_choices(e.size, e.level_count, inputs.params.aniso, &f);
    // Tiles of different levels differ: a tile is marked in every outcome
    // when every choice reads its level and, for every tap set, some tap
    // marks it whichever way its bilinear coordinate in that level floors.
    let mut must = Vec::new();
    let mut may = Vec::new();
    let mut levels: Vec<u32> = choices.iter().flat_map(LevelPair::levels).collect();
    levels.sort_unstable();
    levels.dedup();
    for level in levels {
        let l = &e.levels[level as usize];
        let mut level_must: Option<BTreeSet<u32>> = None;
        for taps in &aniso {
            let mut taps_must = BTreeSet::new();
            for (i, uv) in taps.points().into_iter().enumerate() {
                let tolerance = l.size as f32 * (TEXEL_TOLERANCE * reach + taps.slack(i as u32));
                // `t` as in `bilinear`, floored both ways when near an integer.
                let t = uv * l.size as f32 - 0.5;
                let mut outcomes: Vec<Vec<u32>> = Vec::new();
                for x in floor_candidates(t.x, tolerance) {
                    for y in floor_candidates(t.y, tolerance) {
                        let margin = inputs.params.gather_filter.margin();
                        let (texel, texel_hi) = filter_span(l.size, IVec2::new(x, y), margin);
                        outcomes.push(footprint_tiles(l, inputs.params.tile_size, texel, texel_hi));
                    }
                }
                let in_tap: Vec<u32> = outcomes.concat();
                taps_must.extend(in_tap.iter().copied().filter(|t| outcomes.iter().all(|o| o.contains(t))));
                may.extend(in_tap);
            }
            level_must = Some(match level_must {
                None => taps_must,
                Some(m) => m.intersection(&taps_must).copied().collect(),
            });
        }
        if choices.iter().all(|c| c.levels().contains(&level)) {
            must.extend(level_must.unwrap_or_default());
        }
    }
    may.sort_unstable();
    may.dedup();
    must.sort_unstable();
    must.dedup();
    Some(PixelTiles { must, may })
}

/// The tiles a frame's marking pass marks visible.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VisibleTiles {
    /// Tiles marked whichever way each pixel rounds: some pixel marks them in
    /// every one of its outcomes.
    pub must: BTreeSet<u32>,
    /// Tiles marked by some outcome of some pixel.
    pub may: BTreeSet<u32>,
    /// Pixels whose outcomes mark different tiles.
    pub ambiguous_pixels: usize,
}

/// [`pixel_tiles`] over a visibility buffer (row-major, `width` pixels a row,
/// `(object + 1, triangle)` per pixel, 0 = background).
pub fn visible_tiles(inputs: &MarkInputs, visibility: &[[u32; 2]], width: u32) -> VisibleTiles {
    let mut out = VisibleTiles::default();
    for (i, ids) in visibility.iter().enumerate().filter(|(_, ids)| ids[0] != 0) {
        let pixel = UVec2::new(i as u32 % width, i as u32 / width);
        if let Some(p) = pixel_tiles(inputs, pixel, *ids) {
            out.ambiguous_pixels += usize::from(p.must != p.may);
            out.must.extend(p.must);
            out.may.extend(p.may);
        }
    }
    out
}

/// [`visible_tiles`] under MSAA: `visibility` holds each pixel's `samples`
/// ids side by side (`VisibilityBuffer::read_samples`), and each pixel
/// marks the points of its [`sample_groups`] (`mode`,
/// `ObjectSpaceConfig::msaa_gather`); `islands` as [`same_chart_surface`]'s.
pub fn visible_tiles_samples(
    inputs: &MarkInputs,
    islands: &[Vec<u32>],
    (visibility, samples): (&[[u32; 2]], u32),
    width: u32,
    mode: MsaaGather,
) -> VisibleTiles {
    let mut out = VisibleTiles::default();
    for (i, pixel_samples) in visibility.chunks_exact(samples as usize).enumerate() {
        let pixel = UVec2::new(i as u32 % width, i as u32 / width);
        for g in sample_groups(islands, pixel_samples, mode).into_iter().filter(|g| g.ids[0] != 0) {
            if let Some(p) = pixel_tiles_at(inputs, pixel, g.at, g.ids) {
                out.ambiguous_pixels += usize::from(p.must != p.may);
                out.must.extend(p.must);
                out.may.extend(p.may);
            }
        }
    }
    out
}

/// The `new` rule of `mark_tile`: not visible in the previous frame.
pub fn is_new(previous_visible: u32, stamp: u32) -> bool {
    previous_visible == 0 || previous_visible.wrapping_add(1) != stamp
}

/// The queueing rule of `mark_tile`: never shaded, shaded before the
/// object's shades became stale, or shaded `reuse` or more frames ago with
/// another view (with reuse 1: every frame).
pub fn needs_shading(shaded: u32, stamp: u32, reuse: u32, valid_since: u32, view_since: u32) -> bool {
    if shaded == 0 || shaded < valid_since {
        return true;
    }
    if reuse > 1 && shaded >= view_since {
        return false;
    }
    stamp.wrapping_sub(shaded) >= reuse
}

/// The object and level owning a global tile (the `object << 8 | level` of
/// the queue entries, split), from the tile ranges of the atlas table.
pub fn tile_owner(entries: &[GpuAtlasEntry], tile_size: u32, tile: u32) -> Option<(u32, u32)> {
    entries.iter().enumerate().find_map(|(object, e)| {
        e.levels[..e.level_count as usize].iter().enumerate().find_map(|(level, l)| {
            let tiles = (l.size / tile_size) * (l.size / tile_size);
            (l.tile_base..l.tile_base + tiles).contains(&tile).then_some((object as u32, level as u32))
        })
    })
}

/// Per-tile marking state: the `tile_visible` and `tile_shaded` buffers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileState {
    /// Stamp of the last frame the tile was visible (0: never).
    pub visible: Vec<u32>,
    /// Stamp of the last frame the tile was shaded (0: never).
    pub shaded: Vec<u32>,
}

impl TileState {
    /// The state before the first frame: every tile never visible, never shaded.
    pub fn new(tile_count: usize) -> Self {
        Self { visible: vec![0; tile_count], shaded: vec![0; tile_count] }
    }
}

/// What `mark_tile` does to a frame's visible tiles.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameMarks {
    /// Visible tiles that were not visible in the previous frame.
    pub new: BTreeSet<u32>,
    /// Tiles queued for shading, each with its `object << 8 | level`.
    pub queued: BTreeMap<u32, u32>,
    /// The state after the frame.
    pub next: TileState,
}

/// Mirrors `mark_tile` for every tile of `visible` at once: the first mark of
/// a tile in a frame sees the state before the frame, and later marks of it
/// do nothing, so the order of the pixels does not matter.
pub fn mark_frame(
    previous: &TileState,
    visible: &BTreeSet<u32>,
    params: &MarkParams,
    entries: &[GpuAtlasEntry],
) -> FrameMarks {
    let stamp = params.stamp;
    let mut next = previous.clone();
    let mut new = BTreeSet::new();
    let mut queued = BTreeMap::new();
    for &tile in visible {
        let t = tile as usize;
        next.visible[t] = stamp;
        if is_new(previous.visible[t], stamp) {
            new.insert(tile);
        }
        let (object, level) = tile_owner(entries, params.tile_size, tile)
            .unwrap_or_else(|| panic!("tile {tile} lies in no object's atlas levels"));
        let valid_since = entries[object as usize].valid_since;
        if needs_shading(previous.shaded[t], stamp, params.reuse, valid_since, params.view_since) {
            next.shaded[t] = stamp;
            queued.insert(tile, (object << 8) | level);
        }
    }
    FrameMarks { new, queued, next }
}

#[cfg(test)]
mod tests {
    use glam::Mat4;

    use super::*;
    use crate::render::objectspace::atlas::AtlasLayout;
    use crate::render::objectspace::gather::ISLAND_CODES;
    use crate::scene::{Object, Scene};

    /// Island codes run from the least normal half float to the largest
    /// finite one, each island its own (the gather tells islands apart by
    /// equality), and none is 0, the code of a texel no triangle covers.
    #[test]
    fn island_codes_are_distinct_normal_half_floats() {
        assert_eq!(island_code(0), 2f32.powi(-14));
        assert_eq!(island_code(ISLAND_CODES - 1), 65504.0);
        let codes: Vec<f32> = (0..ISLAND_CODES).map(island_code).collect();
        assert!(codes.windows(2).all(|w| w[0] < w[1]), "codes increase with the island");
        // A half float holds 11 significant bits: each code is one.
        assert!(codes.iter().all(|c| c.to_bits() & 0x1fff == 0), "codes are half floats");
    }

    /// A 2 x 2 quad at depth 0.5 with the chart filling the unit square: seen
    /// through an identity view-projection it covers the whole viewport.
    fn screen_quad(normals: [Vec3; 4]) -> Scene {
        let positions = vec![
            Vec3::new(-1.0, 1.0, 0.5),
            Vec3::new(1.0, 1.0, 0.5),
            Vec3::new(1.0, -1.0, 0.5),
            Vec3::new(-1.0, -1.0, 0.5),
        ];
        let uv = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
        Scene {
            meshes: vec![Mesh {
                positions,
                normals: normals.to_vec(),
                uv0: uv.clone(),
                uv1: Some(uv),
                indices: vec![0, 1, 2, 0, 2, 3],
                ..Default::default()
            }],
            objects: vec![Object {
                name: "quad".into(),
                mesh: 0,
                material: 0,
                transform: Mat4::IDENTITY,
                forward_only: false,
            }],
            ..Default::default()
        }
    }

    fn view(width: u32, height: u32) -> GpuView {
        let (w, h) = (width as f32, height as f32);
        GpuView { view_proj: Mat4::IDENTITY, viewport: Vec4::new(w, h, 1.0 / w, 1.0 / h), ..Default::default() }
    }

    fn params(mip_bias: f32, variable_rate: f32) -> MarkParams {
        MarkParams {
            stamp: 1,
            reuse: 1,
            view_since: 1,
            tile_size: 8,
            mip_bias,
            variable_rate,
            level_blend: 0.0,
            gather_filter: GatherFilter::Bilinear,
            aniso: 1,
        }
    }

    /// One object of texture side 256 in tiles of 8, levels 256 down to 32.
    fn entries() -> Vec<GpuAtlasEntry> {
        AtlasLayout::new(&[Some(256)], 8, 16, 4096, 32).unwrap().gpu_entries()
    }

    #[test]
    fn f16_ulps_follow_the_binades() {
        assert_eq!(f16_ulp(1.0), 1.0 / 1024.0);
        assert_eq!(f16_ulp(-1.99), 1.0 / 1024.0);
        assert_eq!(f16_ulp(2.0), 1.0 / 512.0);
        assert_eq!(f16_ulp(0.3), 1.0 / 4096.0);
        assert_eq!(f16_ulp(0.0), 2f32.powi(-24));
        // Each is the step between neighbouring halves.
        for x in [0.3f32, 1.0, 7.5, 1000.0] {
            let h = half::f16::from_f32(x);
            assert_eq!(half::f16::from_bits(h.to_bits() + 1).to_f32() - h.to_f32(), f16_ulp(x), "{x}");
        }
    }

    #[test]
    fn pixel_centres_map_to_ndc() {
        let viewport = Vec4::new(4.0, 2.0, 0.25, 0.5);
        assert_eq!(pixel_ndc(Vec2::ZERO, viewport), Vec2::new(-0.75, 0.5));
        assert_eq!(pixel_ndc(Vec2::new(3.0, 1.0), viewport), Vec2::new(0.75, -0.5));
    }

    #[test]
    fn barycentrics_are_perspective_correct() {
        let (c0, c1, c2) = (Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(-1.0, 1.0, 1.0));
        assert_eq!(barycentrics(c0, c1, c2, Vec2::new(-1.0, -1.0)), Vec3::X);
        assert_eq!(barycentrics(c0, c1, c2, Vec2::new(0.0, 0.0)), Vec3::new(0.0, 0.5, 0.5));
        // Vertex 1 twice as far (w = 2, same NDC point): the screen midpoint
        // of edge 0-1 is a third of the way along it in space.
        let far = Vec3::new(2.0, -2.0, 2.0);
        let b = barycentrics(c0, far, c2, Vec2::new(0.0, -1.0));
        assert!((b - Vec3::new(2.0 / 3.0, 1.0 / 3.0, 0.0)).abs().max_element() < 1e-6, "{b}");
    }

    #[test]
    fn a_quad_head_on_shades_at_the_matching_level() {
        let scene = screen_quad([Vec3::Z; 4]);
        let entries = entries();
        // 64 pixels across a texture of 256: 4 texels per pixel, level 2.
        let v = view(64, 64);
        let p = sample_pixel(&scene, &v, UVec2::new(10, 20), [1, 0]);
        let f = chart_footprint(&scene, &p);
        assert!((f.uv - Vec2::new(10.5, 20.5) / 64.0).abs().max_element() < 1e-6, "{f:?}");
        assert!((f.du_dx - Vec2::new(1.0 / 64.0, 0.0)).abs().max_element() < 1e-6, "{f:?}");
        assert!((f.du_dy - Vec2::new(0.0, 1.0 / 64.0)).abs().max_element() < 1e-6, "{f:?}");
        let lod = level_of_detail(&entries[0], &params(0.0, 0.0), &f, 0.0);
        assert!((lod - 2.0).abs() < 1e-4, "{lod}");
        assert_eq!(select_level(lod, entries[0].level_count), 2);
        // Biases: a mip bias of -1, and a flat triangle's full variable rate of 0.7.
        assert_eq!(select_level(level_of_detail(&entries[0], &params(-1.0, 0.0), &f, 0.0), 4), 1);
        let bias = variable_rate_bias(0.7, [Vec3::Z; 3]);
        assert_eq!(bias, 0.7);
        assert_eq!(select_level(level_of_detail(&entries[0], &params(0.0, 0.7), &f, bias), 4), 3);
        // Clamped to the levels there are.
        assert_eq!(select_level(-3.2, 4), 0);
        assert_eq!(select_level(9.0, 4), 3);
        // WGSL rounds ties to even.
        assert_eq!((select_level(0.5, 4), select_level(1.5, 4), select_level(2.5, 4)), (0, 2, 2));
    }

    #[test]
    fn aniso_follows_the_shorter_axis_with_taps_along_the_longer() {
        // 256 texels: 8 texels per pixel across, 1 down.
        let entries = entries();
        let f = ChartFootprint {
            uv: Vec2::splat(0.5),
            du_dx: Vec2::new(8.0 / 256.0, 0.0),
            du_dy: Vec2::new(0.0, 1.0 / 256.0),
        };
        let at = |aniso| {
            let lod = level_of_detail(&entries[0], &MarkParams { aniso, ..params(0.0, 0.0) }, &f, 0.0);
            let taps = aniso_choices(256, 9, aniso, &f);
            assert_eq!(taps.len(), 1, "aniso {aniso}: {taps:?}");
            (lod, taps[0])
        };
        // Isotropic: the longer axis's level, one tap at the point.
        let (lod, taps) = at(1);
        assert!((lod - 3.0).abs() < 1e-5 && taps.points() == [f.uv], "{lod} {taps:?}");
        // 8 taps a texel apart along x, at the shorter axis's level 0.
        let (lod, taps) = at(8);
        assert!(lod.abs() < 1e-5 && taps.count == 8 && taps.axis == f.du_dx, "{lod} {taps:?}");
        let xs: Vec<f32> = taps.points().iter().map(|p| (p.x - 0.5) * 256.0).collect();
        assert_eq!(xs, [-3.5, -2.5, -1.5, -0.5, 0.5, 1.5, 2.5, 3.5]);
        // Limited to 4 taps: the level rises until 4 cover the longer axis.
        let (lod, taps) = at(4);
        assert!((lod - 1.0).abs() < 1e-5 && taps.count == 4, "{lod} {taps:?}");
        // A ratio on a `ceil` boundary counts both tap counts; axes of equal
        // length, both axes.
        let f2 = ChartFootprint { du_dx: Vec2::new(2.0 / 256.0, 0.0), du_dy: Vec2::new(0.0, 1.0 / 256.0), ..f };
        let counts: Vec<u32> = aniso_choices(256, 9, 8, &f2).iter().map(|t| t.count).collect();
        assert_eq!(counts, [2, 3]);
        let round = ChartFootprint { du_dx: Vec2::new(2.0 / 256.0, 0.0), du_dy: Vec2::new(0.0, 2.0 / 256.0), ..f };
        let choices = aniso_choices(256, 9, 8, &round);
        assert_eq!(choices.len(), 3, "{choices:?}");
        assert!(choices.iter().any(|t| t.count == 2 && t.axis == round.du_dy), "{choices:?}");
        // Magnified (under a texel a pixel along both axes): one tap.
        let small = ChartFootprint { du_dx: Vec2::new(0.5 / 256.0, 0.0), du_dy: Vec2::new(0.0, 0.1 / 256.0), ..f };
        assert_eq!(aniso_choices(256, 9, 16, &small).iter().map(|t| t.count).collect::<Vec<_>>(), [1]);
        // Wider than the coarsest level resolves (4 levels of 256: its texels
        // are 8 wide): the longer axis capped at 8 of them (64 texels, from
        // 200), the shorter at one (8, from 20), so 8 taps 8 texels apart.
        let wide = ChartFootprint { du_dx: Vec2::new(200.0 / 256.0, 0.0), du_dy: Vec2::new(0.0, 20.0 / 256.0), ..f };
        let taps = aniso_choices(256, 4, 8, &wide);
        assert_eq!(taps.len(), 1, "{taps:?}");
        assert!(taps[0].count == 8 && (taps[0].axis.x * 256.0 - 64.0).abs() < 1e-4, "{taps:?}");
        // With enough levels the same footprint is not capped.
        assert_eq!(aniso_choices(256, 9, 8, &wide)[0].axis, wide.du_dx);
    }

    #[test]
    fn variable_rate_fades_out_where_normals_diverge() {
        assert_eq!(variable_rate_bias(0.0, [Vec3::Z; 3]), 0.0);
        // cos 45 degrees: 1 - 0.707 = 0.29, times 8 is above 1: no bias.
        let tilted = Vec3::new(1.0, 0.0, 1.0);
        assert_eq!(variable_rate_bias(1.0, [Vec3::Z, Vec3::Z, tilted]), 0.0);
        // Unnormalized normals are normalized first; 1 - cos = 1/16: half the bias.
        let slight = Vec3::new((1.0f32 - (15.0f32 / 16.0).powi(2)).sqrt(), 0.0, 15.0 / 16.0) * 3.0;
        assert!((variable_rate_bias(1.0, [Vec3::Z, Vec3::Z, slight]) - 0.5).abs() < 1e-5);
    }

    #[test]
    fn bilinear_taps_are_clamped_into_the_level() {
        let inside = bilinear(16, Vec2::new(0.25, 0.5));
        assert_eq!(
            (inside.texel, inside.texel_hi, inside.weight),
            (IVec2::new(3, 7), IVec2::new(4, 8), Vec2::splat(0.5))
        );
        let top_left = bilinear(16, Vec2::ZERO);
        assert_eq!((top_left.texel, top_left.texel_hi, top_left.weight), (IVec2::ZERO, IVec2::ZERO, Vec2::splat(0.5)));
        let bottom_right = bilinear(16, Vec2::ONE);
        assert_eq!((bottom_right.texel, bottom_right.texel_hi), (IVec2::splat(15), IVec2::splat(15)));
        let outside = bilinear(16, Vec2::new(-3.0, 7.0));
        assert_eq!((outside.texel, outside.texel_hi), (IVec2::new(0, 15), IVec2::new(0, 15)));
    }

    #[test]
    fn cubic_filters_span_one_texel_more_each_side() {
        // Bilinear's span is its pair; a cubic's is clamped into the level.
        assert_eq!(filter_span(32, IVec2::new(7, 3), 0), (IVec2::new(7, 3), IVec2::new(8, 4)));
        assert_eq!(filter_span(32, IVec2::new(7, 3), 1), (IVec2::new(6, 2), IVec2::new(9, 5)));
        assert_eq!(filter_span(32, IVec2::new(-1, 31), 1), (IVec2::new(0, 30), IVec2::new(1, 31)));
        // Bilinear's texels 6-7 lie in tile 0; the cubic's 5-8 reach tile 1.
        let l = GpuAtlasLevel { size: 32, page_base: 0, tile_base: 100, pad: 0 };
        let (lo, hi) = filter_span(32, IVec2::new(6, 3), 0);
        assert_eq!(footprint_tiles(&l, 8, lo, hi), vec![100]);
        let (lo, hi) = filter_span(32, IVec2::new(6, 3), 1);
        assert_eq!(footprint_tiles(&l, 8, lo, hi), vec![100, 101]);
    }

    #[test]
    fn footprints_add_tiles_only_across_tile_edges() {
        let l = GpuAtlasLevel { size: 32, page_base: 0, tile_base: 100, pad: 0 };
        assert_eq!(footprint_tiles(&l, 8, IVec2::new(3, 3), IVec2::new(4, 4)), vec![100]);
        assert_eq!(footprint_tiles(&l, 8, IVec2::new(7, 3), IVec2::new(8, 4)), vec![100, 101]);
        assert_eq!(footprint_tiles(&l, 8, IVec2::new(2, 15), IVec2::new(3, 16)), vec![104, 108]);
        assert_eq!(footprint_tiles(&l, 8, IVec2::new(15, 23), IVec2::new(16, 24)), vec![109, 110, 113, 114]);
        // Clamped at the border: both taps on the last texel.
        assert_eq!(footprint_tiles(&l, 8, IVec2::splat(31), IVec2::splat(31)), vec![115]);
    }

    #[test]
    fn a_pixel_on_a_rounding_boundary_marks_both_outcomes() {
        let scene = screen_quad([Vec3::Z; 4]);
        let entries = entries();
        let v = view(64, 64);
        let pixel_tiles_with = |mip_bias| {
            let inputs = MarkInputs { scene: &scene, view: &v, entries: &entries, params: params(mip_bias, 0.0) };
            pixel_tiles(&inputs, UVec2::new(10, 20), [1, 0]).unwrap()
        };
        // Level 2 (64 texels, tiles of 8): uv * 64 - 0.5 = (10, 20), an
        // integer, but taps 9-10 or 10-11 and 19-20 or 20-21 all lie in
        // tile (1, 2): not ambiguous.
        let level2 = entries[0].levels[2].tile_base + 2 * 8 + 1;
        assert_eq!(pixel_tiles_with(0.0), PixelTiles { must: vec![level2], may: vec![level2] });
        // Level 2.5: level 2, or level 3 (32 texels, t = (4.75, 9.75): tile (0, 1)).
        let level3 = entries[0].levels[3].tile_base + 4;
        assert_eq!(pixel_tiles_with(0.5), PixelTiles { must: vec![], may: vec![level2, level3] });
        // Level 2.9: level 3 only.
        assert_eq!(pixel_tiles_with(0.9), PixelTiles { must: vec![level3], may: vec![level3] });
        // Level 2.5 blended (level blend 1): both levels, certainly.
        let params = MarkParams { level_blend: 1.0, ..params(0.5, 0.0) };
        let inputs = MarkInputs { scene: &scene, view: &v, entries: &entries, params };
        let both = vec![level2, level3];
        assert_eq!(
            pixel_tiles(&inputs, UVec2::new(10, 20), [1, 0]).unwrap(),
            PixelTiles { must: both.clone(), may: both }
        );
    }

    #[test]
    fn level_blend_weighs_the_coarser_level_across_its_band() {
        // No blend: the rounded level alone.
        assert_eq!(select_levels(2.6, 5, 0.0), LevelPair { lo: 3, hi: 3, t: 0.0 });
        // Trilinear: the coarser level weighs the level's fraction.
        let p = select_levels(2.25, 5, 1.0);
        assert_eq!((p.lo, p.hi, p.t, p.levels()), (2, 3, 0.25, vec![2, 3]));
        // A band of 0.5 levels: level 2 alone below 2.25, level 3 alone above 2.75.
        assert_eq!(select_levels(2.2, 5, 0.5).levels(), vec![2]);
        assert_eq!(select_levels(2.5, 5, 0.5).t, 0.5);
        assert_eq!(select_levels(2.8, 5, 0.5).levels(), vec![3]);
        // No jump across an integer level: level 3 alone on both sides.
        assert_eq!(select_levels(2.99, 5, 0.5).levels(), vec![3]);
        assert_eq!(select_levels(3.01, 5, 0.5).levels(), vec![3]);
        // Clamped to the levels there are: one level at either end.
        assert_eq!(select_levels(7.0, 5, 1.0).levels(), vec![4]);
        assert_eq!(select_levels(-1.0, 5, 1.0).levels(), vec![0]);
        // Near a band's edge the GPU may read one level or both.
        let choices: Vec<Vec<u32>> = level_choices(2.25, 5, 0.5, LOD_TOLERANCE).iter().map(LevelPair::levels).collect();
        assert_eq!(choices, [vec![2], vec![2, 3]]);
    }

    #[test]
    fn a_bilinear_coordinate_on_a_tile_edge_marks_both_outcomes() {
        let scene = screen_quad([Vec3::Z; 4]);
        let entries = entries();
        let v = view(64, 64);
        let inputs = MarkInputs { scene: &scene, view: &v, entries: &entries, params: params(0.0, 0.0) };
        // Pixel 7 at level 2 (one texel a pixel): t.x = 7.5 * 1 - 0.5 = 7
        // exactly, floored to 7 (taps 7-8: tiles 0 and 1) or to 6 (taps 6-7:
        // tile 0 only).
        let p = pixel_tiles(&inputs, UVec2::new(7, 2), [1, 0]).unwrap();
        let base = entries[0].levels[2].tile_base;
        assert_eq!(p, PixelTiles { must: vec![base], may: vec![base, base + 1] });
        // Every pixel of the quad sits on a texel boundary; those next to a
        // tile edge (7 and 8, ..., 55 and 56: 14 columns and 14 rows) are
        // ambiguous, but each tile also holds pixels that mark it whichever
        // way they floor: the frame's tiles are certain, all 64 of level 2.
        let visibility: Vec<[u32; 2]> = (0..64 * 64).map(|i| [1, u32::from(i % 64 <= i / 64)]).collect();
        let tiles = visible_tiles(&inputs, &visibility, 64);
        assert_eq!(tiles.ambiguous_pixels, 64 * 64 - 50 * 50);
        assert_eq!(tiles.must, (base..base + 64).collect());
        assert_eq!(tiles.may, tiles.must);
        // Background pixels mark nothing.
        assert_eq!(visible_tiles(&inputs, &[[0, 0]; 4], 2), VisibleTiles::default());
    }

    #[test]
    fn reuse_ages_valid_since_and_view_since_decide_the_queue() {
        // Shaded at stamp 1, the view changed since (every frame): reuse N
        // re-shades at stamp 1 + N.
        for (reuse, stamps) in [(1, [true, true, true]), (2, [false, true, true]), (3, [false, false, true])] {
            let queued = [2, 3, 4].map(|stamp| needs_shading(1, stamp, reuse, 1, stamp));
            assert_eq!(queued, stamps, "reuse {reuse}");
        }
        // The same view since stamp 1: kept whatever its age, but with reuse 1.
        let kept = [1, 2, 3].map(|reuse| needs_shading(1, 9, reuse, 1, 1));
        assert_eq!(kept, [true, false, false]);
        assert!(needs_shading(1, 9, 3, 1, 2), "shaded with an earlier view");
        assert!(needs_shading(0, 5, 3, 1, 1), "never shaded");
        assert!(needs_shading(3, 4, 3, 4, 1), "shaded before the lights changed");
        assert!(!needs_shading(4, 5, 3, 4, 5), "shaded since");
        assert!(is_new(0, 1) && is_new(2, 4) && !is_new(3, 4));
    }

    #[test]
    fn mark_frame_updates_visible_tiles_only() {
        // Object 0: 16 texels, 4 tiles; object 1: 32 then 16 texels, 16 + 4 tiles.
        let mut entries = AtlasLayout::new(&[Some(16), None, Some(32)], 8, 16, 64, 16).unwrap().gpu_entries();
        // Tiles numbered one after the other (a slot's numbers may leave gaps).
        (entries[2].levels[0].tile_base, entries[2].levels[1].tile_base) = (4, 20);
        entries[0].valid_since = 1;
        entries[2].valid_since = 3;
        assert_eq!(tile_owner(&entries, 8, 3), Some((0, 0)));
        assert_eq!(tile_owner(&entries, 8, 4), Some((2, 0)));
        assert_eq!(tile_owner(&entries, 8, 20), Some((2, 1)));
        assert_eq!(tile_owner(&entries, 8, 24), None);
        let previous = TileState {
            visible: (0..24).map(|t| [0, 2, 1, 1][t % 4]).collect(),
            shaded: (0..24).map(|t| [0, 2, 1, 2][t % 4]).collect(),
        };
        let params = MarkParams {
            stamp: 3,
            reuse: 2,
            view_since: 3,
            tile_size: 8,
            mip_bias: 0.0,
            variable_rate: 0.0,
            level_blend: 0.0,
            gather_filter: GatherFilter::Bilinear,
            aniso: 1,
        };
        let visible: BTreeSet<u32> = [0, 1, 2, 3, 21].into();
        let marks = mark_frame(&previous, &visible, &params, &entries);
        assert_eq!(marks.new, [0, 2, 3].into());
        // Tiles 1 and 3 were shaded a frame ago (reuse 2), tile 2 two frames
        // ago; tile 21 (object 2) at 2, before its valid_since 3.
        assert_eq!(marks.queued, [(0, 0), (2, 0), (21, 2 << 8 | 1)].into());
        for t in 0..24 {
            let (v, s) = (marks.next.visible[t], marks.next.shaded[t]);
            if visible.contains(&(t as u32)) {
                assert_eq!(v, 3, "tile {t}");
                assert_eq!(s, if t == 1 || t == 3 { 2 } else { 3 }, "tile {t}");
            } else {
                assert_eq!((v, s), (previous.visible[t], previous.shaded[t]), "tile {t}");
            }
        }
    }

    #[test]
    fn samples_on_one_chart_surface_are_one_point_at_their_centroid() {
        // Object 0: triangles 0 and 1 in island 5, triangle 2 in island 6.
        let islands = vec![vec![5, 5, 6]];
        let (a, a2, b) = ([1, 0], [1, 1], [1, 2]);
        let groups = |samples: &[[u32; 2]], mode| sample_groups(&islands, samples, mode);
        // One island across two triangles: the pixel's centre, exactly.
        let one = groups(&[a, a2, a, a2], MsaaGather::Pixel);
        assert_eq!(one, [SampleGroup { ids: a, at: Vec2::splat(0.5), count: 4 }]);
        // Another island and background: three points, each its samples' centroid.
        let split = groups(&[a, b, [0, 0], a2], MsaaGather::Pixel);
        let centroid = (standard_sample_position(4, 0) + standard_sample_position(4, 3)) / 2.0;
        assert_eq!(
            split,
            [
                SampleGroup { ids: a, at: centroid, count: 2 },
                SampleGroup { ids: b, at: standard_sample_position(4, 1), count: 1 },
                SampleGroup { ids: [0, 0], at: standard_sample_position(4, 2), count: 1 },
            ]
        );
        // Per sample: every sample its own point, even on one surface.
        let each = groups(&[a, a, a, a], MsaaGather::Sample);
        assert_eq!(
            each.iter().map(|g| (g.at, g.count)).collect::<Vec<_>>(),
            (0..4).map(|s| (standard_sample_position(4, s), 1)).collect::<Vec<_>>()
        );
        // The standard positions are centred: 2, 4 and 8 samples average to the centre.
        for n in [2, 4, 8] {
            let sum = (0..n).fold(Vec2::ZERO, |sum, s| sum + standard_sample_position(n, s));
            assert_eq!(sum / n as f32, Vec2::splat(0.5), "{n} samples");
        }
    }
}
