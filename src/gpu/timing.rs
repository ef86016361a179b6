//! GPU time per pass from timestamp queries, read back a few frames later so
//! that the frame loop never waits for the GPU.
//!
//! Each pass asks for its `timestamp_writes`; at the end of the frame the
//! queries are resolved and copied into a read-back buffer from a pool, which
//! is mapped asynchronously. [`GpuTimer::collect`] returns the frames whose
//! results have arrived.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// Timings of one frame, in milliseconds.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameTimings {
    pub frame: u64,
    /// (pass name, GPU milliseconds), in recording order.
    pub passes: Vec<(String, f64)>,
    /// From the first pass's start to the last pass's end.
    pub total_ms: f64,
}

/// Copied into its buffer, mapping not yet asked for.
const RECORDED: u8 = 0;
const MAPPING: u8 = 1;
const MAPPED: u8 = 2;
const FAILED: u8 = 3;

struct InFlight {
    frame: u64,
    names: Vec<String>,
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
}

pub struct GpuTimer {
    queries: Option<wgpu::QuerySet>,
    capacity: u32,
    resolve: Option<wgpu::Buffer>,
    free: Vec<wgpu::Buffer>,
    in_flight: VecDeque<InFlight>,
    names: Vec<String>,
    frame: u64,
    period_ns: f64,
}

impl GpuTimer {
    /// Up to `max_passes` timed passes per frame. Without `TIMESTAMP_QUERY`
    /// the timer is inert and reports no timings.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, max_passes: u32) -> Self {
        let enabled = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let capacity = max_passes * 2;
        let queries = enabled.then(|| {
            device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: capacity,
            })
        });
        let resolve = enabled.then(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: capacity as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        });
        Self {
            queries,
            capacity,
            resolve,
            free: Vec::new(),
            in_flight: VecDeque::new(),
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
        self.names.push(name.to_string());
        self.queries.as_ref().map(|q| (q, index))
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
    /// waits on unwritten ones) into a read-back buffer. Call before `finish`.
    pub fn end_frame(&mut self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder) {
        let (Some(queries), Some(resolve)) = (&self.queries, &self.resolve) else { return };
        let n = self.names.len() as u32 * 2;
        if n == 0 {
            return;
        }
        encoder.resolve_query_set(queries, 0..n, resolve, 0);
        let buffer = self.free.pop().unwrap_or_else(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp read-back"),
                size: self.capacity as u64 * 8,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        encoder.copy_buffer_to_buffer(resolve, 0, &buffer, 0, n as u64 * 8);
        self.in_flight.push_back(InFlight {
            frame: self.frame,
            names: std::mem::take(&mut self.names),
            buffer,
            state: Arc::new(AtomicU8::new(RECORDED)),
        });
    }

    /// Starts mapping the frames submitted since the last call. Call right
    /// after `queue.submit`.
    pub fn after_submit(&mut self) {
        for f in self.in_flight.iter().filter(|f| f.state.load(Ordering::Acquire) == RECORDED) {
            f.state.store(MAPPING, Ordering::Release);
            let state = f.state.clone();
            f.buffer.map_async(wgpu::MapMode::Read, .., move |r| {
                state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
        }
    }

    /// Returns the timings that have arrived, oldest first. With `wait`, first
    /// blocks until every submitted frame's timings are in (end of a run).
    pub fn collect(&mut self, device: &wgpu::Device, wait: bool) -> Vec<FrameTimings> {
        let poll = if wait { wgpu::PollType::wait_indefinitely() } else { wgpu::PollType::Poll };
        if let Err(e) = device.poll(poll) {
            tracing::warn!("timer: poll failed: {e}");
        }
        let mut out = Vec::new();
        while let Some(f) = self.in_flight.front() {
            match f.state.load(Ordering::Acquire) {
                RECORDED | MAPPING => break,
                state => {
                    let f = self.in_flight.pop_front().expect("front exists");
                    if state == MAPPED {
                        out.push(self.decode(&f));
                        f.buffer.unmap();
                    }
                    self.free.push(f.buffer);
                }
            }
        }
        out
    }

    fn decode(&self, f: &InFlight) -> FrameTimings {
        let n = f.names.len() * 2;
        let ticks: Vec<u64> = match f.buffer.get_mapped_range(..(n as u64 * 8)) {
            Ok(view) => bytemuck::cast_slice(&view).to_vec(),
            Err(e) => {
                tracing::warn!("timer: cannot read timestamps: {e}");
                return FrameTimings { frame: f.frame, ..Default::default() };
            }
        };
        let ms = |a: u64, b: u64| b.saturating_sub(a) as f64 * self.period_ns * 1e-6;
        let passes = f.names.iter().enumerate().map(|(i, name)| (name.clone(), ms(ticks[2 * i], ticks[2 * i + 1]))).collect();
        let total_ms = ms(ticks[0], ticks[n - 1]);
        FrameTimings { frame: f.frame, passes, total_ms }
    }
}
