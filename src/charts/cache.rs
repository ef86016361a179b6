//! On-disk cache of generated charts, so that a scene is unwrapped once per
//! machine rather than once per run.
//!
//! Files are named `<key as 16 hex digits>.chart`, where the key is a 64-bit
//! FNV-1a hash of the mesh (positions, indices, uv0), the generator settings
//! and resolution, and [`FORMAT_VERSION`]. Layout, all little-endian:
//!
//! ```text
//! magic         8 bytes  "SSCHART\0"
//! version       u32      FORMAT_VERSION
//! key           u64
//! resolution    u32      page size the charts were packed for
//! vertex_count  u32      n
//! index_count   u32      m
//! remap         n x u32  source vertex of each new vertex
//! uvs           n x 2 x f32
//! indices       m x u32
//! checksum      u64      FNV-1a of every byte before it
//! ```
//!
//! A cache that can't be created or written is a warning, never an error; a
//! file that fails any check is a warning and a regeneration.

use std::ffi::OsString;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec2;

use super::generate::{GeneratedChart, GeneratorSettings};
use crate::hash::Fnv1a;
use crate::scene::Mesh;

/// Version of the file format and of everything that decides a generated chart
/// (bump it when the generator's use of `uvunwrap` changes).
pub const FORMAT_VERSION: u32 = 1;

const MAGIC: &[u8; 8] = b"SSCHART\0";
const HEADER_LEN: usize = 8 + 4 + 8 + 4 + 4 + 4;

/// The cache key of `mesh` unwrapped at `resolution` with `settings`.
pub fn chart_key(mesh: &Mesh, resolution: u32, settings: &GeneratorSettings) -> u64 {
    let mut h = Fnv1a::default();
    h.write(b"shadespace-chart");
    h.write_u32(FORMAT_VERSION);
    // The generator's own version: a new uvunwrap may unwrap differently.
    h.write(b"uvunwrap-0.3");
    h.write_u32(resolution);
    h.write_u32(settings.padding);
    h.write_u32(settings.max_chart_angle.to_bits());
    h.write_u32(settings.fast_packing as u32);
    h.write_pod(&mesh.positions);
    h.write_pod(&mesh.indices);
    h.write_pod(&mesh.uv0);
    h.finish()
}

/// Where generated charts are kept: a folder, or nowhere.
#[derive(Clone, Debug)]
pub struct ChartCache {
    dir: Option<PathBuf>,
}

impl ChartCache {
    /// The cache in `$SHADESPACE_CACHE_DIR`, else `$XDG_CACHE_HOME/shadespace/charts`,
    /// else `$HOME/.cache/shadespace/charts`, created if missing. When none is
    /// set or the folder can't be created, warns and caches nothing.
    pub fn from_env() -> Self {
        match cache_dir_from(|name| std::env::var_os(name)) {
            Some(dir) => Self::in_dir(dir),
            None => {
                tracing::warn!("no cache folder (set SHADESPACE_CACHE_DIR or HOME): generated charts are not cached");
                Self::disabled()
            }
        }
    }

    /// The cache in `dir`, created if missing; warns and caches nothing when
    /// it can't be created.
    pub fn in_dir(dir: impl Into<PathBuf>) -> Self {
        let dir = dir.into();
        match fs::create_dir_all(&dir) {
            Ok(()) => Self { dir: Some(dir) },
            Err(e) => {
                tracing::warn!("chart cache {}: {e}; generated charts are not cached", dir.display());
                Self::disabled()
            }
        }
    }

    /// A cache that keeps nothing.
    pub fn disabled() -> Self {
        Self { dir: None }
    }

