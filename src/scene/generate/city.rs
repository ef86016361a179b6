//! A procedural city (issue 27, item 1): a square grid of blocks with
//! streets between them, built from a handful of meshes instanced many
//! times (one mesh, many transforms), so that the scene is large in
//! triangles and instances but small in memory. See `docs/city.md`.
//!
//! Each block is a sidewalk slab of [`BLOCK`] metres with a ring of eight
//! buildings on a 3 x 3 grid of [`LOT`]-metre lots (the middle one is a
//! courtyard), street furniture along its kerbs (lamps, trees, benches,
//! bollards), and a road tile under it. A building is two instances of one
//! of six building types: its shell (facades with recessed windows, sills,
//! a ledge at every floor, a parapet and roof; brick facades with a normal
//! map) and its glass (glossy panes with frames). Types and quarter turns
//! are drawn from the seed.
//!
//! Every facade is one chart, unfolded along its height: the wall, each
//! ledge's underside, front and top, the parapet's top and inner face, with
//! each window's four reveals folded into its hole; sills, panes and roofs
//! are charts of their own. Objects are listed mesh by mesh, so that the
//! instances of a mesh are consecutive (one instanced draw for a run of
//! visible ones).

use std::f32::consts::FRAC_PI_2;

use glam::{Mat4, Quat, Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Generated;
use super::builder::{ChartId, Faces, MeshBuilder};
use super::terrain::{pose, unwrap_yaw};
use crate::color::linear_to_srgb8;
use crate::scene::detail::brick_textures;
use crate::scene::path::{KeyedPath, Projection};
use crate::scene::{Material, Object, Scene, Texture};

/// Side of a block (sidewalk slab) in metres.
pub const BLOCK: f32 = 52.0;
/// Sidewalk between the kerb and the lots.
pub const SIDEWALK: f32 = 2.0;
/// Street width between two blocks.
pub const STREET: f32 = 12.0;
/// Block plus street: the city's grid spacing.
pub const PITCH: f32 = BLOCK + STREET;
/// Side of a lot (3 x 3 per block).
pub const LOT: f32 = 16.0;
/// Side of a building's square footprint.
pub const FOOTPRINT: f32 = 14.0;
/// Height of the sidewalk slab above the road.
const KERB: f32 = 0.15;
/// Eye height of the street-level path above the road.
const EYE: f32 = 1.7;
/// Facade texture repeats per metre (one 512-texel brick texture a metre).
const FACADE_TILING: f32 = 1.0;
/// Buildings per block (the middle lot is a courtyard).
const BUILDINGS_PER_BLOCK: usize = 8;
/// Street furniture per block side: lamps, trees, benches, bollards, and
/// where along the side (metres from its start) and how far from the kerb.
const LAMPS: [f32; 3] = [8.0, 26.0, 44.0];
const TREES: [f32; 2] = [17.0, 35.0];
const BENCHES: [f32; 2] = [12.5, 39.5];
const BOLLARDS: [f32; 4] = [3.0, 4.5, 47.5, 49.0];

/// Instances per block: road tile, sidewalk, two per building, furniture.
pub const INSTANCES_PER_BLOCK: usize =
    2 + 2 * BUILDINGS_PER_BLOCK + 4 * (LAMPS.len() + TREES.len() + BENCHES.len() + BOLLARDS.len());

/// One building type: floors and windows per facade row.
#[derive(Clone, Copy, Debug)]
struct BuildingType {
    floors: u32,
    windows: u32,
    /// Index of its facade texture.
    facade: usize,
}

const BUILDING_TYPES: [BuildingType; 6] = [
    BuildingType { floors: 3, windows: 5, facade: 0 },
    BuildingType { floors: 5, windows: 6, facade: 1 },
    BuildingType { floors: 8, windows: 5, facade: 2 },
    BuildingType { floors: 12, windows: 6, facade: 0 },
    BuildingType { floors: 16, windows: 7, facade: 1 },
    BuildingType { floors: 24, windows: 6, facade: 2 },
];
/// Ground floor height, upper floor height, parapet height above the roof.
const GROUND_FLOOR: f32 = 4.4;
const FLOOR: f32 = 3.3;
const PARAPET: f32 = 1.0;

/// The city's size and seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CitySpec {
    /// Blocks per side.
    pub blocks: u32,
    /// Seed of the building types and turns.
    pub seed: u64,
}

impl CitySpec {
    /// `--scene city`: 13 x 13 blocks, 10,478 instances of 18 meshes,
    /// over 10 M triangles (`docs/city.md` has the counts).
    pub const DEFAULT: CitySpec = CitySpec { blocks: 13, seed: 27 };
    /// Most blocks per side `city:N` takes (254,000 instances).
    pub const MAX_BLOCKS: u32 = 64;

