//! Is a UV set a unique layout? Rasterizes its triangles into an R x R grid of
//! texel centres and counts the texels that two surface regions share.
//!
//! # The rule
//!
//! - A texel is *covered* by a triangle when its centre `((x + 0.5) / R,
//!   (y + 0.5) / R)` lies inside the triangle. Centres exactly on an edge go to
//!   one side only (a top-left style tie rule, evaluated with edge functions
//!   that are exactly antisymmetric for the two triangles of a shared edge), so
//!   a watertight layout covers every centre at most once, whatever the
//!   triangles' orientation (mirrored charts included).
//! - A texel is *double-covered* when two or more triangles cover it
//!   ([`OverlapReport::double_covered_texels`]).
//! - It is *overlapping* when it is double-covered and lies in a 2 x 2 block of
//!   texels that are all double-covered: an overlap must be at least about one
//!   texel thick. A band of double coverage narrower than one texel cannot hold
//!   the four centres of a 2 x 2 block; such bands come from UV edges that
//!   nearly but not exactly coincide (T-junctions, per-corner UVs rounded
//!   differently), not from two surface regions sharing texels. Any overlap
//!   of area keeps all its texels (the rule is a morphological opening, so
//!   the rim of a real overlap counts too).
//! - UVs outside `[0, 1]` (beyond [`RANGE_EPSILON`]) or non-finite make a
//!   layout non-unique by themselves: with repeat addressing they alias other
//!   texels. They are counted per vertex that a triangle uses; the parts of
//!   triangles outside the grid are clipped, not wrapped.

use glam::Vec2;

/// How far outside `[0, 1]` a UV may lie before it counts as out of range
/// (files store UVs with six decimals, so `1.000001` is still the border).
pub const RANGE_EPSILON: f32 = 1e-5;

/// What [`check_overlap`] found for one UV set at one resolution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverlapReport {
    /// Side of the texel grid, in texels.
    pub resolution: u32,
    /// Texels whose centre at least one triangle covers.
    pub covered_texels: u64,
    /// Texels covered by two or more triangles, before the thickness rule.
    pub double_covered_texels: u64,
    /// Double-covered texels in a 2 x 2 block of double-covered texels: the
    /// overlap that counts (see the module documentation).
    pub overlapping_texels: u64,
    /// `overlapping_texels / covered_texels` (0 when nothing is covered).
    pub fraction: f32,
    /// Vertices used by a triangle whose UV lies outside `[0, 1]` or is not finite.
    pub out_of_range_vertices: usize,
    /// Triangles with zero area in UV space (they cover no texel).
    pub degenerate_triangles: usize,
}

impl OverlapReport {
    /// True when the layout covers something, has no UV out of range and its
    /// overlap fraction is at most `tolerance` (0.001 is 0.1%).
    pub fn is_unique(&self, tolerance: f32) -> bool {
        self.covered_texels > 0 && self.out_of_range_vertices == 0 && self.fraction <= tolerance
    }
}

/// Rasterizes the triangles `indices` (three per triangle, each `< uvs.len()`)
/// of the UV set `uvs` at `resolution` x `resolution` texels and reports
/// coverage and overlap, by the rule of the module documentation.
///
/// Cost: one pass over each triangle's texel bounding box plus two passes over
/// the grid (one byte per texel): tens of milliseconds for 40k triangles at
/// 1024, even in the debug build.
pub fn check_overlap(uvs: &[Vec2], indices: &[u32], resolution: u32) -> OverlapReport {
    let r = resolution.max(1) as usize;
    let mut coverage = vec![0u8; r * r];
    let mut vertex_out = vec![false; uvs.len()];
    let inside = -RANGE_EPSILON..=1.0 + RANGE_EPSILON;
    for &i in indices {
        let uv = uvs[i as usize];
        if !(inside.contains(&uv.x) && inside.contains(&uv.y)) {
            vertex_out[i as usize] = true;
        }
    }
    let degenerate_triangles = rasterize(uvs, indices, resolution, |_, x, y| {
        let cell = &mut coverage[y * r + x];
        *cell = cell.saturating_add(1);
    });

    let covered_texels = coverage.iter().filter(|&&c| c > 0).count() as u64;
    let double_covered_texels = coverage.iter().filter(|&&c| c > 1).count() as u64;
    let overlapping_texels = if double_covered_texels == 0 { 0 } else { opened_count(&coverage, r) };
    let fraction = if covered_texels == 0 { 0.0 } else { (overlapping_texels as f64 / covered_texels as f64) as f32 };
    OverlapReport {
        resolution: r as u32,
        covered_texels,
        double_covered_texels,
        overlapping_texels,
        fraction,
        out_of_range_vertices: vertex_out.iter().filter(|&&o| o).count(),
        degenerate_triangles,
    }
}

