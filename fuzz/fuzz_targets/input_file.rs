//! The fuzz input as a file: the loaders take paths (they resolve buffers,
//! images and material libraries beside the file), so each input is written
//! to a per-process folder (in `/dev/shm` when there is one) and loaded from
//! there, exactly as the command line loads it.

use std::path::PathBuf;

/// Writes `data` to `name` in this process's scratch folder; returns its path.
pub fn input_file(name: &str, data: &[u8]) -> PathBuf {
    let base = if std::path::Path::new("/dev/shm").is_dir() { PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
    let dir = base.join(format!("shadespace-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create the scratch folder");
    let path = dir.join(name);
    std::fs::write(&path, data).expect("write the fuzz input");
    path
}
