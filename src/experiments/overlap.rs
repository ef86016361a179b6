//! Experiment 2, `overlap`: the five fixed cameras of a scene; for each pair
//! (a, b) the tiles both need over the tiles camera a needs (the study's
//! asymmetric definition) and the intersection over union; and what one
//! atlas shared by all five views saves (tiles shaded once against the sum
//! of each view's tiles).

use serde::Serialize;

use super::marking::{Marking, Texture};
use super::plot::HeatMap;
use super::report::{Section, Table, f3};
use super::tile_set::TileSet;
use super::{ExperimentError, Findings, Study};

/// One camera pair at one resolution, tile size and variant.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub width: u32,
    pub height: u32,
    pub tile_size: u32,
    pub marking: Marking,
    pub texture: Texture,
    pub camera_a: usize,
    pub camera_b: usize,
    pub tiles_a: u64,
    pub tiles_b: u64,
    pub tiles_both: u64,
    pub tiles_either: u64,
    /// `tiles_both / tiles_a`; empty where camera a needs no tile.
    pub overlap: Option<f64>,
    /// `tiles_both / tiles_either`; empty where neither needs a tile.
    pub iou: Option<f64>,
}

/// One atlas for all views against one per view.
#[derive(Clone, Debug, Serialize)]
pub struct SharedAtlas {
    /// Tiles some view needs (each shaded once).
    pub union: u64,
    /// The sum over views of the tiles each needs.
    pub sum: u64,
    /// `1 - union / sum`.
    pub saving: Option<f64>,
}

/// One cell: the pair matrices and the shared atlas.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    pub marking: Marking,
    pub texture: Texture,
    pub tile_size: u32,
    pub width: u32,
    pub height: u32,
    pub tiles: Vec<u64>,
    /// `overlap[a][b]`: tiles both need / tiles a needs.
    pub overlap: Vec<Vec<Option<f64>>>,
    pub iou: Vec<Vec<Option<f64>>>,
    /// Mean of the overlap over pairs of different cameras.
    pub mean_overlap: Option<f64>,
    pub shared_atlas: SharedAtlas,
}

fn ratio(a: u64, b: u64) -> Option<f64> {
    (b > 0).then(|| a as f64 / b as f64)
}

/// Tiles both need / tiles `a` needs, and intersection over union.
pub fn pair_overlap(a: &TileSet, b: &TileSet) -> (Option<f64>, Option<f64>) {
    let both = a.intersection_count(b);
    (ratio(both, a.count()), ratio(both, a.count() + b.count() - both))
}

/// One atlas for all `views`: the tiles of their union against their sum.
pub fn shared_atlas(views: &[&TileSet]) -> SharedAtlas {
    let mut union = views[0].clone();
    for v in &views[1..] {
        union.union_with(v);
    }
    let (union, sum) = (union.count(), views.iter().map(|v| v.count()).sum());
    SharedAtlas { union, sum, saving: ratio(union, sum).map(|r| 1.0 - r) }
}

