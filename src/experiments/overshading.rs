//! Experiment 1, `overshading`: per path frame, the tiles a frame needs times
//! the tile area over the screen's pixels (texels shaded per pixel when every
//! needed tile is shaded), per variant, tile size and resolution.

use std::collections::BTreeMap;

use serde::Serialize;

use super::marking::{Marking, Texture, Variant};
use super::plot::{LinePlot, series_per_resolution};
use super::report::{Section, Table, f3};
use super::stats::Summary;
use super::{ExperimentError, Findings, Study};

/// One measurement: one frame, resolution, tile size and variant.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub frame: u32,
    pub width: u32,
    pub height: u32,
    pub tile_size: u32,
    pub marking: Marking,
    pub texture: Texture,
    pub tiles: u64,
    pub pixels: u64,
    /// `tiles * tile_size^2 / pixels`.
    pub ratio: f64,
}

/// The summary of one cell of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub marking: Marking,
    pub texture: Texture,
    pub tile_size: u32,
    pub width: u32,
    pub height: u32,
    pub ratio: Summary,
}

/// Texels per pixel when every needed tile is shaded.
pub fn overshading(tiles: u64, tile_size: u32, pixels: u64) -> f64 {
    (tiles * tile_size as u64 * tile_size as u64) as f64 / pixels as f64
}

pub fn run(study: &mut Study) -> Result<Findings, ExperimentError> {
    let grid = study.grid;
    study.progress.set_length((grid.path_frames.len() * grid.resolutions.len()) as u64);
    let mut rows = Vec::new();
    for &frame in &grid.path_frames {
        let camera = study.cameras.path_camera(frame);
        for (r, &(width, height)) in grid.resolutions.iter().enumerate() {
            let sets = study.tiles(&camera, r)?;
            let pixels = width as u64 * height as u64;
            for (space, set) in study.census.spaces.iter().zip(&sets) {
                let tiles = set.count();
                rows.push(Row {
                    frame,
                    width,
                    height,
                    tile_size: space.tile_size,
                    marking: space.variant.marking,
                    texture: space.variant.texture,
                    tiles,
                    pixels,
                    ratio: overshading(tiles, space.tile_size, pixels),
                });
            }
            study.progress.inc(1);
        }
    }
    study.output.write_rows(&rows)?;

    // Cells in variant, tile size, resolution order.
    let mut samples: BTreeMap<(Variant, u32, (u32, u32)), Vec<f64>> = BTreeMap::new();
    for r in &rows {
        let v = Variant { marking: r.marking, texture: r.texture };
        samples.entry((v, r.tile_size, (r.width, r.height))).or_default().push(r.ratio);
    }
    let cells: Vec<Cell> = samples
        .iter()
        .map(|(&(v, tile_size, (width, height)), values)| Cell {
            marking: v.marking,
            texture: v.texture,
            tile_size,
            width,
            height,
            ratio: Summary::of(values).expect("every cell has a frame"),
        })
        .collect();

    let mut sections = Vec::new();
    for v in study.variants() {
        let mut table = Table::new(&["tile", "resolution", "median", "std", "mean", "p10", "p90"]);
        for c in cells.iter().filter(|c| c.marking == v.marking && c.texture == v.texture) {
            let s = &c.ratio;
            table.rows.push(vec![
                c.tile_size.to_string(),
                format!("{}x{}", c.width, c.height),
                f3(s.median),
                f3(s.std),
                f3(s.mean),
                f3(s.p10),
                f3(s.p90),
            ]);
        }
        let mut figures = Vec::new();
        for &tile_size in &grid.tile_sizes {
            let series = series_per_resolution(&grid.resolutions, &rows, |r, size| {
                let cell = r.tile_size == tile_size && (r.width, r.height) == size;
                (cell && r.marking == v.marking && r.texture == v.texture).then_some((r.frame as f64, r.ratio))
            });
            let plot = LinePlot {
                title: format!("Overshading, tiles of {tile_size}, {v}"),
                x_label: "path frame".into(),
                y_label: "texels of needed tiles / screen pixels".into(),
                series,
            };
            let stem = format!("overshading-{}-{}-tile{tile_size}", v.marking.name(), v.texture.name());
            figures.push((format!("Tiles of {tile_size}, {v}"), study.output.figure(&stem, &plot)?));
        }
        sections.push(Section {
            heading: format!("Overshading: {v}"),
            text: "Tiles needed x tile area / screen pixels, over the path frames: median, standard deviation, mean, \
                   10th and 90th percentiles."
                .into(),
            tables: vec![(String::new(), table)],
            figures,
        });
    }
    let headline = cells
        .iter()
        .filter(|c| c.marking == Marking::Study || c.texture == Texture::Density)
        .map(|c| {
            format!(
                "{}/{} t{} {}x{}: {:.2}",
                c.marking.name(),
                c.texture.name(),
                c.tile_size,
                c.width,
                c.height,
                c.ratio.median
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    Ok(Findings {
        results: serde_json::json!({ "cells": cells, "headline": format!("median overshading: {headline}") }),
        sections,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn overshading_is_texels_per_pixel() {
        assert_eq!(super::overshading(10, 8, 640), 1.0);
        assert_eq!(super::overshading(3, 16, 256), 3.0);
    }
}
