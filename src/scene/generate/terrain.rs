//! A procedural terrain (issue 26, item 4): a seeded heightfield of fractal
//! noise, split into square patches that are separate objects (each its own
//! virtual shading texture, sized by its projected size like any object:
//! Oxide's per-patch density), coloured by height and slope in bands from
//! procedural textures, with "precals" (roads, a power line, scorch marks)
//! stamped into the material before shading, and a camera path that flies
//! low and high.
//!
//! Every patch gets its own albedo texture covering the patch plus a margin
//! of [`MARGIN`] texels on every side, computed from one texel grid over the
//! whole terrain: neighbouring patches hold the same texels where they
//! overlap, and the renderer's repeating sampler does not reach the opposite
//! edge up to level 4 of the texture, so the colour is continuous across
//! patch borders. Vertex normals come from the height function at the vertex
//! (the same on both sides of a border). Charts (`uv1`) are the patch seen
//! from above: one chart per patch, so steep slopes get fewer texels per
//! metre of surface than flat ground.

use glam::{Mat4, Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Generated;
use super::builder::MeshBuilder;
use super::noise::ValueNoise;
use crate::color::linear_to_srgb8;
use crate::scene::path::{KeyedPath, Projection, UnityPose};
use crate::scene::{Material, Object, Scene, Texture};

/// Texels around each patch texture's patch (see the module docs).
pub const MARGIN: u32 = 8;

/// What the precals do to the material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precals {
    /// None: the bands only.
    Off,
    /// Stamped into the albedo (the scene as `--scene terrain` loads it).
    On,
    /// The footprint alone: albedo white where any precal covers the ground,
    /// black elsewhere (for tests of what precals may change).
    Footprint,
}

/// The terrain's size and make-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TerrainSpec {
    /// Side of the square terrain in metres.
    pub size: f32,
    /// Grid cells per side (two triangles each).
    pub cells: u32,
    /// Patches per side (each `cells / patches` cells square).
    pub patches: u32,
    /// Side of each patch's albedo texture in texels (margins included).
    pub texels: u32,
    /// Seed of the heightfield and the precals.
    pub seed: u64,
    pub precals: Precals,
}

impl TerrainSpec {
    /// `--scene terrain`: 2048 m square, 768 x 768 cells (1.18 M triangles),
    /// 12 x 12 patches of 171 m with 256-texel albedos (0.71 m a texel).
    pub const DEFAULT: TerrainSpec =
        TerrainSpec { size: 2048.0, cells: 768, patches: 12, texels: 256, seed: 26, precals: Precals::On };
    /// `--scene terrain-small`, for tests: 256 m square, 64 x 64 cells (8 k
    /// triangles), 4 x 4 patches with 64-texel albedos.
    pub const SMALL: TerrainSpec =
        TerrainSpec { size: 256.0, cells: 64, patches: 4, texels: 64, seed: 26, precals: Precals::On };

    /// Ground height in metres at `(x, z)` (the terrain spans `0..size` on
    /// both): fractal noise over about six hills per side, sharpened into
    /// ridges, up to 17 % of the side high.
    pub(crate) fn height(&self, noise: &ValueNoise, x: f32, z: f32) -> f32 {
        let (u, v) = (6.0 * x / self.size, 6.0 * z / self.size);
        let base = noise.fbm(u, v, 6);
        // Sharper peaks, flatter valleys.
        0.17 * self.size * base * base * (1.5 - 0.5 * base)
    }

    /// The noise field of [`TerrainSpec::height`] for this seed.
    pub(crate) fn noise(&self) -> ValueNoise {
        ValueNoise::new(self.seed)
    }

    /// Unit normal of the heightfield at `(x, z)` by central differences `h` apart.
    fn normal(&self, noise: &ValueNoise, x: f32, z: f32, h: f32) -> Vec3 {
        let dx = self.height(noise, x + h, z) - self.height(noise, x - h, z);
        let dz = self.height(noise, x, z + h) - self.height(noise, x, z - h);
        Vec3::new(-dx, 2.0 * h, -dz).normalize()
    }

    /// The scene: one object per patch, named `patch_I_J` (column I along
    /// x, row J along z).
    pub fn scene(&self) -> Scene {
        self.build().scene
    }

