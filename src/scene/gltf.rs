//! glTF 2.0 loading (`.gltf` with external or data-URI buffers, and `.glb`),
//! with the `gltf` crate.
//!
//! Rules:
//! - The default scene (else the first; else every root node) is walked,
//!   composing node transforms. Each triangle primitive of a node's mesh
//!   becomes an [`Object`] with the node's world transform; the [`Mesh`] of a
//!   primitive is shared by all the nodes that instance it. Strips and fans
//!   are converted to lists; points and lines are skipped with a warning.
//! - Mesh attributes: POSITION, NORMAL, TANGENT, TEXCOORD_0 -> `uv0`,
//!   TEXCOORD_1 -> `uv1`; indices, or `0..n` when there are none. Missing
//!   normals, UVs and tangents are generated ([`Mesh::generate_missing_attributes`];
//!   tangents from the file are kept only when normals are too).
//! - Materials (glTF 2.0 metallic-roughness): base colour factor and
//!   texture, normal texture, metallic and roughness factors
//!   (`shininess = Material::shininess_from_roughness(roughness)`) and
//!   texture (linear: blue = metallic, green = roughness, multiplying the
//!   factors), emissive factor (times `KHR_materials_emissive_strength`) and
//!   texture (sRGB, multiplying the factor), occlusion texture (red, with its
//!   `strength`; applied to ambient light only), alpha mode and cutoff
//!   (`MASK` cuts, `BLEND` blends: [`super::AlphaMode`]). A texture whose factor is
//!   zero is not loaded (it would change nothing). Every texture is sampled
//!   with TEXCOORD_0 (another set is a warning). `KHR_texture_transform`
//!   (offset, rotation, scale) is baked into the primitive's UV0, so every
//!   pipeline samples the transformed coordinates with no shader of its own;
//!   the untransformed UV0 becomes UV1 when the file has none, so that the
//!   object-space charts are those of the file's layout, as without the
//!   extension. Simplified: one transform per material (the first loaded
//!   texture's, in the order base colour, metallic-roughness, emissive,
//!   normal, occlusion; a texture with another one is a warning), and
//!   tangents from the file are kept as they are. Images become RGBA8 textures (grey
//!   and grey+alpha images are expanded, 16-bit channels keep their high
//!   byte, float images are encoded to sRGB). A material without a
//!   (loadable) base colour texture gets the generated UV checker of each
//!   object that uses it, as OBJ objects do. A missing or undecodable image
//!   is a warning.
//! - `KHR_lights_punctual`: point, spot and directional lights become
//!   [`Light`]s at the node's world position, shining along the node's world
//!   -Z; spot cones give `cos_inner`/`cos_outer`. `radius` is the light's
//!   `range`, or `10 * sqrt(intensity)` when it has none: the distance where
//!   the attenuated `intensity / (1 + d²)` has fallen to about 0.01.
//!   Intensities are passed through unchanged (candela for point and spot
//!   lights, lux for directional ones, as glTF defines them).
//! - Perspective cameras become [`Camera`]s looking along the node's world
//!   -Z with the node's world +Y as up (`zfar` 1000 when infinite);
//!   orthographic cameras are skipped with a warning.
//! - Errors carry the file's path. Accessors are read by this module with
//!   every byte range, count and index checked (the `gltf` crate's readers
//!   can panic or read garbage on malformed files), and the GLB header, URIs
//!   and buffer views are checked before the `gltf` crate uses them. An
//!   accessor without a buffer view (sparse values over zeros) may have at
//!   most 2^20 elements, since the file's bytes do not bound its size.
//! - Extensions other than `KHR_lights_punctual` and
//!   `KHR_materials_emissive_strength`, skins, morph targets and animations
//!   are ignored with a warning (`extensionsRequired` of any other extension
//!   is an error).

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::material::AlphaMode;
use ::gltf::mesh::Mode;
use ::gltf::{Accessor, Document, Semantic};
use glam::{Mat4, Vec2, Vec3, Vec4};

use super::obj::{check_indices, checker_texture};
use super::{Camera, Light, LightKind, Material, Mesh, Object, Scene, SceneError, Texture};
use crate::color::linear_to_srgb8;

/// Accessors larger than this (bytes) are refused: no real scene needs one,
/// and a corrupt count must not allocate gigabytes.
const MAX_ACCESSOR_BYTES: usize = 1 << 30;

/// The extensions the loader reads.
const SUPPORTED_EXTENSIONS: [&str; 3] =
    ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform"];

/// Accessors without a buffer view (zeros, but for their sparse values) with
/// more elements than this are refused: their size is not backed by bytes of
/// the file, so a 537-byte file declaring 60 million sparse positions took
/// 4 GB and over 10 s (the fuzzer's timeout) before this limit.
const MAX_UNBACKED_ACCESSOR_ELEMENTS: usize = 1 << 20;

/// Warns about what the file uses and the renderer ignores: extensions
/// besides [`SUPPORTED_EXTENSIONS`] (`extensionsRequired` ones are already
/// refused by the parser), skins, morph targets and animations (meshes are
/// drawn in their bind pose, without morphs).
fn warn_ignored(document: &Document, path: &Path) {
    let path = path.display();
    let extensions: Vec<&str> = document.extensions_used().filter(|e| !SUPPORTED_EXTENSIONS.contains(e)).collect();
    if !extensions.is_empty() {
        tracing::warn!("{path}: extensions ignored: {}", extensions.join(", "));
    }
    let morphed = document.meshes().filter(|m| m.primitives().any(|p| p.morph_targets().len() > 0)).count();
    for (count, what) in [
        (document.skins().len(), "skins ignored (meshes drawn in their bind pose)"),
        (morphed, "meshes with morph targets drawn without them"),
        (document.animations().len(), "animations ignored"),
    ] {
        if count > 0 {
            tracing::warn!("{path}: {count} {what}");
        }
    }
}

/// Loads a `.gltf` or `.glb` file as a scene named after the file stem. The
/// scene is validated.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = fs::read(path).map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
    check_glb_header(&bytes).map_err(|m| parse_error(path, m))?;
    let parsed = std::panic::catch_unwind(|| parse(&bytes));
    let (document, blob) = match parsed {
        Ok(Ok(g)) => g,
        Ok(Err(e)) => return Err(parse_error(path, e)),
        Err(_) => return Err(parse_error(path, "the glTF parser failed (panicked) on this file".into())),
    };
    let base = path.parent().unwrap_or(Path::new("")).to_path_buf();
    check_uris_and_views(&document).map_err(|m| parse_error(path, m))?;
    check_external_files(&document, &base).map_err(|m| parse_error(path, m))?;
    warn_ignored(&document, path);
    let buffers = load_buffers(&document, &base, blob, path)?;

    let mut builder = Builder {
        path,
        base: &base,
        document: &document,
        buffers: &buffers,
        scene: Scene {
            name: path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into()),
            ..Default::default()
        },
        meshes: HashMap::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        checkers: HashMap::new(),
    };
    let walked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| builder.walk()));
    match walked {
        Ok(result) => result?,
        Err(_) => return Err(parse_error(path, "the glTF reader failed (panicked) on this file".into())),
    }
    let scene = builder.scene;
    scene.validate().map_err(|problem| invalid(path, problem))?;
    Ok(scene)
}

fn parse_error(path: &Path, message: String) -> SceneError {
    SceneError::Parse { path: path.to_path_buf(), message }
}

fn invalid(path: &Path, problem: String) -> SceneError {
    SceneError::Invalid { path: path.to_path_buf(), problem }
}

/// Parses and validates the document. `gltf-json`'s validation indexes the
/// accessors with each primitive's POSITION index unchecked, so those
/// indices are checked first.
fn parse(bytes: &[u8]) -> Result<(Document, Option<Vec<u8>>), String> {
    let ::gltf::Gltf { document, blob } =
        ::gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| e.to_string())?;
    let json = document.into_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive.attributes.get(&::gltf::json::validation::Checked::Valid(Semantic::Positions));
            if position.is_some_and(|a| a.value() >= json.accessors.len()) {
                return Err(format!("meshes[{m}].primitives[{p}].attributes.POSITION: index out of bounds"));
            }
        }
    }
    let document = Document::from_json(json).map_err(|e| e.to_string())?;
    Ok((document, blob))
}

/// The `gltf` crate subtracts the header size from a GLB's declared length
/// without checking it.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let Some(length) = bytes.get(8..12) else {
        return Err("truncated GLB header".into());
    };
    let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]) as usize;
    if length < 20 {
        return Err(format!("GLB header declares {length} bytes, less than a header and a chunk header"));
    }
    if length > bytes.len() {
        return Err(format!("GLB header declares {length} bytes but the file has {}", bytes.len()));
    }
    Ok(())
}

