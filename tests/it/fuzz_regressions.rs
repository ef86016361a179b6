//! Inputs on which `cargo fuzz` (`scripts/fuzz`, targets in `fuzz/`) made a
//! loader panic, minimised: each must now load or be refused with an error.
//! No GPU needed.

use std::path::{Path, PathBuf};

use shadespace::scene::gltf;

/// Writes `bytes` to `name` in `dir`; returns its path.
fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// A glTF triangle (positions in a data-URI buffer) whose material's base
/// colour texture is image 0, described by `image` (JSON).
fn textured_triangle(image: &str) -> String {
    // Three f32 positions: (0,0,0), (1,0,0), (0,1,0).
    const POSITIONS: &str = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
    format!(
        r#"{{"asset": {{"version": "2.0"}},
  "buffers": [{{"byteLength": 36, "uri": "data:application/octet-stream;base64,{POSITIONS}"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0, 0, 0], "max": [1, 1, 0]}}],
  "images": [{image}],
  "textures": [{{"source": 0}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}]}}],
  "nodes": [{{"mesh": 0}}]}}"#
    )
}

/// Fuzzer crash (gltf target): an image with a `bufferView` but no
/// `mimeType`, or with neither `uri` nor `bufferView`, made the `gltf`
/// crate's `Image::source` unwrap `None`. The image is now skipped with a
/// warning, like a missing one, and the triangle gets its checker.
#[test]
fn gltf_image_without_mime_type_or_source() {
    let dir = tempfile::tempdir().unwrap();
    for (what, image) in [("bufferView without mimeType", r#"{"bufferView": 0}"#), ("no source", "{}")] {
        let path = write(dir.path(), "image.gltf", textured_triangle(image));
        let scene = gltf::load(&path).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(scene.objects.len(), 1, "{what}");
        let material = &scene.materials[scene.objects[0].material];
        let texture = &scene.textures[material.base_color_texture.unwrap()];
        assert!(texture.name.starts_with("checker:"), "{what}: the broken image is replaced by the checker");
    }
}

/// Found profiling the gltf target (a hang, libFuzzer's 10 s timeout, at
/// 4 GB): a 537-byte file whose POSITION accessor has no buffer view,
/// 60 million elements and one sparse value. Such accessors are now limited
/// to 2^20 elements; the file is refused at once.
#[test]
fn gltf_huge_sparse_accessor_without_buffer_view() {
    // One u32 sparse index (0) and one VEC3 value (1, 2, 3).
    const SPARSE: &str = "AAAAAAAAgD8AAABAAABAQA==";
    let file = format!(
        r#"{{"asset": {{"version": "2.0"}},
  "buffers": [{{"byteLength": 16, "uri": "data:application/octet-stream;base64,{SPARSE}"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 4}}, {{"buffer": 0, "byteOffset": 4, "byteLength": 12}}],
  "accessors": [{{"componentType": 5126, "count": 60000000, "type": "VEC3", "min": [0, 0, 0], "max": [1, 2, 3],
                  "sparse": {{"count": 1, "indices": {{"bufferView": 0, "componentType": 5125}},
                              "values": {{"bufferView": 1}}}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "nodes": [{{"mesh": 0}}]}}"#
    );
    let dir = tempfile::tempdir().unwrap();
    let start = std::time::Instant::now();
    let err = gltf::load(&write(dir.path(), "sparse.gltf", file)).expect_err("60 million zero vertices");
    let message = err.to_string();
    assert!(message.contains("without a buffer view") && message.contains("60000000"), "{message}");
    assert!(start.elapsed().as_secs_f64() < 1.0, "refused in {:?}", start.elapsed());
}

/// Not found by the fuzzer (its inputs name no files), found reading the
/// loader after it: a buffer or image URI naming a device or a folder was
/// read to its end by the `gltf` crate (`file:///dev/zero` never ends). Such
/// URIs are now refused, naming the URI.
#[test]
fn gltf_uris_naming_devices_or_folders_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().display().to_string();
    for (what, file) in [
        (
            "buffer",
            r#"{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": "file:///dev/zero"}]}"#.to_string(),
        ),
        ("image", textured_triangle(r#"{"uri": "file:///dev/zero"}"#)),
        ("image folder", textured_triangle(&format!(r#"{{"uri": "file://{folder}"}}"#))),
    ] {
        let start = std::time::Instant::now();
        let err = gltf::load(&write(dir.path(), "device.gltf", file)).expect_err(what);
        let message = err.to_string();
        assert!(message.contains("not a regular file"), "{what}: {message}");
        assert!(start.elapsed().as_secs_f64() < 1.0, "{what}: refused in {:?}", start.elapsed());
    }
}
