//! The live timing graph: the GPU time of each pass over the last frames,
//! stacked, and the pipeline's latest counters. It is fed from the same
//! read-backs `bench` uses ([`crate::render::Renderer::collect_timings`] and
//! `collect_counters`), polled without waiting: a frame's figures arrive a
//! few frames after it was drawn, and the frame loop never stalls for them.

use std::collections::VecDeque;

use crate::gpu::timing::FrameTimings;
use crate::render::Counters;

/// Frames the graph shows.
pub const HISTORY_FRAMES: usize = 300;

/// The recent frames' pass times and the newest counters.
#[derive(Default)]
pub struct TimingHistory {
    frames: VecDeque<FrameTimings>,
    /// Pass names in the order first seen (stable colours and stacking).
    passes: Vec<String>,
    counters: Counters,
}

impl TimingHistory {
    /// Forgets everything (after a pipeline switch the passes differ).
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Adds the frames' timings that arrived, keeping the newest
    /// [`HISTORY_FRAMES`].
    pub fn push(&mut self, arrived: Vec<FrameTimings>) {
        for t in arrived {
            for (name, _) in &t.passes {
                if !self.passes.contains(name) {
                    self.passes.push(name.clone());
                }
            }
            self.frames.push_back(t);
            while self.frames.len() > HISTORY_FRAMES {
                self.frames.pop_front();
            }
        }
    }

    /// Keeps the newest frame's counters among those that arrived (a frame's
    /// counters may come in parts).
    pub fn push_counters(&mut self, arrived: Vec<(u64, Counters)>) {
        let Some(newest) = arrived.iter().map(|(f, _)| *f).max() else { return };
        self.counters.clear();
        for (_, c) in arrived.into_iter().filter(|(f, _)| *f == newest) {
            self.counters.extend(c);
        }
    }

    pub fn frames(&self) -> impl Iterator<Item = &FrameTimings> {
        self.frames.iter()
    }

    /// Every pass seen, in first-seen order.
    pub fn pass_names(&self) -> &[String] {
        &self.passes
    }

    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Mean GPU milliseconds per pass over the history, in first-seen order.
    pub fn mean_pass_ms(&self) -> Vec<(&str, f64)> {
        let n = self.frames.len().max(1) as f64;
        self.passes
            .iter()
            .map(|p| {
                let sum: f64 =
                    self.frames.iter().flat_map(|f| &f.passes).filter(|(q, _)| q == p).map(|(_, ms)| ms).sum();
                (p.as_str(), sum / n)
            })
            .collect()
    }

    /// Median GPU milliseconds per top-level pass over the history, in
    /// first-seen order (frames without the pass left out).
    pub fn median_pass_ms(&self) -> Vec<(String, f64)> {
        let names: Vec<&String> = self.passes.iter().filter(|p| !p.contains('/')).collect();
        names
            .into_iter()
            .map(|p| {
                let ms: Vec<f64> =
                    self.frames.iter().flat_map(|f| &f.passes).filter(|(q, _)| q == p).map(|(_, ms)| *ms).collect();
                (p.clone(), crate::bench::Summary::of(&ms).median)
            })
            .collect()
    }

    /// Mean GPU frame time over the history, ms (0 without timings).
    pub fn mean_frame_ms(&self) -> f64 {
        self.frames.iter().map(|f| f.total_ms).sum::<f64>() / self.frames.len().max(1) as f64
    }

    /// The graph's scale, ms: the 95th percentile of the frame times, so
    /// that one slow frame (the first, a rebuild) does not flatten the rest.
    pub fn graph_scale_ms(&self) -> f64 {
        let sums: Vec<f64> = self.frames.iter().map(|f| top_level(f).map(|(_, ms)| ms).sum()).collect();
        crate::bench::Summary::of(&sums).p95
    }
}

/// A frame's top-level passes (nested scopes, named `outer/inner`, are
/// already inside their outer scope's time and would count twice).
pub fn top_level(f: &FrameTimings) -> impl Iterator<Item = (&str, f64)> {
    f.passes.iter().filter(|(name, _)| !name.contains('/')).map(|(name, ms)| (name.as_str(), *ms))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(n: u64, passes: &[(&str, f64)]) -> FrameTimings {
        FrameTimings {
            frame: n,
            passes: passes.iter().map(|(p, ms)| (p.to_string(), *ms)).collect(),
            total_ms: passes.iter().map(|(_, ms)| ms).sum(),
        }
    }

    #[test]
    fn keeps_the_newest_frames_and_every_pass_name() {
        let mut h = TimingHistory::default();
        h.push((0..HISTORY_FRAMES as u64 + 10).map(|n| frame(n, &[("a", 1.0), ("b", 2.0)])).collect());
        h.push(vec![frame(1000, &[("c", 4.0), ("c/x", 1.0)])]);
        assert_eq!(h.frames().count(), HISTORY_FRAMES);
        assert_eq!(h.frames().next().map(|f| f.frame), Some(11));
        assert_eq!(h.pass_names(), ["a", "b", "c", "c/x"]);
        assert_eq!(h.graph_scale_ms(), 3.0);
    }

    #[test]
    fn counters_come_from_the_newest_frame() {
        let mut h = TimingHistory::default();
        let c = |k: &str, v: f64| [(k.to_string(), v)].into_iter().collect::<Counters>();
        h.push_counters(vec![(3, c("tiles", 1.0)), (4, c("tiles", 2.0)), (4, c("new", 5.0))]);
        assert_eq!(h.counters().get("tiles"), Some(&2.0));
        assert_eq!(h.counters().get("new"), Some(&5.0));
        h.push_counters(Vec::new());
        assert_eq!(h.counters().len(), 2);
    }
}
