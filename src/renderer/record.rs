//! Step 3 of a frame, record: order the views by their links, then record
//! every view's graph concurrently and submit the command buffers in that
//! order. Its output is [`RecordedFrame`].
//!
//! Each worker thread of ScenePrep's pool runs a small executor: it takes
//! the first view not yet started whose inputs have all recorded (or, when
//! it holds nothing, the first view not yet started), creates its graph's
//! future (with a command encoder of its own) and polls it; when every
//! future it holds is waiting — for a pipeline being compiled, for another
//! view's output — it compiles a queued pipeline, and only when there is
//! nothing else it parks until a future is woken or a view finishes. A future never leaves the thread that created it, so
//! graphs need not be `Send`. Submission order is the link order, whatever
//! order the recording finished in.

use std::collections::{BTreeMap, BTreeSet};
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Wake, Waker};
use std::time::{Duration, Instant};

use oxygen_core::{ResolvedView, ViewId};
use oxygen_passes::{
    CommandRecorder, FrameProgress, LinkedView, LocalShadowsInput, OutputSource, PassError, Pipelines, ProbeId,
    RecordStats, RenderContext, Shading, ShadowMapInput, ViewInputs,
};
use oxygen_sceneprep::DrawMetadata;
use tracing::{Instrument, info_span};

use super::prepare::{FrameView, PreparedFrame, TargetPlan};
use super::{RenderError, Renderer, ViewReport, ViewRole};

/// What a view's targets hold once the frame that rendered it is
/// submitted.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RenderedView {
    /// The view it was rendered as (relative to that frame's origin).
    pub(crate) view: ResolvedView,
    /// The same in world space.
    pub(crate) world: ResolvedView,
    /// Whether its HDR target holds the image (false when shading
    /// tone-mapped in place and wrote only the display colour).
    pub(crate) hdr_written: bool,
}

/// A view the frame recorded. Its poses stay in the prepared frame (a
/// camera's two are a kilobyte, copied once, into what its targets hold:
/// [`RenderedView`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RecordedView {
    pub(crate) id: ViewId,
    /// Its index in the prepared frame's views.
    pub(crate) index: usize,
    /// Whether its HDR target holds the image (see [`RenderedView`]).
    pub(crate) hdr_written: bool,
}

/// The output of the record step: the frame's command buffers are
/// submitted.
pub(crate) struct RecordedFrame {
    /// The first view of each job, in job order, when the jobs wrote GPU
    /// timestamps this frame.
    pub(crate) timed_jobs: Option<Vec<ViewId>>,
    /// Per view, in submission order.
    pub(crate) reports: Vec<ViewReport>,
    /// The views recorded, in submission order.
    pub(crate) rendered: Vec<RecordedView>,
    /// Threads the views were recorded on.
    pub(crate) threads: usize,
    /// Seconds spent recording (wall clock).
    pub(crate) seconds: f64,
    /// Distinct mesh pipelines the frame's passes used.
    pub(crate) pipelines_used: usize,
    /// Pipelines created while recording.
    pub(crate) pipelines_created: u64,
}

/// One unit of recording: a view, or every camera of a batch (with the
/// batch's graph and name).
struct Job {
    /// Indices into the frame's contexts.
    members: Vec<usize>,
    batch: Option<(Arc<crate::graph::BatchGraph>, String)>,
}

/// What the executors share.
struct Work<'a> {
    contexts: &'a [(usize, RenderContext<'a>)],
    jobs: &'a [Job],
    plan: &'a PreparedFrame,
    /// When this frame times its jobs: job `j` writes timestamps `2j` at
    /// its start and `2j + 1` at its end.
    timestamps: Option<&'a wgpu::QuerySet>,
}

/// What one view's recording produced.
struct Recorded {
    result: Result<(), PassError>,
    buffer: wgpu::CommandBuffer,
    stats: RecordStats,
    busy: Duration,
}

