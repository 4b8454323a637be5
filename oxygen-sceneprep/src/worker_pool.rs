//! A small persistent thread pool that runs one borrowed job over `count`
//! indices and returns when all are done.
//!
//! Why not `std::thread::scope`: spawning threads every frame costs tens of
//! microseconds and heap-allocates, and ScenePrep promises zero allocation per
//! frame in steady state. Why not rayon: one dependency tree more for a
//! single fork-join per phase. The pool's threads park on a condition
//! variable between frames; a `run` is two lock/notify round trips and
//! allocates nothing.

use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// The job as the workers see it: a lifetime-erased pointer to the caller's closure.
#[derive(Clone, Copy)]
struct JobPtr(*const (dyn Fn(usize) + Sync + 'static));

// SAFETY: the pointee is `Sync` (required by `run`'s signature), so calling
// it from several threads is allowed; the pointer itself is only
// dereferenced while `run` keeps the closure alive (see `run`).
unsafe impl Send for JobPtr {}

struct State {
    job: Option<JobPtr>,
    generation: u64,
    count: usize,
    active_workers: usize,
    panicked: bool,
    shutdown: bool,
}

struct Shared {
    state: Mutex<State>,
    next: AtomicUsize,
    start: Condvar,
    done: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        // Job panics are caught before they could poison the lock.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Persistent worker threads for ScenePrep's per-view phases.
pub struct WorkerPool {
    shared: Arc<Shared>,
    handles: Vec<JoinHandle<()>>,
}

impl WorkerPool {
    /// A pool that runs jobs on `threads` threads in total (the caller's
    /// thread included), so `threads - 1` workers are spawned; 0 counts as
    /// 1 (the caller alone).
    pub fn new(threads: usize) -> Self {
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                job: None,
                generation: 0,
                count: 0,
                active_workers: 0,
                panicked: false,
                shutdown: false,
            }),
            next: AtomicUsize::new(0),
            start: Condvar::new(),
            done: Condvar::new(),
        });
        let handles = (1..threads.max(1))
            .map(|i| {
                let shared = Arc::clone(&shared);
                std::thread::Builder::new()
                    .name(format!("oxygen-sceneprep-{i}"))
                    .spawn(move || worker(&shared))
                    .expect("spawning a ScenePrep worker thread")
            })
            .collect();
        WorkerPool { shared, handles }
    }

    /// Threads a `run` uses, the caller's included.
    pub fn threads(&self) -> usize {
        self.handles.len() + 1
    }

    /// Calls `job(i)` once for every `i` in `0..count`, spread over the pool,
    /// and returns when all calls have finished. A panic in any call is
    /// re-raised here.
    pub fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync)) {
        if self.handles.is_empty() || count <= 1 {
            (0..count).for_each(job);
            return;
        }
        // SAFETY: only the lifetime is erased. The workers dereference the
        // pointer only between taking it from `state.job` (under the lock, in
        // this generation) and decrementing `active_workers`; this function
        // does not return before `active_workers` is back to zero and `job`
        // is cleared, so `job` outlives every use.
        let erased: &'static (dyn Fn(usize) + Sync) = unsafe { std::mem::transmute(job) };
        {
            let mut state = self.shared.lock();
            self.shared.next.store(0, Ordering::Relaxed);
            state.job = Some(JobPtr(erased));
            state.count = count;
            state.generation += 1;
            state.active_workers = self.handles.len();
            state.panicked = false;
        }
        self.shared.start.notify_all();
        let caller = catch_unwind(AssertUnwindSafe(|| drain(&self.shared, job, count)));
        let mut state = self.shared.lock();
        while state.active_workers > 0 {
            state = self.shared.done.wait(state).unwrap_or_else(|e| e.into_inner());
        }
        state.job = None;
        let worker_panicked = state.panicked;
        drop(state);
        if let Err(payload) = caller {
            resume_unwind(payload);
        }
        assert!(!worker_panicked, "a ScenePrep worker panicked");
    }
}