    /// Reads a `--scene` value naming the city: `city`, `city:N` (N blocks
    /// per side) or `city:N:SEED`. `None` when `spec` is not a city; an
    /// error saying what is wrong with a city spec that is malformed.
    pub fn parse(spec: &str) -> Option<Result<CitySpec, String>> {
        let rest = match spec.strip_prefix("city") {
            Some("") => return Some(Ok(Self::DEFAULT)),
            Some(rest) => rest.strip_prefix(':')?,
            None => return None,
        };
        let mut parts = rest.split(':');
        let blocks = parts.next().and_then(|n| n.parse::<u32>().ok()).filter(|n| (1..=Self::MAX_BLOCKS).contains(n));
        let seed = match parts.next() {
            None => Some(Self::DEFAULT.seed),
            Some(s) => s.parse::<u64>().ok(),
        };
        Some(match (blocks, seed, parts.next()) {
            (Some(blocks), Some(seed), None) => Ok(CitySpec { blocks, seed }),
            _ => Err(format!(
                "expected city, city:N or city:N:SEED with N blocks per side from 1 to {} and SEED a whole number",
                Self::MAX_BLOCKS
            )),
        })
    }

    /// The name the scene reports: `city`, `city:N` or `city:N:SEED`.
    pub fn name(&self) -> String {
        match (self.blocks == Self::DEFAULT.blocks, self.seed == Self::DEFAULT.seed) {
            (true, true) => "city".into(),
            (_, true) => format!("city:{}", self.blocks),
            _ => format!("city:{}:{}", self.blocks, self.seed),
        }
    }

    /// Instances the city has: [`INSTANCES_PER_BLOCK`] per block.
    pub fn instance_count(&self) -> usize {
        (self.blocks * self.blocks) as usize * INSTANCES_PER_BLOCK
    }

    /// Side of the city (blocks and the streets around them) in metres.
    pub fn side(&self) -> f32 {
        self.blocks as f32 * PITCH
    }

    /// The scene.
    pub fn scene(&self) -> Scene {
        self.build().scene
    }

    /// [`CitySpec::scene`] with its meshes' chart layouts.
    pub(crate) fn build(&self) -> Generated {
        let mut kit = Kit::new(&self.name());
        let meshes = kit.meshes();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        // (mesh, transform, name), listed block by block, then sorted by mesh.
        let mut placed: Vec<(usize, Mat4, String)> = Vec::with_capacity(self.instance_count());
        for j in 0..self.blocks {
            for i in 0..self.blocks {
                let tile = Vec3::new(i as f32 * PITCH, 0.0, j as f32 * PITCH);
                placed.push((meshes.road, Mat4::from_translation(tile), format!("road_{i}_{j}")));
                let block = tile + Vec3::new(0.5 * STREET, 0.0, 0.5 * STREET);
                placed.push((meshes.sidewalk, Mat4::from_translation(block), format!("sidewalk_{i}_{j}")));
                for lot in (0..9).filter(|&l| l != 4) {
                    let (a, b) = (lot % 3, lot / 3);
                    let centre =
                        block + Vec3::new(SIDEWALK + (a as f32 + 0.5) * LOT, KERB, SIDEWALK + (b as f32 + 0.5) * LOT);
                    let kind = rng.random_range(0..BUILDING_TYPES.len());
                    let turn = Quat::from_rotation_y(rng.random_range(0..4) as f32 * FRAC_PI_2);
                    let transform = Mat4::from_rotation_translation(turn, centre);
                    let [shell, glass] = meshes.buildings[kind];
                    placed.push((shell, transform, format!("building_{i}_{j}_{lot}")));
                    placed.push((glass, transform, format!("glass_{i}_{j}_{lot}")));
                }
                // Furniture along each side, placed for side 0 (along +x,
                // the kerb at z = 0) and turned about the block's centre.
                let furniture = [
                    (meshes.lamp, &LAMPS[..], 0.4, "lamp"),
                    (meshes.tree, &TREES[..], 1.0, "tree"),
                    (meshes.bench, &BENCHES[..], 1.3, "bench"),
                    (meshes.bollard, &BOLLARDS[..], 0.35, "bollard"),
                ];
                let centre = block + Vec3::new(0.5 * BLOCK, 0.0, 0.5 * BLOCK);
                for side in 0..4 {
                    let turn = Quat::from_rotation_y(side as f32 * FRAC_PI_2);
                    for &(mesh, along, inset, what) in &furniture {
                        for (k, &s) in along.iter().enumerate() {
                            let local = Vec3::new(s - 0.5 * BLOCK, KERB, inset - 0.5 * BLOCK);
                            let transform = Mat4::from_rotation_translation(turn, centre + turn * local);
                            placed.push((mesh, transform, format!("{what}_{i}_{j}_{side}_{k}")));
                        }
                    }
                }
            }
        }
        // Instances of one mesh are consecutive (a stable sort keeps block order).
        placed.sort_by_key(|(mesh, _, _)| *mesh);
        let scene = &mut kit.generated.scene;
        scene.objects = placed
            .into_iter()
            .map(|(mesh, transform, name)| Object { name, mesh, material: mesh, transform, forward_only: false })
            .collect();
        kit.generated
    }