/// Calls `cover(triangle, x, y)` for every texel `(x, y)` of the
/// `resolution` x `resolution` grid whose centre triangle number `triangle`
/// covers, by the rule of the module documentation. Triangles with a
/// non-finite UV are skipped. Returns the number of triangles with zero UV area.
pub fn rasterize(uvs: &[Vec2], indices: &[u32], resolution: u32, mut cover: impl FnMut(usize, usize, usize)) -> usize {
    let r = resolution.max(1) as usize;
    let scale = r as f64;
    let mut degenerate = 0;
    for (t, tri) in indices.chunks_exact(3).enumerate() {
        if tri.iter().any(|&i| !uvs[i as usize].is_finite()) {
            continue;
        }
        // Texel units, in f64: exact for power-of-two resolutions, and the
        // same rounding for every triangle that shares a vertex otherwise.
        let [a, b, c] = [0, 1, 2].map(|k| {
            let uv = uvs[tri[k] as usize];
            [uv.x as f64 * scale, uv.y as f64 * scale]
        });
        let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area2 == 0.0 {
            degenerate += 1;
            continue;
        }
        // Counter-clockwise (positive area) so that "inside" is E > 0 on every edge.
        let [a, b, c] = if area2 > 0.0 { [a, b, c] } else { [a, c, b] };
        let edges = [(a, b), (b, c), (c, a)];

        let lo_x = a[0].min(b[0]).min(c[0]);
        let hi_x = a[0].max(b[0]).max(c[0]);
        let lo_y = a[1].min(b[1]).min(c[1]);
        let hi_y = a[1].max(b[1]).max(c[1]);
        // Texels whose centre (x + 0.5) lies in [lo, hi], clipped to the grid.
        let first = |lo: f64| ((lo - 0.5).ceil().max(0.0) as usize).min(r);
        let last = |hi: f64| ((hi - 0.5).floor() + 1.0).clamp(0.0, r as f64) as usize;
        let (x0, x1, y0, y1) = (first(lo_x), last(hi_x), first(lo_y), last(hi_y));
        for y in y0..y1 {
            let (lo, hi) = row_span(&edges, x0, x1, y as f64 + 0.5);
            for x in lo..hi {
                cover(t, x, y);
            }
        }
    }
    degenerate
}

/// The texels `lo..hi` of `x0..x1` in row `py` (a texel centre's y) whose
/// centres lie inside all three `edges`: exactly the texels a test of every
/// centre with [`inside_edge`] finds, in O(log width) tests per edge.
///
/// Along a row, an edge's computed value is monotone in x even in floating
/// point (it is `c - k * (x - s)` with each operation rounded, and rounding
/// is monotone), in the direction `-dy` of the edge; and the tie rule is the
/// same for the whole edge. So an edge going down (`dy > 0`) keeps a prefix
/// of the row, one going up a suffix, a level one all or nothing, and the
/// triangle keeps their intersection, found by bisection.
fn row_span(edges: &[([f64; 2], [f64; 2]); 3], x0: usize, x1: usize, py: f64) -> (usize, usize) {
    let (mut lo, mut hi) = (x0, x1);
    for &(p0, p1) in edges {
        let inside = |x: usize| inside_edge(p0, p1, [x as f64 + 0.5, py]);
        let dy = p1[1] - p0[1];
        if dy > 0.0 {
            hi = first_in(lo, hi, |x| !inside(x));
        } else if dy < 0.0 {
            lo = first_in(lo, hi, inside);
        } else if lo < hi && !inside(lo) {
            hi = lo;
        }
        if lo >= hi {
            return (lo, lo);
        }
    }
    (lo, hi)
}

/// The first `x` in `lo..hi` where `pred` holds (`hi` if none), for a `pred`
/// that is false then true along the range.
fn first_in(mut lo: usize, mut hi: usize, pred: impl Fn(usize) -> bool) -> usize {
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) { hi = mid } else { lo = mid + 1 }
    }
    lo
}

