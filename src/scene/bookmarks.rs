//! Camera bookmarks: named views (eye, target, vertical field of view) kept
//! in a JSON file. The viewer writes them (`view --bookmarks FILE`); `render`
//! and `bench` read one back with `--camera bookmark:FILE:NAME`, so a view
//! found by hand is rendered and measured from the same numbers.
//!
//! The file is a JSON list:
//! `[{"name": "view-1", "eye": [1, 2, 3], "target": [0, 1, 0], "fov": 60}]`.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::free_camera::LookAt;

/// A saved view: the eye, the point looked at and the vertical field of
/// view in degrees, as `render --eye X,Y,Z --target X,Y,Z --fov DEG` takes them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bookmark {
    pub name: String,
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub fov: f32,
}

impl Bookmark {
    pub fn new(name: String, l: &LookAt) -> Self {
        Self { name, eye: l.eye.to_array(), target: l.target.to_array(), fov: l.fov_deg }
    }

    pub fn look_at(&self) -> LookAt {
        LookAt { eye: Vec3::from(self.eye), target: Vec3::from(self.target), fov_deg: self.fov }
    }
}

/// A `--camera bookmark:FILE:NAME` value: a bookmark file and a name in it
/// (the text after the last colon, so that the file's path may hold colons).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BookmarkRef {
    pub file: PathBuf,
    pub name: String,
}

impl BookmarkRef {
    /// The `--camera` prefix of bookmarks.
    const PREFIX: &str = "bookmark:";

    /// The bookmark a `--camera` value names; `None` for other values.
    pub fn from_camera_arg(s: &str) -> Result<Option<Self>, BookmarkError> {
        let Some(rest) = s.trim().strip_prefix(Self::PREFIX) else { return Ok(None) };
        match rest.rsplit_once(':') {
            Some((file, name)) if !file.is_empty() && !name.is_empty() => {
                Ok(Some(Self { file: file.into(), name: name.into() }))
            }
            _ => Err(BookmarkError::Syntax(s.into())),
        }
    }

    /// The bookmarked view.
    pub fn find(&self) -> Result<LookAt, BookmarkError> {
        find(&self.file, &self.name)
    }
}

impl std::fmt::Display for BookmarkRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}:{}", Self::PREFIX, self.file.display(), self.name)
    }
}

/// Why a bookmark file or a bookmark in it cannot be used. Every variant
/// but `Syntax` names the file.
#[derive(Debug, thiserror::Error)]
pub enum BookmarkError {
    #[error("\"{0}\": expected 'bookmark:FILE:NAME' (NAME: the text after the last colon)")]
    Syntax(String),
    #[error("{}: cannot read the bookmark file: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{}: not a bookmark file (a JSON list of {{\"name\", \"eye\": [x, y, z], \"target\": [x, y, z], \"fov\"}}): {source}",
        path.display()
    )]
    Parse {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{}: no bookmark named '{name}' (the file has: {known})", path.display())]
    Unknown { path: PathBuf, name: String, known: String },
    #[error("{}: cannot write the bookmark file: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Reads a bookmark file.
pub fn load(path: &Path) -> Result<Vec<Bookmark>, BookmarkError> {
    let text = std::fs::read_to_string(path).map_err(|source| BookmarkError::Read { path: path.into(), source })?;
    serde_json::from_str(&text).map_err(|source| BookmarkError::Parse { path: path.into(), source })
}

/// Writes a bookmark file (replacing it).
pub fn save(path: &Path, bookmarks: &[Bookmark]) -> Result<(), BookmarkError> {
    let text = serde_json::to_string_pretty(bookmarks).expect("bookmarks serialize");
    std::fs::write(path, text).map_err(|source| BookmarkError::Write { path: path.into(), source })
}

/// The view of the bookmark `name` in the file at `path`.
pub fn find(path: &Path, name: &str) -> Result<LookAt, BookmarkError> {
    let bookmarks = load(path)?;
    match bookmarks.iter().find(|b| b.name == name) {
        Some(b) => Ok(b.look_at()),
        None => {
            let names: Vec<&str> = bookmarks.iter().map(|b| b.name.as_str()).collect();
            let known = if names.is_empty() { "no bookmarks".to_string() } else { names.join(", ") };
            Err(BookmarkError::Unknown { path: path.into(), name: name.into(), known })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_saved_bookmark_is_found_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("views.json");
        let look = LookAt { eye: Vec3::new(0.1, 2.0, -3.5), target: Vec3::new(1.0 / 3.0, 0.0, 7.0), fov_deg: 47.5 };
        let other = LookAt { eye: Vec3::ONE, target: Vec3::ZERO, fov_deg: 60.0 };
        save(&path, &[Bookmark::new("a".into(), &other), Bookmark::new("view-2".into(), &look)]).unwrap();
        assert_eq!(find(&path, "view-2").unwrap(), look);
        let err = find(&path, "view-3").unwrap_err().to_string();
        assert!(err.contains("views.json") && err.contains("'view-3'") && err.contains("a, view-2"), "{err}");
    }

    #[test]
    fn camera_values_name_a_file_and_a_bookmark() {
        let parse = |s: &str| BookmarkRef::from_camera_arg(s).map_err(|e| e.to_string());
        let mark = BookmarkRef { file: "dir:a/views.json".into(), name: "view-1".into() };
        assert_eq!(parse("bookmark:dir:a/views.json:view-1"), Ok(Some(mark.clone())));
        assert_eq!(mark.to_string(), "bookmark:dir:a/views.json:view-1");
        assert_eq!(parse("fixed:1"), Ok(None));
        for bad in ["bookmark:", "bookmark:views.json", "bookmark::view-1", "bookmark:views.json:"] {
            assert!(parse(bad).unwrap_err().contains("expected 'bookmark:FILE:NAME'"), "{bad}");
        }
    }

    #[test]
    fn bad_files_name_the_file_and_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.json");
        let err = find(&missing, "x").unwrap_err().to_string();
        assert!(err.contains("missing.json") && err.contains("cannot read"), "{err}");
        let bad = dir.path().join("bad.json");
        std::fs::write(&bad, r#"[{"name": "x", "eye": [0, 0], "target": [0, 0, 1], "fov": 60}]"#).unwrap();
        let err = find(&bad, "x").unwrap_err().to_string();
        assert!(err.contains("bad.json") && err.contains("not a bookmark file"), "{err}");
    }
}
