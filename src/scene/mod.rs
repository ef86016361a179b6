//! The scene model every pipeline renders: meshes, materials, textures, object
//! instances, lights and cameras, plus the loaders and generators that build it.
//!
//! A [`Scene`] is plain CPU data. `render::SceneGpu` uploads it once; pipelines
//! never look at files.

pub mod bookmarks;
pub mod camera;
pub mod checker;
pub mod detail;
pub mod environment;
pub mod error;
pub mod framing;
pub mod free_camera;
pub mod generate;
pub mod gloss;
pub mod gltf;
pub mod lights;
pub mod obj;
pub mod path;
mod tangent_cache;

use std::path::Path;

use glam::{Mat4, Vec2, Vec3, Vec4};

pub use camera::Camera;
pub use error::SceneError;
pub use lights::{Light, LightKind, LightSpec};
pub use path::CameraPath;

/// One triangle mesh with one material. glTF primitives and OBJ objects each
/// become one `Mesh`.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit normals, one per vertex (generated from faces when the file has none).
    pub normals: Vec<Vec3>,
    /// Tangent (xyz) and bitangent sign (w), one per vertex (generated when absent).
    pub tangents: Vec<Vec4>,
    /// Texture coordinates of the material's textures (TEXCOORD_0 / OBJ `vt`).
    pub uv0: Vec<Vec2>,
    /// A second UV set when the file has one (glTF TEXCOORD_1). The chart
    /// module prefers it for object-space shading when it is unique.
    pub uv1: Option<Vec<Vec2>>,
    /// Triangle list, three indices per triangle, all `< positions.len()`.
    pub indices: Vec<u32>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Object-space bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    /// Sum of triangle areas in object space (metres squared for the shared scenes).
    pub fn surface_area(&self) -> f32 {
        self.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| self.positions[t[k] as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Fills `normals` with area-weighted face normals when they are missing,
    /// and `tangents` from `uv0` when they are missing.
    pub fn generate_missing_attributes(&mut self) {
        if self.normals.len() != self.positions.len() {
            self.normals = vec![Vec3::ZERO; self.positions.len()];
            for t in self.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| self.positions[t[k] as usize]);
                let n = (b - a).cross(c - a); // length = 2 * area: area weighting
                for &i in t {
                    self.normals[i as usize] += n;
                }
            }
            for n in &mut self.normals {
                *n = n.try_normalize().unwrap_or(Vec3::Y);
            }
        }
        if self.uv0.len() != self.positions.len() {
            self.uv0 = vec![Vec2::ZERO; self.positions.len()];
        }
        if self.tangents.len() != self.positions.len() {
            let inputs = tangent_cache::TangentInputs {
                positions: &self.positions,
                normals: &self.normals,
                uvs: &self.uv0,
                indices: &self.indices,
            };
            self.tangents = tangent_cache::cached(&inputs, || {
                generate_tangents(inputs.positions, inputs.normals, inputs.uvs, inputs.indices)
            });
        }
    }

    /// Checks the invariants the renderer relies on; loaders call this so that a
    /// bad file is reported by name instead of crashing a GPU pass.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.positions.len();
        if !self.indices.len().is_multiple_of(3) {
            return Err(format!("mesh '{}': index count {} is not a multiple of 3", self.name, self.indices.len()));
        }
        if let Some((k, &i)) = self.indices.iter().enumerate().find(|(_, i)| **i as usize >= n) {
            return Err(format!(
                "mesh '{}': index {} at position {} is out of range ({} vertices)",
                self.name, i, k, n
            ));
        }
        if let Some(k) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("mesh '{}': vertex {} has a non-finite position", self.name, k));
        }
        for (what, len) in [("normals", self.normals.len()), ("tangents", self.tangents.len()), ("uv0", self.uv0.len())]
        {
            if len != n {
                return Err(format!("mesh '{}': {} has {} entries for {} vertices", self.name, what, len, n));
            }
        }
        if let Some(uv1) = &self.uv1
            && uv1.len() != n
        {
            return Err(format!("mesh '{}': uv1 has {} entries for {} vertices", self.name, uv1.len(), n));
        }
        Ok(())
    }
}