    /// [`TerrainSpec::scene`] with its chart layouts.
    pub(crate) fn build(&self) -> Generated {
        let noise = self.noise();
        let per_patch = self.cells / self.patches;
        let cell = self.size / self.cells as f32;
        let albedo = Albedo::new(self, &noise);
        let name = if self.size == Self::DEFAULT.size { "terrain" } else { "terrain-small" };
        let mut scene = Scene { name: name.to_string(), ..Scene::default() };
        let mut layouts = Vec::new();
        for j in 0..self.patches {
            for i in 0..self.patches {
                let mut b = MeshBuilder::new();
                let chart = b.chart();
                let row = per_patch + 1;
                for r in 0..=per_patch {
                    for c in 0..=per_patch {
                        let (gx, gz) = (i * per_patch + c, j * per_patch + r);
                        let (x, z) = (gx as f32 * cell, gz as f32 * cell);
                        let p = Vec3::new(x, self.height(&noise, x, z), z);
                        let n = self.normal(&noise, x, z, cell);
                        let f = Vec2::new(c as f32, r as f32) / per_patch as f32;
                        b.vertex(chart, p, n, albedo.uv(f), Vec2::new(x, z));
                    }
                }
                for r in 0..per_patch {
                    for c in 0..per_patch {
                        let a = r * row + c;
                        b.quad(a, a + 1, a + row + 1, a + row);
                    }
                }
                let patch = format!("patch_{i}_{j}");
                let (mesh, layout) = b.finish(&patch);
                scene.textures.push(albedo.patch_texture(&patch, i, j));
                scene.meshes.push(mesh);
                scene.materials.push(Material {
                    name: patch.clone(),
                    base_color_texture: Some(scene.textures.len() - 1),
                    specular: 0.2,
                    shininess: 16.0,
                    roughness: 0.85,
                    ..Material::default()
                });
                scene.objects.push(Object {
                    name: patch,
                    mesh: scene.meshes.len() - 1,
                    material: scene.materials.len() - 1,
                    transform: Mat4::IDENTITY,
                    forward_only: false,
                });
                layouts.push(layout);
            }
        }
        Generated { scene, layouts }
    }

    /// The camera path: a flight in eight legs (300 frames each) from a
    /// valley 25 m over the ground, up to 45 % of the side above the
    /// highest ground and back down, low over the road, and once more up
    /// and down. Low keys clear every height within 15 % of the side by 25 m.
    pub fn path(&self) -> KeyedPath {
        let noise = self.noise();
        let s = self.size;
        let top = self.max_height(&noise);
        let clear = |x: f32, z: f32| {
            let r = 0.15 * s;
            let mut h = f32::MIN;
            for k in 0..=8 {
                for l in 0..=8 {
                    let (px, pz) = (x - r + 2.0 * r * k as f32 / 8.0, z - r + 2.0 * r * l as f32 / 8.0);
                    h = h.max(self.height(&noise, px.clamp(0.0, s), pz.clamp(0.0, s)));
                }
            }
            h + 0.012 * s
        };
        // (x, z, high) in fractions of the side, and where the camera looks.
        let legs: [(f32, f32, bool, f32, f32); 9] = [
            (0.15, 0.2, false, 0.5, 0.45),
            (0.35, 0.35, false, 0.6, 0.55),
            (0.5, 0.5, true, 0.7, 0.7),
            (0.8, 0.6, true, 0.5, 0.5),
            (0.75, 0.85, false, 0.4, 0.9),
            (0.45, 0.85, false, 0.2, 0.7),
            (0.2, 0.6, true, 0.5, 0.4),
            (0.3, 0.3, false, 0.6, 0.6),
            (0.15, 0.2, false, 0.5, 0.45),
        ];
        let keys = legs
            .iter()
            .map(|&(x, z, high, tx, tz)| {
                let (x, z, tx, tz) = (x * s, z * s, tx * s, tz * s);
                let y = if high { top + 0.45 * s } else { clear(x, z) };
                let target = Vec3::new(tx, self.height(&noise, tx, tz), tz);
                pose(Vec3::new(x, y, z), target)
            })
            .collect::<Vec<_>>();
        // Angles interpolate componentwise: unwrap yaw to the shorter turn.
        let keys = unwrap_yaw(keys);
        KeyedPath { keys, frames_per_segment: 300, projection: self.projection() }
    }

