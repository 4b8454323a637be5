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

#[cfg(test)]
mod tests {
    use super::*;
    use std::thread::sleep;

    /// What [`SpanTimes::install`] sets globally, set here for one thread
    /// only: the test process has a single global subscriber, which
    /// `install_feeds_the_totals_it_returns` takes.
    fn scoped(times: &SpanTimes, f: impl FnOnce()) {
        let layer = TimesLayer { times: times.clone() }.with_filter(tracing_subscriber::filter::LevelFilter::INFO);
        tracing::subscriber::with_default(tracing_subscriber::registry().with(layer), f);
    }

    /// Enters `span` for at least `pause`, so that its time is not zero
    /// (a subtracted time then overflows, and a sum differs from a product).
    fn enter(span: &tracing::Span, pause: Duration) {
        let _entered = span.enter();
        sleep(pause);
    }

    #[test]
    fn every_entry_of_a_span_is_timed_and_counted() {
        let times = SpanTimes::default();
        scoped(&times, || {
            let outer = tracing::info_span!("outer");
            let inner = tracing::info_span!("inner");
            enter(&inner, Duration::from_millis(2));
            {
                let _outer = outer.enter();
                enter(&inner, Duration::from_millis(2));
                sleep(Duration::from_millis(8));
            }
            // Below the layer's level: not counted.
            let _debug = tracing::debug_span!("debug").entered();
        });
        // By name: which sum is larger depends on the sleeps' overshoot.
        let mut list = times.take();
        list.sort_by_key(|&(name, ..)| name);
        let counts: Vec<_> = list.iter().map(|&(name, _, count)| (name, count)).collect();
        assert_eq!(counts, [("inner", 2), ("outer", 1)], "{list:?}");
        assert!(list[0].1 >= Duration::from_millis(4), "{list:?}");
        assert!(list[1].1 >= Duration::from_millis(10), "{list:?}");
        assert!(times.take().is_empty(), "take starts afresh");
    }

    #[test]
    fn the_largest_time_comes_first_then_names_in_order() {
        let times = SpanTimes::default();
        let (long, short) = (Duration::from_millis(5), Duration::from_millis(1));
        times.totals.lock().unwrap().extend([("b", (short, 1)), ("c", (long, 2)), ("a", (short, 3))]);
        assert_eq!(times.take(), [("c", long, 2), ("a", short, 3), ("b", short, 1)]);
    }

    #[test]
    fn install_feeds_the_totals_it_returns() {
        let times = SpanTimes::install().expect("the only global subscriber of this test process");
        enter(&tracing::info_span!("installed"), Duration::from_millis(1));
        let list = times.take();
        assert!(
            list.iter().any(|&(name, time, count)| name == "installed" && count == 1 && !time.is_zero()),
            "{list:?}"
        );
        assert!(SpanTimes::install().is_none(), "a second global subscriber");
    }
}