impl WorkerPool {
    /// Calls `job` once for each run of consecutive indices covering
    /// `0..count` (every index in exactly one run, runs in no set order),
    /// spread over the pool like [`WorkerPool::run`]. Runs are sized so that
    /// each thread gets about [`WorkerPool::RUNS_PER_THREAD`] of them: enough
    /// to even out uneven items, few enough that a thousand small items (a
    /// batch's cameras) do not each pay for a turn of the shared counter
    /// and a clock read.
    pub fn run_ranges(&self, count: usize, job: &(dyn Fn(std::ops::Range<usize>) + Sync)) {
        let length = Self::run_length(count, self.threads());
        self.run(count.div_ceil(length), &|r| job(r * length..((r + 1) * length).min(count)));
    }

    /// Runs per thread that [`WorkerPool::run_ranges`] aims for.
    pub const RUNS_PER_THREAD: usize = 8;

    /// The length of [`WorkerPool::run_ranges`]'s runs (at least 1).
    fn run_length(count: usize, threads: usize) -> usize {
        (count / (threads.max(1) * Self::RUNS_PER_THREAD)).max(1)
    }
}

fn drain(shared: &Shared, job: &(dyn Fn(usize) + Sync), count: usize) {
    loop {
        let i = shared.next.fetch_add(1, Ordering::Relaxed);
        if i >= count {
            break;
        }
        job(i);
    }
}

fn worker(shared: &Shared) {
    let mut seen = 0;
    loop {
        let (job, count) = {
            let mut state = shared.lock();
            while state.generation == seen && !state.shutdown {
                state = shared.start.wait(state).unwrap_or_else(|e| e.into_inner());
            }
            if state.shutdown {
                return;
            }
            seen = state.generation;
            match state.job {
                Some(job) => (job, state.count),
                None => continue,
            }
        };
        // SAFETY: see `WorkerPool::run`: the closure is alive until this
        // worker decrements `active_workers` below.
        let job = unsafe { &*job.0 };
        let ok = catch_unwind(AssertUnwindSafe(|| drain(shared, job, count))).is_ok();
        let mut state = shared.lock();
        state.panicked |= !ok;
        state.active_workers -= 1;
        if state.active_workers == 0 {
            shared.done.notify_all();
        }
    }
}