    /// 60 degrees, clip planes from a tenth of a metre per 256 m of side to
    /// twice the diagonal.
    pub fn projection(&self) -> Projection {
        Projection { fov_y: std::f32::consts::FRAC_PI_3, near: 0.1 * self.size / 256.0, far: 3.0 * self.size }
    }

    fn max_height(&self, noise: &ValueNoise) -> f32 {
        let n = 64;
        let mut top: f32 = 0.0;
        for k in 0..=n {
            for l in 0..=n {
                let (x, z) = (self.size * k as f32 / n as f32, self.size * l as f32 / n as f32);
                top = top.max(self.height(noise, x, z));
            }
        }
        top
    }
}

/// A camera pose in the keyed path's (Unity's) conventions at `eye` looking at `target`.
pub(super) fn pose(eye: Vec3, target: Vec3) -> UnityPose {
    let f = (target - eye).normalize();
    // Inverse of `UnityPose::to_camera` for roll 0.
    let pitch = (-f.y).asin().to_degrees();
    let yaw = (-f.x).atan2(f.z).to_degrees();
    UnityPose { position: eye * Vec3::new(-1.0, 1.0, 1.0), euler_deg: Vec3::new(pitch, yaw, 0.0) }
}

/// Unwraps each key's yaw to within half a turn of the previous key's.
pub(super) fn unwrap_yaw(mut keys: Vec<UnityPose>) -> Vec<UnityPose> {
    for k in 1..keys.len() {
        let previous = keys[k - 1].euler_deg.y;
        let y = &mut keys[k].euler_deg.y;
        while *y - previous > 180.0 {
            *y -= 360.0;
        }
        while *y - previous < -180.0 {
            *y += 360.0;
        }
    }
    keys
}

/// The terrain's material: one texel grid over the whole terrain (patch
/// textures are windows of it, [`MARGIN`] texels wider on every side).
struct Albedo {
    spec: TerrainSpec,
    /// Texels of a patch inside its margins.
    inner: u32,
    /// Texel spacing in metres.
    spacing: f32,
    /// Grid side: `patches * inner + 2 * MARGIN` (+1 for slopes at the edge).
    side: u32,
    /// Heights at texel centres, row-major; texel `g` of the terrain (from
    /// `-MARGIN`) is at index `g + MARGIN`.
    heights: Vec<f32>,
    top: f32,
    precals: PrecalSet,
    detail: ValueNoise,
}

impl Albedo {
    fn new(spec: &TerrainSpec, noise: &ValueNoise) -> Self {
        let inner = spec.texels - 2 * MARGIN;
        let spacing = spec.size / (spec.patches * inner) as f32;
        let side = spec.patches * inner + 2 * MARGIN + 1;
        let mut heights = Vec::with_capacity((side * side) as usize);
        for r in 0..side {
            for c in 0..side {
                let (x, z) = Self::centre_of(spacing, c, r);
                heights.push(spec.height(noise, x, z));
            }
        }
        let top = heights.iter().copied().fold(0.0, f32::max);
        Self {
            spec: *spec,
            inner,
            spacing,
            side,
            heights,
            top,
            precals: PrecalSet::new(spec),
            detail: ValueNoise::new(spec.seed ^ 0x5eed),
        }
    }

    /// World (x, z) of grid texel (c, r).
    fn centre_of(spacing: f32, c: u32, r: u32) -> (f32, f32) {
        let at = |k: u32| (k as f32 - MARGIN as f32 + 0.5) * spacing;
        (at(c), at(r))
    }

    /// uv0 of the point at fraction `f` across its patch.
    fn uv(&self, f: Vec2) -> Vec2 {
        (Vec2::splat(MARGIN as f32) + f * self.inner as f32) / self.spec.texels as f32
    }

    fn height_at(&self, c: u32, r: u32) -> f32 {
        let (c, r) = (c.min(self.side - 1), r.min(self.side - 1));
        self.heights[(r * self.side + c) as usize]
    }

