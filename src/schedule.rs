//! When a view renders: its [`Schedule`], and why a frame rendered it
//! ([`RenderReason`]) or left it idle ([`IdleReason`]).
//!
//! A view that does not render in a frame keeps what it rendered last: its
//! targets hold its last images, `read_color` and the other readbacks
//! return them, and views linked to it read them unchanged. A schedule
//! saves the view's whole cost (no culling, no recording, no GPU work), not
//! only its drawing.

use oxygen_core::{NodeKey, ViewId};

/// When a registered view renders ([`crate::ViewDesc::with_schedule`],
/// [`crate::Renderer::set_schedule`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Schedule {
    /// Every frame (the default).
    #[default]
    EveryFrame,
    /// Its first frame, then every `n`-th frame after it (`n` ≥ 1): with
    /// `EveryNth(3)` a view first rendered in frame 1 renders in frames 1,
    /// 4, 7, …
    EveryNth(u32),
    /// At a rate of `hz` renders a second of frame time (the time resolvers
    /// are told: wall-clock seconds since the renderer started, or the time
    /// given to [`crate::Renderer::render_frame_at`]), as a sensor samples:
    /// its first frame, then the first frame at or after each period, the
    /// periods counted from the first one so the average rate holds (a
    /// frame that falls far behind starts the count again).
    Rate(f64),
    /// Its first frame, then only when asked ([`crate::Renderer::request_render`]).
    Once,
    /// Only when asked ([`crate::Renderer::request_render`]), not even a first frame.
    OnDemand,
    /// Its first frame, then whenever something that could change its
    /// picture changed ([`Change`]), or when asked.
    WhenChanged,
}

impl Schedule {
    /// Why the schedule cannot be used, if it cannot: a count of 0 or a
    /// rate that is not a positive finite number.
    pub fn problem(&self) -> Option<String> {
        match *self {
            Schedule::EveryNth(0) => Some("every 0th frame: the count must be at least 1".into()),
            Schedule::Rate(hz) if !(hz.is_finite() && hz > 0.0) => {
                Some(format!("a rate of {hz} Hz: it must be a positive finite number"))
            }
            _ => None,
        }
    }
}

/// Why a view rendered in a frame ([`crate::ViewReport::why`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderReason {
    /// Its schedule is [`Schedule::EveryFrame`].
    EveryFrame,
    /// It had not rendered yet.
    FirstFrame,
    /// Its [`Schedule::EveryNth`] or [`Schedule::Rate`] came due.
    Due,
    /// The application asked for it ([`crate::Renderer::request_render`]).
    Requested,
    /// Something that could change its picture changed
    /// ([`Schedule::WhenChanged`]).
    Changed(Change),
}

/// What changed for a [`Schedule::WhenChanged`] view. When several things
/// changed, the first found is named.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Change {
    /// Its camera moved, turned or changed its projection or size.
    Camera,
    /// A renderable node whose bounds (before or after the change) meet
    /// its frustum moved or changed (its mesh, materials, flags, skin or
    /// morph weights), or was added or removed.
    Node(NodeKey),
    /// A light moved or changed (any light: a light's reach is not
    /// bounded tightly enough to leave a view out).
    Light(NodeKey),
    /// A scene-wide asset changed (a material replaced, a geometry or
    /// texture added) or the renderer's environment did.
    Assets,
    /// A view (or probe face) it reads rendered this frame.
    Input(ViewId),
    /// It was left out of the frames before this one (paused, or its
    /// resolver failed), when nothing was watched for it.
    Unwatched,
}

/// Why a view did not render in a frame ([`crate::FrameReport::idle`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IdleReason {
    /// Its [`Schedule::EveryNth`] is not due; it next renders in frame
    /// `next_frame`.
    NotDue {
        /// The frame it renders next.
        next_frame: u64,
    },
    /// Its [`Schedule::Rate`] is not due; it next renders at or after
    /// `next_seconds` of frame time.
    RateNotDue {
        /// Frame time of its next render.
        next_seconds: f64,
    },
    /// [`Schedule::Once`] (after its first frame) or [`Schedule::OnDemand`],
    /// and not asked for.
    NotRequested,
    /// [`Schedule::WhenChanged`], and nothing it shows changed.
    Unchanged,
    /// Due, but the frame budget ([`FrameBudget`]) went to views of higher
    /// priority; deferred `frames` frames in a row so far (it renders, over
    /// the budget if need be, once [`FrameBudget::max_deferral`] is reached).
    Deferred {
        /// Frames in a row it has been deferred, this one included.
        frames: u32,
    },
}

/// A budget of CPU and GPU time per frame for the registered views
/// ([`crate::Renderer::set_frame_budget`]). The views due in a frame are
/// taken in order of priority ([`crate::ViewDesc::with_priority`], highest
/// first; among equals, the one deferred longest, then the lower id), each
/// at its estimated cost (its own CPU prepare and record time plus GPU
/// time, averaged over the frames it rendered since the budget was set; a
/// view not measured yet counts the mean of those that were), until the
/// next would pass
/// the budget; the rest are deferred to a later frame. The first view is
/// always taken, and a view deferred `max_deferral` frames in a row is
/// taken before all others, so every view renders within a bounded number
/// of frames whatever the budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameBudget {
    /// Seconds of CPU and GPU time a frame's views may take together.
    pub seconds: f64,
    /// Frames in a row a due view may be deferred before it renders over
    /// the budget (at least 1).
    pub max_deferral: u32,
}

impl FrameBudget {
    /// A budget of `seconds` a frame, a view deferred at most 8 frames in a row.
    pub fn new(seconds: f64) -> Self {
        FrameBudget { seconds, max_deferral: 8 }
    }

    /// Why the budget cannot be used, if it cannot: seconds that are not a
    /// finite number of at least 0, or a deferral bound of 0.
    pub fn problem(&self) -> Option<String> {
        if !(self.seconds.is_finite() && self.seconds >= 0.0) {
            return Some(format!("a frame budget of {} s: it must be a finite number of at least 0", self.seconds));
        }
        (self.max_deferral == 0).then(|| "a frame budget deferring views at most 0 frames: use at least 1".into())
    }
}

/// A view a frame left idle, and why ([`crate::FrameReport::idle`]).
#[derive(Clone, Debug, PartialEq)]
pub struct IdleView {
    /// The view.
    pub view: ViewId,
    /// Its name, if it has one.
    pub name: Option<String>,
    /// Why it did not render.
    pub reason: IdleReason,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_rates_that_cannot_schedule_are_named() {
        assert!(Schedule::EveryNth(0).problem().is_some());
        assert!(Schedule::EveryNth(1).problem().is_none());
        for hz in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(Schedule::Rate(hz).problem().is_some(), "{hz}");
        }
        assert!(Schedule::Rate(30.0).problem().is_none());
        assert!(FrameBudget::new(0.004).problem().is_none());
        assert!(FrameBudget::new(0.0).problem().is_none());
        assert!(FrameBudget::new(-1.0).problem().is_some());
        assert!(FrameBudget::new(f64::NAN).problem().is_some());
        assert!(FrameBudget { max_deferral: 0, ..FrameBudget::new(1.0) }.problem().is_some());
        assert_eq!(Schedule::default(), Schedule::EveryFrame);
    }
}