/// `%XX`-decoding of a relative URI, as the `gltf` crate does it (which
/// panics when the result is not UTF-8).
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && let (Some(h), Some(l)) = (b.get(i + 1).and_then(|&c| hex(c)), b.get(i + 2).and_then(|&c| hex(c)))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Checks what the `gltf` crate's importers trust: relative URIs decode to
/// UTF-8, and every buffer view lies inside its buffer's declared length.
fn check_uris_and_views(document: &Document) -> Result<(), String> {
    let uris = document
        .buffers()
        .filter_map(|b| match b.source() {
            ::gltf::buffer::Source::Uri(uri) => Some(uri),
            ::gltf::buffer::Source::Bin => None,
        })
        .chain(document.images().filter_map(|i| match image_source(document, &i) {
            Ok(::gltf::image::Source::Uri { uri, .. }) => Some(uri),
            _ => None,
        }));
    for uri in uris {
        if !uri.contains(':') && percent_decode(uri).is_none() {
            return Err(format!("URI '{uri}' is not valid percent-encoded UTF-8"));
        }
    }
    for view in document.views() {
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > view.buffer().length()) {
            return Err(format!(
                "buffer view {} (bytes {}..+{}) lies outside buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                view.buffer().length()
            ));
        }
    }
    Ok(())
}

/// Every external buffer and image the file names is a regular file (or
/// missing: that is reported where it is read). The `gltf` crate reads a
/// URI's file to its end, so `file:///dev/zero` would never finish.
fn check_external_files(document: &Document, base: &Path) -> Result<(), String> {
    let buffers = document.buffers().filter_map(|b| match b.source() {
        ::gltf::buffer::Source::Uri(uri) => Some(uri),
        ::gltf::buffer::Source::Bin => None,
    });
    let images = document.images().filter_map(|i| match image_source(document, &i) {
        Ok(::gltf::image::Source::Uri { uri, .. }) => Some(uri),
        _ => None,
    });
    for uri in buffers.chain(images).filter(|uri| !uri.starts_with("data:")) {
        let file = uri_path(base, uri);
        if fs::metadata(&file).is_ok_and(|m| !m.is_file()) {
            return Err(format!("URI '{uri}' names {}, which is not a regular file", file.display()));
        }
    }
    Ok(())
}

/// `image.source()`, which the `gltf` crate unwraps unchecked (its validation
/// checks neither): an image needs a `uri` or a `bufferView`, and a
/// `bufferView` needs a `mimeType`.
fn image_source<'a>(document: &Document, image: &::gltf::Image<'a>) -> Result<::gltf::image::Source<'a>, String> {
    let json = &document.as_json().images[image.index()];
    match (&json.uri, &json.buffer_view, &json.mime_type) {
        (_, Some(_), None) => Err("it has a bufferView but no mimeType".into()),
        (None, None, _) => Err("it has neither a uri nor a bufferView".into()),
        _ => Ok(image.source()),
    }
}

/// Reads every buffer (data URI, external file or GLB chunk). A missing
/// external file is an [`SceneError::Io`] naming that file.
fn load_buffers(
    document: &Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
    path: &Path,
) -> Result<Vec<::gltf::buffer::Data>, SceneError> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let data = ::gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), &mut blob);
        let data = match data {
            Ok(data) => data,
            Err(::gltf::Error::Io(source)) => {
                let file = match buffer.source() {
                    ::gltf::buffer::Source::Uri(uri) => uri_path(base, uri),
                    ::gltf::buffer::Source::Bin => path.to_path_buf(),
                };
                return Err(SceneError::Io { path: file, source });
            }
            Err(e) => return Err(parse_error(path, format!("buffer {}: {e}", buffer.index()))),
        };
        if data.len() < buffer.length() {
            return Err(parse_error(
                path,
                format!("buffer {} has {} bytes, the file declares {}", buffer.index(), data.len(), buffer.length()),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// The file a relative or `file:` URI names.
fn uri_path(base: &Path, uri: &str) -> PathBuf {
    if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        PathBuf::from(rest)
    } else {
        base.join(percent_decode(uri).unwrap_or_else(|| uri.to_string()))
    }
}

/// A glTF material as the scene will use it; `textured` is false when it has
/// no usable base colour texture (each object then gets its own checker).
#[derive(Clone)]
struct MaterialTemplate {
    material: Material,
    /// Index in `scene.materials` when shared (textured) and already pushed.
    shared: Option<usize>,
    textured: bool,
    /// The `KHR_texture_transform` its textures are sampled with (baked into
    /// the UV0 of the primitives that use it); `None` for the identity.
    uv_transform: Option<UvTransform>,
}

/// `KHR_texture_transform`: `uv' = offset + rotation * (scale * uv)`, the
/// extension's `translation * rotation * scale`, with its rotation (radians)
/// turning UV +u towards -v: the ratified text's example (offset (0, 1),
/// rotation pi/2, scale 0.5 takes the image's lower-left quarter) holds
/// with this sign.
#[derive(Clone, Copy, Debug, PartialEq)]
struct UvTransform {
    offset: Vec2,
    rotation: f32,
    scale: Vec2,
}

impl UvTransform {
    const IDENTITY: Self = Self { offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::ONE };

    /// Reads the extension's JSON object; also returns its `texCoord`.
    fn parse(json: &serde_json::Value) -> Result<(Self, Option<u32>), String> {
        let pair = |key: &str, default: Vec2| match json.get(key) {
            None => Ok(default),
            Some(v) => match v.as_array().map(|a| a.iter().map(serde_json::Value::as_f64).collect::<Vec<_>>()) {
                Some(a) if a.len() == 2 && a.iter().all(Option::is_some) => {
                    Ok(Vec2::new(a[0].unwrap_or_default() as f32, a[1].unwrap_or_default() as f32))
                }
                _ => Err(format!("'{key}' is not two numbers")),
            },
        };
        let rotation = match json.get("rotation") {
            None => 0.0,
            Some(v) => v.as_f64().ok_or("'rotation' is not a number")? as f32,
        };
        let tex_coord = match json.get("texCoord") {
            None => None,
            Some(v) => Some(v.as_u64().and_then(|k| u32::try_from(k).ok()).ok_or("'texCoord' is not a set index")?),
        };
        let t = Self { offset: pair("offset", Vec2::ZERO)?, rotation, scale: pair("scale", Vec2::ONE)? };
        if !(t.offset.is_finite() && t.rotation.is_finite() && t.scale.is_finite()) {
            return Err("it is not finite".into());
        }
        Ok((t, tex_coord))
    }

    /// The transformed texture coordinate.
    fn apply(&self, uv: Vec2) -> Vec2 {
        let s = uv * self.scale;
        let (sin, cos) = self.rotation.sin_cos();
        self.offset + Vec2::new(cos * s.x + sin * s.y, cos * s.y - sin * s.x)
    }
}

/// A material's texture reference as the file gives it.
struct TextureSlot<'t> {
    texture: ::gltf::Texture<'t>,
    tex_coord: u32,
    /// Its `KHR_texture_transform` object, unparsed: the `gltf` crate reads
    /// the extension on three of the five slots only (not on the normal and
    /// occlusion textures), so all five go through [`UvTransform::parse`].
    transform: Option<serde_json::Value>,
}

struct Builder<'a> {
    path: &'a Path,
    base: &'a Path,
    document: &'a Document,
    buffers: &'a [::gltf::buffer::Data],
    scene: Scene,
    /// (glTF mesh, primitive) -> scene mesh (`None`: skipped).
    meshes: HashMap<(usize, usize), Option<usize>>,
    /// glTF material index (`None`: the default material) -> template.
    materials: HashMap<Option<usize>, MaterialTemplate>,
    /// glTF image -> scene texture (`None`: failed, warned).
    images: HashMap<usize, Option<usize>>,
    checkers: HashMap<usize, usize>,
}

