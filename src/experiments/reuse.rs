//! Experiment 3, `reuse`: between consecutive path frames, the share of the
//! previous frame's tiles still needed ("reusable") and the share of this
//! frame's tiles not needed before ("new"), over all frames and in the
//! study's windows.

use std::collections::BTreeMap;

use serde::Serialize;

use super::marking::{Marking, Texture, Variant};
use super::plot::{LinePlot, series_per_resolution};
use super::report::{Section, Table, f3};
use super::stats::Summary;
use super::tile_set::TileSet;
use super::{ExperimentError, Findings, Study};

/// One frame pair (`frame - 1`, `frame`) at one resolution, tile size and variant.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub frame: u32,
    pub width: u32,
    pub height: u32,
    pub tile_size: u32,
    pub marking: Marking,
    pub texture: Texture,
    pub previous_tiles: u64,
    pub tiles: u64,
    /// Tiles both frames need.
    pub kept: u64,
    /// `kept / previous_tiles`; empty where the previous frame needed none.
    pub reusable: Option<f64>,
    /// `(tiles - kept) / tiles`; empty where this frame needs none.
    pub new: Option<f64>,
    /// The windows (`first-last`) the pair lies in, space-separated.
    pub windows: String,
}

/// Medians (and the rest) of one cell over one window.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub marking: Marking,
    pub texture: Texture,
    pub tile_size: u32,
    pub width: u32,
    pub height: u32,
    /// `all` or `first-last`.
    pub window: String,
    pub reusable: Option<Summary>,
    pub new: Option<Summary>,
}

/// A cell: variant, tile size, resolution, window.
type CellKey = (Variant, u32, (u32, u32), String);

/// (reusable, new) between a previous and a current tile set.
pub fn shares(previous: &TileSet, current: &TileSet) -> (Option<f64>, Option<f64>) {
    let kept = previous.intersection_count(current);
    let ratio = |a: u64, b: u64| (b > 0).then(|| a as f64 / b as f64);
    (ratio(kept, previous.count()), ratio(current.count() - kept, current.count()))
}

fn window_name((a, b): (u32, u32)) -> String {
    format!("{a}-{b}")
}