    /// The street-level path: a walk at eye height down the middle of a
    /// street across half the city, a turn at a crossing, and on down the
    /// cross street to the city's edge (buildings on both sides hide all
    /// but a few blocks). Three legs of 300 frames.
    pub fn street_path(&self) -> KeyedPath {
        let side = self.side();
        let mid = (self.blocks / 2).max(1) as f32 * PITCH;
        let eye = |x: f32, z: f32| Vec3::new(x, EYE, z);
        let keys = vec![
            pose(eye(2.0, mid), eye(side, mid)),
            pose(eye(mid - 4.0, mid), eye(side, mid)),
            pose(eye(mid, mid + 4.0), eye(mid, side)),
            pose(eye(mid, side - 2.0), eye(mid, 2.0 * side)),
        ];
        KeyedPath { keys: unwrap_yaw(keys), frames_per_segment: 300, projection: self.projection() }
    }

    /// The fly-over: four legs of 300 frames round the city, high above
    /// the tallest roofs, looking down at its middle (most of the city in
    /// view, little occlusion).
    pub fn flyover_path(&self) -> KeyedPath {
        let side = self.side();
        let centre = Vec3::new(0.5 * side, 0.0, 0.5 * side);
        let height = 0.35 * side + 2.0 * tallest();
        let keys = (0..5)
            .map(|k| {
                let a = k as f32 * FRAC_PI_2 + 0.6;
                let eye = centre + Vec3::new(0.55 * side * a.cos(), height, 0.55 * side * a.sin());
                pose(eye, centre)
            })
            .collect();
        KeyedPath { keys: unwrap_yaw(keys), frames_per_segment: 300, projection: self.projection() }
    }

    /// 60 degrees, near 0.1 m, far past the city's diagonal from any eye.
    pub fn projection(&self) -> Projection {
        Projection { fov_y: std::f32::consts::FRAC_PI_3, near: 0.1, far: 3.0 * self.side() + 4.0 * tallest() }
    }
}

/// Height of the tallest building type's parapet.
fn tallest() -> f32 {
    let floors = BUILDING_TYPES.iter().map(|t| t.floors).max().unwrap_or(1);
    GROUND_FLOOR + (floors - 1) as f32 * FLOOR + PARAPET
}

/// Mesh indices of the city's kit (material `i` belongs to mesh `i`).
struct KitMeshes {
    road: usize,
    sidewalk: usize,
    /// Per building type: shell and glass.
    buildings: Vec<[usize; 2]>,
    lamp: usize,
    tree: usize,
    bench: usize,
    bollard: usize,
}

/// The meshes, materials and textures, one material per mesh.
struct Kit {
    generated: Generated,
}

impl Kit {
    fn new(name: &str) -> Self {
        let scene = Scene { name: name.to_string(), ..Scene::default() };
        Self { generated: Generated { scene, layouts: Vec::new() } }
    }

    fn texture(&mut self, t: Texture) -> usize {
        self.generated.scene.textures.push(t);
        self.generated.scene.textures.len() - 1
    }

    /// Adds `builder`'s mesh with `material` (named after the mesh); returns its index.
    fn mesh(&mut self, name: &str, builder: MeshBuilder, material: Material) -> usize {
        let (mesh, layout) = builder.finish(name);
        let scene = &mut self.generated.scene;
        scene.meshes.push(mesh);
        scene.materials.push(Material { name: name.to_string(), ..material });
        self.generated.layouts.push(layout);
        scene.meshes.len() - 1
    }