impl Builder<'_> {
    fn invalid(&self, problem: String) -> SceneError {
        invalid(self.path, problem)
    }

    /// Walks the scene's node trees, parents before children.
    fn walk(&mut self) -> Result<(), SceneError> {
        let document = self.document;
        let scene = document.default_scene().or_else(|| document.scenes().next());
        let roots: Vec<::gltf::Node> = match scene {
            Some(s) => s.nodes().collect(),
            None => {
                let mut is_child = vec![false; document.nodes().len()];
                for node in document.nodes() {
                    for child in node.children() {
                        is_child[child.index()] = true;
                    }
                }
                document.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        let mut visited = vec![false; document.nodes().len()];
        let mut stack: Vec<(::gltf::Node, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            if std::mem::replace(&mut visited[node.index()], true) {
                return Err(self.invalid(format!(
                    "node {} is reached twice: the node hierarchy has a cycle or a node with two parents",
                    node.index()
                )));
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            if !world.is_finite() {
                return Err(self.invalid(format!("node {} has a non-finite transform", node.index())));
            }
            self.node(&node, world)?;
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok(())
    }

    fn node(&mut self, node: &::gltf::Node, world: Mat4) -> Result<(), SceneError> {
        let node_name = node.name().map_or_else(|| format!("node{}", node.index()), str::to_string);
        let position = world.w_axis.truncate();
        let forward = world.transform_vector3(Vec3::NEG_Z).try_normalize();
        if let Some(mesh) = node.mesh() {
            let primitives = mesh.primitives().len();
            for primitive in mesh.primitives() {
                let uv_transform = self.template(&primitive.material()).uv_transform;
                let Some(mesh_index) = self.mesh(&mesh, &primitive, uv_transform)? else { continue };
                let name =
                    if primitives > 1 { format!("{node_name}/{}", primitive.index()) } else { node_name.clone() };
                let object_index = self.scene.objects.len();
                let material = self.material(primitive.material(), object_index, &name);
                self.scene.objects.push(Object {
                    name,
                    mesh: mesh_index,
                    material,
                    transform: world,
                    forward_only: false,
                });
            }
        }
        let light = node.light().and_then(|l| {
            if forward.is_none() {
                tracing::warn!("{}: light node '{node_name}' has a zero-scale transform; skipped", self.path.display());
            }
            Some(l).zip(forward)
        });
        if let Some((light, direction)) = light {
            let intensity = light.intensity();
            let mut l = Light {
                kind: LightKind::Point,
                color: Vec3::from(light.color()),
                intensity,
                position,
                direction,
                radius: light.range().unwrap_or(10.0 * intensity.max(0.0).sqrt()),
                cos_inner: 1.0,
                cos_outer: 0.0,
                casts_shadows: false,
            };
            match light.kind() {
                ::gltf::khr_lights_punctual::Kind::Directional => l.kind = LightKind::Directional,
                ::gltf::khr_lights_punctual::Kind::Point => {}
                ::gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                    l.kind = LightKind::Spot;
                    l.cos_inner = inner_cone_angle.cos();
                    l.cos_outer = outer_cone_angle.cos();
                }
            }
            if !(l.color.is_finite() && l.intensity.is_finite() && l.radius.is_finite()) {
                return Err(self.invalid(format!("light '{node_name}' has non-finite parameters")));
            }
            self.scene.lights.push(l);
        }
        if let Some(camera) = node.camera() {
            match camera.projection() {
                ::gltf::camera::Projection::Perspective(p) => {
                    let up = world.transform_vector3(Vec3::Y).try_normalize();
                    let (Some(forward), Some(up)) = (forward, up) else {
                        tracing::warn!(
                            "{}: camera node '{node_name}' has a zero-scale transform; skipped",
                            self.path.display()
                        );
                        return Ok(());
                    };
                    let far = p.zfar().unwrap_or(1000.0);
                    let (fov_y, near) = (p.yfov(), p.znear());
                    if !(fov_y > 0.0 && fov_y < std::f32::consts::PI && near > 0.0 && far > near) {
                        return Err(self.invalid(format!(
                            "camera '{node_name}': yfov {fov_y}, znear {near}, zfar {far} do not make a projection"
                        )));
                    }
                    self.scene.cameras.push(Camera { position, forward, up, fov_y, near, far });
                }
                ::gltf::camera::Projection::Orthographic(_) => {
                    tracing::warn!("{}: camera '{node_name}' is orthographic; skipped", self.path.display());
                }
            }
        }
        Ok(())
    }

    /// The scene mesh of a primitive, built on first use (its UV0 through
    /// its material's `uv_transform`); `None` when the primitive is skipped
    /// (not triangles, no positions).
    fn mesh(
        &mut self,
        mesh: &::gltf::Mesh,
        primitive: &::gltf::Primitive,
        uv_transform: Option<UvTransform>,
    ) -> Result<Option<usize>, SceneError> {
        let key = (mesh.index(), primitive.index());
        if let Some(&known) = self.meshes.get(&key) {
            return Ok(known);
        }
        let mut name = mesh.name().map_or_else(|| format!("mesh{}", mesh.index()), str::to_string);
        if mesh.primitives().len() > 1 {
            name = format!("{name}/{}", primitive.index());
        }
        let built = self.read_primitive(&name, primitive, uv_transform)?;
        let index = built.map(|m| {
            self.scene.meshes.push(m);
            self.scene.meshes.len() - 1
        });
        self.meshes.insert(key, index);
        Ok(index)
    }

    fn read_primitive(
        &self,
        name: &str,
        primitive: &::gltf::Primitive,
        uv_transform: Option<UvTransform>,
    ) -> Result<Option<Mesh>, SceneError> {
        let mode = primitive.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            tracing::warn!("{}: mesh '{name}': {mode:?} primitive skipped (not triangles)", self.path.display());
            return Ok(None);
        }
        let Some(positions) = primitive.get(&Semantic::Positions) else {
            tracing::warn!("{}: mesh '{name}': primitive without POSITION skipped", self.path.display());
            return Ok(None);
        };
        let err = |what: &str, e: String| self.invalid(format!("mesh '{name}': {what}: {e}"));
        let positions = self.read_floats::<3>(&positions).map_err(|e| err("POSITION", e))?;
        let n = positions.len();
        let attribute = |semantic: Semantic, what: &str| match primitive.get(&semantic) {
            Some(a) if a.count() != n => Err(err(what, format!("{} entries for {n} vertices", a.count()))),
            other => Ok(other),
        };
        let normals = match attribute(Semantic::Normals, "NORMAL")? {
            Some(a) => self.read_floats::<3>(&a).map_err(|e| err("NORMAL", e))?,
            None => Vec::new(),
        };
        let tangents = match attribute(Semantic::Tangents, "TANGENT")? {
            Some(a) => self.read_floats::<4>(&a).map_err(|e| err("TANGENT", e))?,
            None => Vec::new(),
        };
        let uv0 = match attribute(Semantic::TexCoords(0), "TEXCOORD_0")? {
            Some(a) => self.read_floats::<2>(&a).map_err(|e| err("TEXCOORD_0", e))?,
            None => {
                tracing::warn!("{}: mesh '{name}': no TEXCOORD_0; UVs set to zero", self.path.display());
                Vec::new()
            }
        };
        let uv1 = match attribute(Semantic::TexCoords(1), "TEXCOORD_1")? {
            Some(a) => Some(self.read_floats::<2>(&a).map_err(|e| err("TEXCOORD_1", e))?),
            None => None,
        };
        let indices = match primitive.indices() {
            Some(a) => self.read_indices(&a).map_err(|e| err("indices", e))?,
            None => (0..u32::try_from(n).map_err(|_| err("POSITION", "too many vertices".into()))?).collect(),
        };
        let indices = triangle_list(mode, indices);
        let vec3 = |v: [f32; 3]| Vec3::from(v);
        let mut mesh = Mesh {
            name: name.to_string(),
            positions: positions.into_iter().map(vec3).collect(),
            normals: normals.into_iter().map(vec3).collect(),
            tangents: tangents.into_iter().map(Vec4::from).collect(),
            uv0: uv0.into_iter().map(Vec2::from).collect(),
            uv1: uv1.map(|uv| uv.into_iter().map(Vec2::from).collect()),
            indices,
        };
        check_indices(&mesh).map_err(|problem| self.invalid(problem))?;
        if let Some(t) = uv_transform
            && !mesh.uv0.is_empty()
        {
            // The file's layout stays the chart module's first choice.
            mesh.uv1.get_or_insert_with(|| mesh.uv0.clone());
            mesh.uv0.iter_mut().for_each(|uv| *uv = t.apply(*uv));
        }
        if let Some(k) = mesh.uv0.iter().chain(mesh.uv1.iter().flatten()).position(|uv| !uv.is_finite()) {
            return Err(self.invalid(format!("mesh '{name}': texture coordinate {k} is not finite")));
        }
        if !mesh.normals.is_empty() {
            match mesh.normals.iter().map(|n| n.try_normalize()).collect::<Option<Vec<_>>>() {
                Some(unit) => mesh.normals = unit,
                None => {
                    tracing::warn!(
                        "{}: mesh '{name}': zero or non-finite normals; normals generated",
                        self.path.display()
                    );
                    mesh.normals.clear();
                }
            }
        }
        if mesh.normals.is_empty() || mesh.tangents.iter().any(|t| !t.is_finite()) {
            // Tangents only make sense with the normals they were made for.
            mesh.tangents.clear();
        }
        mesh.generate_missing_attributes();
        mesh.validate().map_err(|problem| self.invalid(problem))?;
        Ok(Some(mesh))
    }

    /// The scene material of one object: shared for textured glTF materials,
    /// per object (with its checker) otherwise.
    fn material(&mut self, material: ::gltf::Material, object_index: usize, object_name: &str) -> usize {
        let key = material.index();
        let template = self.template(&material);
        if template.textured {
            if let Some(shared) = template.shared {
                return shared;
            }
            self.scene.materials.push(template.material);
            let index = self.scene.materials.len() - 1;
            if let Some(t) = self.materials.get_mut(&key) {
                t.shared = Some(index);
            }
            return index;
        }
        let mut m = template.material;
        m.base_color_texture = Some(checker_texture(&mut self.scene, &mut self.checkers, object_index, object_name));
        self.scene.materials.push(m);
        self.scene.materials.len() - 1
    }

    /// The template of a glTF material, read on first use.
    fn template(&mut self, material: &::gltf::Material) -> MaterialTemplate {
        if let Some(t) = self.materials.get(&material.index()) {
            return t.clone();
        }
        let t = self.material_template(material);
        self.materials.insert(material.index(), t.clone());
        t
    }

    fn material_template(&mut self, material: &::gltf::Material) -> MaterialTemplate {
        let pbr = material.pbr_metallic_roughness();
        let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
        let name = material.name().map_or_else(
            || material.index().map_or_else(|| "default".to_string(), |i| format!("material{i}")),
            str::to_string,
        );
        let emissive_strength = material.emissive_strength().unwrap_or(1.0);
        let mut m = Material {
            name: name.clone(),
            base_color: Vec4::from(pbr.base_color_factor()),
            base_color_texture: None,
            normal_texture: None,
            metallic: pbr.metallic_factor().clamp(0.0, 1.0),
            roughness,
            emissive: Vec3::from(material.emissive_factor()) * emissive_strength,
            shininess: Material::shininess_from_roughness(roughness),
            ..Default::default()
        };
        if !m.emissive.is_finite() || m.emissive.min_element() < 0.0 {
            tracing::warn!(
                "{}: material '{name}': emission {} (factor times strength) is not finite and non-negative; none used",
                self.path.display(),
                m.emissive
            );
            m.emissive = Vec3::ZERO;
        }
        // glTF 2.0, `material.doubleSided`: "When this value is false,
        // back-face culling is enabled. When this value is true, back-face
        // culling is disabled and double-sided lighting is enabled." It
        // defaults to false, so is the default material.
        m.double_sided = material.double_sided();
        m.blend = material.alpha_mode() == AlphaMode::Blend;
        m.alpha_cutoff = match material.alpha_mode() {
            AlphaMode::Opaque | AlphaMode::Blend => None,
            AlphaMode::Mask => Some(material.alpha_cutoff().unwrap_or(0.5)),
        }
        // A cutoff of 0 or less cuts nothing: the material is opaque.
        .filter(|&c| c > 0.0);
        const TRANSFORM: &str = "KHR_texture_transform";
        fn slot<'t>(i: ::gltf::texture::Info<'t>) -> TextureSlot<'t> {
            let transform = i.extension_value(TRANSFORM).cloned();
            TextureSlot { texture: i.texture(), tex_coord: i.tex_coord(), transform }
        }
        // The loaded textures' transforms, in the order the first one wins.
        let mut transforms = Vec::new();
        let base = pbr.base_color_texture().map(slot);
        m.base_color_texture = base.and_then(|s| self.texture(&name, "base colour", s, &mut transforms));
        // Textures that multiply a zero factor change nothing: not loaded.
        if m.metallic > 0.0 || m.roughness > 0.0 {
            let metal_rough = pbr.metallic_roughness_texture().map(slot);
            m.metallic_roughness_texture =
                metal_rough.and_then(|s| self.texture(&name, "metallic-roughness", s, &mut transforms));
        }
        if m.emissive != Vec3::ZERO {
            let emissive = material.emissive_texture().map(slot);
            m.emissive_texture = emissive.and_then(|s| self.texture(&name, "emissive", s, &mut transforms));
        }
        if let Some(normal) = material.normal_texture() {
            let transform = normal.extension_value(TRANSFORM).cloned();
            let s = TextureSlot { texture: normal.texture(), tex_coord: normal.tex_coord(), transform };
            m.normal_texture = self.texture(&name, "normal", s, &mut transforms);
        }
        if let Some(occlusion) = material.occlusion_texture()
            && occlusion.strength() > 0.0
        {
            let transform = occlusion.extension_value(TRANSFORM).cloned();
            let s = TextureSlot { texture: occlusion.texture(), tex_coord: occlusion.tex_coord(), transform };
            m.occlusion_texture = self.texture(&name, "occlusion", s, &mut transforms);
            m.occlusion_strength = occlusion.strength().min(1.0);
        }
        let uv_transform = transforms.first().map(|&(_, t)| t);
        let differing = transforms.iter().find(|(_, t)| Some(*t) != uv_transform);
        if let (Some(&(first, _)), Some(&(other, _))) = (transforms.first(), differing) {
            tracing::warn!(
                "{}: material '{name}': the {other} texture's KHR_texture_transform differs from the {first} \
                 texture's; every texture of the material is sampled with the {first} texture's",
                self.path.display(),
            );
        }
        let textured = m.base_color_texture.is_some();
        let uv_transform = uv_transform.filter(|t| *t != UvTransform::IDENTITY);
        MaterialTemplate { material: m, shared: None, textured, uv_transform }
    }

    /// The scene texture of a material's texture slot (`what`), warning
    /// when it uses another UV set than TEXCOORD_0 (it is sampled with that)
    /// or a malformed transform (ignored); a loaded texture's transform
    /// (the identity without one) joins `transforms`.
    fn texture(
        &mut self,
        material: &str,
        what: &'static str,
        slot: TextureSlot,
        transforms: &mut Vec<(&'static str, UvTransform)>,
    ) -> Option<usize> {
        let path = self.path.display();
        let (transform, tex_coord) = match slot.transform.as_ref().map(UvTransform::parse) {
            None => (UvTransform::IDENTITY, slot.tex_coord),
            Some(Ok((t, tex_coord))) => (t, tex_coord.unwrap_or(slot.tex_coord)),
            Some(Err(e)) => {
                tracing::warn!("{path}: material '{material}': {what} texture's KHR_texture_transform ignored: {e}");
                (UvTransform::IDENTITY, slot.tex_coord)
            }
        };
        if tex_coord != 0 {
            tracing::warn!(
                "{path}: material '{material}': {what} texture uses TEXCOORD_{tex_coord}; sampled with TEXCOORD_0"
            );
        }
        let texture = self.image(slot.texture.source())?;
        transforms.push((what, transform));
        Some(texture)
    }

    /// Decodes an image once into an RGBA8 texture; `None` (warned) when it
    /// is missing or cannot be decoded.
    fn image(&mut self, image: ::gltf::Image) -> Option<usize> {
        if let Some(&known) = self.images.get(&image.index()) {
            return known;
        }
        let source = image_source(self.document, &image);
        let name = match source {
            Ok(::gltf::image::Source::Uri { uri, .. }) if !uri.starts_with("data:") => uri.to_string(),
            _ => image.name().map_or_else(|| format!("image{}", image.index()), str::to_string),
        };
        let decoded = source.and_then(|source| {
            ::gltf::image::Data::from_source(source, Some(self.base), self.buffers)
                .map_err(|e| e.to_string())
                .and_then(|data| to_rgba8(&data))
        });
        let texture = match decoded {
            Ok(rgba8) => {
                let (width, height) = rgba8.1;
                self.scene.textures.push(Texture { name, width, height, rgba8: rgba8.0 });
                Some(self.scene.textures.len() - 1)
            }
            Err(e) => {
                tracing::warn!("{}: image '{name}' cannot be loaded ({e}); ignored", self.path.display());
                None
            }
        };
        self.images.insert(image.index(), texture);
        texture
    }

    /// Reads a float vector attribute (any component type; integer types are
    /// normalised when the accessor says so, per KHR_mesh_quantization).
    fn read_floats<const N: usize>(&self, accessor: &Accessor) -> Result<Vec<[f32; N]>, String> {
        let dims = accessor.dimensions();
        if dims.multiplicity() != N || matches!(dims, Dimensions::Mat2 | Dimensions::Mat3 | Dimensions::Mat4) {
            return Err(format!("accessor {} is {dims:?}, expected {N} components", accessor.index()));
        }
        let ty = accessor.data_type();
        let normalized = accessor.normalized();
        if ty == DataType::U32 && normalized {
            return Err(format!("accessor {}: normalised unsigned int is not allowed", accessor.index()));
        }
        let bytes = accessor_bytes(accessor, self.buffers)?;
        let size = ty.size();
        let component = |b: &[u8]| -> f32 {
            match (ty, normalized) {
                (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                (DataType::U8, false) => b[0] as f32,
                (DataType::U8, true) => b[0] as f32 / 255.0,
                (DataType::I8, false) => b[0] as i8 as f32,
                (DataType::I8, true) => (b[0] as i8 as f32 / 127.0).max(-1.0),
                (DataType::U16, false) => u16::from_le_bytes([b[0], b[1]]) as f32,
                (DataType::U16, true) => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
                (DataType::I16, false) => i16::from_le_bytes([b[0], b[1]]) as f32,
                (DataType::I16, true) => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
                (DataType::U32, _) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            }
        };
        Ok(bytes
            .chunks_exact(N * size)
            .map(|element| std::array::from_fn(|k| component(&element[k * size..(k + 1) * size])))
            .collect())
    }

    fn read_indices(&self, accessor: &Accessor) -> Result<Vec<u32>, String> {
        if accessor.dimensions() != Dimensions::Scalar {
            return Err(format!("accessor {} is {:?}, expected scalars", accessor.index(), accessor.dimensions()));
        }
        let ty = accessor.data_type();
        if !matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) {
            return Err(format!("accessor {}: {ty:?} indices (expected unsigned integers)", accessor.index()));
        }
        let bytes = accessor_bytes(accessor, self.buffers)?;
        Ok(bytes
            .chunks_exact(ty.size())
            .map(|b| match ty {
                DataType::U8 => b[0] as u32,
                DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
            .collect())
    }
}

/// The triangle list of a triangles, strip or fan primitive (glTF's winding rules).
fn triangle_list(mode: Mode, indices: Vec<u32>) -> Vec<u32> {
    let n = indices.len();
    match mode {
        Mode::TriangleStrip => (2..n)
            .flat_map(|i| {
                let [a, b, c] = [indices[i - 2], indices[i - 1], indices[i]];
                if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
            })
            .collect(),
        Mode::TriangleFan => (2..n).flat_map(|i| [indices[0], indices[i - 1], indices[i]]).collect(),
        _ => indices,
    }
}

/// The bytes of a buffer view, checked against the loaded buffer.
fn view_bytes<'b>(view: &::gltf::buffer::View, buffers: &'b [::gltf::buffer::Data]) -> Result<&'b [u8], String> {
    let data = buffers.get(view.buffer().index()).ok_or_else(|| format!("buffer view {}: no buffer", view.index()))?;
    view.offset()
        .checked_add(view.length())
        .and_then(|end| data.get(view.offset()..end))
        .ok_or_else(|| format!("buffer view {} lies outside its buffer", view.index()))
}