/// Is `p` inside the directed edge `p0 -> p1` of a counter-clockwise triangle?
///
/// The edge function is always evaluated from the lexicographically smaller
/// endpoint, so the two triangles of a shared edge get exactly opposite values
/// (bit for bit); a tie (`E == 0`) goes to the side whose edge direction passes
/// the antisymmetric test below, so exactly one of them takes the centre.
#[inline]
fn inside_edge(p0: [f64; 2], p1: [f64; 2], p: [f64; 2]) -> bool {
    let edge = |s: [f64; 2], t: [f64; 2]| (t[0] - s[0]) * (p[1] - s[1]) - (t[1] - s[1]) * (p[0] - s[0]);
    let e = if (p0[0], p0[1]) < (p1[0], p1[1]) { edge(p0, p1) } else { -edge(p1, p0) };
    if e != 0.0 {
        return e > 0.0;
    }
    let (dx, dy) = (p1[0] - p0[0], p1[1] - p0[1]);
    dy < 0.0 || (dy == 0.0 && dx > 0.0)
}

/// Texels with coverage >= 2 that belong to a 2 x 2 block of such texels
/// (the morphological opening of the double-coverage mask by a 2 x 2 square).
fn opened_count(coverage: &[u8], r: usize) -> u64 {
    if r < 2 {
        return 0;
    }
    let double = |x: usize, y: usize| coverage[y * r + x] > 1;
    // block[y][x]: the 2 x 2 block with top-left texel (x, y) is all double.
    let b = r - 1;
    let mut block = vec![false; b * b];
    for y in 0..b {
        for x in 0..b {
            block[y * b + x] = double(x, y) && double(x + 1, y) && double(x, y + 1) && double(x + 1, y + 1);
        }
    }
    let mut count = 0;
    for y in 0..r {
        for x in 0..r {
            if !double(x, y) {
                continue;
            }
            // The up to four blocks that contain texel (x, y).
            let hit = (y.saturating_sub(1)..=y.min(b - 1))
                .any(|by| (x.saturating_sub(1)..=x.min(b - 1)).any(|bx| block[by * b + bx]));
            count += hit as u64;
        }
    }
    count
}

