//! The GPU time of whole frames, for reports and the viewer's title bar:
//! a timestamp written before the frame's first command buffer and one after
//! its last, read back without waiting, so a report carries the time of a
//! frame one or two before it.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

const IDLE: u8 = 0;
const COPIED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;
const FAILED: u8 = 4;

/// Frame timestamps, where the device can write them between commands.
pub(crate) struct GpuTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    state: Arc<AtomicU8>,
    period_ns: f64,
    last_seconds: Option<f64>,
}

impl GpuTimer {
    /// The features it needs.
    pub(crate) const FEATURES: wgpu::Features =
        wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);

    /// A timer, or `None` on a device without those features.
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue, features: wgpu::Features) -> Option<Self> {
        if !features.contains(Self::FEATURES) {
            return None;
        }
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(GpuTimer {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: buffer("frame timestamps", wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
            readback: buffer("frame timestamps readback", wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ),
            state: Arc::new(AtomicU8::new(IDLE)),
            period_ns: f64::from(queue.get_timestamp_period()),
            last_seconds: None,
        })
    }

    /// Collects a finished readback (never waits) and returns the latest
    /// frame time known.
    pub(crate) fn collect(&mut self) -> Option<f64> {
        match self.state.load(Ordering::Acquire) {
            MAPPED => {
                if let Ok(bytes) = self.readback.slice(..).get_mapped_range() {
                    let tick = |i: usize| {
                        let mut word = [0u8; 8];
                        word.copy_from_slice(&bytes[i * 8..i * 8 + 8]);
                        u64::from_le_bytes(word)
                    };
                    let ticks = [tick(0), tick(1)];
                    // A frame whose end precedes its start (a wrapped or reset
                    // counter) is not reported.
                    if ticks[1] >= ticks[0] {
                        self.last_seconds = Some((ticks[1] - ticks[0]) as f64 * self.period_ns * 1e-9);
                    }
                }
                self.readback.unmap();
                self.state.store(IDLE, Ordering::Release);
            }
            // Recorded but never submitted (a frame that failed).
            FAILED | COPIED => self.state.store(IDLE, Ordering::Release),
            _ => {}
        }
        self.last_seconds
    }

    /// Whether this frame is timed (the last readback has been collected).
    pub(crate) fn ready(&self) -> bool {
        self.state.load(Ordering::Acquire) == IDLE
    }

    /// A command buffer writing the start timestamp: submit before the frame.
    pub(crate) fn start(&self, device: &wgpu::Device) -> wgpu::CommandBuffer {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame start") });
        encoder.write_timestamp(&self.queries, 0);
        encoder.finish()
    }

    /// A command buffer writing the end timestamp and copying both for
    /// reading back: submit after the frame, then call [`Self::submitted`].
    pub(crate) fn end(&self, device: &wgpu::Device) -> wgpu::CommandBuffer {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame end") });
        encoder.write_timestamp(&self.queries, 1);
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16);
        self.state.store(COPIED, Ordering::Release);
        encoder.finish()
    }

    /// Starts mapping the copy made by [`Self::end`].
    pub(crate) fn submitted(&self) {
        if self.state.compare_exchange(COPIED, MAPPING, Ordering::AcqRel, Ordering::Acquire).is_ok() {
            let state = Arc::clone(&self.state);
            self.readback.slice(..).map_async(wgpu::MapMode::Read, move |result| {
                state.store(if result.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
        }
    }
}