    /// The cache folder, if caching is on.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// The file that holds (or would hold) the chart with `key`.
    pub fn path_for(&self, key: u64) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| d.join(format!("{key:016x}.chart")))
    }

    /// The cached chart with `key` for `mesh`, if there is a valid one. A file
    /// that exists but fails a check is reported with a warning.
    pub fn load(&self, key: u64, mesh: &Mesh) -> Option<GeneratedChart> {
        let path = self.path_for(key)?;
        let bytes = match fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
            Err(e) => {
                tracing::warn!("chart cache {}: {e}; regenerating", path.display());
                return None;
            }
        };
        match decode(&bytes, key, mesh) {
            Ok(chart) => Some(chart),
            Err(problem) => {
                tracing::warn!("chart cache {}: {problem}; regenerating", path.display());
                None
            }
        }
    }

    /// Writes `chart` under `key` (through a temporary file and a rename, so
    /// that a reader never sees half a file). Failure is a warning.
    pub fn store(&self, key: u64, chart: &GeneratedChart) {
        let Some(path) = self.path_for(key) else { return };
        let tmp = path.with_extension(format!("tmp{}", std::process::id()));
        let result = fs::File::create(&tmp)
            .and_then(|mut f| f.write_all(&encode(key, chart)))
            .and_then(|()| fs::rename(&tmp, &path));
        if let Err(e) = result {
            let _ = fs::remove_file(&tmp);
            tracing::warn!("chart cache {}: {e}; chart not cached", path.display());
        }
    }
}

