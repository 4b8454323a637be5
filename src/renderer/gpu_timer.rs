//! The GPU time of whole frames and of each view's recording job, for
//! reports and the viewer's title bar: a timestamp written before the
//! frame's first command buffer and one after its last, and one at the
//! start and end of each job's command buffer (a view, or a batch's
//! cameras together), read back without waiting, so a report carries the
//! times of a frame one or two before it.

use oxygen_core::ViewId;

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
    /// Per job of the timed frame: two timestamps (start, end).
    jobs: Option<JobTimestamps>,
    /// The first view of each job of the frame in flight, in job order.
    timed_jobs: Vec<ViewId>,
    /// The latest GPU time of each job, under its first view.
    last_jobs: oxygen_core::ViewIdMap<f64>,
}

/// The jobs' timestamps: a query set with room for `capacity` jobs and the
/// buffers it resolves and is read back through.
struct JobTimestamps {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    capacity: usize,
}

impl JobTimestamps {
    /// The most jobs one query set times (wgpu's limit on a set's queries).
    const MAX_JOBS: usize = wgpu::QUERY_SET_MAX_QUERIES as usize / 2;

    fn new(device: &wgpu::Device, capacity: usize) -> Self {
        let bytes = (capacity * 16) as u64;
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage,
                mapped_at_creation: false,
            })
        };
        JobTimestamps {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("job timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: (capacity * 2) as u32,
            }),
            resolve: buffer("job timestamps", wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
            readback: buffer("job timestamps readback", wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ),
            capacity,
        }
    }
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
            jobs: None,
            timed_jobs: Vec::new(),
            last_jobs: oxygen_core::ViewIdMap::default(),
        })
    }

    /// Collects a finished readback (never waits) and returns the latest
    /// frame time known.
    pub(crate) fn collect(&mut self) -> Option<f64> {
        match self.state.load(Ordering::Acquire) {
            MAPPED => {
                if let Ok(bytes) = self.readback.slice(..).get_mapped_range()
                    && let Some(seconds) = span_seconds(&bytes, 0, self.period_ns)
                {
                    self.last_seconds = Some(seconds);
                }
                self.readback.unmap();
                if let Some(jobs) = &self.jobs
                    && !self.timed_jobs.is_empty()
                {
                    let n = self.timed_jobs.len();
                    if let Ok(bytes) = jobs.readback.slice(..(n * 16) as u64).get_mapped_range() {
                        for (j, view) in self.timed_jobs.iter().enumerate() {
                            if let Some(seconds) = span_seconds(&bytes, j, self.period_ns) {
                                self.last_jobs.insert(*view, seconds);
                            }
                        }
                    }
                    jobs.readback.unmap();
                }
                self.timed_jobs.clear();
                self.state.store(IDLE, Ordering::Release);
            }
            // Recorded but never submitted (a frame that failed).
            COPIED => {
                self.timed_jobs.clear();
                self.state.store(IDLE, Ordering::Release);
            }
            // The jobs' mapping may be anywhere: a new set of buffers.
            FAILED => {
                self.timed_jobs.clear();
                self.jobs = None;
                self.state.store(IDLE, Ordering::Release);
            }
            _ => {}
        }
        self.last_seconds
    }

    /// The latest GPU time of the job `view` was the first view of (a
    /// view's own, or its batch's for a batch's first camera), one or two
    /// frames old; `None` when not timed yet.
    pub(crate) fn job_seconds(&self, view: ViewId) -> Option<f64> {
        self.last_jobs.get(&view).copied()
    }

    /// Makes room for the timestamps of up to `jobs` jobs (a frame has no
    /// more jobs than views), when one query set can hold them.
    pub(crate) fn reserve_jobs(&mut self, device: &wgpu::Device, jobs: usize) {
        let jobs = jobs.clamp(1, JobTimestamps::MAX_JOBS);
        if self.ready() && self.jobs.as_ref().is_none_or(|j| j.capacity < jobs) {
            let capacity = jobs.next_power_of_two().min(JobTimestamps::MAX_JOBS);
            self.jobs = Some(JobTimestamps::new(device, capacity));
        }
    }

    /// The query set a frame of `jobs` jobs writes their timestamps into
    /// (`2j` and `2j + 1` for job `j`), when it has room for them.
    pub(crate) fn job_queries(&self, jobs: usize) -> Option<&wgpu::QuerySet> {
        self.jobs.as_ref().filter(|j| jobs > 0 && j.capacity >= jobs).map(|j| &j.queries)
    }

    /// The first view of each job the frame just submitted timed, in job
    /// order: whose times its readback gives.
    pub(crate) fn time_jobs(&mut self, first_views: Vec<ViewId>) {
        self.timed_jobs = first_views;
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
    pub(crate) fn end(&self, device: &wgpu::Device, jobs: usize) -> wgpu::CommandBuffer {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame end") });
        encoder.write_timestamp(&self.queries, 1);
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16);
        if let Some(timestamps) = self.jobs.as_ref().filter(|j| jobs > 0 && j.capacity >= jobs) {
            encoder.resolve_query_set(&timestamps.queries, 0..(2 * jobs) as u32, &timestamps.resolve, 0);
            encoder.copy_buffer_to_buffer(&timestamps.resolve, 0, &timestamps.readback, 0, (jobs * 16) as u64);
        }
        self.state.store(COPIED, Ordering::Release);
        encoder.finish()
    }

    /// Starts mapping the copy made by [`Self::end`].
    pub(crate) fn submitted(&self, jobs: usize) {
        if self.state.compare_exchange(COPIED, MAPPING, Ordering::AcqRel, Ordering::Acquire).is_ok() {
            let state = Arc::clone(&self.state);
            // The jobs' copy is mapped first: the frame's mapping, whose
            // callback says both arrived, comes after it on the same queue.
            if let Some(timestamps) = self.jobs.as_ref().filter(|j| jobs > 0 && j.capacity >= jobs) {
                timestamps.readback.slice(..(jobs * 16) as u64).map_async(wgpu::MapMode::Read, |_| {});
            }
            self.readback.slice(..).map_async(wgpu::MapMode::Read, move |result| {
                state.store(if result.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
        }
    }
}

/// Seconds between timestamps `2 * span` (start) and `2 * span + 1` (end)
/// of a query readback (little-endian u64 ticks of `period_ns` each);
/// `None` when the end precedes the start (a wrapped or reset counter) or
/// the bytes hold no such pair.
fn span_seconds(bytes: &[u8], span: usize, period_ns: f64) -> Option<f64> {
    let tick = |i: usize| -> Option<u64> {
        let word = bytes.get(i * 8..i * 8 + 8)?;
        Some(u64::from_le_bytes(word.try_into().ok()?))
    };
    let (start, end) = (tick(2 * span)?, tick(2 * span + 1)?);
    (end >= start).then(|| (end - start) as f64 * period_ns * 1e-9)
}

#[cfg(test)]
mod tests {
    use super::span_seconds;

    fn ticks(values: &[u64]) -> Vec<u8> {
        values.iter().flat_map(|t| t.to_le_bytes()).collect()
    }

    #[test]
    fn a_span_is_its_ticks_apart_times_the_period() {
        // Two spans: 1 000 ticks of 2.5 ns, and 40 ticks of 1 ns.
        let bytes = ticks(&[5_000, 6_000, 100, 140]);
        assert_eq!(span_seconds(&bytes, 0, 2.5), Some(1_000.0 * 2.5e-9));
        assert_eq!(span_seconds(&bytes, 1, 1.0), Some(40e-9));
        assert_eq!(span_seconds(&ticks(&[7, 7]), 0, 1.0), Some(0.0), "an empty span");
    }

    #[test]
    fn a_span_that_ends_before_it_starts_or_is_missing_has_no_time() {
        assert_eq!(span_seconds(&ticks(&[10, 9]), 0, 1.0), None, "a wrapped or reset counter");
        assert_eq!(span_seconds(&ticks(&[1, 2]), 1, 1.0), None, "past the readback");
        assert_eq!(span_seconds(&ticks(&[1, 2])[..12], 0, 1.0), None, "a cut-off word");
    }
}
