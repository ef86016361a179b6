//! CPU twin of the triangle-map rule in `trimap.wgsl` (same tests, in
//! `f32`, the cells in the order of `--os-trimap-search rings`: the answer
//! does not depend on the order), for the tests that check coverage and the
//! GPU build.

use glam::Vec2;

use super::grid::ChartGrid;

fn cross2(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

/// Whether triangle `p` and the square [lo, hi] overlap (separating axes).
pub fn overlaps(p: [Vec2; 3], lo: Vec2, hi: Vec2) -> bool {
    let (tlo, thi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
    if thi.x < lo.x || thi.y < lo.y || tlo.x > hi.x || tlo.y > hi.y {
        return false;
    }
    let area = cross2(p[1] - p[0], p[2] - p[0]);
    (0..3).all(|i| {
        let a = p[i];
        let e = p[(i + 1) % 3] - a;
        let n = Vec2::new(e.y, -e.x) * sign(area);
        let corner = Vec2::new(if n.x > 0.0 { lo.x } else { hi.x }, if n.y > 0.0 { lo.y } else { hi.y });
        n.dot(corner - a) <= 0.0
    })
}

/// WGSL's `sign` (0 for 0, unlike `f32::signum`).
fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn segment_distance(q: Vec2, a: Vec2, b: Vec2) -> f32 {
    let e = b - a;
    let t = ((q - a).dot(e) / e.dot(e).max(1e-30)).clamp(0.0, 1.0);
    (q - (a + e * t)).length()
}

/// Distance from `q` to triangle `p` (0 inside).
pub fn triangle_distance(p: [Vec2; 3], q: Vec2) -> f32 {
    let area = cross2(p[1] - p[0], p[2] - p[0]);
    let s = sign(area);
    let w = [cross2(p[1] - q, p[2] - q) * s, cross2(p[2] - q, p[0] - q) * s, cross2(p[0] - q, p[1] - q) * s];
    if area != 0.0 && w.iter().all(|&w| w >= 0.0) {
        return 0.0;
    }
    segment_distance(q, p[0], p[1]).min(segment_distance(q, p[1], p[2])).min(segment_distance(q, p[2], p[0]))
}

/// Triangle + 1 for texel `texel` of a level `size` texels wide (0 for
/// none): of the triangles touching the texel's square, the nearest to its
/// centre; else the nearest touching its 3x3 neighbourhood. The grid's
/// cells are searched in rings round the centre's cell ([`ring_cells`]),
/// stopping once no cell left can hold a nearer triangle ([`search_done`]):
/// the shader's order, the same answer as searching every cell.
pub fn covering_triangle(grid: &ChartGrid, uv: &[Vec2], indices: &[u32], size: u32, texel: [u32; 2]) -> u32 {
    covering_triangle_counted(grid, uv, indices, size, texel).0
}

/// [`covering_triangle`] and the grid entries it weighed.
pub fn covering_triangle_counted(
    grid: &ChartGrid,
    uv: &[Vec2],
    indices: &[u32],
    size: u32,
    texel: [u32; 2],
) -> (u32, u32) {
    let s = size as f32;
    let lo = Vec2::new(texel[0] as f32, texel[1] as f32);
    let cell = |p: Vec2| {
        let side = grid.side as f32;
        let c = (p / s * side).floor().clamp(Vec2::ZERO, Vec2::splat(side - 1.0));
        [c.x as u32, c.y as u32]
    };
    let (centre, c0, c1) = (cell(lo + 0.5), cell(lo - 1.0), cell(lo + 2.0));
    let width = s / grid.side as f32;
    let (mut touching, mut near) = ((f32::MAX, 0u32), (f32::MAX, 0u32));
    let mut weighed = 0;
    for ring in 0..=ring_count(centre, c0, c1) {
        for c in ring_cells(centre, c0, c1, ring) {
            let at = (c[1] * grid.side + c[0]) as usize;
            let listed = &grid.triangles[grid.cell_start[at] as usize..grid.cell_start[at + 1] as usize];
            weighed += listed.len() as u32;
            let (t, n) = nearest(listed.iter().copied(), uv, indices, s, lo);
            touching = least(touching, t);
            near = least(near, n);
        }
        if search_done(touching, near, ring, width) {
            break;
        }
    }
    (if touching.1 != 0 { touching.1 } else { near.1 }, weighed)
}

/// The lexicographic least of two (distance, triangle + 1) pairs.
fn least(a: (f32, u32), b: (f32, u32)) -> (f32, u32) {
    if b.0 < a.0 || (b.0 == a.0 && b.1 < a.1) { b } else { a }
}

/// Rings of cells round `centre` within [c0, c1]: the last one's number.
pub fn ring_count(centre: [u32; 2], c0: [u32; 2], c1: [u32; 2]) -> u32 {
    (centre[0] - c0[0]).max(c1[0] - centre[0]).max(centre[1] - c0[1]).max(c1[1] - centre[1])
}

/// The cells of [c0, c1] `ring` cells from `centre` (Chebyshev distance),
/// row by row.
pub fn ring_cells(centre: [u32; 2], c0: [u32; 2], c1: [u32; 2], ring: u32) -> impl Iterator<Item = [u32; 2]> {
    let (x0, x1) = (centre[0].saturating_sub(ring).max(c0[0]), (centre[0] + ring).min(c1[0]));
    let (y0, y1) = (centre[1].saturating_sub(ring).max(c0[1]), (centre[1] + ring).min(c1[1]));
    (y0..=y1).flat_map(move |y| {
        let edge = y + ring == centre[1] || y == centre[1] + ring;
        (x0..=x1).filter(move |&x| edge || x + ring == centre[0] || x == centre[0] + ring).map(move |x| [x, y])
    })
}

/// Whether the search may stop after ring `ring` of cells `width` texels
/// wide, with the nearest touching and near triangles found so far. A
/// triangle's point nearest the texel's centre lies in its bounding box, so
/// in a cell that lists it: a triangle not yet weighed is at least `ring`
/// cells from the centre (less a 64th of a cell for rounding). A triangle
/// holding the centre (distance 0) is listed in the centre's cell (ring 0).
/// Triangles touching the texel are within 0.71 texels of its centre, so
/// past 0.75 texels with none found there is none, and the nearest of the
/// others decides.
pub fn search_done(touching: (f32, u32), near: (f32, u32), ring: u32, width: f32) -> bool {
    let beyond = (ring as f32 - 1.0 / 64.0) * width;
    if touching.1 != 0 {
        return touching.0 == 0.0 || touching.0 < beyond;
    }
    beyond > 0.75 && near.1 != 0 && near.0 < beyond
}

/// Of `triangles`, the nearest (distance, triangle + 1) to the texel at
/// `lo` touching its square, and touching only its 3x3 neighbourhood.
fn nearest(
    triangles: impl Iterator<Item = u32>,
    uv: &[Vec2],
    indices: &[u32],
    s: f32,
    lo: Vec2,
) -> ((f32, u32), (f32, u32)) {
    let (ring_lo, ring_hi) = (lo - 1.0, lo + 2.0);
    let centre = lo + 0.5;
    let (mut touching, mut near) = ((f32::MAX, 0u32), (f32::MAX, 0u32));
    for triangle in triangles {
        let p = [0, 1, 2].map(|k| uv[indices[3 * triangle as usize + k] as usize] * s);
        if !overlaps(p, ring_lo, ring_hi) {
            continue;
        }
        let d = triangle_distance(p, centre);
        let best = if overlaps(p, lo, lo + 1.0) { &mut touching } else { &mut near };
        if d < best.0 || (d == best.0 && triangle + 1 < best.1) {
            *best = (d, triangle + 1);
        }
    }
    (touching, near)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squares_overlap_triangles_by_separating_axes() {
        let t = [Vec2::new(0.0, 0.0), Vec2::new(4.0, 0.0), Vec2::new(0.0, 4.0)];
        assert!(overlaps(t, Vec2::new(1.0, 1.0), Vec2::new(2.0, 2.0)));
        // Inside the box but beyond the hypotenuse x + y = 4.
        assert!(!overlaps(t, Vec2::new(2.5, 2.5), Vec2::new(3.5, 3.5)));
        // Touching the hypotenuse at a corner counts.
        assert!(overlaps(t, Vec2::new(2.0, 2.0), Vec2::new(3.0, 3.0)));
        assert_eq!(triangle_distance(t, Vec2::new(1.0, 1.0)), 0.0);
        assert!((triangle_distance(t, Vec2::new(3.0, 3.0)) - 2.0f32.sqrt()).abs() < 1e-5);
        assert!((triangle_distance(t, Vec2::new(-1.0, 2.0)) - 1.0).abs() < 1e-6);
    }

    /// The grid and the centre-cell shortcut find what a search of every
    /// triangle finds, at every level of a jittered 24 x 24 grid mesh (a
    /// terrain patch's shape: at coarse levels each texel's ring spans many
    /// cells), texels on the chart's border and beyond it included.
    #[test]
    fn the_grid_and_its_shortcut_find_what_searching_every_triangle_finds() {
        let n = 24;
        let jitter = |i: u32, j: u32| ((i * 7 + j * 13) % 5) as f32 * 0.04;
        let mut uv = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let inner = |k: u32| if k == 0 || k == n { 0.0 } else { 1.0 };
                let x = (i as f32 + jitter(i, j) * inner(i)) / n as f32;
                let y = (j as f32 + jitter(j, i) * inner(j)) / n as f32;
                uv.push(Vec2::new(x, y) * 0.9 + 0.05);
            }
        }
        let mut indices = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = j * (n + 1) + i;
                indices.extend([v, v + 1, v + n + 2, v, v + n + 2, v + n + 1]);
            }
        }
        let grid = ChartGrid::new(&uv, &indices);
        let all = (indices.len() / 3) as u32;
        for size in [4, 8, 16, 32, 64, 128] {
            for y in 0..size {
                for x in 0..size {
                    let lo = Vec2::new(x as f32, y as f32);
                    let (touching, near) = nearest(0..all, &uv, &indices, size as f32, lo);
                    let want = if touching.1 != 0 { touching.1 } else { near.1 };
                    assert_eq!(
                        covering_triangle(&grid, &uv, &indices, size, [x, y]),
                        want,
                        "texel ({x}, {y}) of {size}"
                    );
                }
            }
        }
    }

    #[test]
    fn texels_take_touching_triangles_then_one_ring_of_neighbours() {
        // Two triangles of a quad [2, 6]^2 in texel units of a 16-texel level.
        let uv: Vec<Vec2> =
            [(2.0, 2.0), (6.0, 2.0), (6.0, 6.0), (2.0, 6.0)].map(|(x, y)| Vec2::new(x, y) / 16.0).to_vec();
        let indices = [0, 1, 2, 0, 2, 3];
        let grid = ChartGrid::new(&uv, &indices);
        let at = |x, y| covering_triangle(&grid, &uv, &indices, 16, [x, y]);
        // Below the diagonal (x > y) is triangle 0; above it triangle 1.
        assert_eq!(at(4, 2), 1);
        assert_eq!(at(2, 4), 2);
        // The ring just outside the quad takes the nearest triangle; two texels out, nothing.
        assert_eq!(at(6, 3), 1);
        assert_eq!(at(3, 6), 2);
        assert_eq!(at(1, 1), 1);
        assert_eq!(at(8, 3), 0);
        assert_eq!(at(0, 4), 2);
        assert_eq!(at(9, 9), 0);
    }

    /// A city building (fine facades, hundreds of small charts: sills and
    /// reveals): at its coarse levels, where a texel's 3x3 neighbourhood
    /// spans many cells, the ring search finds what searching every triangle
    /// finds, and weighs a small share of what the search before it weighed
    /// (the centre's cell, then, unless it held the centre, every cell of the
    /// neighbourhood).
    #[test]
    fn the_ring_search_finds_every_triangle_search_on_a_city_building_and_weighs_few() {
        let scene = crate::scene::generate::city::CitySpec { blocks: 1, seed: 27 }.scene();
        let mesh = scene.meshes.iter().find(|m| m.name == "building1").expect("the city has building1");
        let uv = mesh.uv1.as_deref().unwrap_or(&mesh.uv0);
        let grid = ChartGrid::new(uv, &mesh.indices);
        let all = (mesh.indices.len() / 3) as u32;
        for size in [8, 16, 32, 64, 128] {
            let (mut weighed, mut before) = (0u64, 0u64);
            let s = size as f32;
            for y in 0..size {
                for x in 0..size {
                    let lo = Vec2::new(x as f32, y as f32);
                    let (got, w) = covering_triangle_counted(&grid, uv, &mesh.indices, size, [x, y]);
                    weighed += w as u64;
                    let centre = (lo + 0.5) / s;
                    before += grid.near(centre, centre).count() as u64;
                    let (own, _) = nearest(grid.near(centre, centre), uv, &mesh.indices, s, lo);
                    if own.1 == 0 || own.0 != 0.0 {
                        before += grid.near((lo - 1.0) / s, (lo + 2.0) / s).count() as u64;
                    }
                    if size <= 32 {
                        let (touching, near) = nearest(0..all, uv, &mesh.indices, s, lo);
                        let want = if touching.1 != 0 { touching.1 } else { near.1 };
                        assert_eq!(got, want, "texel ({x}, {y}) of {size}");
                    }
                }
            }
            // Measured: 2,677 against 60,565 at 8 texels, 10,567 against
            // 50,397 at 16, 25,021 against 57,803 at 32; 1.1 to 1.2 times
            // fewer at 64 and 128, where most centres' cells settle them.
            if size <= 32 {
                assert!(weighed * 2 < before, "{size} texels: {weighed} weighed, {before} before the rings");
            }
            assert!(weighed <= before, "{size} texels: {weighed} weighed, {before} before the rings");
        }
    }
}
