//! Which views of a frame have finished recording: how a view awaits
//! another view's output.

use oxygen_core::ViewId;

/// Which views of a frame have finished recording. Awaiting an input waits
/// here; the renderer marks each view when its graph returns.
pub struct FrameProgress {
    state: std::sync::Mutex<ProgressState>,
}

struct ProgressState {
    /// A set, not a list: a batch of a thousand cameras completes a
    /// thousand views a frame.
    pending: oxygen_core::ViewIdSet,
    wakers: Vec<std::task::Waker>,
}

impl FrameProgress {
    /// Progress of a frame in which `recording` will record; any other view
    /// counts as recorded already (it keeps its last image).
    pub fn new(recording: impl IntoIterator<Item = ViewId>) -> Self {
        FrameProgress {
            state: std::sync::Mutex::new(ProgressState {
                pending: recording.into_iter().collect(),
                wakers: Vec::new(),
            }),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, ProgressState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Marks `view` recorded and wakes whoever awaits it.
    pub fn complete(&self, view: ViewId) {
        let wakers = {
            let mut state = self.lock();
            state.pending.remove(&view);
            std::mem::take(&mut state.wakers)
        };
        wakers.into_iter().for_each(std::task::Waker::wake);
    }

    /// Whether every view of `views` has recorded (or is not recording).
    pub fn all_recorded(&self, views: &[ViewId]) -> bool {
        let state = self.lock();
        !views.iter().any(|v| state.pending.contains(v))
    }

    /// Whether `view` still has to record.
    pub fn is_pending(&self, view: ViewId) -> bool {
        self.lock().pending.contains(&view)
    }

    /// Resolves once every view of `views` has recorded.
    pub fn recorded<'p>(&'p self, views: &'p [ViewId]) -> impl std::future::Future<Output = ()> + 'p {
        std::future::poll_fn(move |cx| {
            let mut state = self.lock();
            if views.iter().any(|v| state.pending.contains(v)) {
                // Woken on every completion; re-checked then. One waker per
                // task, however often it is polled before that.
                if !state.wakers.iter().any(|w| w.will_wake(cx.waker())) {
                    state.wakers.push(cx.waker().clone());
                }
                std::task::Poll::Pending
            } else {
                std::task::Poll::Ready(())
            }
        })
    }
}
