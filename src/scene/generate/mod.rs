//! Procedural scenes, built in code and deterministic: `atrium` (a Sponza-like
//! courtyard, the default scene), `voxels` (a block world), [`terrain()`],
//! [`city`] (a city of instanced buildings), for tests of anti-aliasing
//! [`fence`] (thin tilted bars before a wall) and, for tests of alpha
//! blending, [`panes`] (overlapping transparent panes before a wall).
//!
//! Both are in metres, right-handed, +y up, with the floor at y = 0. Every
//! object has its own Phong material with a UV-checker albedo sampled through
//! world-scaled `uv0` (one checker repeat per metre), and a unique chart layout
//! in `uv1` packed by [`builder::MeshBuilder`] (see there for the gutter rule).

mod atrium;
pub mod builder;
pub mod city;
mod noise;
pub mod terrain;
mod voxels;

use glam::{Mat4, Vec3};

use self::builder::{ChartLayout, MeshBuilder};
use super::checker::uv_checker;
use super::{Material, Object, Scene, Texture};
use crate::color::linear_to_srgb8;

/// The default scene: a Sponza-like courtyard of 30 x 13 x 15 m with two
/// storeys of arcades around a central court and six hanging banners (106k
/// triangles, 26 objects).
pub fn atrium() -> Scene {
    atrium::build().scene
}

/// A Minecraft-like block world, 256 x 256 columns of 1 m blocks with hills,
/// water, trees and a tunnel through a hill (412k triangles in 404 objects:
/// one per 32 x 32-column chunk and block material, at most 4.5k triangles each).
pub fn voxels() -> Scene {
    voxels::build().scene
}

/// A 2 km square terrain of 1.18 M triangles in 12 x 12 patches, coloured
/// in seven bands by height and slope, with roads, a power line and scorch
/// marks stamped into its material ([`terrain::TerrainSpec::DEFAULT`]);
/// `small` gives the 256 m one of 8 k triangles for tests
/// ([`terrain::TerrainSpec::SMALL`]).
pub fn terrain(small: bool) -> Scene {
    let spec = if small { terrain::TerrainSpec::SMALL } else { terrain::TerrainSpec::DEFAULT };
    spec.scene()
}

/// A thin-edged scene for anti-aliasing tests: fourteen dark bars 2 cm wide
/// and 2.4 m long, 25 cm apart, tilted 20 degrees from vertical, in the
/// plane z = 0 in front of a light wall (4 x 3 m at z = -1, facing +z), both
/// flat-coloured so that the bars' edges, not texture, make the aliasing.
/// Seen from 3 m in front of the origin with a 60-degree field of view, a
/// bar is under a pixel wide at 128 pixels of height. Two objects (wall,
/// bars), each with a unique chart layout; no lights (the caller's).
pub fn fence() -> Scene {
    let mut a = Assembler::new("fence");
    let wall_look = a.flat_look("fence wall", Vec3::new(0.85, 0.8, 0.7));
    let bar_look = a.flat_look("fence bars", Vec3::new(0.06, 0.06, 0.08));
    let mut wall = MeshBuilder::new();
    wall.rect(Vec3::new(-2.0, -1.5, -1.0), Vec3::X * 4.0, Vec3::Y * 3.0, 1.0, 1.0);
    a.add("wall", wall, wall_look);
    let (s, c) = 20f32.to_radians().sin_cos();
    let (along, across) = (Vec3::new(s, c, 0.0), Vec3::new(c, -s, 0.0));
    let mut bars = MeshBuilder::new();
    for i in 0..14 {
        let centre = Vec3::new(-1.625 + 0.25 * i as f32, 0.0, 0.0);
        // across x along is +z: the bars face the camera.
        bars.rect(centre - along * 1.2 - across * 0.01, across * 0.02, along * 2.4, 0.5, 1.0);
    }
    a.add("bars", bars, bar_look);
    a.finish().scene
}

/// One transparent pane of [`panes`]: a rectangle facing +z at depth `z`,
/// from `min` to `max` in x and y, of one linear colour and opacity.
#[derive(Clone, Copy, Debug)]
pub struct Pane {
    pub name: &'static str,
    pub color: Vec3,
    pub opacity: f32,
    pub min: glam::Vec2,
    pub max: glam::Vec2,
    pub z: f32,
}