    fn meshes(&mut self) -> KitMeshes {
        let tints = [
            ("facade brick", Vec3::new(0.42, 0.17, 0.11)),
            ("facade sandstone", Vec3::new(0.62, 0.5, 0.33)),
            ("facade plaster", Vec3::new(0.55, 0.55, 0.5)),
            ("paving", Vec3::new(0.42, 0.42, 0.4)),
            ("setts", Vec3::new(0.13, 0.13, 0.14)),
        ];
        let (albedos, normal) = brick_textures(512, &tints, "city relief");
        let albedos: Vec<usize> = albedos.into_iter().map(|t| self.texture(t)).collect();
        let normal = Some(self.texture(normal));
        let glass_texture = Some(self.texture(window_texture(128)));
        let mut flat = |name: &str, c: Vec3| Some(self.texture(flat_texture(name, c)));
        let (metal, leaves, wood, stone) = (
            flat("lamp metal", Vec3::new(0.06, 0.07, 0.08)),
            flat("tree", Vec3::new(0.1, 0.26, 0.07)),
            flat("bench wood", Vec3::new(0.33, 0.18, 0.09)),
            flat("bollard", Vec3::new(0.3, 0.3, 0.32)),
        );
        // Single-sided: the city is seen from outside its closed shells (the
        // slabs' undersides and the buildings' insides never show); culling
        // the back faces changes at most 10 crack pixels of 57,600 along its
        // paths at 320x180 (docs/culling.md).
        let look = |texture: Option<usize>, specular: f32, shininess: f32, roughness: f32| Material {
            base_color_texture: texture,
            specular,
            shininess,
            roughness,
            double_sided: false,
            ..Material::default()
        };
        let bricks = |k: usize| Material { normal_texture: normal, ..look(Some(albedos[k]), 0.35, 40.0, 0.45) };

        let mut road = MeshBuilder::new();
        road.rect(Vec3::ZERO, Vec3::Z * PITCH, Vec3::X * PITCH, 4.0, 0.5);
        let road = self.mesh("road", road, bricks(4));
        let mut slab = MeshBuilder::new();
        slab.cuboid(Vec3::ZERO, Vec3::new(BLOCK, KERB, BLOCK), Faces::ALL.without(Faces::NEG_Y), 4.0, 0.5);
        let sidewalk = self.mesh("sidewalk", slab, bricks(3));
        let buildings = BUILDING_TYPES
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let (shell, glass) = building(t);
                let shell = self.mesh(&format!("building{k}"), shell, bricks(t.facade));
                let glass_look = Material { metallic: 0.0, ..look(glass_texture, 1.0, 256.0, 0.08) };
                [shell, self.mesh(&format!("glass{k}"), glass, glass_look)]
            })
            .collect();
        let lamp = self.mesh("lamp", lamp(), Material { metallic: 0.8, ..look(metal, 0.8, 128.0, 0.25) });
        let tree = self.mesh("tree", tree(), look(leaves, 0.1, 8.0, 0.9));
        let bench = self.mesh("bench", bench(), look(wood, 0.2, 16.0, 0.7));
        let bollard = self.mesh("bollard", bollard(), look(stone, 0.5, 64.0, 0.35));
        KitMeshes { road, sidewalk, buildings, lamp, tree, bench, bollard }
    }
}

/// A 4x4 texture of one linear colour.
fn flat_texture(name: &str, c: Vec3) -> Texture {
    let texel = [linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z), 255];
    Texture { name: name.to_string(), width: 4, height: 4, rgba8: texel.repeat(16) }
}

/// A window seen once per pane: a pale frame and a cross of glazing bars
/// around four dark, slightly graded panes of glass.
fn window_texture(n: u32) -> Texture {
    let frame = (n / 16).max(1);
    let bar = (n / 32).max(1);
    let mut rgba8 = Vec::with_capacity((n * n * 4) as usize);
    for y in 0..n {
        for x in 0..n {
            let edge = x.min(y).min(n - 1 - x).min(n - 1 - y) < frame;
            let cross = x.abs_diff(n / 2) < bar || y.abs_diff(n / 2) < bar;
            let c = if edge || cross {
                Vec3::new(0.7, 0.7, 0.68)
            } else {
                Vec3::new(0.04, 0.06, 0.09) * (1.0 + 0.8 * y as f32 / n as f32)
            };
            rgba8.extend([linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z), 255]);
        }
    }
    Texture { name: "window".into(), width: n, height: n, rgba8 }
}

/// One facade of a building in its own frame: `x` along the facade from
/// `origin`, `y` up, `z` out of the wall; one chart unfolded along the height.
struct Facade<'a> {
    shell: &'a mut MeshBuilder,
    glass: &'a mut MeshBuilder,
    chart: ChartId,
    origin: Vec3,
    along: Vec3,
    out: Vec3,
    /// Column breakpoints: 0, each window's left and right edge, the width.
    xs: Vec<f32>,
    /// How far the chart is unfolded so far (metres).
    v: f32,
}

