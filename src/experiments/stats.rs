//! The summary statistics the studies' tables report, and the least-squares
//! line behind per-light costs.

use serde::Serialize;

/// Median, standard deviation, mean, 10th and 90th percentiles of a sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub median: f64,
    /// Population standard deviation (divides by n, as numpy's default).
    pub std: f64,
    pub mean: f64,
    pub p10: f64,
    pub p90: f64,
    pub samples: usize,
}

impl Summary {
    /// `None` for an empty sample. NaNs are not expected (every measure is a
    /// finite ratio) and sort last.
    pub fn of(values: &[f64]) -> Option<Summary> {
        if values.is_empty() {
            return None;
        }
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len() as f64;
        let mean = sorted.iter().sum::<f64>() / n;
        let var = sorted.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        Some(Summary {
            median: percentile(&sorted, 50.0),
            std: var.sqrt(),
            mean,
            p10: percentile(&sorted, 10.0),
            p90: percentile(&sorted, 90.0),
            samples: sorted.len(),
        })
    }
}

/// Percentile `p` of sorted values, linearly interpolated between the
/// closest ranks (numpy's default).
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    let rank = p / 100.0 * (sorted.len() - 1) as f64;
    let (lo, hi) = (rank.floor() as usize, rank.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (rank - lo as f64)
}

/// A least-squares line `y = intercept + slope x`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LinearFit {
    pub slope: f64,
    pub intercept: f64,
    /// Coefficient of determination (1: the points lie on the line; 1 also
    /// when y does not vary).
    pub r2: f64,
    pub points: usize,
}

impl LinearFit {
    /// The ordinary least-squares fit of `points`; `None` for fewer than two
    /// distinct x values, where no slope is defined.
    pub fn of(points: &[(f64, f64)]) -> Option<LinearFit> {
        let n = points.len() as f64;
        let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
        let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
        let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
        let syy: f64 = points.iter().map(|p| (p.1 - mean_y).powi(2)).sum();
        if points.len() < 2 || sxx <= 0.0 {
            return None;
        }
        let slope = sxy / sxx;
        let r2 = if syy > 0.0 { sxy * sxy / (sxx * syy) } else { 1.0 };
        Some(LinearFit { slope, intercept: mean_y - slope * mean_x, r2, points: points.len() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_of_a_known_sample() {
        let s = Summary::of(&[4.0, 1.0, 3.0, 2.0, 5.0]).unwrap();
        assert_eq!((s.median, s.mean, s.samples), (3.0, 3.0, 5));
        assert!((s.std - 2f64.sqrt()).abs() < 1e-12);
        // Ranks 0.4 and 3.6 of 1..5.
        assert!((s.p10 - 1.4).abs() < 1e-12 && (s.p90 - 4.6).abs() < 1e-12);
        assert_eq!(Summary::of(&[]), None);
        assert_eq!(Summary::of(&[7.0]).unwrap().p90, 7.0);
    }

    #[test]
    fn linear_fit_of_known_points() {
        // On a line: y = 2 + 0.5 x.
        let f = LinearFit::of(&[(0.0, 2.0), (2.0, 3.0), (4.0, 4.0)]).unwrap();
        assert_eq!((f.slope, f.intercept, f.r2, f.points), (0.5, 2.0, 1.0, 3));
        // (0,0), (1,1), (2,1), (3,2): means 1.5, 1; Sxx 5, Sxy 3, Syy 2, so
        // slope 0.6, intercept 0.1, r² = 9 / 10.
        let f = LinearFit::of(&[(0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 2.0)]).unwrap();
        assert!((f.slope - 0.6).abs() < 1e-12 && (f.intercept - 0.1).abs() < 1e-12, "{f:?}");
        assert!((f.r2 - 0.9).abs() < 1e-12, "{f:?}");
        // Flat: slope 0, a perfect fit.
        assert_eq!(LinearFit::of(&[(1.0, 3.0), (5.0, 3.0)]).unwrap().r2, 1.0);
        assert_eq!(LinearFit::of(&[(1.0, 3.0)]), None);
        assert_eq!(LinearFit::of(&[(1.0, 3.0), (1.0, 4.0)]), None);
        assert_eq!(LinearFit::of(&[]), None);
    }
}