impl Drop for WorkerPool {
    fn drop(&mut self) {
        self.shared.lock().shutdown = true;
        self.shared.start.notify_all();
        for handle in self.handles.drain(..) {
            // A worker that panicked outside a job has nothing left to report.
            let _ = handle.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicU64;

    #[test]
    fn every_index_runs_exactly_once_across_many_runs() {
        let pool = WorkerPool::new(4);
        for count in [0usize, 1, 2, 3, 17, 100] {
            let hits: Vec<AtomicU64> = (0..count).map(|_| AtomicU64::new(0)).collect();
            for _ in 0..50 {
                pool.run(count, &|i| {
                    hits[i].fetch_add(1, Ordering::Relaxed);
                });
            }
            assert!(hits.iter().all(|h| h.load(Ordering::Relaxed) == 50), "count {count}");
        }
    }

    /// Runs cover every index once, each run consecutive and non-empty;
    /// few items get a run each (nothing heavy is serialised behind
    /// another), many get about `RUNS_PER_THREAD` runs a thread.
    #[test]
    fn ranges_cover_every_index_once_in_runs_sized_by_the_threads() {
        let pool = WorkerPool::new(4);
        for count in [0usize, 1, 2, 5, 31, 32, 33, 100, 1024, 1031] {
            let hits: Vec<AtomicU64> = (0..count).map(|_| AtomicU64::new(0)).collect();
            let runs = AtomicU64::new(0);
            pool.run_ranges(count, &|range| {
                assert!(!range.is_empty() && range.end <= count, "count {count}: run {range:?}");
                runs.fetch_add(1, Ordering::Relaxed);
                for i in range {
                    hits[i].fetch_add(1, Ordering::Relaxed);
                }
            });
            assert!(hits.iter().all(|h| h.load(Ordering::Relaxed) == 1), "count {count}");
            let expected = count.div_ceil(WorkerPool::run_length(count, 4));
            assert_eq!(runs.load(Ordering::Relaxed), expected as u64, "count {count}");
        }
        assert_eq!(WorkerPool::run_length(5, 4), 1, "few items: one a run");
        assert_eq!(WorkerPool::run_length(1024, 4), 32, "1 024 items on 4 threads: 8 runs a thread");
        assert_eq!(WorkerPool::run_length(1024, 16), 8);
        assert_eq!(WorkerPool::run_length(1024, 0), 128, "no threads counts as one");
    }

    #[test]
    fn a_panicking_job_is_reported_and_the_pool_survives() {
        let pool = WorkerPool::new(3);
        let result = catch_unwind(AssertUnwindSafe(|| pool.run(8, &|i| assert!(i != 5, "boom"))));
        assert!(result.is_err());
        let total = AtomicU64::new(0);
        pool.run(8, &|i| {
            total.fetch_add(i as u64, Ordering::Relaxed);
        });
        assert_eq!(total.load(Ordering::Relaxed), 28);
    }

    /// A job that panics only on the pool's worker threads (never on the
    /// caller's, which reports its own panic whatever the workers did):
    /// `run` still fails, so a worker's panic is never lost.
    #[test]
    fn a_panic_on_a_worker_thread_alone_is_reported() {
        let pool = WorkerPool::new(3);
        let caller = std::thread::current().id();
        let on_workers = AtomicU64::new(0);
        let result = catch_unwind(AssertUnwindSafe(|| {
            pool.run(64, &|_| {
                // Slow enough that the workers take some of the 64.
                std::thread::sleep(std::time::Duration::from_millis(2));
                if std::thread::current().id() != caller {
                    on_workers.fetch_add(1, Ordering::Relaxed);
                    panic!("a job fails on a worker");
                }
            })
        }));
        assert!(on_workers.load(Ordering::Relaxed) > 0, "no job ran on a worker");
        assert!(result.is_err(), "a worker's panic was lost");
    }

    /// `threads` counts the caller's thread with the spawned workers: a
    /// pool of four (three workers and the caller) reports 4, one of one
    /// (or zero, which is one) reports 1.
    #[test]
    fn a_pool_counts_the_callers_thread_among_its_threads() {
        assert_eq!(WorkerPool::new(4).threads(), 4);
        assert_eq!(WorkerPool::new(1).threads(), 1);
        assert_eq!(WorkerPool::new(0).threads(), 1);
    }

    /// A run of at most one item, or on a pool without workers, is done
    /// inline: the workers are never woken, so the pool's generation (bumped
    /// by every run that hands the job to the workers) stays 0. Read from
    /// the state rather than from which thread ran the job, which would
    /// only race.
    #[test]
    fn a_run_of_one_item_or_without_workers_wakes_no_worker() {
        let caller = std::thread::current().id();
        let on_caller = AtomicU64::new(0);
        let job = |_| {
            if std::thread::current().id() == caller {
                on_caller.fetch_add(1, Ordering::Relaxed);
            }
        };
        let pool = WorkerPool::new(3);
        pool.run(0, &job);
        pool.run(1, &job);
        assert_eq!(pool.shared.lock().generation, 0, "a run of one item woke the workers");
        let alone = WorkerPool::new(1);
        alone.run(5, &job);
        assert_eq!(alone.shared.lock().generation, 0, "a pool without workers handed out a job");
        assert_eq!(on_caller.load(Ordering::Relaxed), 6);
    }

    /// Dropping the pool ends its workers: each holds the shared state
    /// until its thread returns, so once `drop` is back nothing holds it.
    /// (A pool that never told them to stop would leave them parked
    /// forever, still holding it.)
    #[test]
    fn dropping_the_pool_ends_its_worker_threads() {
        let pool = WorkerPool::new(3);
        pool.run(8, &|_| {});
        let shared = Arc::downgrade(&pool.shared);
        drop(pool);
        assert!(shared.upgrade().is_none(), "a worker thread outlived its pool");
    }
}
