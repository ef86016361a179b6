//! Output files, written so that a failed run never leaves a truncated one,
//! and the command line as text for reports.

use std::path::{Path, PathBuf};

use anyhow::Context;
use shadespace::bench::RunReport;
use shadespace::render::Renderer;

use super::{Failure, input};

/// Writes `image` to `path` as PNG.
pub fn save_png(image: &image::RgbaImage, path: &Path) -> Result<(), Failure> {
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).context("encoding PNG")?;
    write_file(path, &bytes)
}

/// Writes a run's report (`render --stats`, `bench`) as JSON.
pub fn write_report(report: &RunReport, path: &Path) -> Result<(), Failure> {
    write_file(path, serde_json::to_string_pretty(report)?.as_bytes())
}

/// Writes the GPU trace through a temporary file, like every other output.
pub fn write_trace(renderer: &Renderer, path: &Path) -> Result<(), Failure> {
    let tmp = temp_path(path);
    match renderer.write_trace(&tmp) {
        Ok(true) => input(std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))),
        Ok(false) => {
            tracing::warn!("--trace: the adapter has no timestamp queries; no trace written");
            Ok(())
        }
        Err(e) => input(Err(anyhow::Error::new(e).context(format!("{}: cannot write", path.display())))),
    }
}

/// The temporary file an output is written to before its rename.
fn temp_path(path: &Path) -> PathBuf {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    dir.join(format!(".{}.tmp", path.file_name().and_then(|n| n.to_str()).unwrap_or("out")))
}

/// Writes through a temporary file and a rename, so that a failed run never
/// leaves a truncated result behind.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    let tmp = temp_path(path);
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    input(result.with_context(|| format!("{}: cannot write", path.display())))
}

/// The command line as typed, arguments with spaces or quotes single-quoted.
pub fn command_line() -> String {
    std::env::args().map(|a| shell_quote(&a)).collect::<Vec<_>>().join(" ")
}

/// A word as a shell reads it back: single-quoted when it holds spaces or quotes.
pub fn shell_quote(s: &str) -> String {
    if s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}