/// Per-vertex tangents by MikkTSpace (`bevy_mikktspace`, a port that gives
/// the reference implementation's results), the tangent space that glTF and
/// the usual bakers assume, so that normal maps come out as baked. MikkTSpace
/// works per triangle corner; corners that share a vertex almost always get
/// the same tangent (it welds equal vertices first). Where they differ
/// (corners split by its angle threshold), the vertex keeps their average.
/// Vertices no triangle uses, or with degenerate UVs, get a tangent
/// perpendicular to their normal.
pub fn generate_tangents(positions: &[Vec3], normals: &[Vec3], uvs: &[Vec2], indices: &[u32]) -> Vec<Vec4> {
    struct Corners<'a> {
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        uvs: &'a [Vec2],
        indices: &'a [u32],
        sums: Vec<Vec4>,
    }
    impl bevy_mikktspace::Geometry for Corners<'_> {
        fn num_faces(&self) -> usize {
            self.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.indices[face * 3 + vert] as usize].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.normals[self.indices[face * 3 + vert] as usize].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uvs[self.indices[face * 3 + vert] as usize].to_array()
        }
        fn set_tangent(&mut self, tangent: Option<bevy_mikktspace::TangentSpace>, face: usize, vert: usize) {
            if let Some(t) = tangent {
                self.sums[self.indices[face * 3 + vert] as usize] += Vec4::from(t.tangent_encoded());
            }
        }
    }
    let mut corners = Corners { positions, normals, uvs, indices, sums: vec![Vec4::ZERO; positions.len()] };
    // The generator has no failure cases (its error type has no variants).
    let _ = bevy_mikktspace::generate_tangents(&mut corners);
    corners
        .sums
        .iter()
        .zip(normals)
        .map(|(sum, &n)| {
            let t = sum.truncate();
            let t = (t - n * n.dot(t)).try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
            t.extend(if sum.w < 0.0 { -1.0 } else { 1.0 })
        })
        .collect()
}

/// An RGBA8 texture in sRGB, as decoded from a file or generated.
#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// `width * height * 4` bytes, row-major, sRGB-encoded colour.
    pub rgba8: Vec<u8>,
}

/// A material of the shared lighting models (`shaders/shared/lighting.wgsl`):
/// Phong's specular strength and exponent, glTF 2.0's metallic-roughness
/// factors and textures, emission, a normal map and an occlusion map. The
/// Phong exponent is derived from roughness where a file gives one (and per
/// texel from a metallic-roughness texture's roughness).
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Linear RGBA multiplier of the base colour texture.
    pub base_color: Vec4,
    /// Index into [`Scene::textures`].
    pub base_color_texture: Option<usize>,
    /// Index into [`Scene::textures`] (tangent-space normal map).
    pub normal_texture: Option<usize>,
    pub metallic: f32,
    pub roughness: f32,
    /// Index into [`Scene::textures`] (linear): glTF's metallic-roughness
    /// texture, blue = metallic, green = roughness, each multiplying its factor.
    pub metallic_roughness_texture: Option<usize>,
    /// Linear emitted radiance (glTF: `emissiveFactor` times
    /// `KHR_materials_emissive_strength`).
    pub emissive: Vec3,
    /// Index into [`Scene::textures`] (sRGB colour, multiplying `emissive`).
    pub emissive_texture: Option<usize>,
    /// Index into [`Scene::textures`] (linear): ambient occlusion in red,
    /// applied to ambient light only, as `1 + occlusion_strength * (red - 1)`.
    pub occlusion_texture: Option<usize>,
    pub occlusion_strength: f32,
    /// Strength of the specular term.
    pub specular: f32,
    /// Phong exponent p in `max(R·V, 0)^p`.
    pub shininess: f32,
    /// Alpha masking (glTF `MASK`): where the alpha of `base_color` times
    /// the base colour texture's is below this, the surface is not there
    /// (not drawn, casts no shadow). `None`: opaque, alpha ignored.
    pub alpha_cutoff: Option<f32>,
    /// Alpha blending (glTF `BLEND`): the surface is composited over what is
    /// behind it with its [`Material::opacity`], after the opaque surfaces
    /// and back to front. Never set together with `alpha_cutoff`.
    pub blend: bool,
    /// Layers over the material's own surface, bottom first
    /// ([`crate::materials`]); none for a plain material.
    pub layers: Vec<crate::materials::Layer>,
    /// Both faces are drawn. When false the surface is seen from its front
    /// only (counter-clockwise on screen): every pipeline culls its back
    /// faces, the compute rasterizer and cluster cone culling included, and
    /// object space never shades them; shadow maps draw both faces of every
    /// caster. glTF gives it per material (`doubleSided`, default false),
    /// OBJ is single-sided except for cut-out and blended materials
    /// ([`obj`]); `Default` (the procedural scenes) is true, and the city
    /// sets false where that changes no image ([`generate::city`]).
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            normal_texture: None,
            metallic: 0.0,
            roughness: 0.6,
            metallic_roughness_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            specular: 0.25,
            shininess: 32.0,
            alpha_cutoff: None,
            blend: false,
            layers: Vec::new(),
            double_sided: true,
        }
    }
}

