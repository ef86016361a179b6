//! The folder where files derived from the inputs (references, tangents)
//! are kept between runs: `$SHADESPACE_CACHE_DIR`, else
//! `$XDG_CACHE_HOME/shadespace`, else `~/.cache/shadespace`. Each kind has a
//! folder of its own in it. (The charts, cached first, keep theirs in
//! `$SHADESPACE_CACHE_DIR` itself: `charts::cache::cache_dir_from`.)

use std::ffi::OsString;
use std::path::PathBuf;

/// The cache folder from the environment (`var` reads one variable). Empty
/// values count as unset and a relative `XDG_CACHE_HOME` is ignored, as the
/// XDG specification says.
pub fn cache_root_from(var: impl Fn(&str) -> Option<OsString>) -> Option<PathBuf> {
    let set = |name: &str| var(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(dir) = set("SHADESPACE_CACHE_DIR") {
        return Some(dir);
    }
    if let Some(xdg) = set("XDG_CACHE_HOME").filter(|p| p.is_absolute()) {
        return Some(xdg.join("shadespace"));
    }
    set("HOME").map(|home| home.join(".cache").join("shadespace"))
}