    /// Slope (rise over run) at grid texel (c, r), by differences to the
    /// next texels (the grid has one more row and column for the last).
    fn slope_at(&self, c: u32, r: u32) -> f32 {
        let h = self.height_at(c, r);
        let dx = self.height_at(c + 1, r) - h;
        let dz = self.height_at(c, r + 1) - h;
        (dx * dx + dz * dz).sqrt() / self.spacing
    }

    /// The albedo texture of patch (i, j).
    fn patch_texture(&self, name: &str, i: u32, j: u32) -> Texture {
        let n = self.spec.texels;
        let mut rgba8 = Vec::with_capacity((n * n * 4) as usize);
        for t in 0..n {
            for s in 0..n {
                // Grid texel: the patch's first inner texel is i * inner (+ MARGIN in the grid).
                let (c, r) = (i * self.inner + s, j * self.inner + t);
                let (x, z) = Self::centre_of(self.spacing, c, r);
                let cover = self.precals.cover(x, z);
                let colour = self.colour(c, r, x, z, cover);
                // Alpha: 1 less the precals' cover (the terrain is opaque;
                // `--materials bands` keeps the precals over its layers by it).
                let covered = match (self.spec.precals, cover) {
                    (Precals::On, Some((_, alpha))) => alpha,
                    _ => 0.0,
                };
                let alpha = ((1.0 - covered) * 255.0).round() as u8;
                rgba8.extend([linear_to_srgb8(colour.x), linear_to_srgb8(colour.y), linear_to_srgb8(colour.z), alpha]);
            }
        }
        Texture { name: name.to_string(), width: n, height: n, rgba8 }
    }

    /// Linear albedo of grid texel (c, r) at world (x, z): the bands, then
    /// the precals over them (`cover`: [`PrecalSet::cover`] there).
    fn colour(&self, c: u32, r: u32, x: f32, z: f32, cover: Option<(Vec3, f32)>) -> Vec3 {
        match self.spec.precals {
            Precals::Footprint => return if cover.is_some() { Vec3::ONE } else { Vec3::ZERO },
            Precals::Off => {}
            Precals::On => {}
        }
        let height = self.height_at(c, r) / self.top.max(1e-6);
        let slope = self.slope_at(c, r);
        // Procedural texture detail: two scales of noise in world metres.
        let fine = self.detail.fbm(x / 3.0, z / 3.0, 3);
        let coarse = self.detail.fbm(x / 40.0 + 11.0, z / 40.0 - 7.0, 3);
        let ground = band_albedo(height, slope, fine, coarse);
        match (self.spec.precals, cover) {
            (Precals::On, Some((colour, alpha))) => ground.lerp(colour * (0.85 + 0.3 * fine), alpha),
            _ => ground,
        }
    }
}

/// The bands' colours (linear albedo) and limits: what [`band_albedo`]
/// bakes, and what `--materials bands` (`materials::preset::bands`) shades
/// as layers.
pub mod bands {
    use glam::Vec3;

    pub const SAND: Vec3 = Vec3::new(0.62, 0.55, 0.38);
    pub const GRASS: Vec3 = Vec3::new(0.22, 0.38, 0.12);
    pub const FOREST: Vec3 = Vec3::new(0.08, 0.2, 0.07);
    pub const DIRT: Vec3 = Vec3::new(0.36, 0.26, 0.16);
    pub const ROCK: Vec3 = Vec3::new(0.33, 0.31, 0.3);
    pub const SCREE: Vec3 = Vec3::new(0.5, 0.48, 0.45);
    pub const SNOW: Vec3 = Vec3::new(0.9, 0.92, 0.95);
    /// Relative heights (0 at sea level, 1 at the highest ground): the top
    /// of the sand, the grass, the forest and the scree (snow above).
    pub const SAND_TOP: f32 = 0.06;
    pub const GRASS_TOP: f32 = 0.3;
    pub const FOREST_TOP: f32 = 0.5;
    pub const SCREE_TOP: f32 = 0.72;
    /// Slopes (rise over run): dirt from, bare rock from, and scree on the
    /// snow's slopes from.
    pub const DIRT_SLOPE: f32 = 0.6;
    pub const ROCK_SLOPE: f32 = 1.2;
    pub const SNOW_SCREE_SLOPE: f32 = 0.35;
}