impl Facade<'_> {
    fn at(&self, x: f32, y: f32, z: f32) -> Vec3 {
        self.origin + self.along * x + Vec3::Y * y + self.out * z
    }

    /// A shell vertex at facade point (x, y, z) with `normal` and chart
    /// coordinates (u, v) in metres (uv0 follows them).
    fn vertex(&mut self, p: Vec3, normal: Vec3, u: f32, v: f32) -> u32 {
        let local = Vec2::new(u, v);
        self.shell.vertex(self.chart, p, normal, local * FACADE_TILING, local)
    }

    /// Rows of vertices, one per `(xs, y, z, normal, v)`, joined by quads
    /// between consecutive rows (every row has as many points).
    fn strip(&mut self, rows: &[(Vec<f32>, f32, f32, Vec3, f32)]) {
        let mut previous: Option<Vec<u32>> = None;
        for (xs, y, z, normal, v) in rows {
            let row: Vec<u32> = xs.iter().map(|&x| self.vertex(self.at(x, *y, *z), *normal, x, *v)).collect();
            if let Some(p) = &previous {
                for k in 0..row.len() - 1 {
                    self.shell.quad(p[k], p[k + 1], row[k + 1], row[k]);
                }
            }
            previous = Some(row);
        }
    }

    /// A storey from `y0`, `height` tall: the wall, and each window (sill
    /// `sill` above `y0`, `window` tall) as a hole with reveals `reveal`
    /// deep, a pane of glass, and with `ledge` a stone sill under it.
    fn storey(&mut self, y0: f32, height: f32, sill: f32, window: f32, reveal: f32, ledge: bool) {
        let ys = [y0, y0 + sill, y0 + sill + window, y0 + height];
        let v0 = self.v;
        let xs = self.xs.clone();
        let grid: Vec<Vec<u32>> = ys
            .iter()
            .map(|&y| xs.iter().map(|&x| self.vertex(self.at(x, y, 0.0), self.out, x, v0 + y - y0)).collect())
            .collect();
        for j in 0..3 {
            for i in 0..xs.len() - 1 {
                // Odd columns are windows; the middle row is their hole.
                if j == 1 && i % 2 == 1 {
                    continue;
                }
                self.shell.quad(grid[j][i], grid[j][i + 1], grid[j + 1][i + 1], grid[j + 1][i]);
            }
        }
        for w in (1..xs.len() - 1).step_by(2) {
            let (x0, x1) = (xs[w], xs[w + 1]);
            let (ya, yb) = (ys[1], ys[2]);
            let (va, vb) = (v0 + sill, v0 + sill + window);
            self.reveals([x0, x1], [ya, yb], [va, vb], reveal);
            self.pane([x0, x1], [ya, yb], reveal);
            if ledge {
                self.sill([x0 - 0.08, x1 + 0.08], ya);
            }
        }
        self.v += height;
    }

    /// The window hole's four reveals, `r` deep, folded into the hole in
    /// the chart (mitred at the corners).
    fn reveals(&mut self, x: [f32; 2], y: [f32; 2], v: [f32; 2], r: f32) {
        let (up, side) = (Vec3::Y, self.along);
        // (outer a, outer b, normal, inner offsets in the chart for a and b)
        let edges = [
            ([x[0], y[0]], [x[1], y[0]], up, [Vec2::new(r, r), Vec2::new(-r, r)]),
            ([x[1], y[1]], [x[0], y[1]], -up, [Vec2::new(-r, -r), Vec2::new(r, -r)]),
            ([x[0], y[1]], [x[0], y[0]], side, [Vec2::new(r, -r), Vec2::new(r, r)]),
            ([x[1], y[0]], [x[1], y[1]], -side, [Vec2::new(-r, r), Vec2::new(-r, -r)]),
        ];
        let chart_v = |yy: f32| if yy == y[0] { v[0] } else { v[1] };
        for (a, b, normal, inset) in edges {
            let (ua, ub) = (Vec2::new(a[0], chart_v(a[1])), Vec2::new(b[0], chart_v(b[1])));
            let (ia, ib) = (ua + inset[0], ub + inset[1]);
            let pa = self.vertex(self.at(a[0], a[1], 0.0), normal, ua.x, ua.y);
            let pb = self.vertex(self.at(b[0], b[1], 0.0), normal, ub.x, ub.y);
            let qb = self.vertex(self.at(b[0], b[1], -r), normal, ib.x, ib.y);
            let qa = self.vertex(self.at(a[0], a[1], -r), normal, ia.x, ia.y);
            self.shell.quad(pa, pb, qb, qa);
        }
    }

    /// A pane of glass at the back of the reveals, its own chart, the
    /// window texture once across it, cut into 2 x 2 quads.
    fn pane(&mut self, x: [f32; 2], y: [f32; 2], r: f32) {
        let chart = self.glass.chart();
        let first = (0..9)
            .map(|k| {
                let (s, t) = ((k % 3) as f32 / 2.0, (k / 3) as f32 / 2.0);
                let (px, py) = (x[0] + s * (x[1] - x[0]), y[0] + t * (y[1] - y[0]));
                let local = Vec2::new(px - x[0], py - y[0]);
                self.glass.vertex(chart, self.at(px, py, -r), self.out, Vec2::new(s, 1.0 - t), local)
            })
            .collect::<Vec<u32>>();
        for k in [0, 1, 3, 4] {
            self.glass.quad(first[k], first[k + 1], first[k + 4], first[k + 3]);
        }
    }

    /// A stone sill spanning `x` with its top at `y`: front, top, underside
    /// and ends, unfolded around the front as one chart.
    fn sill(&mut self, x: [f32; 2], y: f32) {
        let (depth, height) = (0.14, 0.07);
        let chart = self.shell.chart();
        let length = x[1] - x[0];
        let (lo, hi) = (y - height, y);
        // (corners (x, y, z), normal, chart corners)
        let faces = [
            (
                [[x[0], lo, depth], [x[1], lo, depth], [x[1], hi, depth], [x[0], hi, depth]],
                self.out,
                [[0.0, 0.0], [length, 0.0], [length, height], [0.0, height]],
            ),
            (
                [[x[0], hi, depth], [x[1], hi, depth], [x[1], hi, 0.0], [x[0], hi, 0.0]],
                Vec3::Y,
                [[0.0, height], [length, height], [length, height + depth], [0.0, height + depth]],
            ),
            (
                [[x[0], lo, 0.0], [x[1], lo, 0.0], [x[1], lo, depth], [x[0], lo, depth]],
                -Vec3::Y,
                [[0.0, -depth], [length, -depth], [length, 0.0], [0.0, 0.0]],
            ),
            (
                [[x[0], lo, 0.0], [x[0], lo, depth], [x[0], hi, depth], [x[0], hi, 0.0]],
                -self.along,
                [[-depth, 0.0], [0.0, 0.0], [0.0, height], [-depth, height]],
            ),
            (
                [[x[1], lo, depth], [x[1], lo, 0.0], [x[1], hi, 0.0], [x[1], hi, depth]],
                self.along,
                [[length, 0.0], [length + depth, 0.0], [length + depth, height], [length, height]],
            ),
        ];
        for (corners, normal, local) in faces {
            let v: Vec<u32> = corners
                .iter()
                .zip(local)
                .map(|(c, l)| {
                    let l = Vec2::from(l);
                    self.shell.vertex(chart, self.at(c[0], c[1], c[2]), normal, l * FACADE_TILING, l)
                })
                .collect();
            self.shell.quad(v[0], v[1], v[2], v[3]);
        }
    }

    /// A ledge `height` tall and `depth` deep at `y`, mitred at the
    /// building's corners: underside, front and top, continuing the chart.
    fn ledge(&mut self, y: f32, height: f32, depth: f32) {
        let inner = self.xs.clone();
        let mut outer = inner.clone();
        let last = outer.len() - 1;
        outer[0] -= depth;
        outer[last] += depth;
        let v = self.v;
        self.strip(&[(inner.clone(), y, 0.0, -Vec3::Y, v), (outer.clone(), y, depth, -Vec3::Y, v + depth)]);
        let front = v + depth;
        self.strip(&[
            (outer.clone(), y, depth, self.out, front),
            (outer.clone(), y + height, depth, self.out, front + height),
        ]);
        let top = front + height;
        self.strip(&[(outer, y + height, depth, Vec3::Y, top), (inner, y + height, 0.0, Vec3::Y, top + depth)]);
        self.v = top + depth;
    }

    /// The parapet from `y` (a plain wall `PARAPET` tall), its top `depth`
    /// deep and its inner face down to the roof; returns the roof's height.
    fn parapet(&mut self, y: f32, depth: f32) -> f32 {
        let xs = self.xs.clone();
        let v = self.v;
        let top = y + PARAPET;
        self.strip(&[(xs.clone(), y, 0.0, self.out, v), (xs.clone(), top, 0.0, self.out, v + PARAPET)]);
        let mut inner = xs.clone();
        let last = inner.len() - 1;
        inner[0] += depth;
        inner[last] -= depth;
        let v = v + PARAPET;
        self.strip(&[(xs, top, 0.0, Vec3::Y, v), (inner.clone(), top, -depth, Vec3::Y, v + depth)]);
        let v = v + depth;
        let drop = 0.8 * PARAPET;
        self.strip(&[(inner.clone(), top, -depth, -self.out, v), (inner, top - drop, -depth, -self.out, v + drop)]);
        self.v = v + drop;
        top - drop
    }
}

