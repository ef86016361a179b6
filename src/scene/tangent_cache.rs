//! MikkTSpace tangents kept on disk between runs, under a hash of the mesh
//! they are for. Every process that loads a scene without tangents (the
//! generated scenes, OBJ files, most glTF files) generated them again: a
//! quarter of a second for the generated atrium's 106,000 triangles on a
//! CPU of this project's CI, most of a small render through the command line.
//!
//! Files are `<key as 16 hex digits>.tangents` in `tangents/` of the cache
//! folder ([`crate::cache_dir`]); the key is a 64-bit FNV-1a hash of the
//! positions, normals, UVs and indices and [`VERSION`]. Layout, all
//! little-endian: magic `SSTANGT\0`, version `u32`, key `u64`, count `u32`,
//! count x 4 `f32` (x, y, z, sign), checksum `u64` (FNV-1a of every byte
//! before it). A file that fails a check is derived and written again; a
//! folder that cannot be written caches nothing (logged at debug level:
//! tangents are as right either way).

use std::path::{Path, PathBuf};
use std::sync::LazyLock;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec2, Vec3, Vec4};

use crate::hash::Fnv1a;

/// Version of the file format and of what decides the tangents (bump it
/// when `generate_tangents` changes).
const VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"SSTANGT\0";
const HEADER_LEN: usize = 8 + 4 + 8 + 4;
/// Meshes with fewer triangles are derived each time: a file per small mesh
/// (a corpus model, a test quad) would cost more than it saves.
const MIN_TRIANGLES: usize = 4096;

/// The mesh a tangent set is derived from.
pub(super) struct TangentInputs<'a> {
    pub positions: &'a [Vec3],
    pub normals: &'a [Vec3],
    pub uvs: &'a [Vec2],
    pub indices: &'a [u32],
}

impl TangentInputs<'_> {
    fn key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write(b"shadespace-tangents");
        h.write_u32(VERSION);
        h.write_pod(self.positions);
        h.write_pod(self.normals);
        h.write_pod(self.uvs);
        h.write_pod(self.indices);
        h.finish()
    }
}

/// `tangents/` in the environment's cache folder, if it has one.
static FOLDER: LazyLock<Option<PathBuf>> =
    LazyLock::new(|| crate::cache_dir::cache_root_from(|name| std::env::var_os(name)).map(|d| d.join("tangents")));

/// The tangents of `mesh`: from the environment's cache folder when stored
/// there before, else `derive`'s (then stored).
pub(super) fn cached(mesh: &TangentInputs, derive: impl FnOnce() -> Vec<Vec4>) -> Vec<Vec4> {
    cached_in(FOLDER.as_deref(), mesh, derive)
}

/// [`cached`] with the folder given (`None`: derive, keep nothing).
fn cached_in(folder: Option<&Path>, mesh: &TangentInputs, derive: impl FnOnce() -> Vec<Vec4>) -> Vec<Vec4> {
    let Some(folder) = folder.filter(|_| mesh.indices.len() / 3 >= MIN_TRIANGLES) else {
        return derive();
    };
    let key = mesh.key();
    let path = folder.join(format!("{key:016x}.tangents"));
    if let Ok(bytes) = std::fs::read(&path) {
        match decode(&bytes, key, mesh.positions.len()) {
            Ok(tangents) => return tangents,
            Err(problem) => tracing::debug!("tangent cache {}: {problem}; deriving again", path.display()),
        }
    }
    let tangents = derive();
    let write = || -> std::io::Result<()> {
        std::fs::create_dir_all(folder)?;
        // Unique to this write: threads of one process may store one key at once.
        static WRITES: AtomicU64 = AtomicU64::new(0);
        let tmp = path.with_extension(format!("tmp{}-{}", std::process::id(), WRITES.fetch_add(1, Ordering::Relaxed)));
        std::fs::write(&tmp, encode(key, &tangents))?;
        std::fs::rename(&tmp, &path)
    };
    if let Err(e) = write() {
        tracing::debug!("tangent cache {}: {e}; tangents not cached", path.display());
    }
    tangents
}

