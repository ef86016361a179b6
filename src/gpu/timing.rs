//! GPU time per pass from timestamp queries, read back a few frames later so
//! that the frame loop never waits for the GPU.
//!
//! Each pass asks for its `timestamp_writes`; at the end of the frame the
//! queries are resolved and copied out through a [`ReadbackRing`], and
//! [`GpuTimer::collect`] returns the frames whose results have arrived.

use super::readback::ReadbackRing;

/// Timings of one frame, in milliseconds.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameTimings {
    pub frame: u64,
    /// (pass name, GPU milliseconds), in recording order.
    pub passes: Vec<(String, f64)>,
    /// From the first pass's start to the last pass's end.
    pub total_ms: f64,
}

pub struct GpuTimer {
    queries: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    capacity: u32,
    ring: ReadbackRing<(u64, Vec<String>)>,
    names: Vec<String>,
    frame: u64,
    period_ns: f64,
}

impl GpuTimer {
    /// Up to `max_passes` timed passes per frame. Without `TIMESTAMP_QUERY`
    /// the timer is inert and reports no timings.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, max_passes: u32) -> Self {
        let capacity = max_passes * 2;
        let queries = device.features().contains(wgpu::Features::TIMESTAMP_QUERY).then(|| {
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: capacity,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: capacity as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        });
        Self {
            queries,
            capacity,
            ring: ReadbackRing::new("timestamp read-back", capacity as u64 * 8),
            names: Vec::new(),
            frame: 0,
            period_ns: queue.get_timestamp_period() as f64,
        }
    }

    pub fn enabled(&self) -> bool {
        self.queries.is_some()
    }

    pub fn begin_frame(&mut self, frame: u64) {
        self.frame = frame;
        self.names.clear();
    }

    fn next_pair(&mut self, name: &str) -> Option<(&wgpu::QuerySet, u32)> {
        let index = self.names.len() as u32 * 2;
        if index + 2 > self.capacity {
            tracing::warn!("timer: more than {} passes in a frame; '{name}' is not timed", self.capacity / 2);
            return None;
        }
        let (set, _) = self.queries.as_ref()?;
        self.names.push(name.to_string());
        Some((set, index))
    }

    pub fn compute_pass(&mut self, name: &str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.next_pair(name).map(|(query_set, i)| wgpu::ComputePassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    pub fn render_pass(&mut self, name: &str) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.next_pair(name).map(|(query_set, i)| wgpu::RenderPassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    /// Resolves this frame's queries (only those written: the Vulkan backend
    /// waits on unwritten ones) and queues their read-back. Call before `finish`.
    pub fn end_frame(&mut self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder) {
        let Some((set, resolve)) = &self.queries else { return };
        let n = self.names.len() as u32 * 2;
        if n == 0 {
            return;
        }
        encoder.resolve_query_set(set, 0..n, resolve, 0);
        self.ring.copy(device, encoder, resolve, n as u64 * 8, (self.frame, std::mem::take(&mut self.names)));
    }

    /// Starts mapping this frame's read-back. Call right after `queue.submit`.
    pub fn after_submit(&mut self) {
        self.ring.after_submit();
    }

    /// The timings that have arrived, oldest first; `wait` waits for all.
    pub fn collect(&mut self, device: &wgpu::Device, wait: bool) -> Vec<FrameTimings> {
        self.ring
            .collect(device, wait)
            .into_iter()
            .map(|((frame, names), bytes)| self.decode(frame, names, &bytes))
            .collect()
    }

    fn decode(&self, frame: u64, names: Vec<String>, bytes: &[u8]) -> FrameTimings {
        // Copied bytes carry no alignment guarantee: decode rather than cast.
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(bytes);
        let ms = |a: u64, b: u64| b.saturating_sub(a) as f64 * self.period_ns * 1e-6;
        let total_ms = ms(ticks[0], ticks[ticks.len() - 1]);
        let passes =
            names.into_iter().enumerate().map(|(i, name)| (name, ms(ticks[2 * i], ticks[2 * i + 1]))).collect();
        FrameTimings { frame, passes, total_ms }
    }
}