/// `count` elements of `element` bytes each, `stride` apart from `offset`
/// in `bytes`, copied tightly packed; every range checked.
fn gather(bytes: &[u8], offset: usize, stride: usize, element: usize, count: usize) -> Option<Vec<u8>> {
    if count == 0 {
        return Some(Vec::new());
    }
    let end = stride.checked_mul(count - 1)?.checked_add(element)?.checked_add(offset)?;
    if end > bytes.len() {
        return None;
    }
    let mut out = Vec::with_capacity(element * count);
    for i in 0..count {
        let start = offset + i * stride;
        out.extend_from_slice(&bytes[start..start + element]);
    }
    Some(out)
}

/// An accessor's elements, tightly packed, with sparse substitutions applied.
fn accessor_bytes(accessor: &Accessor, buffers: &[::gltf::buffer::Data]) -> Result<Vec<u8>, String> {
    let index = accessor.index();
    let element = accessor.data_type().size() * accessor.dimensions().multiplicity();
    let count = accessor.count();
    if count.checked_mul(element).is_none_or(|bytes| bytes > MAX_ACCESSOR_BYTES) {
        return Err(format!("accessor {index}: count {count} is too large"));
    }
    let mut out = match accessor.view() {
        Some(view) => {
            let stride = view.stride().unwrap_or(element);
            if stride < element {
                return Err(format!("accessor {index}: byte stride {stride} is less than the element size {element}"));
            }
            gather(view_bytes(&view, buffers)?, accessor.offset(), stride, element, count).ok_or_else(|| {
                format!("accessor {index}: {count} elements do not fit in buffer view {}", view.index())
            })?
        }
        // Zeros but for the sparse values: not backed by the file's bytes,
        // so its size is the file's word alone.
        None if count > MAX_UNBACKED_ACCESSOR_ELEMENTS => {
            return Err(format!(
                "accessor {index}: {count} elements without a buffer view (zeros but for the sparse values); \
                 at most {MAX_UNBACKED_ACCESSOR_ELEMENTS} are accepted"
            ));
        }
        None => vec![0; element * count],
    };
    if let Some(sparse) = accessor.sparse() {
        let k = sparse.count();
        let indices = sparse.indices();
        let index_size = indices.index_type().size();
        let raw = gather(view_bytes(&indices.view(), buffers)?, indices.offset(), index_size, index_size, k)
            .ok_or_else(|| format!("accessor {index}: sparse indices do not fit in their buffer view"))?;
        let values = sparse.values();
        let values = gather(view_bytes(&values.view(), buffers)?, values.offset(), element, element, k)
            .ok_or_else(|| format!("accessor {index}: sparse values do not fit in their buffer view"))?;
        for (i, value) in raw.chunks_exact(index_size).zip(values.chunks_exact(element)) {
            let target = match index_size {
                1 => i[0] as usize,
                2 => u16::from_le_bytes([i[0], i[1]]) as usize,
                _ => u32::from_le_bytes([i[0], i[1], i[2], i[3]]) as usize,
            };
            if target >= count {
                return Err(format!("accessor {index}: sparse index {target} is out of range ({count} elements)"));
            }
            out[target * element..(target + 1) * element].copy_from_slice(value);
        }
    }
    Ok(out)
}

