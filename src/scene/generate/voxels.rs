//! The `voxels` scene: a Minecraft-like world of 256 x 256 columns of 1 m
//! blocks (at most 64 high), centred on the origin in x and z, bottom at y = 0.
//!
//! Terrain heights come from seeded value noise plus one big hill, which a
//! tunnel crosses from side to side (its mouths open onto lower ground).
//! Block kinds follow height: sand near the water line, grass (snow on the
//! peaks) on top, three blocks of dirt, stone below; water fills the low
//! ground up to y = 10; seeded trees (wood trunks, leaf crowns) stand on grass.
//!
//! Only exposed faces are emitted, two triangles per block face (no merged
//! triangles, so the scene keeps a realistic triangle load). For the charts,
//! coplanar faces of one kind are merged greedily into rectangles of at most
//! 8 x 8 blocks: each rectangle is one chart laid out at its true size, so
//! charts stay few enough for the gutter. One object per 32 x 32-column
//! chunk and block kind.

use glam::{IVec3, Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::builder::MeshBuilder;
use super::noise::ValueNoise;
use super::{Assembler, Generated, Look};

/// Columns along x and z.
const SIZE: usize = 256;
/// Cells along y.
const HEIGHT: usize = 64;
/// Columns per chunk side (one object per chunk and kind).
const CHUNK: usize = 32;
/// Water fills air cells below this height.
const WATER: usize = 10;
/// Surfaces at or above this height are snow.
const SNOW: usize = 34;
const SEED: u64 = 0x5eed_b10c;
/// Centre (x, z) of the hill the tunnel goes through.
const HILL: Vec2 = Vec2::new(88.0, 168.0);
/// Longest chart side in blocks: long thin charts (a cliff along a chunk)
/// would cap the atlas scale of the whole object.
const MAX_CHART: usize = 8;
/// Random tree sites tried (most fail: not grass, or too near another tree).
const TREE_ATTEMPTS: usize = 1200;

/// Block kinds; the value is the cell byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(super) enum Block {
    Air = 0,
    Water,
    Grass,
    Dirt,
    Stone,
    Sand,
    Snow,
    Wood,
    Leaves,
}

/// (kind, name, linear tint, specular, shininess) of every block that has faces.
const KINDS: [(Block, &str, Vec3, f32, f32); 8] = [
    (Block::Water, "water", Vec3::new(0.1, 0.25, 0.6), 0.5, 64.0),
    (Block::Grass, "grass", Vec3::new(0.2, 0.5, 0.12), 0.2, 8.0),
    (Block::Dirt, "dirt", Vec3::new(0.4, 0.26, 0.14), 0.2, 8.0),
    (Block::Stone, "stone", Vec3::new(0.45, 0.45, 0.45), 0.3, 16.0),
    (Block::Sand, "sand", Vec3::new(0.75, 0.68, 0.45), 0.2, 12.0),
    (Block::Snow, "snow", Vec3::new(0.9, 0.92, 0.95), 0.4, 32.0),
    (Block::Wood, "wood", Vec3::new(0.35, 0.22, 0.1), 0.2, 8.0),
    (Block::Leaves, "leaves", Vec3::new(0.1, 0.38, 0.08), 0.25, 16.0),
];

/// The block grid.
pub(super) struct World {
    cells: Vec<u8>,
}

impl World {
    fn index(x: usize, y: usize, z: usize) -> usize {
        (y * SIZE + z) * SIZE + x
    }

    /// The block at `p`, or `None` outside the grid.
    pub(super) fn get(&self, p: IVec3) -> Option<u8> {
        let inside = p.cmpge(IVec3::ZERO).all() && p.x < SIZE as i32 && p.y < HEIGHT as i32 && p.z < SIZE as i32;
        inside.then(|| self.cells[Self::index(p.x as usize, p.y as usize, p.z as usize)])
    }

    fn set(&mut self, x: usize, y: usize, z: usize, b: Block) {
        self.cells[Self::index(x, y, z)] = b as u8;
    }
}

/// Terrain height (number of solid cells) of every column.
fn heights() -> Vec<usize> {
    let noise = ValueNoise::new(SEED);
    let mut h = vec![0; SIZE * SIZE];
    for z in 0..SIZE {
        for x in 0..SIZE {
            let (fx, fz) = (x as f32, z as f32);
            // Broad landscape, stretched so that both lakes and hills occur.
            let n = noise.fbm(fx / 48.0, fz / 48.0, 5);
            let land = ((n - 0.3) / 0.5).clamp(0.0, 1.0);
            let hill = 24.0 * (-(Vec2::new(fx, fz) - HILL).length_squared() / (2.0 * 16.0 * 16.0)).exp();
            // Small bumps on land, as in block games (flat near the water line).
            let bumps = 3.0 * land * noise.sample(fx / 5.0 + 100.0, fz / 5.0 - 100.0);
            let height = 4.0 + 44.0 * land.powf(1.5) + hill + bumps;
            h[z * SIZE + x] = (height as usize).clamp(1, HEIGHT - 4);
        }
    }
    h
}