impl Material {
    /// Every texture slot: base colour, normal, metallic-roughness, emissive, occlusion.
    pub fn textures(&self) -> [Option<usize>; 5] {
        [
            self.base_color_texture,
            self.normal_texture,
            self.metallic_roughness_texture,
            self.emissive_texture,
            self.occlusion_texture,
        ]
    }

    /// How the material's alpha is used.
    pub fn alpha_mode(&self) -> AlphaMode {
        match (self.blend, self.alpha_cutoff) {
            (true, _) => AlphaMode::Blend,
            (false, Some(cutoff)) => AlphaMode::Mask(cutoff),
            (false, None) => AlphaMode::Opaque,
        }
    }

    /// The surface's opacity where its base colour texel's alpha is
    /// `texel_alpha`: the base colour factor's alpha times it (glTF), in
    /// 0..=1. Only blended materials use it (`alpha_blend.wgsl` on the GPU).
    pub fn opacity(&self, texel_alpha: f32) -> f32 {
        (self.base_color.w * texel_alpha).clamp(0.0, 1.0)
    }

    /// Phong exponent equivalent to a GGX roughness (the Blinn-Phong mapping
    /// 2/alpha^2 - 2, halved for the reflection-vector form).
    pub fn shininess_from_roughness(roughness: f32) -> f32 {
        let alpha = (roughness * roughness).max(1e-3);
        ((2.0 / (alpha * alpha) - 2.0) * 0.25).clamp(1.0, 512.0)
    }
}

/// Which back faces are drawn (`--back-faces`, [`Scene::set_back_faces`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackFaces {
    /// Each material's rule ([`Material::double_sided`]), as loaded.
    #[default]
    Material,
    /// Every back face is culled (every material single-sided).
    Cull,
    /// Every back face is drawn (every material double-sided).
    Draw,
}

/// How a material's alpha is used (glTF's `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored: the surface is everywhere.
    Opaque,
    /// Cut away where the alpha is below the cutoff ([`Material::alpha_cutoff`]).
    Mask(f32),
    /// Composited over what is behind it ([`Material::blend`]).
    Blend,
}

/// One instance of a mesh in the world.
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Object-to-world transform.
    pub transform: Mat4,
    /// Shade this object with forward shading even in the object-space
    /// pipeline (the sources do this for foliage and particles).
    pub forward_only: bool,
}

/// Axis-aligned bounding box. An empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| Aabb { min: b.min.min(p), max: b.max.max(p) })
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }

    /// The box of this box's corners moved by `m`.
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        Aabb::from_points(self.corners().map(|c| m.transform_point3(c)))
    }
}

/// Everything one render needs besides the view and the lights.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Short name used in reports (`atrium`, `sponza-thesis`, ...).
    pub name: String,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub objects: Vec<Object>,
    /// Lights that came with the scene file (glTF `KHR_lights_punctual`).
    pub lights: Vec<Light>,
    /// Cameras that came with the scene file (glTF cameras).
    pub cameras: Vec<Camera>,
    /// The environment that lights of kind [`LightKind::Environment`] add
    /// (`--env`; default none).
    pub environment: Option<environment::Environment>,
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| self.meshes[o.mesh].triangle_count()).sum()
    }

    /// World-space bounds of one object.
    pub fn object_bounds(&self, object: usize) -> Aabb {
        let o = &self.objects[object];
        self.meshes[o.mesh].bounds().transformed(&o.transform)
    }

    /// World-space bounds of every object, in object order: each mesh's box
    /// is found once and moved by each instance's transform, so the cost
    /// grows with the meshes' vertices plus the instances, not their product.
    pub fn all_object_bounds(&self) -> Vec<Aabb> {
        let meshes: Vec<Aabb> = self.meshes.iter().map(Mesh::bounds).collect();
        self.objects.iter().map(|o| meshes[o.mesh].transformed(&o.transform)).collect()
    }

    /// World-space bounds of the whole scene.
    pub fn bounds(&self) -> Aabb {
        self.all_object_bounds().iter().fold(Aabb::EMPTY, |b, o| b.union(o))
    }

    /// Whether some object's material is alpha-masked.
    pub fn has_alpha_masks(&self) -> bool {
        self.objects.iter().any(|o| self.materials[o.material].alpha_cutoff.is_some())
    }

    /// Overrides every material's [`Material::double_sided`] as `faces` says
    /// (`--back-faces`); [`BackFaces::Material`] leaves them as loaded.
    pub fn set_back_faces(&mut self, faces: BackFaces) {
        let double_sided = match faces {
            BackFaces::Material => return,
            BackFaces::Cull => false,
            BackFaces::Draw => true,
        };
        for m in &mut self.materials {
            m.double_sided = double_sided;
        }
    }

    /// Whether object `object`'s back faces are culled (its material is not
    /// [`Material::double_sided`]).
    pub fn single_sided(&self, object: usize) -> bool {
        !self.materials[self.objects[object].material].double_sided
    }

    /// Whether some object's material is alpha-blended.
    pub fn has_blended(&self) -> bool {
        self.objects.iter().any(|o| self.materials[o.material].blend)
    }

    /// Every object's vertices in world space (for framing the scene).
    pub fn world_positions(&self) -> Vec<Vec3> {
        self.objects
            .iter()
            .flat_map(|o| self.meshes[o.mesh].positions.iter().map(|p| o.transform.transform_point3(*p)))
            .collect()
    }

    /// Checks every invariant the renderer relies on (see [`Mesh::validate`]),
    /// and that every reference between scene parts is in range.
    pub fn validate(&self) -> Result<(), String> {
        if self.objects.is_empty() || self.triangle_count() == 0 {
            return Err("the scene has no triangles".into());
        }
        for m in &self.meshes {
            m.validate()?;
        }
        for o in &self.objects {
            if o.mesh >= self.meshes.len() || o.material >= self.materials.len() {
                return Err(format!("object '{}' refers to a missing mesh or material", o.name));
            }
            if !o.transform.is_finite() {
                return Err(format!("object '{}' has a non-finite transform", o.name));
            }
        }
        for m in &self.materials {
            for t in m.textures().into_iter().flatten() {
                if t >= self.textures.len() {
                    return Err(format!("material '{}' refers to missing texture {}", m.name, t));
                }
            }
        }
        Ok(())
    }
}