/// Converts a decoded glTF image to RGBA8 (sRGB-encoded as stored).
fn to_rgba8(data: &::gltf::image::Data) -> Result<(Vec<u8>, (u32, u32)), String> {
    use ::gltf::image::Format as F;
    let (channels, bytes_per_channel) = match data.format {
        F::R8 => (1, 1),
        F::R8G8 => (2, 1),
        F::R8G8B8 => (3, 1),
        F::R8G8B8A8 => (4, 1),
        F::R16 => (1, 2),
        F::R16G16 => (2, 2),
        F::R16G16B16 => (3, 2),
        F::R16G16B16A16 => (4, 2),
        F::R32G32B32FLOAT => (3, 4),
        F::R32G32B32A32FLOAT => (4, 4),
    };
    let pixels = data.width as usize * data.height as usize;
    if data.pixels.len() != pixels * channels * bytes_per_channel {
        return Err(format!(
            "{:?} image of {}x{} has {} bytes of pixels",
            data.format,
            data.width,
            data.height,
            data.pixels.len()
        ));
    }
    // Channel `k` of a pixel as a byte.
    let channel = |c: &[u8], k: usize| -> u8 {
        match bytes_per_channel {
            1 => c[0],
            // 16-bit: the nearest 8-bit value.
            2 => ((u16::from_le_bytes([c[0], c[1]]) as u32 * 255 + 32767) / 65535) as u8,
            // Float images are linear: encode colour to sRGB; alpha stays linear.
            _ => {
                let v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                if k < 3 { linear_to_srgb8(v) } else { (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8 }
            }
        }
    };
    let mut rgba8 = Vec::with_capacity(pixels * 4);
    for px in data.pixels.chunks_exact(channels * bytes_per_channel) {
        let mut c = [0u8; 4];
        for (k, bytes) in px.chunks_exact(bytes_per_channel).enumerate() {
            // Grey (+ alpha) images: the grey value is colour channel 0, alpha is last.
            let k_meaning = if channels <= 2 && k == 1 { 3 } else { k };
            c[k] = channel(bytes, k_meaning);
        }
        rgba8.extend_from_slice(&match channels {
            1 => [c[0], c[0], c[0], 255],
            2 => [c[0], c[0], c[0], c[1]],
            3 => [c[0], c[1], c[2], 255],
            _ => c,
        });
    }
    Ok((rgba8, (data.width, data.height)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{Value, json};

    fn base64(bytes: &[u8]) -> String {
        const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in bytes.chunks(3) {
            let byte = |k: usize| *c.get(k).unwrap_or(&0) as u32;
            let n = (byte(0) << 16) | (byte(1) << 8) | byte(2);
            for k in 0..4 {
                s.push(if k <= c.len() { A[(n >> (18 - 6 * k)) as usize & 63] as char } else { '=' });
            }
        }
        s
    }

    /// Three positions (36 bytes), three u16 indices (6 bytes), 2 bytes of padding.
    fn triangle_buffer(indices: [u16; 3]) -> Vec<u8> {
        let mut b = Vec::new();
        for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in p {
                b.extend(c.to_le_bytes());
            }
        }
        for i in indices {
            b.extend(i.to_le_bytes());
        }
        b.extend([0, 0]);
        b
    }

    fn data_uri(bytes: &[u8]) -> Value {
        json!({ "byteLength": bytes.len(), "uri": format!("data:application/octet-stream;base64,{}", base64(bytes)) })
    }

    /// One triangle instanced by two nodes, a point light on a rotated node,
    /// a spot light on a child node, a rotated camera.
    fn document(buffer: Value) -> Value {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        json!({
            "asset": { "version": "2.0" },
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": { "KHR_lights_punctual": { "lights": [
                { "type": "point", "color": [1.0, 0.5, 0.25], "intensity": 100.0 },
                { "type": "spot", "intensity": 5.0, "range": 7.0,
                  "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 } }
            ]}},
            "buffers": [buffer],
            "bufferViews": [
                { "buffer": 0, "byteOffset": 0, "byteLength": 36 },
                { "buffer": 0, "byteOffset": 36, "byteLength": 6 }
            ],
            "accessors": [
                { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] },
                { "bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR" }
            ],
            "meshes": [{ "name": "tri", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
            "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }],
            "nodes": [
                { "name": "a", "mesh": 0, "translation": [1.0, 2.0, 3.0], "children": [2] },
                { "name": "sun", "translation": [0.0, 5.0, 0.0], "rotation": [-s, 0.0, 0.0, s],
                  "extensions": { "KHR_lights_punctual": { "light": 0 } } },
                { "name": "spot", "translation": [0.0, 0.0, 1.0],
                  "extensions": { "KHR_lights_punctual": { "light": 1 } } },
                { "name": "eye", "camera": 0, "translation": [0.0, 1.0, 10.0], "rotation": [0.0, s, 0.0, s] },
                { "name": "b", "mesh": 0, "scale": [2.0, 2.0, 2.0] }
            ],
            "scenes": [{ "nodes": [0, 1, 3, 4] }],
            "scene": 0
        })
    }

    fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let path = dir.join(name);
        fs::write(&path, bytes).unwrap();
        path
    }

    fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
        let mut j = serde_json::to_vec(json).unwrap();
        while !j.len().is_multiple_of(4) {
            j.push(b' ');
        }
        let mut b = bin.to_vec();
        while !b.len().is_multiple_of(4) {
            b.push(0);
        }
        let total = 12 + 8 + j.len() + 8 + b.len();
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((j.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(j);
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(b);
        out
    }

    fn check_scene(scene: &Scene) {
        assert_eq!(scene.meshes.len(), 1, "the instanced primitive shares one mesh");
        assert_eq!(scene.objects.len(), 2);
        assert_eq!(scene.triangle_count(), 2);
        let a = &scene.objects[0];
        assert_eq!(a.name, "a");
        assert_eq!(a.transform, Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)));
        assert_eq!(scene.objects[1].transform, Mat4::from_scale(Vec3::splat(2.0)));
        let mesh = &scene.meshes[a.mesh];
        assert_eq!(mesh.indices, [0, 1, 2]);
        assert!(mesh.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)), "generated normals");
        assert_eq!(mesh.uv0.len(), 3);
        // No material: each object gets its own checker.
        let t: Vec<_> = scene.objects.iter().map(|o| scene.materials[o.material].base_color_texture).collect();
        assert!(t[0].is_some() && t[1].is_some() && t[0] != t[1]);

        assert_eq!(scene.lights.len(), 2);
        // Depth-first order: the spot (child of the first root) comes first.
        let (spot, point) = (&scene.lights[0], &scene.lights[1]);
        assert_eq!(point.kind, LightKind::Point);
        assert_eq!(point.color, Vec3::new(1.0, 0.5, 0.25));
        assert_eq!(point.intensity, 100.0);
        assert!(point.position.abs_diff_eq(Vec3::new(0.0, 5.0, 0.0), 1e-6));
        assert!(point.direction.abs_diff_eq(Vec3::NEG_Y, 1e-6), "{}", point.direction);
        assert_eq!(point.radius, 100.0, "10 * sqrt(intensity) without a range");
        assert_eq!(spot.kind, LightKind::Spot);
        assert!(spot.position.abs_diff_eq(Vec3::new(1.0, 2.0, 4.0), 1e-6), "child of node a: {}", spot.position);
        assert!(spot.direction.abs_diff_eq(Vec3::NEG_Z, 1e-6));
        assert_eq!(spot.radius, 7.0);
        assert!((spot.cos_inner - 0.2f32.cos()).abs() < 1e-6 && (spot.cos_outer - 0.5f32.cos()).abs() < 1e-6);

        assert_eq!(scene.cameras.len(), 1);
        let cam = &scene.cameras[0];
        assert!(cam.position.abs_diff_eq(Vec3::new(0.0, 1.0, 10.0), 1e-6));
        assert!(cam.forward.abs_diff_eq(Vec3::NEG_X, 1e-6), "{}", cam.forward);
        assert!(cam.up.abs_diff_eq(Vec3::Y, 1e-6));
        assert_eq!((cam.fov_y, cam.near, cam.far), (0.8, 0.1, 1000.0));
    }

    #[test]
    fn gltf_with_data_uri() {
        let dir = tempfile::tempdir().unwrap();
        let doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        let scene = load(&write(dir.path(), "tri.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        assert_eq!(scene.name, "tri");
        check_scene(&scene);
    }

    #[test]
    fn glb_with_bin_chunk() {
        let dir = tempfile::tempdir().unwrap();
        let doc = document(json!({ "byteLength": 44 }));
        let scene = load(&write(dir.path(), "tri.glb", glb(&doc, &triangle_buffer([0, 1, 2])))).unwrap();
        check_scene(&scene);
        // Through `scene::load` too (extension dispatch and validation).
        let path = dir.path().join("tri.glb");
        assert_eq!(crate::scene::load(path.to_str().unwrap()).unwrap().objects.len(), 2);
    }

    #[test]
    fn external_buffer_and_materials() {
        let dir = tempfile::tempdir().unwrap();
        // Positions, UVs (u16 normalised) and u8 indices, in one external file.
        let mut bin = Vec::new();
        for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            bin.extend(c.to_le_bytes());
        }
        for c in [0u16, 0, 65535, 0, 0, 65535] {
            bin.extend(c.to_le_bytes());
        }
        bin.extend([0u8, 1, 2, 0]);
        write(dir.path(), "geo%20data.bin", &bin);
        let mut png = Vec::new();
        image::RgbImage::from_pixel(2, 3, image::Rgb([200, 100, 50]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let doc = json!({
            "asset": { "version": "2.0" },
            "buffers": [{ "byteLength": bin.len(), "uri": "geo%2520data.bin" }],
            "bufferViews": [
                { "buffer": 0, "byteOffset": 0, "byteLength": 36 },
                { "buffer": 0, "byteOffset": 36, "byteLength": 12 },
                { "buffer": 0, "byteOffset": 48, "byteLength": 3 }
            ],
            "accessors": [
                { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] },
                { "bufferView": 1, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC2" },
                { "bufferView": 2, "componentType": 5121, "count": 3, "type": "SCALAR" }
            ],
            "images": [{ "uri": format!("data:image/png;base64,{}", base64(&png)) }],
            "textures": [{ "source": 0 }],
            "materials": [
                { "name": "painted", "pbrMetallicRoughness": {
                    "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "baseColorTexture": { "index": 0 },
                    "metallicFactor": 0.25, "roughnessFactor": 0.5 },
                  "emissiveFactor": [0.1, 0.2, 0.3] },
                { "name": "plain", "pbrMetallicRoughness": { "roughnessFactor": 1.0 } }
            ],
            "meshes": [{ "primitives": [
                { "attributes": { "POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 1 }, "indices": 2, "material": 0 },
                { "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2, "material": 1 },
                { "attributes": { "POSITION": 0 }, "mode": 1 }
            ]}],
            "nodes": [{ "mesh": 0 }, { "mesh": 0 }]
        });
        let scene = load(&write(dir.path(), "m.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        // No `scenes`: every root node; the line primitive is skipped.
        assert_eq!(scene.objects.len(), 4);
        assert_eq!(scene.meshes.len(), 2);
        let mesh = &scene.meshes[scene.objects[0].mesh];
        assert_eq!(mesh.uv0, [Vec2::ZERO, Vec2::X, Vec2::Y]);
        assert_eq!(mesh.uv1.as_deref(), Some(&[Vec2::ZERO, Vec2::X, Vec2::Y][..]));
        let painted = &scene.materials[scene.objects[0].material];
        assert_eq!(scene.objects[2].material, scene.objects[0].material, "textured materials are shared");
        assert_eq!(painted.name, "painted");
        assert_eq!(painted.base_color, Vec4::new(0.5, 0.5, 0.5, 1.0));
        assert_eq!((painted.metallic, painted.roughness), (0.25, 0.5));
        assert_eq!(painted.shininess, Material::shininess_from_roughness(0.5));
        assert_eq!(painted.emissive, Vec3::new(0.1, 0.2, 0.3));
        let tex = &scene.textures[painted.base_color_texture.unwrap()];
        assert_eq!((tex.width, tex.height, &tex.rgba8[..4]), (2, 3, &[200, 100, 50, 255][..]));
        // Untextured material: one checker per object.
        let plain = [1, 3].map(|o| &scene.materials[scene.objects[o].material]);
        assert_eq!(plain[0].name, "plain");
        assert_eq!(plain[0].shininess, Material::shininess_from_roughness(1.0));
        assert_ne!(plain[0].base_color_texture, plain[1].base_color_texture);
    }

    /// Alpha modes: `MASK` keeps its cutoff (0.5 where the file gives none),
    /// `BLEND` blends (no cutoff), `OPAQUE` and a cutoff of 0 mask nothing;
    /// a mode glTF does not define is an error naming the file.
    #[test]
    fn alpha_modes() {
        let mut doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        doc["materials"] = json!([
            { "alphaMode": "MASK", "alphaCutoff": 0.3 },
            { "alphaMode": "MASK" },
            { "alphaMode": "BLEND" },
            { "alphaMode": "OPAQUE", "alphaCutoff": 0.3 },
            { "alphaMode": "MASK", "alphaCutoff": 0.0 }
        ]);
        let primitive = |m: usize| json!({ "attributes": { "POSITION": 0 }, "indices": 1, "material": m });
        doc["meshes"][0]["primitives"] = json!((0..5).map(primitive).collect::<Vec<_>>());
        let dir = tempfile::tempdir().unwrap();
        let scene = load(&write(dir.path(), "t.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        let cutoffs: Vec<Option<f32>> =
            (0..5).map(|o| scene.materials[scene.objects[o].material].alpha_cutoff).collect();
        assert_eq!(cutoffs, [Some(0.3), Some(0.5), None, None, None]);
        use crate::scene::AlphaMode as A;
        let modes: Vec<A> = (0..5).map(|o| scene.materials[scene.objects[o].material].alpha_mode()).collect();
        assert_eq!(modes, [A::Mask(0.3), A::Mask(0.5), A::Blend, A::Opaque, A::Opaque]);
        assert!(scene.has_alpha_masks() && scene.has_blended());

        doc["materials"][0]["alphaMode"] = json!("DITHER");
        let path = write(dir.path(), "bad.gltf", serde_json::to_vec(&doc).unwrap());
        let message = load(&path).expect_err("an undefined alpha mode").to_string();
        assert!(message.contains("bad.gltf"), "{message}");
    }

    /// Emissive (with `KHR_materials_emissive_strength`), metallic-roughness
    /// and occlusion textures are read, each to its own image's pixels; a
    /// material packing occlusion into its metallic-roughness image shares
    /// it; glTF's defaults hold where the file says nothing.
    #[test]
    fn material_textures() {
        let png = |pixel: [u8; 4]| {
            let mut bytes = Vec::new();
            image::RgbaImage::from_pixel(2, 2, image::Rgba(pixel))
                .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
                .unwrap();
            json!({ "uri": format!("data:image/png;base64,{}", base64(&bytes)) })
        };
        let mut doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        doc["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
        doc["images"] = json!([png([10, 20, 30, 255]), png([255, 128, 64, 255]), png([200, 0, 0, 255])]);
        doc["textures"] = json!([{ "source": 0 }, { "source": 1 }, { "source": 2 }]);
        doc["materials"] = json!([
            { "name": "glowing",
              "pbrMetallicRoughness": { "metallicFactor": 0.5, "roughnessFactor": 0.25,
                                        "metallicRoughnessTexture": { "index": 1 } },
              "emissiveFactor": [1.0, 0.5, 0.25], "emissiveTexture": { "index": 0 },
              "occlusionTexture": { "index": 1, "strength": 0.75 },
              "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": 4.0 } } },
            { "name": "occluded", "occlusionTexture": { "index": 2 }, "emissiveTexture": { "index": 0 } }
        ]);
        doc["meshes"][0]["primitives"] = json!([
            { "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 },
            { "attributes": { "POSITION": 0 }, "indices": 1, "material": 1 },
            { "attributes": { "POSITION": 0 }, "indices": 1 }
        ]);
        let dir = tempfile::tempdir().unwrap();
        let scene = load(&write(dir.path(), "t.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        let [glowing, occluded, plain] = [0, 1, 2].map(|o| &scene.materials[scene.objects[o].material]);
        let pixel = |t: Option<usize>| scene.textures[t.expect("a texture")].rgba8[..4].to_vec();
        assert_eq!(glowing.name, "glowing");
        assert_eq!(glowing.emissive, Vec3::new(4.0, 2.0, 1.0), "factor times strength");
        assert_eq!(pixel(glowing.emissive_texture), [10, 20, 30, 255]);
        assert_eq!((glowing.metallic, glowing.roughness), (0.5, 0.25));
        assert_eq!(pixel(glowing.metallic_roughness_texture), [255, 128, 64, 255]);
        assert_eq!(glowing.occlusion_texture, glowing.metallic_roughness_texture, "one packed image, loaded once");
        assert_eq!(glowing.occlusion_strength, 0.75);
        assert_eq!(occluded.name, "occluded");
        assert_eq!(pixel(occluded.occlusion_texture), [200, 0, 0, 255]);
        assert_eq!(occluded.occlusion_strength, 1.0, "glTF's default strength");
        assert_eq!(occluded.emissive, Vec3::ZERO, "glTF's default emissive factor");
        assert_eq!(occluded.emissive_texture, None, "a texture multiplying zero is not loaded");
        assert_eq!(occluded.metallic_roughness_texture, None);
        let none = (plain.emissive_texture, plain.metallic_roughness_texture, plain.occlusion_texture);
        assert_eq!(none, (None, None, None));
        assert_eq!(plain.emissive, Vec3::ZERO);
    }

    /// `KHR_texture_transform` is baked into UV0, the file's UV0 kept as
    /// UV1: the extension's own example (offset (0, 1), rotation pi/2, scale
    /// 0.5) maps the unit square onto the image's lower-left quarter. A
    /// material whose textures disagree takes its first texture's (here the
    /// base colour's, over the normal map's); a malformed transform is
    /// ignored, and so is one on a later texture when the first has none.
    #[test]
    fn texture_transform_is_baked_into_uv0() {
        let mut png = Vec::new();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([90, 90, 90, 255]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let mut doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        // UV0: the positions' x and y.
        doc["bufferViews"][0]["byteStride"] = json!(12);
        let uv = json!({ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC2" });
        doc["accessors"].as_array_mut().unwrap().push(uv);
        doc["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_texture_transform"]);
        doc["images"] = json!([{ "uri": format!("data:image/png;base64,{}", base64(&png)) }]);
        doc["textures"] = json!([{ "source": 0 }]);
        let t = |v: Value| json!({ "index": 0, "extensions": { "KHR_texture_transform": v } });
        let example = json!({ "offset": [0.0, 1.0], "rotation": std::f32::consts::FRAC_PI_2, "scale": [0.5, 0.5] });
        doc["materials"] = json!([
            { "pbrMetallicRoughness": { "baseColorTexture": t(example) }, "normalTexture": t(json!({ "scale": [2, 2] })) },
            { "pbrMetallicRoughness": { "baseColorTexture": t(json!({ "offset": "up" })) } },
            { "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } },
              "emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": t(json!({ "offset": [0.25, 0.0] })) }
        ]);
        doc["meshes"][0]["primitives"] = json!([0, 1, 2].map(|material| json!({
            "attributes": { "POSITION": 0, "TEXCOORD_0": 2 }, "indices": 1, "material": material })));
        let dir = tempfile::tempdir().unwrap();
        let scene = load(&write(dir.path(), "t.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        let file_uv = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let mesh = |o: usize| &scene.meshes[scene.objects[o].mesh];
        let baked = &mesh(0).uv0;
        let expected = [Vec2::new(0.0, 1.0), Vec2::new(0.0, 0.5), Vec2::new(0.5, 1.0)];
        assert!(baked.iter().zip(expected).all(|(a, b)| a.abs_diff_eq(b, 1e-6)), "{baked:?}");
        assert_eq!(mesh(0).uv1.as_deref(), Some(&file_uv[..]), "the file's layout for the charts");
        for o in [1, 2] {
            assert_eq!(mesh(o).uv0, file_uv, "object {o}");
            assert_eq!(mesh(o).uv1, None, "object {o}");
        }
    }

    #[test]
    fn image_formats_become_rgba8() {
        use ::gltf::image::{Data, Format};
        let data = |format, pixels: Vec<u8>| Data { pixels, format, width: 1, height: 1 };
        let cases = [
            (data(Format::R8, vec![7]), [7, 7, 7, 255]),
            (data(Format::R8G8, vec![7, 9]), [7, 7, 7, 9]),
            (data(Format::R8G8B8, vec![1, 2, 3]), [1, 2, 3, 255]),
            (data(Format::R8G8B8A8, vec![1, 2, 3, 4]), [1, 2, 3, 4]),
            (data(Format::R16, vec![0xff, 0xff]), [255, 255, 255, 255]),
            (data(Format::R16G16, vec![0, 0x80, 0, 0]), [128, 128, 128, 0]),
            (data(Format::R16G16B16, vec![0, 0, 0xff, 0xff, 0x01, 0x01]), [0, 255, 1, 255]),
            (data(Format::R16G16B16A16, [0u8, 0, 0, 0, 0, 0, 0xff, 0xff].to_vec()), [0, 0, 0, 255]),
        ];
        for (d, expected) in cases {
            assert_eq!(to_rgba8(&d).unwrap().0, expected, "{:?}", d.format);
        }
        let f: Vec<u8> = [1.0f32, 0.0, 0.5, 0.5].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(to_rgba8(&data(Format::R32G32B32A32FLOAT, f)).unwrap().0, [255, 0, 188, 128]);
        assert!(to_rgba8(&data(Format::R8G8B8, vec![1, 2])).is_err(), "short pixel data");
    }

    fn error_of(name: &str, bytes: impl AsRef<[u8]>) -> (SceneError, String) {
        let dir = tempfile::tempdir().unwrap();
        let err = load(&write(dir.path(), name, bytes)).expect_err("the load must fail");
        let msg = err.to_string();
        assert!(msg.contains(name), "the error names the file: {msg}");
        (err, msg)
    }

    #[test]
    fn truncated_or_garbage_gltf_is_a_parse_error() {
        let text = serde_json::to_string(&document(data_uri(&triangle_buffer([0, 1, 2])))).unwrap();
        for bytes in [&text.as_bytes()[..text.len() / 2], b"", b"not json at all", b"glTF\x02\0\0\0\x04\0\0\0"] {
            let (err, _) = error_of("broken.gltf", bytes);
            assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
        }
        // A GLB cut short, and one whose header lies about its length.
        let full = glb(&document(json!({ "byteLength": 44 })), &triangle_buffer([0, 1, 2]));
        let (err, _) = error_of("cut.glb", &full[..full.len() - 10]);
        assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
        let mut lying = full.clone();
        lying[8..12].copy_from_slice(&3u32.to_le_bytes());
        let (err, _) = error_of("lying.glb", &lying);
        assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
    }

    #[test]
    fn index_out_of_range_is_invalid() {
        let doc = document(data_uri(&triangle_buffer([0, 1, 5])));
        let (err, msg) = error_of("bad_index.gltf", serde_json::to_vec(&doc).unwrap());
        assert!(matches!(err, SceneError::Invalid { .. }), "{err:?}");
        assert!(msg.contains("index 5") && msg.contains("out of range"), "{msg}");
    }

    #[test]
    fn malformed_accessors_and_nodes_are_errors() {
        let base = document(data_uri(&triangle_buffer([0, 1, 2])));
        type Mutation = (&'static str, fn(&mut Value));
        let variants: [Mutation; 8] = [
            ("count beyond the view", |d| d["accessors"][0]["count"] = json!(1000)),
            ("huge count", |d| d["accessors"][0]["count"] = json!(u64::MAX / 2)),
            ("zero count", |d| d["accessors"][1]["count"] = json!(0)),
            ("offset beyond the view", |d| d["accessors"][1]["byteOffset"] = json!(4)),
            ("view beyond the buffer", |d| d["bufferViews"][1]["byteLength"] = json!(600)),
            ("positions as VEC2", |d| d["accessors"][0]["type"] = json!("VEC2")),
            ("float indices", |d| d["accessors"][1]["componentType"] = json!(5126)),
            ("node cycle", |d| d["nodes"][2]["children"] = json!([0])),
        ];
        for (what, change) in variants {
            let mut doc = base.clone();
            change(&mut doc);
            let dir = tempfile::tempdir().unwrap();
            let result = load(&write(dir.path(), "m.gltf", serde_json::to_vec(&doc).unwrap()));
            let err = result.expect_err(what);
            assert!(matches!(err, SceneError::Invalid { .. } | SceneError::Parse { .. }), "{what}: {err:?}");
            eprintln!("{what}: {err}");
        }
    }

    #[test]
    fn missing_files_and_bad_uris() {
        let dir = tempfile::tempdir().unwrap();
        let err = load(&dir.path().join("absent.gltf")).unwrap_err();
        assert!(matches!(err, SceneError::Io { .. }), "{err:?}");
        let doc = document(json!({ "byteLength": 44, "uri": "missing.bin" }));
        let err = load(&write(dir.path(), "ext.gltf", serde_json::to_vec(&doc).unwrap())).unwrap_err();
        assert!(matches!(&err, SceneError::Io { path, .. } if path.ends_with("missing.bin")), "{err:?}");
        let doc = document(json!({ "byteLength": 44, "uri": "%FF%FE.bin" }));
        let (err, _) = error_of("uri.gltf", serde_json::to_vec(&doc).unwrap());
        assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
        // A buffer shorter than declared.
        let doc = document(data_uri(&triangle_buffer([0, 1, 2])[..40]));
        let mut doc = doc;
        doc["buffers"][0]["byteLength"] = json!(44);
        let (err, _) = error_of("short.gltf", serde_json::to_vec(&doc).unwrap());
        assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
    }

    /// Every number of the test document, as a JSON pointer.
    fn number_pointers(v: &Value, at: String, out: &mut Vec<String>) {
        match v {
            Value::Number(_) => out.push(at),
            Value::Array(a) => a.iter().enumerate().for_each(|(i, x)| number_pointers(x, format!("{at}/{i}"), out)),
            Value::Object(o) => o.iter().for_each(|(k, x)| number_pointers(x, format!("{at}/{k}"), out)),
            _ => {}
        }
    }

    #[test]
    fn mutated_gltf_files_never_panic() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let doc = document(json!({ "byteLength": 44 }));
        let bin = triangle_buffer([0, 1, 2]);
        let mut pointers = Vec::new();
        number_pointers(&doc, String::new(), &mut pointers);
        let values = [
            json!(0),
            json!(1),
            json!(2),
            json!(3),
            json!(5),
            json!(6),
            json!(40),
            json!(44),
            json!(-1),
            json!(4_294_967_295u64),
            json!(1e30),
            json!(0.5),
            json!(5126),
            json!(5121),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.glb");
        let (mut ok, mut failed) = (0, 0);
        for i in 0..400 {
            let bytes = if i % 2 == 0 {
                // Structured: change a few numbers of the document.
                let mut d = doc.clone();
                for _ in 0..rng.random_range(1..3) {
                    let p = &pointers[rng.random_range(0..pointers.len())];
                    *d.pointer_mut(p).unwrap() = values[rng.random_range(0..values.len())].clone();
                }
                glb(&d, &bin)
            } else {
                // Raw: flip a few bytes of the file.
                let mut b = glb(&doc, &bin);
                for _ in 0..rng.random_range(1..4) {
                    let k = rng.random_range(0..b.len());
                    b[k] = rng.random();
                }
                b
            };
            fs::write(&path, &bytes).unwrap();
            match load(&path) {
                Ok(scene) => {
                    scene.validate().unwrap();
                    ok += 1;
                }
                Err(e) => {
                    assert!(!e.to_string().contains("panicked"), "{e}");
                    failed += 1;
                }
            }
        }
        eprintln!("mutated glTF files: {ok} loaded, {failed} rejected");
        assert!(ok > 0 && failed > 0);
    }

    #[test]
    fn zero_scale_light_and_camera_are_skipped() {
        let mut doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        doc["nodes"][1]["scale"] = json!([0.0, 0.0, 0.0]);
        doc["nodes"][3]["scale"] = json!([0.0, 0.0, 0.0]);
        let dir = tempfile::tempdir().unwrap();
        let scene = load(&write(dir.path(), "z.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        assert_eq!(scene.lights.len(), 1, "only the spot light is left");
        assert_eq!(scene.lights[0].kind, LightKind::Spot);
        assert!(scene.cameras.is_empty());
    }

    #[test]
    fn strips_and_fans_become_lists() {
        let mut doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        doc["meshes"][0]["primitives"][0]["mode"] = json!(5);
        let dir = tempfile::tempdir().unwrap();
        let scene = load(&write(dir.path(), "s.gltf", serde_json::to_vec(&doc).unwrap())).unwrap();
        assert_eq!(scene.meshes[0].indices, [0, 1, 2]);
        assert_eq!(triangle_list(Mode::TriangleStrip, vec![0, 1, 2, 3, 4]), [0, 1, 2, 2, 1, 3, 2, 3, 4]);
        assert_eq!(triangle_list(Mode::TriangleFan, vec![0, 1, 2, 3]), [0, 1, 2, 0, 2, 3]);
        assert_eq!(triangle_list(Mode::TriangleStrip, vec![0, 1]), Vec::<u32>::new());
        let mut doc = document(data_uri(&triangle_buffer([0, 1, 2])));
        doc["meshes"][0]["primitives"][0]["mode"] = json!(0);
        let err = load(&write(dir.path(), "p.gltf", serde_json::to_vec(&doc).unwrap())).unwrap_err();
        assert!(err.to_string().contains("no triangles"), "{err}");
    }
}
