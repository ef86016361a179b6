//! Chart grids: per mesh, a uniform grid over its chart UV square listing
//! the triangles whose UV bounding box overlaps each cell, so that building
//! a page of a triangle-index map visits only the triangles near it.

use glam::Vec2;

/// Most cells per side.
const MAX_SIDE: u32 = 256;

/// One mesh's grid: `side` x `side` cells over [0, 1]^2; the triangles of
/// cell `c` are `triangles[cell_start[c]..cell_start[c + 1]]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChartGrid {
    pub side: u32,
    pub cell_start: Vec<u32>,
    pub triangles: Vec<u32>,
}

impl ChartGrid {
    /// The grid of a mesh with chart UVs `uv` and `indices` (three per
    /// triangle): about two triangles per cell.
    pub fn new(uv: &[Vec2], indices: &[u32]) -> Self {
        Self::scaled(uv, indices, 1)
    }

    /// The grid with `scale` times [`ChartGrid::new`]'s cells per side (and
    /// as many times its largest side): finer cells list fewer triangles.
    pub fn scaled(uv: &[Vec2], indices: &[u32], scale: u32) -> Self {
        let count = indices.len() / 3;
        let side = ((count as f64 / 2.0).sqrt().ceil() as u32).clamp(1, MAX_SIDE);
        Self::with_side(uv, indices, side * scale)
    }

    /// The grid of `side` x `side` cells.
    pub fn with_side(uv: &[Vec2], indices: &[u32], side: u32) -> Self {
        let count = indices.len() / 3;
        let cells = |t: usize| {
            let p = [0, 1, 2].map(|k| uv[indices[3 * t + k] as usize]);
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            let cell = |v: f32| ((v * side as f32).floor() as i64).clamp(0, side as i64 - 1) as u32;
            (cell(lo.x)..=cell(hi.x), cell(lo.y)..=cell(hi.y))
        };
        // Counting sort by cell: sizes, offsets, then fill.
        let mut cell_start = vec![0u32; (side * side) as usize + 1];
        for t in 0..count {
            let (xs, ys) = cells(t);
            for y in ys {
                for x in xs.clone() {
                    cell_start[(y * side + x) as usize + 1] += 1;
                }
            }
        }
        for c in 1..cell_start.len() {
            cell_start[c] += cell_start[c - 1];
        }
        let mut fill = cell_start.clone();
        let mut triangles = vec![0u32; *cell_start.last().expect("at least one cell") as usize];
        for t in 0..count {
            let (xs, ys) = cells(t);
            for y in ys {
                for x in xs.clone() {
                    let c = (y * side + x) as usize;
                    triangles[fill[c] as usize] = t as u32;
                    fill[c] += 1;
                }
            }
        }
        Self { side, cell_start, triangles }
    }

    /// The triangles listed in the cells that the UV rectangle [lo, hi] overlaps.
    pub fn near(&self, lo: Vec2, hi: Vec2) -> impl Iterator<Item = u32> + '_ {
        let side = self.side as f32;
        let cell = |v: f32| (v * side).floor().clamp(0.0, side - 1.0) as u32;
        let (x0, x1, y0, y1) = (cell(lo.x), cell(hi.x), cell(lo.y), cell(hi.y));
        (y0..=y1).flat_map(move |y| {
            (x0..=x1).flat_map(move |x| {
                let c = (y * self.side + x) as usize;
                self.triangles[self.cell_start[c] as usize..self.cell_start[c + 1] as usize].iter().copied()
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_triangle_is_listed_in_the_cells_its_box_overlaps() {
        // Eight triangles: a fan of small ones and one across the square.
        let mut uv = Vec::new();
        let mut indices = Vec::new();
        for i in 0..7 {
            let o = Vec2::new(0.1 + 0.11 * i as f32, 0.2 + 0.1 * i as f32);
            uv.extend([o, o + Vec2::new(0.05, 0.0), o + Vec2::new(0.0, 0.05)]);
        }
        uv.extend([Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)]);
        indices.extend(0..uv.len() as u32);
        let g = ChartGrid::new(&uv, &indices);
        assert_eq!(g.side, 2);
        // The big triangle is in every cell; each small one in the cell of its box.
        for c in 0..4 {
            let listed = &g.triangles[g.cell_start[c] as usize..g.cell_start[c + 1] as usize];
            assert!(listed.contains(&7), "cell {c}: {listed:?}");
        }
        let near: Vec<u32> = g.near(Vec2::new(0.1, 0.2), Vec2::new(0.15, 0.25)).collect();
        assert!(near.contains(&0) && near.contains(&7) && !near.contains(&6), "{near:?}");
        let far: Vec<u32> = g.near(Vec2::new(0.76, 0.8), Vec2::new(0.8, 0.85)).collect();
        assert!(far.contains(&6) && !far.contains(&0), "{far:?}");
    }
}