/// Generates the block grid: terrain, layers, water, then the tunnel.
pub(super) fn world() -> World {
    let h = heights();
    let mut w = World { cells: vec![Block::Air as u8; SIZE * SIZE * HEIGHT] };
    for z in 0..SIZE {
        for x in 0..SIZE {
            let top = h[z * SIZE + x];
            let beach = top <= WATER + 1;
            for y in 0..top {
                let depth = top - 1 - y;
                let b = match depth {
                    0 if beach => Block::Sand,
                    0 if top > SNOW => Block::Snow,
                    0 => Block::Grass,
                    1..=3 if beach => Block::Sand,
                    1..=3 => Block::Dirt,
                    _ => Block::Stone,
                };
                w.set(x, y, z, b);
            }
            for y in top..WATER {
                w.set(x, y, z, Block::Water);
            }
        }
    }
    carve_tunnel(&mut w, &h);
    plant_trees(&mut w, &h);
    w
}

/// Seeded trees on grass: a trunk of 4-6 blocks under a ragged blob of
/// leaves, at least 6 columns apart. Leaves give the scene the many small
/// faces of a real block world.
fn plant_trees(w: &mut World, h: &[usize]) {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED ^ 0x7ee5);
    let mut taken = vec![false; SIZE * SIZE];
    for _ in 0..TREE_ATTEMPTS {
        let (x, z) = (rng.random_range(3..SIZE - 3), rng.random_range(3..SIZE - 3));
        let top = h[z * SIZE + x];
        let trunk = rng.random_range(4..=6usize);
        let grass = w.get(IVec3::new(x as i32, top as i32 - 1, z as i32)) == Some(Block::Grass as u8);
        if !grass || top + trunk + 3 >= HEIGHT || taken[z * SIZE + x] {
            continue;
        }
        // Keep the next trees 6 columns away.
        for tz in z.saturating_sub(5)..(z + 6).min(SIZE) {
            for tx in x.saturating_sub(5)..(x + 6).min(SIZE) {
                taken[tz * SIZE + tx] = true;
            }
        }
        let crown = (top + trunk) as i32;
        for dy in -2..=1i32 {
            let r: i32 = if dy == 1 { 1 } else { 2 };
            for dz in -r..=r {
                for dx in -r..=r {
                    // Round the corners, and drop a few cells for a ragged crown.
                    let corner = dx.abs() == r && dz.abs() == r;
                    if (corner && (dy == 1 || rng.random_bool(0.6))) || rng.random_bool(0.08) {
                        continue;
                    }
                    let (cx, cy, cz) = ((x as i32 + dx) as usize, (crown + dy) as usize, (z as i32 + dz) as usize);
                    if w.get(IVec3::new(cx as i32, cy as i32, cz as i32)) == Some(Block::Air as u8) {
                        w.set(cx, cy, cz, Block::Leaves);
                    }
                }
            }
        }
        for y in top..top + trunk {
            w.set(x, y, z, Block::Wood);
        }
    }
}

/// A winding tube of radius 2.6 along x through the hill, above the water,
/// running on until the ground on both sides has dropped below its floor.
fn carve_tunnel(w: &mut World, h: &[usize]) {
    let radius = 2.6f32;
    let centre = |x: f32| Vec2::new(HILL.y + 3.0 * (x / 11.0).sin(), (WATER + 5) as f32 + 1.5 * (x / 13.0).sin());
    let ground = |x: usize| {
        let z = (centre(x as f32 + 0.5).x as usize).min(SIZE - 1);
        h[z * SIZE + x] as f32
    };
    let open = |x: usize| ground(x) < centre(x as f32 + 0.5).y - radius;
    let start = HILL.x as usize;
    let x0 = (0..start).rev().find(|&x| open(x)).unwrap_or(0);
    let x1 = (start..SIZE).find(|&x| open(x)).unwrap_or(SIZE - 1);
    for x in x0..=x1 {
        let c = centre(x as f32 + 0.5);
        let (zlo, zhi) = ((c.x - radius).floor() as usize, (c.x + radius).ceil() as usize);
        let (ylo, yhi) = ((c.y - radius).floor().max(0.0) as usize, (c.y + radius).ceil() as usize);
        for z in zlo..=zhi.min(SIZE - 1) {
            for y in ylo..=yhi.min(HEIGHT - 1) {
                if (Vec2::new(z as f32 + 0.5, y as f32 + 0.5) - c).length() < radius {
                    w.set(x, y, z, Block::Air);
                }
            }
        }
    }
}