/// The share of a mesh's 3D surface area whose triangles have zero UV area.
/// Such triangles get no texels, so a layout that collapses a visible share of
/// the surface is not a unique parameterization even when nothing overlaps.
pub fn collapsed_area_fraction(positions: &[glam::Vec3], uvs: &[Vec2], indices: &[u32]) -> f32 {
    let (mut total, mut collapsed) = (0.0f64, 0.0f64);
    for tri in indices.chunks_exact(3) {
        let [i, j, k] = [0, 1, 2].map(|n| tri[n] as usize);
        let area = 0.5 * (positions[j] - positions[i]).cross(positions[k] - positions[i]).length() as f64;
        total += area;
        let (a, b, c) = (uvs[i].as_dvec2(), uvs[j].as_dvec2(), uvs[k].as_dvec2());
        if (b - a).perp_dot(c - a) == 0.0 {
            collapsed += area;
        }
    }
    if total > 0.0 { (collapsed / total) as f32 } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32) -> Vec2 {
        Vec2::new(x, y)
    }

    /// The texels of one triangle by testing every centre of its bounding
    /// box: what [`rasterize`]'s bisection of each row must reproduce.
    fn brute_force(uvs: &[Vec2], tri: &[u32], resolution: u32) -> Vec<(usize, usize)> {
        let r = resolution as f64;
        let [a, b, c] = [0, 1, 2].map(|k| [uvs[tri[k] as usize].x as f64 * r, uvs[tri[k] as usize].y as f64 * r]);
        let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        let [a, b, c] = if area2 > 0.0 { [a, b, c] } else { [a, c, b] };
        let mut texels = Vec::new();
        for y in 0..resolution as usize {
            for x in 0..resolution as usize {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                if area2 != 0.0 && [(a, b), (b, c), (c, a)].iter().all(|&(p0, p1)| inside_edge(p0, p1, p)) {
                    texels.push((x, y));
                }
            }
        }
        texels
    }

    /// Random triangles (slivers, level and vertical edges, vertices on
    /// texel centres, outside the square, at power-of-two and other
    /// resolutions): the row bisection covers exactly the texels a test of
    /// every centre covers.
    #[test]
    fn row_bisection_covers_what_testing_every_centre_covers() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for case in 0..3000 {
            let resolution = [16, 37, 64][case % 3];
            let snap =
                |v: f32| if case % 4 == 0 { ((v * resolution as f32).round() + 0.5) / resolution as f32 } else { v };
            let mut uvs: Vec<Vec2> =
                (0..3).map(|_| v(snap(rng.random_range(-0.2..1.2)), snap(rng.random_range(-0.2..1.2)))).collect();
            match case % 5 {
                1 => uvs[1].y = uvs[0].y,
                2 => uvs[2].x = uvs[1].x,
                3 => uvs[2] = uvs[0].lerp(uvs[1], 0.5) + v(1e-3, -1e-3),
                _ => {}
            }
            let mut got = Vec::new();
            rasterize(&uvs, &[0, 1, 2], resolution, |_, x, y| got.push((x, y)));
            got.sort_by_key(|&(x, y)| (y, x));
            assert_eq!(got, brute_force(&uvs, &[0, 1, 2], resolution), "case {case}: {uvs:?} at {resolution}");
        }
    }

    /// Two triangles of the quad [x0, x1] x [y0, y1], appended to `uvs`/`idx`;
    /// `mirror` reverses the winding (a mirrored chart).
    fn quad(uvs: &mut Vec<Vec2>, idx: &mut Vec<u32>, x0: f32, y0: f32, x1: f32, y1: f32, mirror: bool) {
        let base = uvs.len() as u32;
        uvs.extend([v(x0, y0), v(x1, y0), v(x1, y1), v(x0, y1)]);
        if mirror {
            idx.extend([0, 2, 1, 0, 3, 2].map(|i| base + i));
        } else {
            idx.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
        }
    }

    #[test]
    fn unit_quad_covers_every_texel_once() {
        let (mut uvs, mut idx) = (vec![], vec![]);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 1.0, 1.0, false);
        let r = check_overlap(&uvs, &idx, 64);
        assert_eq!(r.covered_texels, 64 * 64);
        // The diagonal passes exactly through 64 texel centres: the tie rule
        // must give each to one triangle only.
        assert_eq!(r.double_covered_texels, 0);
        assert_eq!(r.overlapping_texels, 0);
        assert_eq!(r.fraction, 0.0);
        assert_eq!(r.out_of_range_vertices, 0);
        assert!(r.is_unique(0.001));
    }

    #[test]
    fn irregular_grid_is_watertight_without_double_coverage() {
        // A 37 x 23 grid with jittered interior vertices, both diagonal
        // directions, some cells mirrored: every shared edge and vertex fan
        // must cover each centre exactly once.
        let (nx, ny) = (37usize, 23usize);
        let mut uvs = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                let mut p = v(i as f32 / nx as f32, j as f32 / ny as f32);
                if i > 0 && i < nx && j > 0 && j < ny {
                    let h = ((i * 7919 + j * 104729) % 1000) as f32 / 1000.0 - 0.5;
                    let g = ((i * 15485863 + j * 32452843) % 1000) as f32 / 1000.0 - 0.5;
                    p += v(h * 0.3 / nx as f32, g * 0.3 / ny as f32);
                }
                uvs.push(p);
            }
        }
        let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
        let mut idx = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                match (i + 2 * j) % 3 {
                    0 => idx.extend([a, b, c, a, c, d]),
                    1 => idx.extend([a, b, d, b, c, d]),
                    _ => idx.extend([a, c, b, a, d, c]), // reversed winding
                }
            }
        }
        for res in [64, 100, 256, 1024] {
            let r = check_overlap(&uvs, &idx, res);
            assert_eq!(r.covered_texels, (res * res) as u64, "cracks at {res}");
            assert_eq!(r.double_covered_texels, 0, "double coverage at {res}");
            assert_eq!(r.overlapping_texels, 0);
        }
    }

    #[test]
    fn two_copies_of_a_quad_overlap_completely() {
        let (mut uvs, mut idx) = (vec![], vec![]);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 1.0, 1.0, false);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 1.0, 1.0, false);
        let r = check_overlap(&uvs, &idx, 64);
        assert_eq!(r.covered_texels, 64 * 64);
        assert_eq!(r.overlapping_texels, 64 * 64);
        assert_eq!(r.fraction, 1.0);
        assert!(!r.is_unique(0.001));
        // Sharing every vertex does not excuse an overlap.
        let shared: Vec<u32> = idx[..6].iter().chain(&idx[..6]).copied().collect();
        assert_eq!(check_overlap(&uvs, &shared, 64).fraction, 1.0);
    }

    #[test]
    fn mirrored_half_overlap_gives_the_expected_fraction() {
        // [0, 0.6] and a mirrored [0.4, 1]: they share [0.4, 0.6], 20% of the
        // covered square.
        let (mut uvs, mut idx) = (vec![], vec![]);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 0.6, 1.0, false);
        quad(&mut uvs, &mut idx, 0.4, 0.0, 1.0, 1.0, true);
        let r = check_overlap(&uvs, &idx, 256);
        assert_eq!(r.covered_texels, 256 * 256);
        assert!((r.fraction - 0.2).abs() < 0.01, "fraction {}", r.fraction);
        // And a mirror image onto itself (the usual symmetric-mesh layout).
        let (mut uvs, mut idx) = (vec![], vec![]);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 0.5, 1.0, false);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 0.5, 1.0, true);
        quad(&mut uvs, &mut idx, 0.5, 0.0, 1.0, 1.0, false);
        let r = check_overlap(&uvs, &idx, 256);
        assert!((r.fraction - 0.5).abs() < 0.01, "fraction {}", r.fraction);
    }

    #[test]
    fn thin_bands_of_double_coverage_are_not_overlap() {
        // Two triangles whose diagonals nearly coincide: B is A's partner
        // moved right by `shift` texels.
        let res = 128;
        let case = |shift: f32| {
            let d = shift / res as f32;
            let uvs = vec![v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0), v(d, 0.0), v(1.0 + d, 1.0), v(d, 1.0)];
            check_overlap(&uvs, &[0, 1, 2, 3, 4, 5], res)
        };
        let thin = case(0.7);
        assert!(thin.double_covered_texels > 0, "the band should double-cover the diagonal");
        assert_eq!(thin.overlapping_texels, 0);
        assert_eq!(thin.out_of_range_vertices, 1, "(1 + d, 1) is outside");
        let thick = case(3.0);
        assert!(thick.overlapping_texels >= 3 * 120, "{thick:?}");
    }

    #[test]
    fn out_of_range_and_degenerate_are_reported() {
        let (mut uvs, mut idx) = (vec![], vec![]);
        quad(&mut uvs, &mut idx, 0.0, 0.0, 1.5, 1.0, false);
        let r = check_overlap(&uvs, &idx, 32);
        assert_eq!(r.out_of_range_vertices, 2);
        assert!(!r.is_unique(0.001));
        // Negative and non-finite UVs count too; unused vertices don't.
        let uvs = vec![v(-0.25, 0.0), v(1.0, 0.0), v(0.0, f32::NAN), v(5.0, 5.0), v(0.5, 0.5)];
        let r = check_overlap(&uvs, &[0, 1, 4, 0, 2, 1], 32);
        assert_eq!(r.out_of_range_vertices, 2);
        // A collapsed triangle covers nothing.
        let r = check_overlap(&[v(0.1, 0.1), v(0.2, 0.2), v(0.3, 0.3)], &[0, 1, 2], 32);
        assert_eq!((r.degenerate_triangles, r.covered_texels), (1, 0));
        assert!(!r.is_unique(0.001), "a layout that covers nothing is not unique");
    }

    #[test]
    fn forty_thousand_triangles_at_1024_are_fast() {
        // 141 x 141 cells, 39,762 triangles.
        let n = 141usize;
        let uvs: Vec<Vec2> =
            (0..=n).flat_map(|j| (0..=n).map(move |i| v(i as f32 / n as f32, j as f32 / n as f32))).collect();
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let idx: Vec<u32> = (0..n)
            .flat_map(|j| {
                (0..n).flat_map(move |i| {
                    [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1)]
                })
            })
            .collect();
        let start = std::time::Instant::now();
        let r = check_overlap(&uvs, &idx, 1024);
        let took = start.elapsed();
        eprintln!("{} triangles at 1024: {:?}", idx.len() / 3, took);
        assert_eq!(r.covered_texels, 1024 * 1024);
        assert_eq!(r.double_covered_texels, 0);
        assert!(took.as_secs_f32() < 1.0, "took {took:?}");
    }

    #[test]
    fn collapsed_area_is_measured_in_3d() {
        use glam::Vec3;
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        let uvs = [v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0), v(0.0, 1.0)];
        // Triangle 2 (x, (1,1), y) has UVs (1,0), (0,1), (0,1): collapsed.
        let f = collapsed_area_fraction(&p, &uvs, &[0, 1, 2, 1, 3, 2]);
        assert!((f - 0.5).abs() < 1e-6);
    }
}