/// The terrain's bands: linear albedo at relative height `height` (0 at
/// sea level, 1 at the highest ground) and `slope` (rise over run), with
/// detail noise `fine` and `coarse` in [0, 1] jittering the borders and
/// the tone. Seven bands: sand, grass, forest, dirt, rock, scree and snow.
///
/// This is where the layered materials (issue 26 item 1, branch `layers`)
/// will replace the bands: each band becomes a layer whose mask is this
/// height and slope rule, lit with its own BRDF instead of baked into one
/// albedo.
pub fn band_albedo(height: f32, slope: f32, fine: f32, coarse: f32) -> Vec3 {
    use bands::*;
    let h = height + 0.08 * (coarse - 0.5);
    let s = slope * (0.8 + 0.4 * fine);
    let by_height = if h < SAND_TOP {
        SAND
    } else if h < GRASS_TOP {
        GRASS.lerp(FOREST, smooth(0.5, 0.7, coarse))
    } else if h < FOREST_TOP {
        FOREST.lerp(GRASS, smooth(0.35, FOREST_TOP, h))
    } else if h < SCREE_TOP {
        SCREE
    } else {
        SNOW
    };
    let colour = if s > ROCK_SLOPE {
        ROCK
    } else if s > DIRT_SLOPE {
        DIRT.lerp(ROCK, smooth(DIRT_SLOPE, ROCK_SLOPE, s))
    } else if h >= SCREE_TOP && s > SNOW_SCREE_SLOPE {
        SCREE
    } else {
        by_height
    };
    colour * (0.8 + 0.4 * fine)
}