/// The panes of [`panes`], nearest first: red over green over blue, each
/// overlapping the others, so that one region shows all three.
pub const PANES: [Pane; 3] = [
    Pane {
        name: "pane red",
        color: Vec3::new(0.9, 0.08, 0.05),
        opacity: 0.5,
        min: glam::Vec2::new(-1.2, -0.6),
        max: glam::Vec2::new(0.4, 1.0),
        z: 0.6,
    },
    Pane {
        name: "pane green",
        color: Vec3::new(0.08, 0.8, 0.15),
        opacity: 0.4,
        min: glam::Vec2::new(-0.4, -0.2),
        max: glam::Vec2::new(1.2, 1.0),
        z: 0.2,
    },
    Pane {
        name: "pane blue",
        color: Vec3::new(0.06, 0.15, 0.9),
        opacity: 0.6,
        min: glam::Vec2::new(-0.8, -1.0),
        max: glam::Vec2::new(0.8, 0.2),
        z: -0.2,
    },
];

/// The linear colour of the opaque wall behind [`PANES`].
pub const PANES_BACKDROP: Vec3 = Vec3::new(0.6, 0.6, 0.55);

/// A scene for alpha blending: an opaque wall (4 x 3 m at z = -1, facing
/// +z, [`PANES_BACKDROP`]) behind three alpha-blended panes ([`PANES`]),
/// each flat-coloured with its opacity in its base colour's alpha. The
/// panes are listed nearest first, so that drawing them in object order
/// (front to back) composites them wrongly. Its own camera looks at the
/// panes from in front and to the side, so that `--scene panes` alone shows
/// them overlapping (framing from outside may face the wall's back); tests
/// look from (0, 0, 4) down -z. No lights (the caller's).
pub fn panes() -> Scene {
    let mut a = Assembler::new("panes");
    let wall_look = a.flat_look("panes wall", PANES_BACKDROP);
    let mut wall = MeshBuilder::new();
    wall.rect(Vec3::new(-2.0, -1.5, -1.0), Vec3::X * 4.0, Vec3::Y * 3.0, 1.0, 1.0);
    a.add("wall", wall, wall_look);
    for pane in PANES {
        let look = a.flat_look(pane.name, pane.color);
        let mut mesh = MeshBuilder::new();
        let size = pane.max - pane.min;
        mesh.rect(pane.min.extend(pane.z), Vec3::X * size.x, Vec3::Y * size.y, 1.0, 1.0);
        a.add(pane.name, mesh, look);
        let m = a.generated.scene.materials.last_mut().expect("just added");
        m.blend = true;
        m.base_color.w = pane.opacity;
    }
    let mut scene = a.finish().scene;
    let eye = Vec3::new(1.5, 0.8, 4.0);
    scene.cameras.push(super::Camera {
        position: eye,
        forward: (-eye).normalize(),
        up: Vec3::Y,
        fov_y: 60f32.to_radians(),
        near: 0.1,
        far: 20.0,
    });
    scene
}

/// A generated scene plus the chart layout of each mesh (for tests and reports).
pub(crate) struct Generated {
    pub scene: Scene,
    /// `layouts[i]` belongs to `scene.meshes[i]`.
    pub layouts: Vec<ChartLayout>,
}

/// How one kind of surface looks: a shared checker texture and Phong terms.
#[derive(Clone, Copy)]
struct Look {
    texture: usize,
    specular: f32,
    shininess: f32,
}

/// Collects objects into a scene, one mesh and one material per object.
struct Assembler {
    generated: Generated,
}

impl Assembler {
    fn new(name: &str) -> Self {
        let scene = Scene { name: name.to_string(), ..Scene::default() };
        Self { generated: Generated { scene, layouts: Vec::new() } }
    }

    /// Adds a checker texture (shared by every object of a look) and returns
    /// the look. `cells` checker squares per texture repeat.
    fn look(&mut self, name: &str, tint: Vec3, cells: u32, specular: f32, shininess: f32) -> Look {
        let textures = &mut self.generated.scene.textures;
        textures.push(uv_checker(name, tint, 256, cells));
        Look { texture: textures.len() - 1, specular, shininess }
    }

