//! Writes small glTF 2.0 models for tests (a `.gltf` document and its `.bin`
//! buffer), so that no downloaded sample has to live in the repository.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{Value, json};

/// A triangle mesh with per-vertex normals.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
}

/// An ellipsoid of semi-axes `radii` around `centre`, `rings` x `segments`
/// quads (latitude-longitude).
pub fn ellipsoid(centre: Vec3, radii: Vec3, rings: u32, segments: u32) -> MeshData {
    let mut m = MeshData::default();
    for i in 0..=rings {
        let polar = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let azimuth = std::f32::consts::TAU * j as f32 / segments as f32;
            let unit = Vec3::new(polar.sin() * azimuth.cos(), polar.cos(), polar.sin() * azimuth.sin());
            m.positions.push(centre + radii * unit);
            // The gradient of the implicit surface.
            m.normals.push((unit / radii).normalize());
        }
    }
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b) = (i * row + j, (i + 1) * row + j);
            m.indices.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    m
}

/// An axis-aligned box from `min` to `max`, four vertices per face.
pub fn cuboid(min: Vec3, max: Vec3) -> MeshData {
    let mut m = MeshData::default();
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let n = Vec3::AXES[axis] * side;
            let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
            let base = m.positions.len() as u32;
            for (a, b) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                let t = Vec3::AXES[axis] * (0.5 * (side + 1.0)) + a * u + b * v;
                m.positions.push(min + (max - min) * t);
                m.normals.push(n);
            }
            // Counter-clockwise seen from outside.
            if side > 0.0 {
                m.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
            } else {
                m.indices.extend([base, base + 2, base + 1, base, base + 3, base + 2]);
            }
        }
    }
    m
}

/// A teapot-like model: a squat body, a lid, a spout and a handle; 3.3
/// units wide and 1.85 tall, standing on y = 0. Something with a silhouette
/// of its own, not a ball or a brick.
pub fn teapot() -> Vec<MeshData> {
    vec![
        ellipsoid(Vec3::new(0.0, 0.8, 0.0), Vec3::new(1.2, 0.8, 1.2), 16, 24),
        ellipsoid(Vec3::new(0.0, 1.6, 0.0), Vec3::new(0.5, 0.25, 0.5), 8, 16),
        cuboid(Vec3::new(1.0, 0.6, -0.15), Vec3::new(1.8, 0.9, 0.15)),
        cuboid(Vec3::new(-1.5, 0.5, -0.1), Vec3::new(-1.1, 1.2, 0.1)),
    ]
}

/// How the models of [`write_gltf`] are placed: a root node scaled by
/// `scale` and moved by `translation`, and perspective cameras at the given
/// positions looking along -z (glTF's camera convention).
#[derive(Clone, Debug)]
pub struct Placement {
    pub scale: f32,
    pub translation: Vec3,
    pub cameras: Vec<Vec3>,
}

impl Default for Placement {
    fn default() -> Self {
        Self { scale: 1.0, translation: Vec3::ZERO, cameras: Vec::new() }
    }
}

/// Writes `meshes` as `dir/name.gltf` (with `dir/name.bin`), one child node
/// per mesh under the root node of `placement`, and returns the `.gltf` path.
pub fn write_gltf(dir: &Path, name: &str, meshes: &[MeshData], placement: &Placement) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut gltf_meshes, mut children) = (vec![], vec![], vec![], vec![]);
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8]| -> usize {
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    for (k, m) in meshes.iter().enumerate() {
        let floats = |v: &[Vec3]| v.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
        let (lo, hi) =
            m.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
        let p = view(&mut bin, &floats(&m.positions));
        let n = view(&mut bin, &floats(&m.normals));
        let i = view(&mut bin, &m.indices.iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<u8>>());
        let base = accessors.len();
        accessors.push(json!({ "bufferView": p, "componentType": 5126, "count": m.positions.len(), "type": "VEC3",
                               "min": lo.to_array(), "max": hi.to_array() }));
        accessors.push(json!({ "bufferView": n, "componentType": 5126, "count": m.normals.len(), "type": "VEC3" }));
        accessors.push(json!({ "bufferView": i, "componentType": 5125, "count": m.indices.len(), "type": "SCALAR" }));
        gltf_meshes.push(json!({ "name": format!("part{k}"), "primitives": [{
            "attributes": { "POSITION": base, "NORMAL": base + 1 }, "indices": base + 2, "material": 0 }] }));
        children.push(k + 1);
    }
    let scale = [placement.scale; 3];
    let mut nodes: Vec<Value> = vec![json!({
        "name": "root", "children": children,
        "scale": scale, "translation": placement.translation.to_array() })];
    nodes.extend((0..meshes.len()).map(|k| json!({ "name": format!("part{k}"), "mesh": k })));
    let mut roots = vec![0];
    for (k, eye) in placement.cameras.iter().enumerate() {
        roots.push(nodes.len());
        nodes.push(json!({ "name": format!("camera{k}"), "camera": 0, "translation": eye.to_array() }));
    }
    let bin_name = format!("{name}.bin");
    let document = json!({
        "asset": { "version": "2.0", "generator": "shadespace tests" },
        "buffers": [{ "byteLength": bin.len(), "uri": bin_name }],
        "bufferViews": views,
        "accessors": accessors,
        "materials": [{ "name": "clay", "pbrMetallicRoughness": {
            "baseColorFactor": [0.8, 0.55, 0.35, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7 } }],
        "meshes": gltf_meshes,
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.9, "znear": 0.01, "zfar": 100000.0 } }],
        "nodes": nodes,
        "scenes": [{ "nodes": roots }],
        "scene": 0
    });
    std::fs::write(dir.join(&bin_name), &bin).unwrap();
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec_pretty(&document).unwrap()).unwrap();
    path
}