/// Indices of `keys` in an order where every index comes after the
/// indices `deps` names for it, the ready one with the lowest key first
/// (Kahn's algorithm). Should `deps` hold a cycle (registration rejects
/// them), the stalled indices go in key order rather than never. A heap of
/// ready indices and a count of what each still waits for keep it
/// O(n log n): a batch of a thousand cameras is a thousand views.
fn dependency_order<K: Ord + Copy>(keys: &[K], deps: &[BTreeSet<usize>]) -> Vec<usize> {
    let n = keys.len();
    let mut waiting: Vec<usize> = deps.iter().map(BTreeSet::len).collect();
    let mut dependents: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, d) in deps.iter().enumerate() {
        for &producer in d {
            if let Some(list) = dependents.get_mut(producer) {
                list.push(i);
            }
        }
    }
    let key = |i: usize| std::cmp::Reverse((keys[i], i));
    let mut ready: std::collections::BinaryHeap<_> = (0..n).filter(|i| waiting[*i] == 0).map(key).collect();
    let mut by_key: Vec<usize> = (0..n).collect();
    by_key.sort_by_key(|i| keys[*i]);
    let mut stalled = by_key.into_iter();
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    while order.len() < n {
        // An index enters `ready` once, when its last producer is done and
        // it is not; the stalled walk only runs with `ready` empty, so
        // nothing popped is done already.
        let next = match ready.pop() {
            Some(std::cmp::Reverse((_, i))) => i,
            None => match stalled.find(|i| !done[*i]) {
                Some(i) => i,
                None => break,
            },
        };
        done[next] = true;
        order.push(next);
        for &d in &dependents[next] {
            waiting[d] -= 1;
            if waiting[d] == 0 && !done[d] {
                ready.push(key(d));
            }
        }
    }
    order
}

/// Makes the views `members` (indices into `deps`, each view's set of the
/// views it waits for) record as one, as a batch's cameras do: each waits
/// for what any of them waits for outside them, and a view waiting for
/// any of them waits for all of them.
fn record_as_one(deps: &mut [BTreeSet<usize>], members: &[usize]) {
    let inside: BTreeSet<usize> = members.iter().copied().collect();
    let union: BTreeSet<usize> =
        members.iter().flat_map(|m| deps[*m].iter().copied()).filter(|d| !inside.contains(d)).collect();
    for (i, d) in deps.iter_mut().enumerate() {
        if inside.contains(&i) {
            d.clone_from(&union);
        } else if !d.is_disjoint(&inside) {
            d.extend(inside.iter().copied());
        }
    }
}

/// Triangles a view drew: its CPU draws' (a third of each index count,
/// times its instances), plus on a GPU path (`gpu_path`) the GPU's count of
/// its depth pass's indices, `gpu_indices`; on a GPU path without that
/// count (not read back yet), no figure.
fn drawn_triangles(cpu_draws: &[DrawMetadata], gpu_path: bool, gpu_indices: Option<u64>) -> Option<u64> {
    let cpu: u64 = cpu_draws.iter().map(|d| u64::from(d.index_count / 3) * u64::from(d.instance_count)).sum();
    if !gpu_path {
        return Some(cpu);
    }
    gpu_indices.map(|indices| indices / 3 + cpu)
}

impl Renderer {
    /// The frame's views in recording and submission order: every view after
    /// the views it reads (its links, its sun cascades, and for colour views
    /// the local shadow views), ties broken by id. Links were checked for
    /// cycles at registration.
    fn link_order(&self, plan: &PreparedFrame) -> (Vec<usize>, Vec<Vec<ViewId>>) {
        let index: oxygen_core::ViewIdMap<usize> = plan.views.iter().enumerate().map(|(i, v)| (v.id, i)).collect();
        let local: Vec<usize> =
            (0..plan.views.len()).filter(|i| matches!(plan.views[*i].target, TargetPlan::AtlasLayer { .. })).collect();
        let dependencies = |view: &FrameView| -> BTreeSet<usize> {
            let mut deps: BTreeSet<usize> = view
                .links
                .iter()
                .flat_map(|source| self.views.producers(*source))
                .chain(self.shadows.views.cascades_of(view.id))
                .filter_map(|id| index.get(&id).copied())
                .collect();
            if !view.options.depth_only {
                deps.extend(local.iter().copied());
            }
            deps
        };
        let mut deps: Vec<BTreeSet<usize>> = plan.views.iter().map(dependencies).collect();
        let mut batches: BTreeMap<crate::batch::BatchId, Vec<usize>> = BTreeMap::new();
        for (i, view) in plan.views.iter().enumerate() {
            if let TargetPlan::Tile { batch, .. } = view.target {
                batches.entry(batch).or_default().push(i);
            }
        }
        for members in batches.values() {
            record_as_one(&mut deps, members);
        }
        let ids: Vec<ViewId> = plan.views.iter().map(|v| v.id).collect();
        let order = dependency_order(&ids, &deps);
        let producers = deps.iter().map(|d| d.iter().map(|i| plan.views[*i].id).collect()).collect();
        (order, producers)
    }