/// Whether the face of block `b` towards `neighbour` is visible: solid blocks
/// show against air and the open sides of the world (not the bottom), water
/// only against air and the open sides. Water hides what is under it.
fn visible(b: u8, neighbour: Option<u8>, down: bool) -> bool {
    match neighbour {
        Some(n) => b != Block::Air as u8 && n == Block::Air as u8,
        None => b != Block::Air as u8 && !down,
    }
}

pub(super) fn build() -> Generated {
    let world = world();
    let mut a = Assembler::new("voxels");
    let looks: Vec<Look> = KINDS.iter().map(|&(_, name, tint, spec, shin)| a.look(name, tint, 4, spec, shin)).collect();
    let kind_slot = |b: u8| KINDS.iter().position(|k| k.0 as u8 == b).expect("a block with faces");
    let chunks = SIZE / CHUNK;
    for cz in 0..chunks {
        for cx in 0..chunks {
            let mut builders: Vec<MeshBuilder> = KINDS.iter().map(|_| MeshBuilder::new()).collect();
            mesh_chunk(&world, IVec3::new((cx * CHUNK) as i32, 0, (cz * CHUNK) as i32), |b, rect| {
                emit(&mut builders[kind_slot(b)], rect);
            });
            for (k, builder) in builders.into_iter().enumerate() {
                if !builder.is_empty() {
                    a.add(&format!("chunk_{cx}_{cz}_{}", KINDS[k].1), builder, looks[k]);
                }
            }
        }
    }
    a.finish()
}

/// A rectangle of same-kind faces in one plane.
struct FaceRect {
    /// Axis of the normal (0 = x, 1 = y, 2 = z) and its sign.
    axis: usize,
    sign: i32,
    /// Plane coordinate along `axis` (cell boundary).
    plane: i32,
    /// First cell and size along the two in-plane axes (see [`plane_axes`]).
    start: (i32, i32),
    size: (i32, i32),
}

