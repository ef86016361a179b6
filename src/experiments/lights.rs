//! Experiment 4, `lights`: the forward/deferred study extended to every
//! pipeline. Median GPU frame time and fps against the light count in the
//! study's four scenarios (mixed at 1:5 and 1:10), and each pipeline's cost
//! per light: the slope of a least-squares line through its points.

use serde::Serialize;

use super::plot::LinePlot;
use super::report::{Section, Table};
use super::scenarios::{Scenario, study_counts};
use super::stats::LinearFit;
use super::timing::{Bench, Measurement, Shading, Status, Sweep, TimingGrid, ms_cell, series};
use super::{ExperimentError, Findings, Output};

/// The largest count of the study's own grid; ours continue to 10,000.
const STUDY_MAX: u32 = 100;

/// The grid: every pipeline, every scenario, the study's counts and ours
/// (quick: two scenarios at 1, 4 and 16 lights).
pub fn grid(quick: bool) -> TimingGrid {
    let (scenarios, counts) = if quick {
        (vec![Scenario::Small, Scenario::Mixed(5)], vec![1, 4, 16])
    } else {
        (Scenario::STUDY.to_vec(), study_counts())
    };
    let sweeps = scenarios.into_iter().map(|scenario| Sweep { scenario, counts: counts.clone() }).collect();
    TimingGrid::new(quick, Shading::pipelines(), sweeps)
}

/// Cost per light of one pipeline in one scenario.
#[derive(Clone, Debug, Serialize)]
pub struct PerLight {
    pub shading: Shading,
    pub scenario: Scenario,
    /// Over the study's counts (1-100).
    pub study_range: Option<LinearFit>,
    /// Over every measured count.
    pub all: Option<LinearFit>,
}

/// The least-squares line of frame time (ms) against light count over the
/// measured points of `shading` in `scenario` with at most `max` lights.
fn fit(rows: &[Measurement], shading: Shading, scenario: Scenario, max: u32) -> Option<LinearFit> {
    let points: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.shading == shading && r.scenario == scenario && r.lights <= max)
        .filter_map(|r| r.median_ms.map(|ms| (f64::from(r.lights), ms)))
        .collect();
    LinearFit::of(&points)
}

