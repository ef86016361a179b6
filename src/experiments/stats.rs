//! The summary statistics the study's tables report.

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
}
