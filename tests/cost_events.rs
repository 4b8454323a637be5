//! The costs of the frame report as `tracing` data (issue 30): a binary of
//! its own, because a `tracing` subscriber set for one thread sees events
//! only from callsites whose interest was decided while it existed, and the
//! other tests' frames on other threads would decide them first.

mod support;

use oxygen::glam::UVec2;
use oxygen::prelude::*;

/// The costs of the frame report are `tracing` data too: one "view cost"
/// event per view and one "frame cost" event per frame, under the
/// `oxygen::cost` target, with the report's numbers as fields.
#[test]
fn each_views_costs_are_tracing_events_too() {
    use std::sync::{Arc, Mutex};
    use tracing_subscriber::layer::SubscriberExt;

    /// One event's fields (the message among them), as text.
    type Event = Vec<(String, String)>;
    /// Every `oxygen::cost` event.
    #[derive(Clone, Default)]
    struct Costs(Arc<Mutex<Vec<Event>>>);
    struct Fields<'a>(&'a mut Vec<(String, String)>);
    impl tracing::field::Visit for Fields<'_> {
        fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
            self.0.push((field.name().to_owned(), format!("{value:?}")));
        }
    }
    impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Costs {
        fn on_event(&self, event: &tracing::Event<'_>, _: tracing_subscriber::layer::Context<'_, S>) {
            if event.metadata().target() == "oxygen::cost" {
                let mut fields = Vec::new();
                event.record(&mut Fields(&mut fields));
                self.0.lock().unwrap().push(fields);
            }
        }
    }

    let costs = Costs::default();
    let subscriber = tracing_subscriber::registry().with(costs.clone());
    let demo = oxygen_demo::multi_view_scene();
    let report = tracing::subscriber::with_default(subscriber, || {
        // Callsites first hit before this subscriber existed would keep
        // the interest they had then.
        tracing::callsite::rebuild_interest_cache();
        let mut renderer = support::gpu_renderer();
        renderer.register_view(oxygen_demo::main_camera(UVec2::new(32, 24)), standard_render_graph).unwrap();
        renderer.render_frame(&demo.scene).unwrap()
    });
    let events = costs.0.lock().unwrap().clone();
    let field =
        |event: &Event, name: &str| event.iter().find(|(n, _)| n == name).map(|(_, v)| v.clone()).unwrap_or_default();
    let views: Vec<_> = events.iter().filter(|e| field(e, "message") == "view cost").collect();
    let frames: Vec<_> = events.iter().filter(|e| field(e, "message") == "frame cost").collect();
    assert_eq!(views.len(), report.views.len(), "one event per view: {events:?}");
    assert_eq!(frames.len(), 1);
    for (event, view) in views.iter().zip(&report.views) {
        assert_eq!(field(event, "view"), view.view.to_string());
        assert_eq!(field(event, "draws"), view.draws.to_string());
        assert_eq!(field(event, "uploaded_bytes"), view.uploaded_bytes.to_string());
        assert_eq!(field(event, "target_bytes"), view.target_bytes.to_string());
    }
    assert_eq!(field(frames[0], "uploaded_bytes"), report.uploaded_bytes.to_string());
}