/// Measures every pipeline over the grid and writes `data.csv` and the figures.
pub fn run(bench: &Bench, output: Output) -> Result<Findings, ExperimentError> {
    let grid = bench.grid;
    let mut rows = Vec::new();
    for &shading in &grid.shadings {
        rows.extend(bench.measure(shading, |_, _| Ok(()))?);
    }
    output.write_rows(&rows)?;

    let mut sections = Vec::new();
    for sweep in &grid.sweeps {
        let scenario = sweep.scenario;
        let labels: Vec<String> = grid.shadings.iter().map(Shading::label).collect();
        let mut header = vec!["lights"];
        header.extend(labels.iter().map(String::as_str));
        let mut table = Table::new(&header);
        for &count in &sweep.counts {
            let mut row = vec![count.to_string()];
            for &s in &grid.shadings {
                row.push(ms_cell(rows.iter().find(|r| r.shading == s && r.scenario == scenario && r.lights == count)));
            }
            table.rows.push(row);
        }
        let mut figures = Vec::new();
        let largest = sweep.counts.last().copied().unwrap_or(0);
        let mut ranges = vec![(STUDY_MAX, format!("lights-{scenario}"), "1-100 lights, the study's range")];
        if largest > STUDY_MAX {
            ranges.push((u32::MAX, format!("lights-{scenario}-all"), "every count"));
        }
        for (max, stem, what) in ranges {
            let plot = LinePlot {
                title: format!("{scenario} lights, {}x{}: GPU frame time", grid.width, grid.height),
                x_label: "lights".into(),
                y_label: "median GPU frame time (ms)".into(),
                series: series(&rows, &grid.shadings, scenario, max),
            };
            figures.push((format!("{scenario}, {what}"), output.figure(&stem.replace(':', "-"), &plot)?));
        }
        sections.push(Section {
            heading: format!("Frame time: {scenario}"),
            text: format!(
                "Median GPU frame time in ms (fps in brackets) of each pipeline with {scenario} lights \
                 (`{}` for 12). `skipped`: a smaller count was above the {} ms cap or failed; `failed`: the GPU could not render it \
                 (data.csv's `note` says why).",
                scenario.spec(12),
                grid.cap_ms
            ),
            tables: vec![(String::new(), table)],
            figures,
        });
    }

    let per_light: Vec<PerLight> = grid
        .shadings
        .iter()
        .flat_map(|&shading| {
            let rows = &rows;
            grid.sweeps.iter().map(move |sw| PerLight {
                shading,
                scenario: sw.scenario,
                study_range: fit(rows, shading, sw.scenario, STUDY_MAX),
                all: fit(rows, shading, sw.scenario, u32::MAX),
            })
        })
        .collect();
    let names: Vec<String> = grid.sweeps.iter().map(|s| s.scenario.to_string()).collect();
    let mut header = vec!["pipeline"];
    header.extend(names.iter().map(String::as_str));
    let cost = |f: &Option<LinearFit>| f.map_or("-".into(), |f| format!("{:.2} (r² {:.2})", 1e3 * f.slope, f.r2));
    // (caption, whether the fit is over every count rather than the study's)
    let mut fits = vec![("Over the study's counts (1-100 lights):", false)];
    if grid.sweeps.iter().any(|s| s.counts.iter().any(|&n| n > STUDY_MAX)) {
        fits.push(("Over every measured count:", true));
    }
    let mut tables = Vec::new();
    for (caption, all) in fits {
        let mut t = Table::new(&header);
        for shading in &grid.shadings {
            let mut row = vec![shading.label()];
            let of_shading = per_light.iter().filter(|p| p.shading == *shading);
            row.extend(of_shading.map(|p| cost(if all { &p.all } else { &p.study_range })));
            t.rows.push(row);
        }
        tables.push((caption.to_string(), t));
    }
    sections.push(Section {
        heading: "Cost per light".into(),
        text: "Microseconds of GPU frame time per added light: the slope of the least-squares line through a \
               pipeline's median frame times against the light count (r², its coefficient of determination, says \
               how straight the points lie). Skipped points are left out of the fits."
            .into(),
        tables,
        figures: Vec::new(),
    });

    let measured = rows.iter().filter(|r| r.median_ms.is_some()).count();
    // Per scenario, the fastest pipeline at the largest count any measured.
    let fastest: Vec<String> = grid
        .sweeps
        .iter()
        .filter_map(|sw| {
            let best = |n: u32| {
                rows.iter()
                    .filter(|r| r.scenario == sw.scenario && r.lights == n)
                    .filter_map(|r| r.median_ms.map(|ms| (r, ms)))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
            };
            let (r, ms) = sw.counts.iter().rev().find_map(|&n| best(n))?;
            Some(format!("{} {} {:.2} ms", r.lights_spec, r.shading.label(), ms))
        })
        .collect();
    let headline =
        format!("{measured} of {} points measured; fastest at the most lights: {}", rows.len(), fastest.join(", "));
    Ok(Findings {
        results: serde_json::json!({
            "points": rows.len(),
            "measured": measured,
            "skipped": rows.iter().filter(|r| r.status == Status::Skipped).count(),
            "failed": rows.iter().filter(|r| r.status == Status::Failed).count(),
            "per_light": per_light,
            "headline": headline,
        }),
        sections,
    })
}

/// Where these figures differ from what the study's method would give.
pub fn differences(grid: &TimingGrid) -> Vec<String> {
    let largest = grid.sweeps.iter().flat_map(|s| s.counts.iter().copied()).max().unwrap_or(0);
    let mut counts = "Counts: the study went to 100 lights".to_string();
    if largest > STUDY_MAX {
        counts += &format!("; 200 to {largest} are ours");
    }
    counts += ", and a pipeline above the cap at one count is not run at the larger counts of that scenario.";
    vec![
        "Pipelines: the study compared multi-pass forward with deferred shading through light volumes; ours also \
         measures single-pass forward, clustered forward, tiled deferred in compute and object space, all with \
         the same lighting code."
            .into(),
        counts,
        "Mixed scenarios: a set of N lights holds round(N / (1 + R)) big shadowed lights (at least one) and small \
         ones for the rest, so that every scenario is measured at the same total count; at N below 1 + R the \
         ratio cannot hold."
            .into(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(shading: Shading, lights: u32, ms: Option<f64>) -> Measurement {
        Measurement::for_test(shading, Scenario::Small, lights, ms)
    }

    #[test]
    fn fits_leave_out_skipped_points_and_larger_counts() {
        let f = Shading::Forward;
        let rows = [row(f, 1, Some(1.5)), row(f, 3, Some(2.5)), row(f, 200, Some(50.0)), row(f, 500, None)];
        let study = fit(&rows, f, Scenario::Small, STUDY_MAX).unwrap();
        assert_eq!((study.slope, study.intercept, study.points), (0.5, 1.0, 2));
        assert_eq!(fit(&rows, f, Scenario::Small, u32::MAX).unwrap().points, 3);
        assert!(fit(&rows, Shading::Deferred, Scenario::Small, u32::MAX).is_none());
        assert_eq!(ms_cell(Some(&rows[0])), "1.500 (667)");
        assert_eq!(ms_cell(Some(&rows[3])), "skipped");
    }
}