    /// Adds a 4x4 texture of one linear colour `tint` and returns its look
    /// (dull: specular 0.2, exponent 8).
    fn flat_look(&mut self, name: &str, tint: Vec3) -> Look {
        let texel = [linear_to_srgb8(tint.x), linear_to_srgb8(tint.y), linear_to_srgb8(tint.z), 255];
        let rgba8 = texel.repeat(16);
        let textures = &mut self.generated.scene.textures;
        textures.push(Texture { name: name.to_string(), width: 4, height: 4, rgba8 });
        Look { texture: textures.len() - 1, specular: 0.2, shininess: 8.0 }
    }

    /// Finishes `builder` into a mesh and adds it as an object with its own material.
    fn add(&mut self, name: &str, builder: MeshBuilder, look: Look) {
        let (mesh, layout) = builder.finish(name);
        let scene = &mut self.generated.scene;
        scene.meshes.push(mesh);
        scene.materials.push(Material {
            name: name.to_string(),
            base_color_texture: Some(look.texture),
            specular: look.specular,
            shininess: look.shininess,
            ..Material::default()
        });
        scene.objects.push(Object {
            name: name.to_string(),
            mesh: scene.meshes.len() - 1,
            material: scene.materials.len() - 1,
            transform: Mat4::IDENTITY,
            forward_only: false,
        });
        self.generated.layouts.push(layout);
    }

    fn finish(self) -> Generated {
        self.generated
    }
}

#[cfg(test)]
mod tests {
    use std::time::Instant;

    use super::builder::tests::check_mesh;
    use super::*;

    /// Every check that both scenes share; `density_spread` bounds max / min
    /// world area per uv1 area over each object's triangles.
    fn check_scene(g: &Generated, tris: std::ops::RangeInclusive<usize>, density_spread: f32) {
        let s = &g.scene;
        s.validate().unwrap();
        assert!(tris.contains(&s.triangle_count()), "{}: {} triangles", s.name, s.triangle_count());
        assert_eq!(g.layouts.len(), s.meshes.len());
        for (o, obj) in s.objects.iter().enumerate() {
            assert!(!obj.forward_only);
            let m = &s.materials[obj.material];
            assert!(m.base_color_texture.is_some());
            assert!((0.2..=0.5).contains(&m.specular) && (8.0..=64.0).contains(&m.shininess));
            // Own material per object.
            assert!(s.objects.iter().enumerate().all(|(p, q)| p == o || q.material != obj.material));
        }
        for (mesh, layout) in s.meshes.iter().zip(&g.layouts) {
            let spread = check_mesh(mesh, layout);
            assert!(spread <= density_spread, "{}: texel density spread {spread}", mesh.name);
        }
    }

    fn same_geometry(a: &Scene, b: &Scene) -> bool {
        a.meshes.len() == b.meshes.len()
            && a.meshes.iter().zip(&b.meshes).all(|(x, y)| {
                x.positions == y.positions && x.indices == y.indices && x.uv1 == y.uv1 && x.normals == y.normals
            })
    }

    #[test]
    fn atrium_is_valid_with_unique_uniform_charts() {
        let t = Instant::now();
        let g = atrium::build();
        eprintln!(
            "atrium: {:?}, {} triangles, {} objects",
            t.elapsed(),
            g.scene.triangle_count(),
            g.scene.objects.len()
        );
        // Lathe rings and banner waves are unrolled to within a few percent.
        check_scene(&g, 50_000..=200_000, 1.25);
        assert!((10..=60).contains(&g.scene.objects.len()));
        let b = g.scene.bounds();
        eprintln!("atrium bounds {:?}", b);
        assert!(b.min.y.abs() < 1e-4, "floor at y = 0");
        let e = b.extent();
        assert!((28.0..=32.0).contains(&e.x) && (12.0..=14.0).contains(&e.y) && (14.0..=16.0).contains(&e.z), "{e}");
        let banners = g.scene.objects.iter().filter(|o| o.name.starts_with("banner")).count();
        assert!((3..=6).contains(&banners));
    }

    #[test]
    fn atrium_is_deterministic() {
        assert!(same_geometry(&atrium(), &atrium()));
    }