/// The cache folder from the environment (`var` reads one variable), by the
/// precedence of [`ChartCache::from_env`]. Empty values count as unset, and a
/// relative `XDG_CACHE_HOME` is ignored, as the XDG specification says.
pub fn cache_dir_from(var: impl Fn(&str) -> Option<OsString>) -> Option<PathBuf> {
    let set = |name: &str| var(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(dir) = set("SHADESPACE_CACHE_DIR") {
        return Some(dir);
    }
    if let Some(xdg) = set("XDG_CACHE_HOME").filter(|p| p.is_absolute()) {
        return Some(xdg.join("shadespace").join("charts"));
    }
    set("HOME").map(|home| home.join(".cache").join("shadespace").join("charts"))
}

fn encode(key: u64, chart: &GeneratedChart) -> Vec<u8> {
    let n = chart.remap.len();
    let mut out = Vec::with_capacity(HEADER_LEN + n * 12 + chart.indices.len() * 4 + 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&key.to_le_bytes());
    for x in [chart.resolution, n as u32, chart.indices.len() as u32] {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for &r in &chart.remap {
        out.extend_from_slice(&r.to_le_bytes());
    }
    for uv in &chart.uvs {
        out.extend_from_slice(&uv.x.to_le_bytes());
        out.extend_from_slice(&uv.y.to_le_bytes());
    }
    for &i in &chart.indices {
        out.extend_from_slice(&i.to_le_bytes());
    }
    crate::hash::seal(&mut out);
    out
}

/// Parses and checks a cache file against the key and the mesh it is for.
fn decode(bytes: &[u8], key: u64, mesh: &Mesh) -> Result<GeneratedChart, String> {
    if bytes.len() < HEADER_LEN + 8 || &bytes[..8] != MAGIC {
        return Err("not a chart cache file".into());
    }
    let body = crate::hash::unseal(bytes)?;
    let u32_at = |at: usize| u32::from_le_bytes(body[at..at + 4].try_into().expect("4 bytes"));
    let version = u32_at(8);
    if version != FORMAT_VERSION {
        return Err(format!("format version {version}, expected {FORMAT_VERSION}"));
    }
    if u64::from_le_bytes(body[12..20].try_into().expect("8 bytes")) != key {
        return Err("key mismatch".into());
    }
    let (resolution, n, m) = (u32_at(20), u32_at(24) as usize, u32_at(28) as usize);
    if body.len() != HEADER_LEN + n * 12 + m * 4 {
        return Err(format!("length {} does not match {n} vertices and {m} indices", bytes.len()));
    }
    let words = |from: usize, count: usize| -> Vec<u32> {
        body[from..from + 4 * count]
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect()
    };
    let remap = words(HEADER_LEN, n);
    let uvs: Vec<Vec2> = words(HEADER_LEN + 4 * n, 2 * n)
        .chunks_exact(2)
        .map(|c| Vec2::new(f32::from_bits(c[0]), f32::from_bits(c[1])))
        .collect();
    let indices = words(HEADER_LEN + 12 * n, m);

    // The chart must describe this very mesh: same triangles, in order.
    if m != mesh.indices.len() {
        return Err(format!("{m} indices for a mesh with {}", mesh.indices.len()));
    }
    if remap.iter().any(|&r| r as usize >= mesh.positions.len()) || indices.iter().any(|&i| i as usize >= n) {
        return Err("index out of range".into());
    }
    if indices.iter().zip(&mesh.indices).any(|(&i, &orig)| remap[i as usize] != orig) {
        return Err("triangles do not match the mesh".into());
    }
    if uvs.iter().any(|uv| !uv.is_finite()) {
        return Err("non-finite UV".into());
    }
    Ok(GeneratedChart { resolution, remap, uvs, indices })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cache_folder_precedence() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| pairs.iter().find(|(k, _)| *k == name).map(|(_, v)| OsString::from(v))
        };
        let all = env(&[("SHADESPACE_CACHE_DIR", "/c"), ("XDG_CACHE_HOME", "/x"), ("HOME", "/h")]);
        assert_eq!(cache_dir_from(all), Some(PathBuf::from("/c")));
        let xdg = env(&[("SHADESPACE_CACHE_DIR", ""), ("XDG_CACHE_HOME", "/x"), ("HOME", "/h")]);
        assert_eq!(cache_dir_from(xdg), Some(PathBuf::from("/x/shadespace/charts")));
        let relative_xdg = env(&[("XDG_CACHE_HOME", "rel"), ("HOME", "/h")]);
        assert_eq!(cache_dir_from(relative_xdg), Some(PathBuf::from("/h/.cache/shadespace/charts")));
        assert_eq!(cache_dir_from(env(&[])), None);
    }

    fn tri_mesh() -> Mesh {
        Mesh {
            positions: vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y],
            indices: vec![0, 1, 2],
            ..Mesh::default()
        }
    }

    #[test]
    fn files_round_trip_and_damage_is_detected() {
        let mesh = tri_mesh();
        let chart = GeneratedChart {
            resolution: 256,
            remap: vec![0, 1, 2, 0],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE],
            indices: vec![3, 1, 2],
        };
        let bytes = encode(7, &chart);
        assert_eq!(decode(&bytes, 7, &mesh), Ok(chart.clone()));
        assert!(decode(&bytes, 8, &mesh).unwrap_err().contains("key"));
        assert!(decode(&bytes[..bytes.len() - 1], 7, &mesh).is_err());
        let mut flipped = bytes.clone();
        flipped[HEADER_LEN + 5] ^= 1;
        assert!(decode(&flipped, 7, &mesh).unwrap_err().contains("checksum"));
        // A well-formed file for other triangles is rejected too.
        let other = Mesh { indices: vec![0, 2, 1], ..tri_mesh() };
        assert!(decode(&bytes, 7, &other).unwrap_err().contains("triangles"));
    }

    #[test]
    fn the_key_sees_every_input() {
        let s = GeneratorSettings::default();
        let base = chart_key(&tri_mesh(), 256, &s);
        assert_eq!(base, chart_key(&tri_mesh(), 256, &s), "stable");
        assert_ne!(base, chart_key(&tri_mesh(), 512, &s));
        assert_ne!(base, chart_key(&tri_mesh(), 256, &GeneratorSettings { padding: 2, ..s }));
        let moved = Mesh { positions: vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Z], ..tri_mesh() };
        assert_ne!(base, chart_key(&moved, 256, &s));
        let uv = Mesh { uv0: vec![Vec2::ZERO; 3], ..tri_mesh() };
        assert_ne!(base, chart_key(&uv, 256, &s));
    }
}
