//! What every experiment writes: `data.csv` (one row per measurement),
//! `summary.json`, and `report.md` with the provenance of the run (adapter,
//! driver, date, commit, command), its tables and its figures.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use serde::Serialize;

use crate::gpu::GpuContext;

/// The commit the binary was built from (`-modified` when tracked files differed).
pub const GIT_COMMIT: &str = env!("SHADESPACE_GIT_COMMIT");

/// Where a run's figures came from.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Provenance {
    pub adapter: String,
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    /// UTC date and time the run started (ISO 8601).
    pub date: String,
    pub commit: String,
    /// The command line, as typed.
    pub command: String,
}

impl Provenance {
    pub fn new(ctx: &GpuContext, command: &str) -> Self {
        Self {
            adapter: ctx.info.name.clone(),
            backend: format!("{:?}", ctx.info.backend),
            driver: ctx.info.driver.clone(),
            driver_info: ctx.info.driver_info.clone(),
            date: utc_now(),
            commit: GIT_COMMIT.to_string(),
            command: command.to_string(),
        }
    }
}

/// The current UTC time as `YYYY-MM-DDTHH:MM:SSZ`.
pub(crate) fn utc_now() -> String {
    let secs = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    utc_from_unix(secs)
}

/// A Unix time as `YYYY-MM-DDTHH:MM:SSZ` (Howard Hinnant's civil-from-days).
fn utc_from_unix(secs: u64) -> String {
    let (days, rest) = ((secs / 86_400) as i64, secs % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z", rest / 3600, rest / 60 % 60, rest % 60)
}

/// A Markdown table.
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new(header: &[&str]) -> Self {
        Self { header: header.iter().map(|s| s.to_string()).collect(), rows: Vec::new() }
    }

    pub fn markdown(&self) -> String {
        let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
        let mut out = line(&self.header);
        out += &line(&vec!["---".to_string(); self.header.len()]);
        for r in &self.rows {
            out += &line(r);
        }
        out
    }
}

/// One part of a report: text, tables, then figures.
#[derive(Clone, Debug, Default)]
pub struct Section {
    pub heading: String,
    pub text: String,
    pub tables: Vec<(String, Table)>,
    /// PNG figures, relative to the report's folder; the report embeds the
    /// SVG that lies beside each.
    pub figures: Vec<(String, PathBuf)>,
}

/// `report.md`: a title, the provenance, then the sections.
pub fn markdown(title: &str, provenance: &Provenance, sections: &[Section]) -> String {
    let mut out = format!("# {title}\n\n");
    let mut p = Table::new(&["", ""]);
    for (k, v) in [
        ("adapter", format!("{} ({})", provenance.adapter, provenance.backend)),
        ("driver", format!("{} {}", provenance.driver, provenance.driver_info)),
        ("date", provenance.date.clone()),
        ("commit", format!("`{}`", provenance.commit)),
        ("command", format!("`{}`", provenance.command.replace('|', "\\|"))),
    ] {
        p.rows.push(vec![k.to_string(), v]);
    }
    out += &p.markdown();
    for s in sections {
        let _ = write!(out, "\n## {}\n\n", s.heading);
        if !s.text.is_empty() {
            out += s.text.trim_end();
            out += "\n\n";
        }
        for (caption, t) in &s.tables {
            if !caption.is_empty() {
                let _ = write!(out, "{caption}\n\n");
            }
            out += &t.markdown();
            out += "\n";
        }
        // The SVG is embedded: it is what gets committed under docs/ (small,
        // text), so the report's links resolve there; the PNG stays beside it.
        for (caption, png) in &s.figures {
            let svg = png.with_extension("svg").display().to_string();
            let _ = write!(out, "![{caption}]({svg})\n\n{caption}\n\n");
        }
    }
    out
}

/// Writes serde records as CSV with a header row.
pub fn write_csv<R: Serialize>(path: &Path, rows: &[R]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_path(path)?;
    for r in rows {
        w.serialize(r)?;
    }
    w.flush()?;
    Ok(())
}

/// Fixed-point formatting for tables.
pub fn f3(v: f64) -> String {
    format!("{v:.3}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unix_times_format_as_utc_dates() {
        assert_eq!(utc_from_unix(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_from_unix(951_782_400 + 3_723), "2000-02-29T01:02:03Z");
        assert_eq!(utc_from_unix(1_798_761_599), "2026-12-31T23:59:59Z");
    }

    #[test]
    fn tables_render_as_markdown() {
        let mut t = Table::new(&["a", "b"]);
        t.rows.push(vec!["1".into(), "2".into()]);
        assert_eq!(t.markdown(), "| a | b |\n| --- | --- |\n| 1 | 2 |\n");
    }
}