fn smooth(lo: f32, hi: f32, t: f32) -> f32 {
    let t = ((t - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The precals, in world metres: a winding road across the terrain, a
/// straight power line with its pylons' pads, and scorch marks.
struct PrecalSet {
    size: f32,
    /// Road: z = centre + amplitude sin(2 pi x / wavelength), this wide.
    road: (f32, f32, f32, f32),
    /// Power line: from a to b, corridor width, pylon spacing and pad side.
    line: (Vec2, Vec2, f32, f32, f32),
    /// Scorch marks: centre and radius.
    scorches: Vec<(Vec2, f32)>,
}

impl PrecalSet {
    fn new(spec: &TerrainSpec) -> Self {
        let s = spec.size;
        let mut rng = ChaCha8Rng::seed_from_u64(spec.seed ^ 0x9eca1);
        let scorches = (0..12)
            .map(|_| {
                let centre = Vec2::new(rng.random_range(0.1..0.9), rng.random_range(0.1..0.9)) * s;
                (centre, rng.random_range(0.005..0.02) * s)
            })
            .collect();
        Self {
            size: s,
            road: (0.45 * s, 0.08 * s, 0.6 * s, (0.004 * s).max(3.0)),
            line: (Vec2::new(0.05, 0.9) * s, Vec2::new(0.95, 0.15) * s, (0.001 * s).max(1.0), 0.07 * s, 0.003 * s),
            scorches,
        }
    }

    /// The precal covering (x, z), as its linear colour and coverage in
    /// (0, 1], the last stamped wins; `None` where none covers the ground.
    fn cover(&self, x: f32, z: f32) -> Option<(Vec3, f32)> {
        let p = Vec2::new(x, z);
        let mut top = None;
        for &(c, radius) in &self.scorches {
            let d = (p - c).length() / radius;
            if d < 1.0 {
                top = Some((Vec3::new(0.03, 0.025, 0.02), 0.95 * (1.0 - d * d)));
            }
        }
        let (centre, amplitude, wavelength, width) = self.road;
        let k = std::f32::consts::TAU / wavelength;
        let road_z = centre + amplitude * (k * x).sin();
        let across = (z - road_z).abs() / (1.0 + (amplitude * k * (k * x).cos()).powi(2)).sqrt();
        if across < 0.5 * width && (0.0..=self.size).contains(&x) {
            // Asphalt with a pale centre line.
            let line = across < 0.04 * width;
            top = Some((if line { Vec3::new(0.7, 0.68, 0.5) } else { Vec3::new(0.07, 0.07, 0.075) }, 1.0));
        }
        let (a, b, corridor, spacing, pad) = self.line;
        let along = (b - a).normalize();
        let t = (p - a).dot(along);
        let off = (p - a).perp_dot(along).abs();
        if (0.0..=(b - a).length()).contains(&t) {
            if off < 0.5 * corridor {
                top = Some((Vec3::new(0.12, 0.1, 0.08), 0.8));
            }
            let nearest = (t / spacing).round() * spacing;
            if (t - nearest).abs() < 0.5 * pad && off < 0.5 * pad {
                top = Some((Vec3::new(0.45, 0.45, 0.45), 1.0));
            }
        }
        top
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_seven_colours() {
        let mut seen: Vec<[u8; 3]> = Vec::new();
        for h in 0..50 {
            for s in 0..30 {
                let c = band_albedo(h as f32 / 49.0, s as f32 * 0.06, 0.5, 0.5);
                let key = [c.x, c.y, c.z].map(|v| (v * 20.0) as u8);
                if !seen.contains(&key) {
                    seen.push(key);
                }
            }
        }
        assert!(seen.len() >= 6, "{} distinct colours", seen.len());
    }

    #[test]
    fn patches_agree_on_their_shared_texels_and_the_path_clears_the_ground() {
        let spec = TerrainSpec::SMALL;
        let g = spec.build();
        let s = &g.scene;
        s.validate().unwrap();
        assert_eq!(s.objects.len(), 16);
        let n = spec.texels as usize;
        let inner = n - 2 * MARGIN as usize;
        // Patch (0, 0)'s texel (inner + k) is patch (1, 0)'s texel k, row by row.
        let (a, b) = (&s.textures[0].rgba8, &s.textures[1].rgba8);
        for row in 0..n {
            for k in 0..2 * MARGIN as usize {
                let (ia, ib) = ((row * n + inner + k) * 4, (row * n + k) * 4);
                assert_eq!(a[ia..ia + 4], b[ib..ib + 4], "row {row} texel {k}");
            }
        }
        // Shared border vertices have the same position and normal.
        let (ma, mb) = (&s.meshes[0], &s.meshes[1]);
        let right: Vec<_> = ma.positions.iter().zip(&ma.normals).filter(|(p, _)| p.x == 64.0).collect();
        let left: Vec<_> = mb.positions.iter().zip(&mb.normals).filter(|(p, _)| p.x == 64.0).collect();
        assert_eq!(right.len(), 17);
        assert_eq!(right, left);
        // Low keys clear the ground; high keys are well above it.
        let noise = spec.noise();
        let path = spec.path();
        let lows = path.keys.iter().filter(|k| {
            let p = k.position * Vec3::new(-1.0, 1.0, 1.0);
            let ground = spec.height(&noise, p.x, p.z);
            assert!(p.y > ground + 1.0, "{p} under the ground {ground}");
            p.y < ground + 0.1 * spec.size
        });
        assert!(lows.count() >= 3);
        assert_eq!(spec.build().scene.textures[5].rgba8, s.textures[5].rgba8, "deterministic");
    }

    #[test]
    fn precals_change_only_their_footprint() {
        let with = TerrainSpec::SMALL.build().scene;
        let without = TerrainSpec { precals: Precals::Off, ..TerrainSpec::SMALL }.build().scene;
        let mask = TerrainSpec { precals: Precals::Footprint, ..TerrainSpec::SMALL }.build().scene;
        let (mut changed, mut covered) = (0, 0);
        for ((a, b), m) in with.textures.iter().zip(&without.textures).zip(&mask.textures) {
            for ((pa, pb), pm) in a.rgba8.chunks(4).zip(b.rgba8.chunks(4)).zip(m.rgba8.chunks(4)) {
                covered += (pm[0] > 0) as u32;
                if pa != pb {
                    changed += 1;
                    assert!(pm[0] > 0, "a texel outside the footprint changed");
                }
            }
        }
        assert!(changed > 200 && covered >= changed, "{changed} changed, {covered} covered");
    }
}