    #[test]
    fn voxels_is_valid_with_unique_uniform_charts() {
        let t = Instant::now();
        let g = voxels::build();
        eprintln!(
            "voxels: {:?}, {} triangles, {} objects",
            t.elapsed(),
            g.scene.triangle_count(),
            g.scene.objects.len()
        );
        // Every voxel chart is flat and unit-scaled: density is exact.
        check_scene(&g, 300_000..=500_000, 1.001);
        for m in &g.scene.meshes {
            assert!(m.triangle_count() <= 40_000, "{}: {} triangles", m.name, m.triangle_count());
        }
        let b = g.scene.bounds();
        eprintln!("voxels bounds {:?}", b);
        assert_eq!(b.min.y, 0.0);
        assert_eq!(b.extent().x, 256.0);
        assert_eq!(b.extent().z, 256.0);
        assert!((32.0..=64.0).contains(&b.max.y));
        // Blocks are 1 m: every vertex is on the integer grid.
        for m in &g.scene.meshes {
            assert!(m.positions.iter().all(|p| *p == p.round()), "{}", m.name);
        }
    }

    #[test]
    fn fence_is_valid_with_thin_tilted_bars() {
        let g = fence();
        g.validate().unwrap();
        assert_eq!(g.objects.len(), 2);
        let bars = &g.meshes[g.objects[1].mesh];
        assert_eq!(bars.triangle_count(), 14 * 2 * 5, "14 bars of 5 quads (2.4 m in cells of 0.5 m)");
        // Each bar is 2 cm across: every bar vertex lies within 1 cm of its
        // bar's centre line, which leans 20 degrees from vertical.
        let normal = Vec3::new(20f32.to_radians().cos(), -20f32.to_radians().sin(), 0.0);
        for p in &bars.positions {
            let offset = (p.dot(normal) + 1.625 * normal.x) / 0.25 / normal.x;
            let nearest_bar_distance = (offset - offset.round()).abs() * 0.25 * normal.x;
            assert!(nearest_bar_distance <= 0.0101, "{p}: {nearest_bar_distance} m from a bar's centre line");
        }
    }

    /// The wall is opaque and the panes blended, nearest first, each with
    /// its opacity.
    #[test]
    fn panes_are_blended_nearest_first() {
        let g = panes();
        g.validate().unwrap();
        assert_eq!(g.objects.len(), 4);
        assert!(!g.materials[g.objects[0].material].blend);
        for (o, pane) in g.objects[1..].iter().zip(PANES) {
            let m = &g.materials[o.material];
            assert_eq!(m.alpha_mode(), crate::scene::AlphaMode::Blend);
            assert_eq!(m.opacity(1.0), pane.opacity);
            assert!(g.meshes[o.mesh].positions.iter().all(|p| p.z == pane.z));
        }
        assert!(PANES.windows(2).all(|w| w[0].z > w[1].z), "nearest first");
    }

    #[test]
    fn voxels_is_deterministic() {
        assert!(same_geometry(&voxels(), &voxels()));
    }

    /// Numbers for reports: `cargo test --lib scene::generate::tests::report -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn report() {
        for (name, build) in [("atrium", atrium::build as fn() -> Generated), ("voxels", voxels::build)] {
            let t = Instant::now();
            let g = build();
            let elapsed = t.elapsed();
            let s = &g.scene;
            let spread = s.meshes.iter().zip(&g.layouts).map(|(m, l)| check_mesh(m, l)).fold(1.0, f32::max);
            let util: Vec<f32> = g.layouts.iter().map(|l| l.utilisation()).collect();
            let charts: usize = g.layouts.iter().map(|l| l.rects.len()).sum();
            let most = s.meshes.iter().map(|m| m.triangle_count()).max().unwrap_or(0);
            eprintln!(
                "{name}: {elapsed:?}, {} triangles ({most} at most per object), {} objects, {charts} charts, \
                 bounds {:?}, density spread {spread:.3}, utilisation {:.2}..{:.2} (mean {:.2})",
                s.triangle_count(),
                s.objects.len(),
                s.bounds(),
                util.iter().copied().fold(1.0, f32::min),
                util.iter().copied().fold(0.0, f32::max),
                util.iter().sum::<f32>() / util.len() as f32,
            );
        }
    }
}