pub fn run(study: &mut Study) -> Result<Findings, ExperimentError> {
    let grid = study.grid;
    let cameras = study.cameras.fixed.clone();
    study.progress.set_length((cameras.len() * grid.resolutions.len()) as u64);
    let (mut rows, mut cells) = (Vec::new(), Vec::new());
    for (r, &(width, height)) in grid.resolutions.iter().enumerate() {
        // views[camera][space]
        let mut views = Vec::new();
        for camera in &cameras {
            views.push(study.tiles(camera, r)?);
            study.progress.inc(1);
        }
        for (s, space) in study.census.spaces.iter().enumerate() {
            let sets: Vec<&TileSet> = views.iter().map(|v| &v[s]).collect();
            let n = sets.len();
            let (mut overlap, mut iou) = (vec![vec![None; n]; n], vec![vec![None; n]; n]);
            for a in 0..n {
                for b in 0..n {
                    let both = sets[a].intersection_count(sets[b]);
                    let (o, u) = pair_overlap(sets[a], sets[b]);
                    (overlap[a][b], iou[a][b]) = (o, u);
                    rows.push(Row {
                        width,
                        height,
                        tile_size: space.tile_size,
                        marking: space.variant.marking,
                        texture: space.variant.texture,
                        camera_a: a,
                        camera_b: b,
                        tiles_a: sets[a].count(),
                        tiles_b: sets[b].count(),
                        tiles_both: both,
                        tiles_either: sets[a].count() + sets[b].count() - both,
                        overlap: o,
                        iou: u,
                    });
                }
            }
            let off: Vec<f64> = (0..n)
                .flat_map(|a| (0..n).filter(move |&b| b != a).map(move |b| (a, b)))
                .filter_map(|(a, b)| overlap[a][b])
                .collect();
            cells.push(Cell {
                marking: space.variant.marking,
                texture: space.variant.texture,
                tile_size: space.tile_size,
                width,
                height,
                tiles: sets.iter().map(|s| s.count()).collect(),
                mean_overlap: (!off.is_empty()).then(|| off.iter().sum::<f64>() / off.len() as f64),
                overlap,
                iou,
                shared_atlas: shared_atlas(&sets),
            });
        }
    }
    study.output.write_rows(&rows)?;

    // The heat maps' resolution: 1920x1080 where measured, else the largest.
    let heat_res = if grid.resolutions.contains(&(1920, 1080)) {
        (1920, 1080)
    } else {
        *grid.resolutions.iter().max_by_key(|(w, h)| w * h).expect("a resolution")
    };
    let labels: Vec<String> = (0..cameras.len()).map(|c| c.to_string()).collect();
    let opt = |v: Option<f64>| v.map_or("-".to_string(), f3);
    let mut sections = Vec::new();
    for v in study.variants() {
        let of_variant = |c: &&Cell| c.marking == v.marking && c.texture == v.texture;
        let mut summary =
            Table::new(&["tile", "resolution", "mean overlap (a ≠ b)", "shared atlas: union", "sum", "saving"]);
        for c in cells.iter().filter(of_variant) {
            summary.rows.push(vec![
                c.tile_size.to_string(),
                format!("{}x{}", c.width, c.height),
                opt(c.mean_overlap),
                c.shared_atlas.union.to_string(),
                c.shared_atlas.sum.to_string(),
                opt(c.shared_atlas.saving),
            ]);
        }
        let mut tables = vec![(String::new(), summary)];
        let mut figures = Vec::new();
        for c in cells.iter().filter(of_variant).filter(|c| (c.width, c.height) == heat_res) {
            let mut header = vec!["a \\ b".to_string()];
            header.extend(labels.iter().cloned());
            let mut t = Table { header, rows: Vec::new() };
            for (a, row) in c.overlap.iter().enumerate() {
                let mut cells = vec![a.to_string()];
                cells.extend(row.iter().map(|&x| opt(x)));
                t.rows.push(cells);
            }
            tables.push((
                format!("Tiles of {}, {}x{}: tiles both need / tiles a needs", c.tile_size, c.width, c.height),
                t,
            ));
            let heat = HeatMap {
                title: format!("Overlap, tiles of {}, {}x{}, {v}", c.tile_size, c.width, c.height),
                labels: labels.clone(),
                values: c.overlap.iter().map(|r| r.iter().map(|x| x.unwrap_or(0.0)).collect()).collect(),
            };
            let stem = format!("overlap-{}-{}-tile{}", v.marking.name(), v.texture.name(), c.tile_size);
            figures.push((
                format!("Tiles of {}, {}x{}, {v}", c.tile_size, c.width, c.height),
                study.output.figure(&stem, &heat)?,
            ));
        }
        sections.push(Section {
            heading: format!("Overlap: {v}"),
            text:
                "Per tile size and resolution: the mean over ordered pairs of different cameras of tiles both need / \
                   tiles camera a needs, and the tiles one atlas shared by the five views shades against the sum of \
                   each view's (saving = 1 - union / sum). The pair matrices (and intersection over union) of every \
                   cell are in summary.json and data.csv."
                    .into(),
            tables,
            figures,
        });
    }
    let headline = cells
        .iter()
        .filter(|c| c.marking == Marking::Study || c.texture == Texture::Density)
        .filter(|c| (c.width, c.height) == heat_res)
        .map(|c| {
            format!(
                "{}/{} t{}: overlap {}, saving {}",
                c.marking.name(),
                c.texture.name(),
                c.tile_size,
                opt(c.mean_overlap),
                opt(c.shared_atlas.saving)
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    Ok(Findings {
        results: serde_json::json!({
            "cameras": cameras.len(),
            "heat_map_resolution": heat_res,
            "cells": cells,
            "headline": format!("{}x{}: {headline}", heat_res.0, heat_res.1),
        }),
        sections,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_is_asymmetric_and_a_view_overlaps_itself_fully() {
        let a = TileSet::from_tiles(100, [1, 2, 3, 4]);
        let b = TileSet::from_tiles(100, [3, 4, 5, 6, 7, 8, 9, 10]);
        assert_eq!(pair_overlap(&a, &b), (Some(0.5), Some(0.2)));
        assert_eq!(pair_overlap(&b, &a), (Some(0.25), Some(0.2)));
        assert_eq!(pair_overlap(&a, &a), (Some(1.0), Some(1.0)));
        assert_eq!(pair_overlap(&TileSet::new(100), &a), (None, Some(0.0)));
        let s = shared_atlas(&[&a, &b, &a]);
        assert_eq!((s.union, s.sum), (10, 16));
        assert!((s.saving.unwrap() - 0.375).abs() < 1e-12);
    }
}