    /// The shadow map `v` rendered this frame, as another view reads it.
    fn shadow_map_input<'a>(&'a self, v: &'a FrameView) -> Option<ShadowMapInput<'a>> {
        let t = self.targets.get(v.id)?.targets.as_ref()?;
        Some(ShadowMapInput { producer: v.id, view: &v.gpu, depth: &t.depth_view, resolution: t.width })
    }

    /// The frame's local shadow maps by tile, once for every view that reads them.
    fn local_shadows<'a>(
        &'a self,
        plan: &'a PreparedFrame,
        atlas: Option<&'a wgpu::TextureView>,
    ) -> Option<LocalShadowsInput<'a>> {
        let atlas = atlas?;
        let mut tiles = vec![None; super::targets::atlas_layers(&plan.views) as usize];
        for v in &plan.views {
            if let TargetPlan::AtlasLayer { tile } = v.target {
                tiles[tile as usize] = self.shadow_map_input(v);
            }
        }
        Some(LocalShadowsInput { atlas, tiles })
    }

    /// What `view` may read this frame.
    fn inputs<'a>(
        &'a self,
        plan: &'a PreparedFrame,
        view: &FrameView,
        local: Option<&LocalShadowsInput<'a>>,
    ) -> ViewInputs<'a> {
        let in_frame = |id: ViewId| plan.views.iter().find(|v| v.id == id);
        let cascades = self
            .shadows
            .views
            .cascades_of(view.id)
            .filter_map(in_frame)
            .filter_map(|v| self.shadow_map_input(v))
            .collect();
        let local_shadows = local.filter(|_| !view.options.depth_only).cloned();
        let mut probes = Vec::new();
        let mut views = Vec::new();
        for source in &view.links {
            match *source {
                OutputSource::Probe(probe) => {
                    let Some(input) = self.views.probes.get(&probe).and_then(|faces| self.probes.input(probe, *faces))
                    else {
                        continue;
                    };
                    probes.push(input);
                }
                OutputSource::View(id) => {
                    let Some(gpu) = self.targets.get(id) else { continue };
                    // A paused view is read as it was last rendered.
                    let resolved = in_frame(id).map(|v| &v.gpu).or(self.targets.last_view(id));
                    if let (Some(resolved), Some(targets)) = (resolved, gpu.targets.as_ref()) {
                        views.push(LinkedView { id, view: resolved, targets });
                    }
                }
            }
        }
        ViewInputs {
            cascades,
            local_shadows,
            probes,
            views,
            visibility: self.visibility.gpu.as_ref(),
            reference: self.reference.tracer.as_ref(),
        }
    }

    /// What the threads record, in submission order: a view alone, or a
    /// batch's cameras together (in tile order, at the place of the last
    /// of them in link order, which follows everything any of them reads
    /// and precedes everything reading one of them).
    fn jobs(&self, plan: &PreparedFrame, contexts: &[(usize, RenderContext<'_>)]) -> Vec<Job> {
        let batch_of = |c: usize| match plan.views[contexts[c].0].target {
            TargetPlan::Tile { batch, slot } => Some((batch, slot)),
            _ => None,
        };
        let mut last: BTreeMap<crate::batch::BatchId, usize> = BTreeMap::new();
        for c in 0..contexts.len() {
            if let Some((batch, _)) = batch_of(c) {
                last.insert(batch, c);
            }
        }
        let mut jobs = Vec::with_capacity(contexts.len());
        for c in 0..contexts.len() {
            let Some((batch, _)) = batch_of(c) else {
                jobs.push(Job { members: vec![c], batch: None });
                continue;
            };
            if last.get(&batch) != Some(&c) {
                continue;
            }
            let mut members: Vec<(u32, usize)> = (0..contexts.len())
                .filter_map(|m| batch_of(m).filter(|(b, _)| *b == batch).map(|(_, slot)| (slot, m)))
                .collect();
            members.sort_unstable();
            let members = members.into_iter().map(|(_, m)| m).collect();
            let graph = self.views.batches.get(&batch).map(|b| (Arc::clone(&b.graph), b.name.clone()));
            jobs.push(Job { members, batch: graph });
        }
        jobs
    }

    /// Step 3: records every view of `plan` and submits them in link order.
    pub(super) fn record(&self, plan: &PreparedFrame) -> Result<RecordedFrame, RenderError> {
        let started = Instant::now();
        let created_before = self.pipelines.pipelines_created();
        self.pipelines.begin_frame();
        let (order, producers) = self.link_order(plan);
        let _span = info_span!("record", views = order.len()).entered();
        let atlas = plan.atlas.as_ref().map(|t| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        });
        let local_shadows = self.local_shadows(plan, atlas.as_ref());
        let frames = &plan.frames;
        let hdr_readers = super::prepare::hdr_readers(&plan.views);
        let progress = FrameProgress::new(order.iter().map(|i| plan.views[*i].id));
        let mut contexts = Vec::with_capacity(order.len());
        for &i in &order {
            let view = &plan.views[i];
            let Some(gpu) = self.targets.get(view.id) else { continue };
            let Some(targets) = gpu.targets.as_ref() else {
                // No target this frame (e.g. a probe face whose probe is gone).
                progress.complete(view.id);
                continue;
            };
            contexts.push((
                i,
                RenderContext {
                    gpu: &self.gpu,
                    view: &view.gpu,
                    prepared: &frames[i],
                    scene_constants: &gpu.constants,
                    heap: &self.heap,
                    targets,
                    pipelines: &self.pipelines,
                    lighting: &self.lighting,
                    draw_path: self.settings.draw_path,
                    inputs: self.inputs(plan, view, local_shadows.as_ref()),
                    progress: &progress,
                    origin: plan.origin,
                    hdr_read_by_others: self.settings.keep_hdr || hdr_readers.contains(&view.id),
                    shading: Shading {
                        materials: plan.materials,
                        vertex_attributes: plan.vertex_attributes,
                        specialize: self.settings.specialize_shaders,
                    },
                    time_seconds: plan.clock.time_seconds,
                    overlay: self.overlays.get(&view.id),
                },
            ));
        }

        let jobs = self.jobs(plan, &contexts);
        let threads = self.prep.worker_pool().threads().min(jobs.len()).max(1);
        let results: Vec<Mutex<Option<Recorded>>> = jobs.iter().map(|_| Mutex::new(None)).collect();
        let queue = ViewQueue {
            started: Mutex::new(vec![false; jobs.len()]),
            producers: jobs.iter().map(|j| producers[contexts[j.members[0]].0].as_slice()).collect(),
            idle: Mutex::new(Vec::new()),
        };
        // Times each job when the last frame's times have been read.
        let timer = self.frames.gpu_timer.as_ref().filter(|t| t.ready());
        let timestamps = timer.and_then(|t| t.job_queries(jobs.len()));
        let work_timed = timestamps.is_some();
        let work = Work { contexts: &contexts, jobs: &jobs, plan, timestamps };
        let job = |_thread: usize| {
            let _compiler = self.pipelines.attach_compiler();
            run_executor(&work, &queue, &results, &self.pipelines, &self.gpu.device, &progress);
        };
        self.prep.worker_pool().run(threads, &job);

        let mut buffers = Vec::with_capacity(contexts.len());
        let mut reports = Vec::with_capacity(contexts.len());
        let mut rendered = Vec::with_capacity(contexts.len());
        // Per probe whose faces rendered: how many buffers precede its
        // prefilter (one past its last face's).
        let mut probe_filters: BTreeMap<ProbeId, usize> = BTreeMap::new();
        for (job, slot) in jobs.iter().zip(results) {
            let recorded = slot.into_inner().unwrap_or_else(|e| e.into_inner());
            // Every job was taken and finished by some thread before `run` returned.
            let Some(recorded) = recorded else { continue };
            let first = &plan.views[contexts[job.members[0]].0];
            recorded.result.map_err(|source| RenderError::Pass {
                view: first.id,
                name: self.views.name(first.id).map(str::to_owned),
                source,
            })?;
            buffers.push(recorded.buffer);
            for (k, member) in job.members.iter().enumerate() {
                let i = contexts[*member].0;
                let view = &plan.views[i];
                if let ViewRole::ProbeFace { probe, .. } = view.role {
                    probe_filters.insert(probe, buffers.len());
                }
                rendered.push(RecordedView { id: view.id, index: i, hdr_written: !recorded.stats.tone_mapped_in_pass });
                // A batch's recording is counted once, at its first camera.
                let (stats, busy) = if k == 0 { (recorded.stats, recorded.busy) } else { Default::default() };
                reports.push(ViewReport {
                    view: view.id,
                    name: view.name.clone(),
                    role: view.role,
                    draws: frames[i].draws().len()
                        + match (frames[i].gpu_plan(), &self.visibility.gpu) {
                            (Some(_), Some(gpu)) => gpu.gpu_draws(view.id).unwrap_or(0) as usize,
                            _ => 0,
                        },
                    visibility: view.options.visibility,
                    partitions: frames[i].partitions().len(),
                    recorded: stats,
                    prep_seconds: frames[i].prep_seconds() as f64,
                    record_seconds: busy.as_secs_f64(),
                    // Filled in from the schedules' decisions (FrameReport::new).
                    why: None,
                    // Filled in from the timer's latest readback (render_frame).
                    gpu_seconds: None,
                    triangles: drawn_triangles(
                        frames[i].draws(),
                        frames[i].gpu_plan().is_some(),
                        self.visibility.gpu.as_ref().and_then(|gpu| gpu.depth_pass_indices(view.id)),
                    ),
                    // Its constants are added from the targets (render_frame).
                    uploaded_bytes: (std::mem::size_of_val(frames[i].draws())
                        + std::mem::size_of_val(frames[i].indirect_args())) as u64,
                    // Filled in from the targets and streams (render_frame).
                    target_bytes: 0,
                    streamed_bytes: 0,
                });
            }
        }
        // A probe's levels are prefiltered across its faces, so after all
        // six have rendered and before any view reads it (link order puts
        // readers after the faces). Later positions first, so earlier ones
        // stay valid.
        let mut filters: Vec<(ProbeId, usize)> = probe_filters.into_iter().collect();
        filters.sort_by_key(|(_, at)| std::cmp::Reverse(*at));
        for (probe, at) in filters {
            let Some(prefilter) = self.probes.prefilter(&self.lighting, &self.gpu.device, probe) else { continue };
            buffers.insert(at, prefilter);
        }
        // The frame's GPU time, when the last one has been read back, and
        // its jobs' when they wrote timestamps.
        let timed_jobs: Option<Vec<ViewId>> =
            work_timed.then(|| jobs.iter().map(|job| plan.views[contexts[job.members[0]].0].id).collect());
        let job_count = timed_jobs.as_ref().map_or(0, Vec::len);
        let timer = self.frames.gpu_timer.as_ref().filter(|t| t.ready());
        if let Some(timer) = timer {
            buffers.insert(0, timer.start(&self.gpu.device));
            buffers.push(timer.end(&self.gpu.device, job_count));
        }
        self.gpu.queue.submit(buffers);
        if let Some(timer) = timer {
            timer.submitted(job_count);
        }
        if let Some(visibility) = &self.visibility.gpu {
            visibility.after_submit();
        }
        Ok(RecordedFrame {
            timed_jobs,
            reports,
            rendered,
            threads,
            seconds: started.elapsed().as_secs_f64(),
            pipelines_used: self.pipelines.used_this_frame().len(),
            pipelines_created: self.pipelines.pipelines_created() - created_before,
        })
    }
}

