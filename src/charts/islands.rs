//! Which chart each triangle lies in: triangles joined by an edge whose two
//! UV endpoints are the same on both sides (continuous in the layout) form
//! one island. Object space filters shades only within the island of the
//! pixel's triangle, so a bilinear tap that reaches a neighbouring chart's
//! texels (they sit closer than a texel at coarse levels) is left out instead
//! of bleeding its colour across the border.

use std::collections::HashMap;

use glam::Vec2;

/// Island of each triangle of `indices` (three per triangle) in the layout
/// `uv`: islands numbered from 0 in the order of their first triangles, so
/// equal numbers mean one island, the numbering does not depend on the edge
/// order, and a mesh's numbers stay below its island count (object space
/// codes them in the atlas's alpha, `gather::ISLAND_CODES`).
pub fn triangle_islands(indices: &[u32], uv: &[Vec2]) -> Vec<u32> {
    let triangles = indices.len() / 3;
    let mut parent: Vec<u32> = (0..triangles as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let key = |i: u32| {
        let p = uv[i as usize];
        (u64::from(p.x.to_bits()) << 32) | u64::from(p.y.to_bits())
    };
    let mut edges: HashMap<[u64; 2], u32> = HashMap::with_capacity(indices.len());
    for t in 0..triangles as u32 {
        for k in 0..3 {
            let (a, b) = (key(indices[3 * t as usize + k]), key(indices[3 * t as usize + (k + 1) % 3]));
            let edge = if a < b { [a, b] } else { [b, a] };
            match edges.get(&edge) {
                Some(&other) => {
                    let (ra, rb) = (root(&mut parent, t), root(&mut parent, other));
                    // The smaller index becomes the root: islands are named
                    // by their first triangle.
                    parent[ra.max(rb) as usize] = ra.min(rb);
                }
                None => {
                    edges.insert(edge, t);
                }
            }
        }
    }
    // A root is its island's first triangle: its island is numbered when
    // the walk reaches it, before any other triangle of the island.
    let mut number = vec![u32::MAX; triangles];
    let mut islands = 0;
    (0..triangles as u32)
        .map(|t| {
            let r = root(&mut parent, t) as usize;
            if number[r] == u32::MAX {
                number[r] = islands;
                islands += 1;
            }
            number[r]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two quads side by side: joined where their shared edge has the same
    /// UVs, two islands where the second quad's copy of it is moved.
    #[test]
    fn shared_uv_edges_join_triangles() {
        let indices = [0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2];
        let joined = [
            Vec2::new(0.0, 0.0),
            Vec2::new(0.5, 0.0),
            Vec2::new(0.5, 1.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
        ];
        assert_eq!(triangle_islands(&indices, &joined), [0, 0, 0, 0]);
        // The second quad's vertices 1 and 2 split off (a chart seam): its
        // triangles use 6 and 7 at other UVs.
        let split_indices = [0, 1, 2, 0, 2, 3, 6, 4, 5, 6, 5, 7];
        let mut split = joined.to_vec();
        split.extend([Vec2::new(0.6, 0.0), Vec2::new(0.6, 1.0)]);
        assert_eq!(triangle_islands(&split_indices, &split), [0, 0, 1, 1]);
    }
}