/// The names of the procedural scenes, for `--scene` and `--help` (the
/// city also takes a size: `city:N`, [`generate::city::CitySpec::parse`]).
pub const PROCEDURAL_SCENES: [&str; 6] = ["atrium", "voxels", "terrain", "terrain-small", "panes", "city"];

/// Loads a scene by procedural name (`atrium`, `voxels`, `terrain`,
/// `terrain-small`, `panes`, `city`, `city:N`, `city:N:SEED`) or by path: a `.gltf`
/// or `.glb` file, an `.obj` file, or a folder of `.obj` files (one scene).
/// The result is validated, so a bad file fails here with its name.
pub fn load(spec: &str) -> Result<Scene, SceneError> {
    let scene = match spec {
        "atrium" => generate::atrium(),
        "voxels" => generate::voxels(),
        "terrain" => generate::terrain(false),
        "terrain-small" => generate::terrain(true),
        "panes" => generate::panes(),
        _ => match generate::city::CitySpec::parse(spec) {
            Some(city) => city.map_err(|problem| SceneError::Invalid { path: spec.into(), problem })?.scene(),
            None => load_path(Path::new(spec))?,
        },
    };
    scene.validate().map_err(|problem| SceneError::Invalid { path: spec.into(), problem })?;
    Ok(scene)
}

/// A scene file or folder (see [`load`]).
fn load_path(path: &Path) -> Result<Scene, SceneError> {
    if !path.exists() {
        return Err(SceneError::NotFound(path.to_path_buf()));
    }
    if path.is_dir() {
        return obj::load_folder(path);
    }
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("gltf" | "glb") => gltf::load(path),
        Some("obj") => obj::load_file(path),
        _ => Err(SceneError::UnknownFormat(path.to_path_buf())),
    }
}

#[cfg(test)]
mod tangent_tests {
    use super::*;

    /// A unit quad in the xy plane facing +z, its u along +x; v along -y
    /// (glTF's convention: v grows down the image) or, mirrored, along +y.
    fn quad_tangents(v_along_y: f32) -> Vec<Vec4> {
        let positions =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let uvs: Vec<Vec2> = positions.iter().map(|p| Vec2::new(p.x, v_along_y * p.y)).collect();
        generate_tangents(&positions, &[Vec3::Z; 4], &uvs, &[0, 1, 2, 0, 2, 3])
    }

    #[test]
    fn tangents_follow_u_and_the_sign_follows_v() {
        // Bitangent = w * cross(n, t): with t = +x and n = +z, cross is +y,
        // so w = +1 where v grows along +y and -1 where it grows along -y.
        for (v_along_y, sign) in [(1.0, 1.0), (-1.0, -1.0)] {
            for t in quad_tangents(v_along_y) {
                assert!((t.truncate() - Vec3::X).length() < 1e-5, "tangent {t} should be +x");
                assert_eq!(t.w, sign, "bitangent sign for v along {v_along_y} y");
            }
        }
        // A vertex no triangle uses still gets a unit tangent perpendicular to its normal.
        let t = generate_tangents(&[Vec3::ZERO], &[Vec3::Y], &[Vec2::ZERO], &[]);
        assert!((t[0].truncate().length() - 1.0).abs() < 1e-5 && t[0].truncate().dot(Vec3::Y).abs() < 1e-5);
    }
}