fn encode(key: u64, tangents: &[Vec4]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + tangents.len() * 16 + 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(&(tangents.len() as u32).to_le_bytes());
    for v in tangents.iter().flat_map(|t| t.to_array()) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    crate::hash::seal(&mut out);
    out
}

fn decode(bytes: &[u8], key: u64, count: usize) -> Result<Vec<Vec4>, String> {
    if bytes.len() != HEADER_LEN + count * 16 + 8 || &bytes[..8] != MAGIC {
        return Err(format!("not a tangent file of {count} vertices"));
    }
    let body = crate::hash::unseal(bytes)?;
    let u32_at = |at: usize| u32::from_le_bytes(body[at..at + 4].try_into().expect("4 bytes"));
    if u32_at(8) != VERSION || u64::from_le_bytes(body[12..20].try_into().expect("8 bytes")) != key {
        return Err("another version or key".into());
    }
    let float = |b: &[u8]| f32::from_le_bytes(b.try_into().expect("4 bytes"));
    Ok(body[HEADER_LEN..]
        .chunks_exact(16)
        .map(|t| Vec4::from_array(std::array::from_fn(|k| float(&t[4 * k..][..4]))))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::generate_tangents;

    /// A wavy grid of `n` x `n` quads (2 n² triangles), its UVs turned by
    /// `turn` radians.
    fn grid(n: u32, turn: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<u32>) {
        let (mut p, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
                p.push(Vec3::new(x, y, 0.1 * (7.0 * x).sin() * (5.0 * y).cos()));
                uv.push(Vec2::from_angle(turn).rotate(Vec2::new(x, y)));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                idx.extend([a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]);
            }
        }
        let normals = vec![Vec3::Z; p.len()];
        (p, normals, uv, idx)
    }

    #[test]
    fn tangents_come_back_from_disk_and_a_damaged_file_is_derived_again() {
        let dir = tempfile::tempdir().unwrap();
        let (p, n, uv, idx) = grid(64, 0.0);
        let mesh = TangentInputs { positions: &p, normals: &n, uvs: &uv, indices: &idx };
        let derived = generate_tangents(&p, &n, &uv, &idx);
        assert_eq!(cached_in(Some(dir.path()), &mesh, || derived.clone()), derived);
        let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
        assert_eq!(files.len(), 1, "one file: {files:?}");
        let again = cached_in(Some(dir.path()), &mesh, || panic!("stored: nothing to derive"));
        assert_eq!(again, derived);
        // Damaged: derived again (a wrong set would show), and rewritten.
        let mut bytes = std::fs::read(&files[0]).unwrap();
        bytes[HEADER_LEN + 5] ^= 0x40;
        std::fs::write(&files[0], &bytes).unwrap();
        let mut calls = 0;
        let repaired = cached_in(Some(dir.path()), &mesh, || {
            calls += 1;
            derived.clone()
        });
        assert_eq!((repaired, calls), (derived.clone(), 1));
        assert_eq!(cached_in(Some(dir.path()), &mesh, || panic!("rewritten")), derived);
    }

    #[test]
    fn other_uvs_are_another_key_and_small_meshes_are_not_stored() {
        let dir = tempfile::tempdir().unwrap();
        let (p, n, uv, idx) = grid(64, 0.0);
        let (_, _, turned, _) = grid(64, 1.0);
        let mesh = |uvs| TangentInputs { positions: &p, normals: &n, uvs, indices: &idx };
        let straight = cached_in(Some(dir.path()), &mesh(&uv), || generate_tangents(&p, &n, &uv, &idx));
        let expected = generate_tangents(&p, &n, &turned, &idx);
        assert_eq!(cached_in(Some(dir.path()), &mesh(&turned), || expected.clone()), expected);
        assert!(straight.iter().zip(&expected).any(|(a, b)| (*a - *b).length() > 0.1), "the turn changes them");
        let (sp, sn, suv, sidx) = grid(8, 0.0);
        let small = TangentInputs { positions: &sp, normals: &sn, uvs: &suv, indices: &sidx };
        cached_in(Some(dir.path()), &small, || generate_tangents(&sp, &sn, &suv, &sidx));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "the 128-triangle grid is not stored");
    }
}