/// Wakes one view's future: marks it and unparks its thread.
struct TaskWaker {
    woken: AtomicBool,
    thread: std::thread::Thread,
}

impl Wake for TaskWaker {
    fn wake(self: Arc<Self>) {
        self.wake_by_ref();
    }

    fn wake_by_ref(self: &Arc<Self>) {
        self.woken.store(true, Ordering::Release);
        self.thread.unpark();
    }
}

/// The views not yet started, handed out so that a thread never holds views
/// stuck behind work held by a busier thread (a future cannot move between
/// threads): see [`ViewQueue::take`].
struct ViewQueue<'a> {
    started: Mutex<Vec<bool>>,
    /// Per context: the views it reads.
    producers: Vec<&'a [ViewId]>,
    /// Threads with nothing to do until some view finishes recording.
    idle: Mutex<Vec<std::thread::Thread>>,
}

/// What a thread may do next with the queue.
enum Next {
    /// Start this context.
    Start(usize),
    /// Views remain, but none is ready yet.
    Wait,
    /// Every view has started.
    Done,
}

impl ViewQueue<'_> {
    /// Registers the calling thread to be unparked when a view finishes.
    fn wait_for_a_view(&self) {
        self.idle.lock().unwrap_or_else(|e| e.into_inner()).push(std::thread::current());
    }

    /// A view finished: idle threads may find one ready now.
    fn view_finished(&self) {
        let idle = std::mem::take(&mut *self.idle.lock().unwrap_or_else(|e| e.into_inner()));
        idle.iter().for_each(std::thread::Thread::unpark);
    }

    /// The first view not yet started whose inputs have all recorded; when
    /// there is none and `idle` (the thread holds no view), the first view
    /// not yet started anyway: it records what it can (a depth pre-pass,
    /// its pipeline requests) and then waits for its inputs. A thread thus
    /// holds at most one view that waits for others, so no thread is left
    /// with a pile of them while the others run dry.
    fn take(&self, progress: &FrameProgress, idle: bool) -> Next {
        let mut started = self.started.lock().unwrap_or_else(|e| e.into_inner());
        let mut first_unready = None;
        for (index, taken) in started.iter().enumerate() {
            if *taken {
                continue;
            }
            if progress.all_recorded(self.producers[index]) {
                started[index] = true;
                return Next::Start(index);
            }
            first_unready.get_or_insert(index);
        }
        match first_unready {
            Some(index) if idle => {
                started[index] = true;
                Next::Start(index)
            }
            Some(_) => Next::Wait,
            None => Next::Done,
        }
    }
}