/// The in-plane axes (u, v) of faces whose normal is along `axis`.
fn plane_axes(axis: usize) -> (usize, usize) {
    match axis {
        0 => (2, 1),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Finds every visible face of the chunk whose first column is `origin` and
/// passes them to `out` merged into maximal rectangles (greedy meshing per
/// plane, kind by kind).
fn mesh_chunk(world: &World, origin: IVec3, mut out: impl FnMut(u8, FaceRect)) {
    let (x0, z0) = (origin.x as usize, origin.z as usize);
    // Only the layers up to the chunk's highest block can have faces.
    let occupied =
        |y: usize| (z0..z0 + CHUNK).any(|z| (x0..x0 + CHUNK).any(|x| world.cells[World::index(x, y, z)] != 0));
    let top = (0..HEIGHT).rev().find(|&y| occupied(y)).map_or(0, |y| y + 1) as i32;
    let extent = IVec3::new(CHUNK as i32, top, CHUNK as i32);
    let world_size = IVec3::new(SIZE as i32, HEIGHT as i32, SIZE as i32);
    // Index strides of x, y, z in `World::cells`.
    let stride = [1, (SIZE * SIZE) as isize, SIZE as isize];
    let mut mask = Vec::new();
    for axis in 0..3 {
        let (ua, va) = plane_axes(axis);
        let (nu, nv) = (extent[ua], extent[va]);
        let down_axis = axis == 1;
        for sign in [-1, 1] {
            let down = down_axis && sign < 0;
            for c in 0..extent[axis] {
                let layer = origin[axis] + c;
                let neighbour_inside = (0..world_size[axis]).contains(&(layer + sign));
                mask.clear();
                for v in 0..nv {
                    let mut p = origin;
                    p[axis] = layer;
                    p[va] += v;
                    let row = World::index(p.x as usize, p.y as usize, p.z as usize);
                    for u in 0..nu as usize {
                        let i = row.wrapping_add_signed(stride[ua] * u as isize);
                        let b = world.cells[i];
                        let n =
                            neighbour_inside.then(|| world.cells[i.wrapping_add_signed(stride[axis] * sign as isize)]);
                        mask.push(if visible(b, n, down) { b } else { 0 });
                    }
                }
                greedy(&mut mask, nu as usize, nv as usize, |b, (u, v), (w, h)| {
                    let plane = layer + (sign > 0) as i32;
                    let start = (origin[ua] + u as i32, origin[va] + v as i32);
                    out(b, FaceRect { axis, sign, plane, start, size: (w as i32, h as i32) });
                });
            }
        }
    }
}

/// Greedy rectangle cover of a `nu` x `nv` mask (row-major, v outer): grows
/// each rectangle along u, then along v while whole rows match. Clears the mask.
fn greedy(mask: &mut [u8], nu: usize, nv: usize, mut out: impl FnMut(u8, (usize, usize), (usize, usize))) {
    for v in 0..nv {
        let mut u = 0;
        while u < nu {
            let b = mask[v * nu + u];
            if b == 0 {
                u += 1;
                continue;
            }
            let mut w = 1;
            while u + w < nu && w < MAX_CHART && mask[v * nu + u + w] == b {
                w += 1;
            }
            let mut h = 1;
            while v + h < nv && h < MAX_CHART && mask[(v + h) * nu + u..(v + h) * nu + u + w].iter().all(|&m| m == b) {
                h += 1;
            }
            for row in v..v + h {
                mask[row * nu + u..row * nu + u + w].fill(0);
            }
            out(b, (u, v), (w, h));
            u += w;
        }
    }
}

/// Emits a face rectangle as one chart of unit quads (shared vertices).
fn emit(b: &mut MeshBuilder, r: FaceRect) {
    let (ua, va) = plane_axes(r.axis);
    let mut normal = Vec3::ZERO;
    normal[r.axis] = r.sign as f32;
    // World placement: centred in x and z.
    let offset = Vec3::new(-0.5 * SIZE as f32, 0.0, -0.5 * SIZE as f32);
    let chart = b.chart();
    let mut first = None;
    for j in 0..=r.size.1 {
        for i in 0..=r.size.0 {
            let mut p = Vec3::ZERO;
            p[r.axis] = r.plane as f32;
            p[ua] = (r.start.0 + i) as f32;
            p[va] = (r.start.1 + j) as f32;
            let p = p + offset;
            // One checker repeat per block, in world units.
            let uv0 = Vec2::new(p[ua], -p[va]);
            let v = b.vertex(chart, p, normal, uv0, Vec2::new(i as f32, j as f32));
            first.get_or_insert(v);
        }
    }
    let first = first.expect("a rectangle has vertices");
    let row = (r.size.0 + 1) as u32;
    for j in 0..r.size.1 as u32 {
        for i in 0..r.size.0 as u32 {
            let v = first + j * row + i;
            b.quad(v, v + 1, v + 1 + row, v + row);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use super::*;

    /// Flood-fills the air reachable from the sky and the open sides, and
    /// counts reached air cells that have a solid block above them: a cave
    /// open to the outside (a pure height field has none).
    #[test]
    fn tunnel_is_open_to_the_outside() {
        let w = world();
        let air = |p: IVec3| w.get(p) == Some(Block::Air as u8);
        let mut seen = vec![false; SIZE * SIZE * HEIGHT];
        let mut queue = VecDeque::new();
        for z in 0..SIZE as i32 {
            for x in 0..SIZE as i32 {
                let p = IVec3::new(x, HEIGHT as i32 - 1, z);
                assert!(air(p), "the top layer must be sky");
                seen[World::index(x as usize, HEIGHT - 1, z as usize)] = true;
                queue.push_back(p);
            }
        }
        let dirs = [IVec3::X, IVec3::NEG_X, IVec3::Y, IVec3::NEG_Y, IVec3::Z, IVec3::NEG_Z];
        while let Some(p) = queue.pop_front() {
            for d in dirs {
                let q = p + d;
                if air(q) {
                    let i = World::index(q.x as usize, q.y as usize, q.z as usize);
                    if !seen[i] {
                        seen[i] = true;
                        queue.push_back(q);
                    }
                }
            }
        }
        let mut covered = 0;
        for z in 0..SIZE {
            for x in 0..SIZE {
                let mut roof = false;
                for y in (0..HEIGHT).rev() {
                    let b = w.get(IVec3::new(x as i32, y as i32, z as i32)).unwrap();
                    // Only terrain makes a roof (air under a tree crown is no cave).
                    let terrain = ![Block::Air, Block::Water, Block::Wood, Block::Leaves].iter().any(|&t| t as u8 == b);
                    if terrain {
                        roof = true;
                    } else if roof && b == Block::Air as u8 && seen[World::index(x, y, z)] {
                        covered += 1;
                    }
                }
            }
        }
        assert!(covered > 200, "only {covered} reachable air cells under a roof");
    }

    #[test]
    fn greedy_covers_the_mask_exactly() {
        let (nu, nv) = (7, 5);
        let mut mask: Vec<u8> = (0..nu * nv).map(|i| [0, 1, 1, 2][(i * 7 / 3) % 4]).collect();
        let original = mask.clone();
        let mut cover = vec![0u8; nu * nv];
        greedy(&mut mask, nu, nv, |b, (u, v), (w, h)| {
            for y in v..v + h {
                for x in u..u + w {
                    assert_eq!(cover[y * nu + x], 0, "rectangles overlap");
                    cover[y * nu + x] = b;
                }
            }
        });
        assert_eq!(cover, original);
        assert!(mask.iter().all(|&m| m == 0));
    }
}