pub fn run(study: &mut Study) -> Result<Findings, ExperimentError> {
    let grid = study.grid;
    let frames = &grid.reuse_frames;
    study.progress.set_length((frames.len() * grid.resolutions.len()) as u64);
    let mut rows = Vec::new();
    // The previous measured frame's tiles, per resolution.
    let mut previous: Vec<Option<(u32, Vec<TileSet>)>> = vec![None; grid.resolutions.len()];
    for &frame in frames {
        let camera = study.cameras.path_camera(frame);
        // A pair lies in a window when both its frames do.
        let windows: Vec<String> =
            grid.reuse_windows.iter().filter(|&&(a, b)| a < frame && frame <= b).map(|&w| window_name(w)).collect();
        for (r, &(width, height)) in grid.resolutions.iter().enumerate() {
            let sets = study.tiles(&camera, r)?;
            if let Some((f, before)) = &previous[r]
                && *f + 1 == frame
            {
                for ((space, set), old) in study.census.spaces.iter().zip(&sets).zip(before) {
                    let (reusable, new) = shares(old, set);
                    rows.push(Row {
                        frame,
                        width,
                        height,
                        tile_size: space.tile_size,
                        marking: space.variant.marking,
                        texture: space.variant.texture,
                        previous_tiles: old.count(),
                        tiles: set.count(),
                        kept: old.intersection_count(set),
                        reusable,
                        new,
                        windows: windows.join(" "),
                    });
                }
            }
            previous[r] = Some((frame, sets));
            study.progress.inc(1);
        }
    }
    study.output.write_rows(&rows)?;

    let mut groups: BTreeMap<CellKey, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    let window_names: Vec<String> =
        std::iter::once("all".to_string()).chain(grid.reuse_windows.iter().map(|&w| window_name(w))).collect();
    for r in &rows {
        let v = Variant { marking: r.marking, texture: r.texture };
        for w in window_names.iter().filter(|w| *w == "all" || r.windows.split(' ').any(|x| x == w.as_str())) {
            let g = groups.entry((v, r.tile_size, (r.width, r.height), w.clone())).or_default();
            g.0.extend(r.reusable);
            g.1.extend(r.new);
        }
    }
    let cells: Vec<Cell> = groups
        .iter()
        .map(|((v, tile_size, (width, height), window), (reusable, new))| Cell {
            marking: v.marking,
            texture: v.texture,
            tile_size: *tile_size,
            width: *width,
            height: *height,
            window: window.clone(),
            reusable: Summary::of(reusable),
            new: Summary::of(new),
        })
        .collect();

    let median = |s: &Option<Summary>| s.map_or("-".to_string(), |s| f3(s.median));
    let mut sections = Vec::new();
    for v in study.variants() {
        let mut header = vec!["tile", "resolution"];
        let labels: Vec<String> =
            window_names.iter().flat_map(|w| [format!("reusable {w}"), format!("new {w}")]).collect();
        header.extend(labels.iter().map(String::as_str));
        let mut table = Table::new(&header);
        for &tile_size in &grid.tile_sizes {
            for &(w, h) in &grid.resolutions {
                let mut row = vec![tile_size.to_string(), format!("{w}x{h}")];
                for name in &window_names {
                    let c = cells.iter().find(|c| {
                        c.marking == v.marking
                            && c.texture == v.texture
                            && c.tile_size == tile_size
                            && (c.width, c.height) == (w, h)
                            && &c.window == name
                    });
                    row.push(c.map_or("-".to_string(), |c| median(&c.reusable)));
                    row.push(c.map_or("-".to_string(), |c| median(&c.new)));
                }
                table.rows.push(row);
            }
        }
        let mut figures = Vec::new();
        for &tile_size in &grid.tile_sizes {
            for (measure, label) in
                [("reusable", "previous frame's tiles still needed"), ("new", "this frame's tiles not needed before")]
            {
                let series = series_per_resolution(&grid.resolutions, &rows, |r, size| {
                    let cell = r.tile_size == tile_size && (r.width, r.height) == size;
                    let value = if measure == "new" { r.new } else { r.reusable };
                    value
                        .filter(|_| cell && r.marking == v.marking && r.texture == v.texture)
                        .map(|y| (r.frame as f64, y))
                });
                let plot = LinePlot {
                    title: format!("Reuse ({measure}), tiles of {tile_size}, {v}"),
                    x_label: "path frame".into(),
                    y_label: format!("share of {label}"),
                    series,
                };
                let stem = format!("reuse-{measure}-{}-{}-tile{tile_size}", v.marking.name(), v.texture.name());
                figures.push((format!("{measure}, tiles of {tile_size}, {v}"), study.output.figure(&stem, &plot)?));
            }
        }
        sections.push(Section {
            heading: format!("Reuse: {v}"),
            text: "Median over consecutive frame pairs of the share of the previous frame's tiles still needed \
                   (reusable) and of this frame's tiles not needed before (new), over every measured pair (all) and \
                   within each window (pairs whose two frames both lie in it). Standard deviations and percentiles \
                   are in summary.json."
                .into(),
            tables: vec![(String::new(), table)],
            figures,
        });
    }
    let headline = cells
        .iter()
        .filter(|c| c.window == "all" && (c.marking == Marking::Study || c.texture == Texture::Density))
        .map(|c| {
            format!(
                "{}/{} t{} {}x{}: reusable {}, new {}",
                c.marking.name(),
                c.texture.name(),
                c.tile_size,
                c.width,
                c.height,
                median(&c.reusable),
                median(&c.new)
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    Ok(Findings {
        results: serde_json::json!({ "pairs": rows.len(), "cells": cells, "headline": format!("median reuse: {headline}") }),
        sections,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reusable_and_new_shares() {
        let a = TileSet::from_tiles(64, [1, 2, 3, 4]);
        let b = TileSet::from_tiles(64, [3, 4, 5]);
        assert_eq!(shares(&a, &b), (Some(0.5), Some(1.0 / 3.0)));
        assert_eq!(shares(&a, &a), (Some(1.0), Some(0.0)));
        assert_eq!(shares(&TileSet::new(64), &b), (None, Some(1.0)));
    }
}