/// A building type's shell and glass meshes, centred on the origin of its
/// footprint, ground at y = 0.
fn building(t: &BuildingType) -> (MeshBuilder, MeshBuilder) {
    let (mut shell, mut glass) = (MeshBuilder::new(), MeshBuilder::new());
    let half = 0.5 * FOOTPRINT;
    let spacing = FOOTPRINT / t.windows as f32;
    let width = 0.55 * spacing;
    let mut xs = vec![0.0];
    for k in 0..t.windows {
        let c = (k as f32 + 0.5) * spacing;
        xs.extend([c - 0.5 * width, c + 0.5 * width]);
    }
    xs.push(FOOTPRINT);
    let (parapet_depth, mut roof) = (0.3, 0.0);
    for side in 0..4 {
        let turn = Quat::from_rotation_y(side as f32 * FRAC_PI_2);
        let chart = shell.chart();
        let mut f = Facade {
            shell: &mut shell,
            glass: &mut glass,
            chart,
            origin: turn * Vec3::new(-half, 0.0, half),
            along: turn * Vec3::X,
            out: turn * Vec3::Z,
            xs: xs.clone(),
            v: 0.0,
        };
        // Shop windows on the ground floor, then a ledge and a storey per floor.
        f.storey(0.0, GROUND_FLOOR, 0.5, 2.8, 0.15, false);
        let mut y = GROUND_FLOOR;
        for _ in 1..t.floors {
            let ledge = 0.3;
            f.ledge(y, ledge, 0.18);
            f.storey(y + ledge, FLOOR - ledge, 0.6, 1.7, 0.22, true);
            y += FLOOR;
        }
        roof = f.parapet(y, parapet_depth);
    }
    let inner = FOOTPRINT - 2.0 * parapet_depth;
    let corner = Vec3::new(-half + parapet_depth, roof, -half + parapet_depth);
    shell.rect(corner, Vec3::Z * inner, Vec3::X * inner, 4.0, FACADE_TILING);
    (shell, glass)
}