struct Task<'a> {
    index: usize,
    future: Pin<Box<dyn Future<Output = Recorded> + 'a>>,
    waker: Arc<TaskWaker>,
    busy: Duration,
}

/// One thread's executor (see the module docs).
fn run_executor<'a>(
    work: &Work<'a>,
    queue: &ViewQueue<'_>,
    results: &[Mutex<Option<Recorded>>],
    pipelines: &Pipelines,
    device: &wgpu::Device,
    progress: &FrameProgress,
) {
    let mut tasks: Vec<Task<'a>> = Vec::new();
    loop {
        let mut progressed = false;
        let mut t = 0;
        while t < tasks.len() {
            if !tasks[t].waker.woken.swap(false, Ordering::AcqRel) {
                t += 1;
                continue;
            }
            progressed = true;
            let waker = Waker::from(Arc::clone(&tasks[t].waker));
            let started = Instant::now();
            let poll = tasks[t].future.as_mut().poll(&mut Context::from_waker(&waker));
            tasks[t].busy += started.elapsed();
            match poll {
                Poll::Pending => t += 1,
                Poll::Ready(mut recorded) => {
                    let task = tasks.swap_remove(t);
                    recorded.busy = task.busy;
                    *results[task.index].lock().unwrap_or_else(|e| e.into_inner()) = Some(recorded);
                    for member in &work.jobs[task.index].members {
                        progress.complete(work.plan.views[work.contexts[*member].0].id);
                    }
                    queue.view_finished();
                }
            }
        }
        if progressed {
            continue;
        }
        // Start another view before compiling, so that its pipeline requests
        // join the queue and compile side by side with the others'. An idle
        // thread registers before looking, so a view finishing between the
        // look and the park still unparks it (unpark tokens persist).
        if tasks.is_empty() {
            queue.wait_for_a_view();
        }
        let next = queue.take(progress, tasks.is_empty());
        if let Next::Start(index) = next {
            let job = &work.jobs[index];
            if let Some((graph, name)) = &job.batch {
                let views: Vec<&RenderContext<'a>> = job.members.iter().map(|m| &work.contexts[*m].1).collect();
                let device = &views[0].gpu.device;
                let span = info_span!("render_batch", batch = %name, cameras = views.len());
                let timestamps = work.timestamps;
                let future = async move {
                    let mut rec = CommandRecorder::new(device, name);
                    if let Some(queries) = timestamps {
                        rec.encoder().write_timestamp(queries, 2 * index as u32);
                    }
                    // GPU visibility's first phase for every camera on a GPU
                    // path (one compute pass for the batch), before any pass
                    // reads their draws.
                    if let Some(visibility) = views.first().and_then(|ctx| ctx.inputs.visibility) {
                        let ids: Vec<ViewId> = views.iter().map(|ctx| ctx.view.view_id).collect();
                        visibility.record_early_batch(rec.encoder(), &ids);
                    }
                    let result = graph.record_batch(&views, &mut rec).await;
                    // No coverage readback for a batch's cameras: it feeds
                    // the automatic depth pre-pass, which a batch graph does
                    // not choose per camera, and a copy and a mapping a
                    // camera are a thousand of each a frame.
                    if let Some(queries) = timestamps {
                        rec.encoder().write_timestamp(queries, 2 * index as u32 + 1);
                    }
                    let (buffer, stats) = rec.finish();
                    Recorded { result, buffer, stats, busy: Duration::ZERO }
                }
                .instrument(span);
                let waker = Arc::new(TaskWaker { woken: AtomicBool::new(true), thread: std::thread::current() });
                tasks.push(Task { index, future: Box::pin(future), waker, busy: Duration::ZERO });
                continue;
            }
            let (i, ctx) = &work.contexts[job.members[0]];
            let view = &work.plan.views[*i];
            let graph = &*view.graph;
            let timestamps = work.timestamps;
            let future = async move {
                let mut rec = CommandRecorder::new(&ctx.gpu.device, &view.id.to_string());
                if let Some(queries) = timestamps {
                    rec.encoder().write_timestamp(queries, 2 * index as u32);
                }
                // GPU visibility's first phase, before any pass reads its draws.
                if let Some(visibility) = ctx.inputs.visibility {
                    visibility.record_early(rec.encoder(), view.id);
                }
                let result = graph.record_boxed(ctx, &mut rec).await;
                if let Some(visibility) = ctx.inputs.visibility {
                    visibility.record_readback(rec.encoder(), view.id);
                }
                if let Some(queries) = timestamps {
                    rec.encoder().write_timestamp(queries, 2 * index as u32 + 1);
                }
                let (buffer, stats) = rec.finish();
                Recorded { result, buffer, stats, busy: Duration::ZERO }
            }
            // Instrumented rather than entered: the span must not stay
            // entered while this thread polls other views.
            .instrument(info_span!("render_graph", view = %view.id));
            let waker = Arc::new(TaskWaker { woken: AtomicBool::new(true), thread: std::thread::current() });
            tasks.push(Task { index, future: Box::pin(future), waker, busy: Duration::ZERO });
            continue;
        }
        if pipelines.compile_next(device) {
            continue;
        }
        match next {
            Next::Done if tasks.is_empty() => return,
            // Unpark tokens persist, so a wake between the checks above and
            // here is not lost (views finishing unpark idle threads, woken
            // futures their own); the timeout only bounds the cost of a
            // missed one.
            _ => std::thread::park_timeout(Duration::from_millis(20)),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use oxygen_sceneprep::DrawMetadata;

    use super::dependency_order;

    /// The order as first written: at each step the lowest key among the
    /// ready indices, scanning them all (O(n²)); the stalled ones by key.
    fn scanning_order(keys: &[u32], deps: &[BTreeSet<usize>]) -> Vec<usize> {
        let mut by_key: Vec<usize> = (0..keys.len()).collect();
        by_key.sort_by_key(|i| keys[*i]);
        let mut done = vec![false; keys.len()];
        let mut order = Vec::new();
        while order.len() < keys.len() {
            let next = by_key.iter().copied().find(|i| !done[*i] && deps[*i].iter().all(|d| done[*d]));
            let next = next.unwrap_or_else(|| by_key.iter().copied().find(|i| !done[*i]).unwrap_or(0));
            done[next] = true;
            order.push(next);
        }
        order
    }

    #[test]
    fn the_heap_order_is_the_scanning_order() {
        // Seeded xorshift64*: the same 2 000 graphs on every run. Distinct
        // keys (view ids are), dependencies on any indices, cycles and
        // self-dependencies included.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = |n: usize| {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 33) as usize % n.max(1)
        };
        for _ in 0..2000 {
            let n = 1 + next(40);
            let mut keys: Vec<u32> = (0..n as u32).collect();
            for i in (1..n).rev() {
                keys.swap(i, next(i + 1));
            }
            let deps: Vec<BTreeSet<usize>> = (0..n).map(|_| (0..next(4)).map(|_| next(n)).collect()).collect();
            assert_eq!(dependency_order(&keys, &deps), scanning_order(&keys, &deps), "keys {keys:?}, deps {deps:?}");
        }
    }

    #[test]
    fn a_view_comes_after_what_it_reads_and_ties_go_by_key() {
        // 0 reads 2; 1 and 2 read nothing. Ready at first: 1 (key 9) and
        // 2 (key 7), so 2; then 0 (key 5) is ready and goes before 1.
        let keys = [5u32, 9, 7];
        let deps = [BTreeSet::from([2]), BTreeSet::new(), BTreeSet::new()];
        assert_eq!(dependency_order(&keys, &deps), vec![2, 0, 1]);
    }

    #[test]
    fn a_batch_waits_as_one_and_is_waited_for_as_one() {
        // 0, 1 and 2 are a batch; 0 reads 3, 2 reads 4 and 1 (inside: no
        // wait); 5 reads 1; 6 reads nothing of them.
        let set = |s: &[usize]| s.iter().copied().collect::<BTreeSet<usize>>();
        let mut deps = vec![set(&[3]), set(&[]), set(&[4, 1]), set(&[]), set(&[]), set(&[1]), set(&[3])];
        super::record_as_one(&mut deps, &[0, 1, 2]);
        let want = [set(&[3, 4]), set(&[3, 4]), set(&[3, 4]), set(&[]), set(&[]), set(&[0, 1, 2]), set(&[3])];
        assert_eq!(deps, want);
    }

    #[test]
    fn a_views_triangles_are_its_draws_times_their_instances_and_the_gpus_count() {
        let draw = |index_count, instance_count| DrawMetadata { index_count, instance_count, ..Default::default() };
        // 36 indices twice and 7 indices (2 whole triangles) three times.
        let draws = [draw(36, 2), draw(7, 3)];
        assert_eq!(super::drawn_triangles(&draws, false, None), Some(24 + 6));
        assert_eq!(super::drawn_triangles(&draws, false, Some(999)), Some(30), "a CPU path has no GPU count");
        // A GPU path adds the GPU's depth-pass indices to its CPU draws'
        // (blended draws stay on the CPU); none counted yet, no figure.
        assert_eq!(super::drawn_triangles(&draws, true, Some(300)), Some(100 + 30));
        assert_eq!(super::drawn_triangles(&draws, true, None), None);
        assert_eq!(super::drawn_triangles(&[], true, Some(2)), Some(0));
    }

    #[test]
    fn a_cycle_goes_in_key_order_rather_than_never() {
        let keys = [3u32, 1];
        let deps = [BTreeSet::from([1]), BTreeSet::from([0])];
        assert_eq!(dependency_order(&keys, &deps), vec![1, 0]);
    }
}
