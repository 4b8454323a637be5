//! Where a bench's CPU time goes: a `tracing` layer that adds up, per span
//! name, the time spent inside spans of that name (every thread, every
//! entry: an instrumented future counts only while it is being polled).
//!
//! Oxygen puts a span on every phase of a frame, so the sums break a
//! frame's CPU time down on any machine, the device machine included,
//! without a profiler. Nested spans are counted in their own name and in
//! every enclosing one: read the figures as "time inside", not "time
//! exclusive to".
//!
//! ```no_run
//! let times = oxygen_demo::span_times::SpanTimes::install().expect("no other subscriber is set");
//! // ... frames ...
//! for (name, total, entries) in times.take() {
//!     println!("{name}: {total:?} in {entries} entries");
//! }
//! ```

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use tracing::span;
use tracing::subscriber::Subscriber;
use tracing_subscriber::layer::{Context, Layer};
use tracing_subscriber::prelude::*;
use tracing_subscriber::registry::LookupSpan;

/// The running totals, shared between the layer and the bench.
#[derive(Clone, Default)]
pub struct SpanTimes {
    totals: Arc<Mutex<HashMap<&'static str, (Duration, u64)>>>,
}

/// When the current entry of a span began (kept in the span's extensions).
struct Entered(Instant);

/// The layer feeding a [`SpanTimes`].
struct TimesLayer {
    times: SpanTimes,
}

impl<S: Subscriber + for<'a> LookupSpan<'a>> Layer<S> for TimesLayer {
    fn on_enter(&self, id: &span::Id, ctx: Context<'_, S>) {
        if let Some(span) = ctx.span(id) {
            span.extensions_mut().replace(Entered(Instant::now()));
        }
    }

    fn on_exit(&self, id: &span::Id, ctx: Context<'_, S>) {
        let Some(span) = ctx.span(id) else { return };
        let Some(Entered(at)) = span.extensions_mut().remove::<Entered>() else { return };
        let mut totals = self.times.totals.lock().unwrap_or_else(PoisonError::into_inner);
        let entry = totals.entry(span.name()).or_default();
        entry.0 += at.elapsed();
        entry.1 += 1;
    }
}

impl SpanTimes {
    /// Installs the layer as the global subscriber (info level and above:
    /// the frame's phase spans) and returns its totals. Fails, returning
    /// `None`, where a global subscriber is already set.
    pub fn install() -> Option<SpanTimes> {
        let times = SpanTimes::default();
        let layer = TimesLayer { times: times.clone() }.with_filter(tracing_subscriber::filter::LevelFilter::INFO);
        tracing_subscriber::registry().with(layer).try_init().ok()?;
        Some(times)
    }

    /// The totals since the last call, largest first (name, time inside,
    /// entries), and a fresh start.
    pub fn take(&self) -> Vec<(&'static str, Duration, u64)> {
        let mut totals = self.totals.lock().unwrap_or_else(PoisonError::into_inner);
        let mut list: Vec<_> = totals.drain().map(|(name, (time, count))| (name, time, count)).collect();
        list.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
        list
    }
}