/// A street lamp: a tapering pole, an arm out over the street (-z) and a head.
fn lamp() -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let pole = [(0.09, 0.0), (0.09, 0.4), (0.06, 0.5), (0.05, 5.5), (0.04, 6.0)].map(|(r, h)| Vec2::new(r, h));
    b.lathe(Vec3::ZERO, &pole, 12, 2.0);
    b.cuboid(Vec3::new(-0.03, 5.8, -1.2), Vec3::new(0.03, 5.88, 0.0), Faces::ALL, 1.0, 2.0);
    b.cuboid(Vec3::new(-0.15, 5.65, -1.45), Vec3::new(0.15, 5.8, -1.0), Faces::ALL, 1.0, 2.0);
    b
}

/// A tree: a trunk and a round crown.
fn tree() -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let trunk = [(0.15, 0.0), (0.12, 2.2), (0.1, 2.6)].map(|(r, h)| Vec2::new(r, h));
    b.lathe(Vec3::ZERO, &trunk, 8, 1.0);
    let crown: Vec<Vec2> = (0..=8)
        .map(|k| {
            let a = (-80.0 + 20.0 * k as f32).to_radians();
            Vec2::new(1.8 * a.cos(), 4.2 + 1.8 * a.sin())
        })
        .collect();
    b.lathe(Vec3::ZERO, &crown, 14, 1.0);
    b
}

/// A bench facing the street (-z): seat, back and two legs.
fn bench() -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let boxes = [
        (Vec3::new(-0.9, 0.42, -0.22), Vec3::new(0.9, 0.47, 0.22)),
        (Vec3::new(-0.9, 0.5, 0.18), Vec3::new(0.9, 0.85, 0.23)),
        (Vec3::new(-0.85, 0.0, -0.2), Vec3::new(-0.75, 0.42, 0.2)),
        (Vec3::new(0.75, 0.0, -0.2), Vec3::new(0.85, 0.42, 0.2)),
    ];
    for (min, max) in boxes {
        b.cuboid(min, max, Faces::ALL, 1.0, 2.0);
    }
    b
}

