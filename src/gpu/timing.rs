//! GPU time per pass, through `wgpu-profiler` (timestamp queries written by
//! each pass, resolved at the end of the frame, read back a few frames later
//! so that the frame loop never waits for the GPU). Its results also export
//! as a Chrome trace (`render --trace`).

use std::collections::VecDeque;
use std::path::Path;

use wgpu_profiler::{GpuProfiler, GpuProfilerSettings, GpuTimerQueryResult};

/// What a frame's GPU timestamps time (`--timing`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum GpuTiming {
    /// Every pass (and the stages of object space's chain pass) between its
    /// own two timestamps: the per-pass breakdown, and the frame from the
    /// first pass's start to the last pass's end. The timestamps cost time
    /// of their own, so a pipeline of more passes pays more: on the H100
    /// about 0.014 ms of `deferred-compute`'s frame (6 passes) and 0.038 of
    /// object space's at 1920x1080 (BENCHMARKS.md, "Object space in one
    /// pass").
    #[default]
    Passes,
    /// Two timestamps a frame, around all of its work, timed as `frame`:
    /// the frame's time without the per-pass timestamps' own cost; no
    /// breakdown. For comparing pipelines' frame times.
    Frame,
}

/// Timings of one frame, in milliseconds.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameTimings {
    pub frame: u64,
    /// (pass name, GPU milliseconds), in recording order.
    pub passes: Vec<(String, f64)>,
    /// From the first pass's start to the last pass's end.
    pub total_ms: f64,
}

/// Frames whose timings may be in flight at once. The profiler drops frames
/// beyond this; a benchmark submits frames faster than a slow pipeline
/// finishes them and must lose none, so the bound is far above any run's
/// backlog (each pending frame holds one small query set).
const MAX_PENDING_FRAMES: usize = 4096;

pub struct GpuTimer {
    profiler: GpuProfiler,
    enabled: bool,
    /// Frame numbers of the frames handed to the profiler, oldest first.
    pending: VecDeque<u64>,
    period: f32,
    /// The raw results of the newest collected frame (for trace export).
    last: Option<Vec<GpuTimerQueryResult>>,
}

impl GpuTimer {
    /// Without `TIMESTAMP_QUERY` the timer records nothing and reports no timings.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let enabled = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let settings = GpuProfilerSettings {
            enable_timer_queries: enabled,
            max_num_pending_frames: MAX_PENDING_FRAMES,
            ..Default::default()
        };
        let profiler = GpuProfiler::new(device, settings).expect("profiler settings are valid");
        Self { profiler, enabled, pending: VecDeque::new(), period: queue.get_timestamp_period(), last: None }
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// The profiler that passes open their timing scopes on.
    pub fn profiler(&self) -> &GpuProfiler {
        &self.profiler
    }

    /// Resolves this frame's queries. Call before the encoder is finished.
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.profiler.resolve_queries(encoder);
    }

    /// Ends frame `frame` and starts its read-back. Call right after `queue.submit`.
    pub fn end_frame(&mut self, frame: u64) {
        match self.profiler.end_frame() {
            Ok(()) => self.pending.push_back(frame),
            Err(e) => tracing::warn!("timer: frame {frame} not timed: {e}"),
        }
    }

    /// The timings that have arrived, oldest first; `wait` waits for all.
    pub fn collect(&mut self, device: &wgpu::Device, wait: bool) -> Vec<FrameTimings> {
        let poll = if wait { wgpu::PollType::wait_indefinitely() } else { wgpu::PollType::Poll };
        if let Err(e) = device.poll(poll) {
            tracing::warn!("timer: poll failed: {e}");
        }
        let mut out = Vec::new();
        self.take_finished(&mut out);
        // Another thread polling the same device (tests share one; so may an
        // embedding program) can be running a frame's mapping callbacks when
        // this thread's wait returns, as `readback::settled` says: wait for
        // them rather than lose the frame's timings (a timing study's row
        // once came back one frame short under four tests at once). Gives
        // up after ten seconds.
        let start = std::time::Instant::now();
        while wait && !self.pending.is_empty() && start.elapsed() < std::time::Duration::from_secs(10) {
            std::thread::yield_now();
            let _ = device.poll(wgpu::PollType::Poll);
            self.take_finished(&mut out);
        }
        out
    }

    /// Appends the timings of the frames whose read-back has finished, oldest first.
    fn take_finished(&mut self, out: &mut Vec<FrameTimings>) {
        while let Some(results) = self.profiler.process_finished_frame(self.period) {
            let frame = self.pending.pop_front().expect("one pending frame number per profiler frame");
            if self.enabled {
                out.push(decode(frame, &results));
                self.last = Some(results);
            }
        }
    }

    /// Writes the newest collected frame as a Chrome trace (chrome://tracing,
    /// Perfetto). Returns false when no frame has been collected.
    pub fn write_trace(&self, path: &Path) -> std::io::Result<bool> {
        match &self.last {
            Some(results) => wgpu_profiler::chrometrace::write_chrometrace(path, results).map(|()| true),
            None => Ok(false),
        }
    }
}

/// Flattens one frame's scopes into (name, ms) in recording order; nested
/// scopes are named `outer/inner`.
fn decode(frame: u64, results: &[GpuTimerQueryResult]) -> FrameTimings {
    fn walk(prefix: &str, results: &[GpuTimerQueryResult], out: &mut Vec<(String, f64)>, span: &mut (f64, f64)) {
        for r in results {
            let name = if prefix.is_empty() { r.label.clone() } else { format!("{prefix}/{}", r.label) };
            if let Some(t) = &r.time {
                out.push((name.clone(), (t.end - t.start) * 1e3));
                span.0 = span.0.min(t.start);
                span.1 = span.1.max(t.end);
            }
            walk(&name, &r.nested_queries, out, span);
        }
    }
    let mut passes = Vec::new();
    let mut span = (f64::INFINITY, f64::NEG_INFINITY);
    walk("", results, &mut passes, &mut span);
    let total_ms = if span.1 >= span.0 { (span.1 - span.0) * 1e3 } else { 0.0 };
    FrameTimings { frame, passes, total_ms }
}