/// A bollard: a post with a rounded cap.
fn bollard() -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let profile = [(0.1, 0.0), (0.1, 0.8), (0.07, 0.9), (0.03, 0.95)].map(|(r, h)| Vec2::new(r, h));
    b.lathe(Vec3::ZERO, &profile, 10, 2.0);
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default city meets the counts (10 M triangles, 10,000
    /// instances) from a handful of meshes, and the same seed gives the same
    /// city while another seed changes it.
    #[test]
    fn the_default_city_meets_its_counts_and_is_deterministic() {
        let t = std::time::Instant::now();
        let city = CitySpec::DEFAULT.scene();
        let (triangles, instances) = (city.triangle_count(), city.objects.len());
        let mesh_triangles: usize = city.meshes.iter().map(|m| m.triangle_count()).sum();
        eprintln!(
            "city: {triangles} triangles, {instances} instances of {} meshes ({mesh_triangles} triangles) in {:?}",
            city.meshes.len(),
            t.elapsed()
        );
        city.validate().unwrap();
        assert!(triangles >= 10_000_000, "{triangles} triangles");
        assert!(instances >= 10_000 && instances == CitySpec::DEFAULT.instance_count(), "{instances}");
        assert!(city.meshes.len() <= 20 && mesh_triangles * 100 < triangles, "{} meshes", city.meshes.len());
        // Instances of a mesh are consecutive.
        assert!(city.objects.windows(2).all(|w| w[0].mesh <= w[1].mesh));
        let again = CitySpec::DEFAULT.scene();
        let placement = |s: &Scene| s.objects.iter().map(|o| (o.mesh, o.transform)).collect::<Vec<_>>();
        assert_eq!(placement(&city), placement(&again));
        assert!(city.meshes.iter().zip(&again.meshes).all(|(a, b)| a.positions == b.positions && a.uv1 == b.uv1));
        let other = CitySpec { seed: 28, ..CitySpec::DEFAULT }.scene();
        assert_ne!(placement(&city), placement(&other));
    }

    /// Every mesh's charts keep their gutters and stay in the square, its
    /// triangles face their normals, and facades unfold within a bounded
    /// density spread (that no chart overlaps itself is checked with the
    /// charts module's overlap test in `tests/it/city.rs`).
    #[test]
    fn every_mesh_has_separate_charts_wound_with_their_normals() {
        let g = CitySpec { blocks: 1, seed: 1 }.build();
        for (mesh, layout) in g.scene.meshes.iter().zip(&g.layouts) {
            let spread = super::super::builder::tests::check_mesh(mesh, layout);
            eprintln!(
                "{}: {} triangles, {} charts, utilisation {:.2}, density spread {spread:.2}",
                mesh.name,
                mesh.triangle_count(),
                layout.rects.len(),
                layout.utilisation(),
            );
            assert!(spread < 4.0, "{}: density spread {spread}", mesh.name);
        }
    }

    #[test]
    fn specs_parse_and_bad_ones_say_why() {
        assert_eq!(CitySpec::parse("city"), Some(Ok(CitySpec::DEFAULT)));
        assert_eq!(CitySpec::parse("city:2"), Some(Ok(CitySpec { blocks: 2, seed: CitySpec::DEFAULT.seed })));
        assert_eq!(CitySpec::parse("city:3:9"), Some(Ok(CitySpec { blocks: 3, seed: 9 })));
        assert_eq!(CitySpec::parse("atrium"), None);
        assert_eq!(CitySpec::parse("cityscape.obj"), None);
        for bad in ["city:", "city:0", "city:65", "city:x", "city:2:y", "city:2:3:4"] {
            let e = CitySpec::parse(bad).unwrap().unwrap_err();
            assert!(e.contains("from 1 to 64"), "{bad}: {e}");
        }
        assert_eq!(CitySpec { blocks: 2, seed: 27 }.name(), "city:2");
        assert_eq!(CitySpec { blocks: 2, seed: 5 }.name(), "city:2:5");
    }

    #[test]
    fn paths_stay_in_the_city_and_the_street_path_at_eye_height() {
        let spec = CitySpec { blocks: 3, seed: 1 };
        let street = spec.street_path();
        for f in (0..=900).step_by(50) {
            let c = street.pose_at(f).to_camera(street.projection);
            assert!((c.position.y - EYE).abs() < 1e-4, "frame {f}: {}", c.position);
            assert!(c.position.x >= 0.0 && c.position.x <= spec.side() && c.position.z >= 0.0);
            assert!(c.forward.y.abs() < 1e-4, "level view");
            // On a street: within half a street of a grid line on one axis.
            let off = |v: f32| (v / PITCH - (v / PITCH).round()).abs() * PITCH;
            assert!(off(c.position.x).min(off(c.position.z)) <= 0.5 * STREET, "frame {f}: {}", c.position);
        }
        let fly = spec.flyover_path();
        for f in (0..=1200).step_by(100) {
            let c = fly.pose_at(f).to_camera(fly.projection);
            assert!(c.position.y > tallest() && c.forward.y < -0.3, "frame {f}: {} {}", c.position, c.forward);
        }
    }
}
