//! Streams: a batch's images copied back to the CPU every frame without
//! waiting for them, a subsystem of the renderer.
//!
//! After a frame's command buffers are submitted, each streaming batch
//! gets one copy of its atlas pages (colour and/or depth, whole pages: one
//! copy a page and output for every camera, not one per camera) into the
//! next free staging buffer of its ring, which is then mapped
//! asynchronously. [`Renderer::take_streamed`] hands over what has arrived,
//! oldest first, cut into one buffer per plane with the cameras' images one
//! after another, tagged with the frame number, the frame's time and each
//! camera's view id; it never waits. Frames handed back
//! ([`Renderer::recycle_streamed`]) lend their buffers to later frames.
//! With `frames_in_flight` buffers a result arrives at most that many
//! frames after its frame (one on an idle GPU); when every buffer is still
//! taken, the next frame waits for the oldest one and moves its images into
//! memory (the ring's back-pressure), so nothing is dropped: what the
//! application has not taken waits for it there. Each frame on its way has
//! a thread of its own that waits for its copy to land, then cuts it on
//! every core: the cut of a
//! thousand-camera frame starts the moment its copy is done and overlaps
//! the next frames' preparing and recording.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use oxygen_core::ViewId;
use oxygen_gpu::{Label, LabelSet, Tile, TileAtlas};
use tracing::info_span;

use super::resolve::FrameClock;
use super::{RenderError, Renderer};
use crate::batch::BatchId;

/// Which of a batch's images are streamed back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamOptions {
    /// Display colour (sRGB, 8 bits a channel).
    pub color: bool,
    /// Device depth (reverse-Z, `f32`).
    pub depth: bool,
    /// Instance labels (the node seen at each pixel, id + 1; 0 for
    /// none): a batch that draws them only ([`crate::batch::BatchDesc::with_labels`]).
    pub instances: bool,
    /// Semantic classes (the class of the node seen at each pixel; 0 for
    /// none), written by the GPU: a batch that draws them only.
    pub semantic: bool,
    /// Linear depth (each pixel's distance from the camera's plane in world
    /// units; 0 where nothing was drawn), written by the GPU: a batch that
    /// draws it only.
    pub linear_depth: bool,
    /// Staging buffers in the ring: how many frames' images may be on
    /// their way at once. At least 1; 2 (the default) lets a frame render
    /// while the last one's images are copied and mapped.
    pub frames_in_flight: u32,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            color: true,
            depth: true,
            instances: false,
            semantic: false,
            linear_depth: false,
            frames_in_flight: 2,
        }
    }
}

impl StreamOptions {
    /// The label planes these options stream.
    fn label_planes(&self) -> LabelSet {
        let mut set = LabelSet::NONE;
        for (on, label) in [
            (self.instances, Label::Instance),
            (self.semantic, Label::Semantic),
            (self.linear_depth, Label::LinearDepth),
        ] {
            if on {
                set = set.with(label);
            }
        }
        set
    }
}

/// A batch's images of one frame, as they arrived: one buffer per plane
/// streamed, camera after camera in tile order (camera `i`'s image is the
/// `i`-th block of `width × height` texels, row by row from the top), so a
/// frame is a handful of allocations however many cameras it holds.
/// [`StreamedFrame::cameras`] walks the cameras with their slices; hand a
/// frame back with [`Renderer::recycle_streamed`] once read, and a later
/// frame is cut into its buffers instead of fresh memory.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamedFrame {
    /// The batch.
    pub batch: BatchId,
    /// The frame's number ([`crate::FrameReport::frame_index`]).
    pub frame: u64,
    /// The frame's time, seconds since the renderer started (what the
    /// resolvers were told).
    pub time_seconds: f32,
    /// Width and height of every camera's images.
    pub size: (u32, u32),
    /// The cameras that rendered that frame, in tile order.
    pub views: Vec<ViewId>,
    /// Display colour (sRGB RGBA, 4 bytes a texel), when streamed.
    pub color: Option<Vec<u8>>,
    /// Device depth (reverse-Z), when streamed.
    pub depth: Option<Vec<f32>>,
    /// Instance labels (the node's stable id + 1; 0 for none), when streamed.
    pub instances: Option<Vec<u32>>,
    /// Semantic classes (0 for none), when streamed.
    pub semantic: Option<Vec<u32>>,
    /// Linear depth in world units (0 where nothing was drawn), when streamed.
    pub linear_depth: Option<Vec<f32>>,
}

/// One camera's images of a [`StreamedFrame`]: slices of the frame's planes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamedCamera<'a> {
    /// The camera.
    pub view: ViewId,
    /// Width and height of its images.
    pub size: (u32, u32),
    /// Its colour (sRGB RGBA, row by row), when streamed.
    pub color: Option<&'a [u8]>,
    /// Its device depth (reverse-Z, row by row), when streamed.
    pub depth: Option<&'a [f32]>,
    /// Its instance labels (row by row), when streamed.
    pub instances: Option<&'a [u32]>,
    /// Its semantic classes (row by row), when streamed.
    pub semantic: Option<&'a [u32]>,
    /// Its linear depth (row by row, 0 where nothing was drawn), when streamed.
    pub linear_depth: Option<&'a [f32]>,
}

impl StreamedCamera<'_> {
    /// Its colour as an image (a copy), when streamed.
    pub fn color_image(&self) -> Option<image::RgbaImage> {
        image::RgbaImage::from_raw(self.size.0, self.size.1, self.color?.to_vec())
    }
}

impl StreamedFrame {
    /// Texels of one camera's image.
    fn texels(&self) -> usize {
        self.size.0 as usize * self.size.1 as usize
    }

    /// Camera `i` of the frame (in tile order), `None` past the last.
    pub fn camera(&self, i: usize) -> Option<StreamedCamera<'_>> {
        let view = *self.views.get(i)?;
        let n = self.texels();
        // Camera i's block of a plane of `per_texel` elements a texel.
        fn block<T>(plane: &Option<Vec<T>>, i: usize, n: usize, per_texel: usize) -> Option<&[T]> {
            plane.as_ref()?.get(i * n * per_texel..(i + 1) * n * per_texel)
        }
        Some(StreamedCamera {
            view,
            size: self.size,
            color: block(&self.color, i, n, 4),
            depth: block(&self.depth, i, n, 1),
            instances: block(&self.instances, i, n, 1),
            semantic: block(&self.semantic, i, n, 1),
            linear_depth: block(&self.linear_depth, i, n, 1),
        })
    }

    /// Every camera of the frame, in tile order.
    pub fn cameras(&self) -> impl Iterator<Item = StreamedCamera<'_>> + '_ {
        (0..self.views.len()).filter_map(|i| self.camera(i))
    }

    /// The camera `view`'s images, if it rendered that frame.
    pub fn camera_of(&self, view: ViewId) -> Option<StreamedCamera<'_>> {
        self.camera(self.views.iter().position(|v| *v == view)?)
    }

    /// Bytes of images the frame holds.
    pub fn bytes(&self) -> u64 {
        let len = |n: Option<usize>| n.unwrap_or(0) as u64;
        len(self.color.as_ref().map(Vec::len))
            + 4 * (len(self.depth.as_ref().map(Vec::len))
                + len(self.instances.as_ref().map(Vec::len))
                + len(self.semantic.as_ref().map(Vec::len))
                + len(self.linear_depth.as_ref().map(Vec::len)))
    }
}

/// Per batch that rendered this frame: its atlas and the cameras that
/// rendered, with their tiles.
pub(crate) type RenderedBatches<'a> = BTreeMap<BatchId, (&'a TileAtlas, Vec<(ViewId, Tile)>)>;

/// Where a staging buffer's mapping stands.
const MAPPING: u8 = 1;
const MAPPED: u8 = 2;
const FAILED: u8 = 3;

/// One staging buffer of a ring.
struct Slot {
    buffer: wgpu::Buffer,
    /// It holds a frame on its way (or not yet taken from its arrival).
    busy: bool,
}

/// What a staging buffer holds: a frame's pages, and whose they are.
struct SlotContent {
    frame: u64,
    time_seconds: f32,
    layout: PageLayout,
    cameras: Vec<(ViewId, Tile)>,
}

/// One image of a page in a staging buffer; every plane has 4-byte texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Plane {
    Color,
    Depth,
    Label(Label),
}

/// Where each page's images lie in a staging buffer: page after page, each
/// page's planes after one another in [`Plane`] order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct PageLayout {
    /// Page size in pixels.
    width: u32,
    height: u32,
    pages: u32,
    tile: (u32, u32),
    /// Bytes of a row (4-byte texels, padded to the copy alignment).
    row_bytes: u32,
    color: bool,
    depth: bool,
    /// The label planes streamed (those asked for that the atlas has).
    labels: LabelSet,
}

impl PageLayout {
    fn of(atlas: &TileAtlas, options: &StreamOptions) -> Self {
        let (width, height) = atlas.page_size();
        let row_bytes = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        PageLayout {
            width,
            height,
            pages: atlas.pages.len() as u32,
            tile: atlas.tile_size,
            row_bytes,
            color: options.color,
            depth: options.depth,
            labels: options
                .label_planes()
                .iter()
                .filter(|l| atlas.labels().contains(*l))
                .fold(LabelSet::NONE, LabelSet::with),
        }
    }

    /// The planes streamed, in their order within a page.
    fn planes(&self) -> impl Iterator<Item = Plane> + '_ {
        let images = [(Plane::Color, self.color), (Plane::Depth, self.depth)];
        images.into_iter().filter_map(|(plane, on)| on.then_some(plane)).chain(self.labels.iter().map(Plane::Label))
    }

    fn page_bytes(&self) -> u64 {
        u64::from(self.row_bytes) * u64::from(self.height)
    }

    /// Byte offset of `plane` of page `page` (a plane that is streamed).
    fn offset(&self, page: u32, plane: Plane) -> u64 {
        let within = self.planes().position(|p| p == plane).unwrap_or(0) as u64;
        (u64::from(page) * self.planes().count() as u64 + within) * self.page_bytes()
    }

    fn bytes(&self) -> u64 {
        u64::from(self.pages) * self.planes().count() as u64 * self.page_bytes()
    }
}

/// A frame on its way: a thread that waits for its copy to land, then cuts
/// it (the buffer stays mapped, and its slot taken, until joined).
type Arrival = std::thread::JoinHandle<Result<StreamedFrame, RenderError>>;

/// One batch's ring.
struct Ring {
    options: StreamOptions,
    /// Staging buffers, each free or holding one frame's arrival.
    slots: Vec<Slot>,
    /// The slots' arrivals, oldest first.
    arriving: VecDeque<(usize, Arrival)>,
    /// Plane buffers of frames handed back, to cut later frames into
    /// (shared with the arrivals, which take them).
    spare: Arc<std::sync::Mutex<Spare>>,
}

/// The streams of every streaming batch.
pub(crate) struct Streams {
    rings: BTreeMap<BatchId, Ring>,
    /// Frames moved out of a full ring, not taken yet.
    pending: Vec<StreamedFrame>,
    /// Whether depth reaches a buffer only through a float texture (GL).
    pub(crate) depth_copy_needed: bool,
    /// The pass that makes that float texture.
    pub(crate) depth_copy: oxygen_passes::DepthCopy,
}

impl Streams {
    /// No streams yet, on an adapter with these capabilities.
    pub(crate) fn new(downlevel: &wgpu::DownlevelCapabilities) -> Self {
        Streams {
            rings: BTreeMap::new(),
            pending: Vec::new(),
            depth_copy_needed: oxygen_passes::DepthCopy::needed(downlevel),
            depth_copy: Default::default(),
        }
    }

    /// Bytes a camera of `batch` streams back a frame at `size`: its planes
    /// (each 4 bytes a texel), or 0 when the batch is not streamed.
    pub(crate) fn camera_bytes(&self, batch: BatchId, size: (u32, u32), labels: LabelSet) -> u64 {
        let Some(ring) = self.rings.get(&batch) else { return 0 };
        let o = &ring.options;
        let labels = o.label_planes().iter().filter(|l| labels.contains(*l)).count() as u64;
        let planes = u64::from(o.color) + u64::from(o.depth) + labels;
        planes * 4 * u64::from(size.0) * u64::from(size.1)
    }

    /// Copies each streaming batch's pages of the frame just submitted
    /// into a free staging buffer, starts mapping it and starts the thread
    /// that cuts it as soon as it lands. `rendered` holds, per batch, its
    /// atlas and the cameras that rendered with their tiles.
    pub(crate) fn after_submit(
        &mut self,
        gpu: &oxygen_gpu::GpuContext,
        rendered: &RenderedBatches<'_>,
        clock: FrameClock,
    ) -> Result<(), RenderError> {
        for (batch, ring) in &mut self.rings {
            let Some((atlas, cameras)) = rendered.get(batch) else { continue };
            if cameras.is_empty() {
                continue;
            }
            let _span = info_span!("stream_copy", batch = %batch, cameras = cameras.len()).entered();
            let layout = PageLayout::of(atlas, &ring.options);
            let slot = ring.free_slot(gpu, layout.bytes(), &mut self.pending)?;
            let buffer = &ring.slots[slot].buffer;
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            let size = wgpu::Extent3d { width: layout.width, height: layout.height, depth_or_array_layers: 1 };
            for (page, textures) in (0..layout.pages).zip(&atlas.pages) {
                // Where depth cannot be copied into a buffer, its float copy is.
                let depth_as_float = (layout.depth && self.depth_copy_needed).then(|| {
                    let view = textures.depth.create_view(&Default::default());
                    self.depth_copy.record(&gpu.device, &mut encoder, &view, (layout.width, layout.height))
                });
                let depth_source = depth_as_float.as_ref().unwrap_or(&textures.depth);
                for plane in layout.planes() {
                    let (texture, aspect) = match plane {
                        Plane::Color => (&textures.color, wgpu::TextureAspect::All),
                        Plane::Depth if depth_as_float.is_some() => (depth_source, wgpu::TextureAspect::All),
                        Plane::Depth => (depth_source, wgpu::TextureAspect::DepthOnly),
                        Plane::Label(label) => match textures.labels.as_ref().and_then(|l| l.plane(label)) {
                            Some(plane) => (&plane.texture, wgpu::TextureAspect::All),
                            None => continue,
                        },
                    };
                    encoder.copy_texture_to_buffer(
                        wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect },
                        wgpu::TexelCopyBufferInfo {
                            buffer,
                            layout: wgpu::TexelCopyBufferLayout {
                                offset: layout.offset(page, plane),
                                bytes_per_row: Some(layout.row_bytes),
                                rows_per_image: Some(layout.height),
                            },
                        },
                        size,
                    );
                }
            }
            let submission = gpu.queue.submit([encoder.finish()]);
            let state = Arc::new(AtomicU8::new(MAPPING));
            let mapped = Arc::clone(&state);
            buffer.slice(..layout.bytes()).map_async(wgpu::MapMode::Read, move |result| {
                mapped.store(if result.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
            let content =
                SlotContent { frame: clock.index, time_seconds: clock.time_seconds, layout, cameras: cameras.clone() };
            let (device, buffer, batch, spare) = (gpu.device.clone(), buffer.clone(), *batch, Arc::clone(&ring.spare));
            let arrival = std::thread::Builder::new()
                .name("oxygen-stream".into())
                .spawn(move || arrive(&device, submission, &state, &buffer, content, &spare, batch))
                .map_err(|e| RenderError::Unsupported(format!("starting a thread to stream {batch}'s images: {e}")))?;
            ring.arriving.push_back((slot, arrival));
        }
        Ok(())
    }

    /// The frames that have arrived and been cut, oldest first (per batch
    /// in frame order); `wait` waits for every frame on its way first.
    pub(crate) fn take(&mut self, gpu: &oxygen_gpu::GpuContext, wait: bool) -> Result<Vec<StreamedFrame>, RenderError> {
        let _span = info_span!("stream_take", wait).entered();
        {
            // The arrivals poll for themselves; this delivers any mapping
            // whose callback is due on this thread too.
            let _span = info_span!("stream_poll").entered();
            gpu.device.poll(wgpu::PollType::Poll).map_err(oxygen_gpu::GpuError::from)?;
        }
        let mut arrived = std::mem::take(&mut self.pending);
        for ring in self.rings.values_mut() {
            // Without waiting, only the frames already cut: one still on
            // its way is taken next time.
            while ring.arriving.front().is_some_and(|(_, a)| wait || a.is_finished()) {
                ring.join_oldest(&mut arrived)?;
            }
        }
        arrived.sort_by_key(|f| (f.frame, f.batch));
        Ok(arrived)
    }
}

/// Waits for the copy (`submission`) and `buffer`'s mapping (`state`),
/// then cuts the frame. The wait blocks this thread only: wgpu's wait holds
/// no lock that the thread recording the next frame needs (its submissions
/// share the device's resource lock for reading).
fn arrive(
    device: &wgpu::Device,
    submission: wgpu::SubmissionIndex,
    state: &AtomicU8,
    buffer: &wgpu::Buffer,
    content: SlotContent,
    spare: &std::sync::Mutex<Spare>,
    batch: BatchId,
) -> Result<StreamedFrame, RenderError> {
    {
        let _span = info_span!("stream_wait_copy", batch = %batch, frame = content.frame).entered();
        loop {
            match state.load(Ordering::Acquire) {
                MAPPED => break,
                FAILED => return Err(RenderError::Gpu(oxygen_gpu::GpuError::from(wgpu::BufferAsyncError))),
                _ => {}
            }
            // Delivers the mapping once the copy is done (the callback may
            // also run in another thread's poll: the loop then ends too).
            let wait = wgpu::PollType::Wait { submission_index: Some(submission.clone()), timeout: None };
            device.poll(wait).map_err(oxygen_gpu::GpuError::from)?;
        }
    }
    // The planes are taken now, not when the copy was recorded: frames
    // handed back meanwhile lend their buffers, and a fresh one's pages
    // are touched here, off the recording thread.
    let planes = {
        let mut spare = spare.lock().unwrap_or_else(|e| e.into_inner());
        Planes::for_layout(&content.layout, content.cameras.len(), &mut spare)
    };
    cut(buffer, content, planes, batch)
}

impl Ring {
    fn new(options: StreamOptions) -> Self {
        Ring { options, slots: Vec::new(), arriving: VecDeque::new(), spare: Arc::default() }
    }

    /// Waits for the oldest arrival, adds its frame to `out` and frees its
    /// slot (returned); `None` when nothing is on its way. A failed
    /// arrival's slot is freed too; a panicking one is re-raised here.
    fn join_oldest(&mut self, out: &mut Vec<StreamedFrame>) -> Result<Option<usize>, RenderError> {
        let Some((slot, arrival)) = self.arriving.pop_front() else { return Ok(None) };
        let frame = arrival.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        self.slots[slot].busy = false;
        out.push(frame?);
        Ok(Some(slot))
    }

    /// A slot free to take a frame of `bytes`: an unused one, a new one
    /// while the ring has room, or else the oldest on its way, waited for
    /// and moved into `pending`. Its buffer grows when the batch did.
    fn free_slot(
        &mut self,
        gpu: &oxygen_gpu::GpuContext,
        bytes: u64,
        pending: &mut Vec<StreamedFrame>,
    ) -> Result<usize, RenderError> {
        let slot = match self.slots.iter().position(|s| !s.busy) {
            Some(slot) => slot,
            None if (self.slots.len() as u32) < self.options.frames_in_flight.max(1) => {
                self.slots.push(Slot::new(gpu, bytes));
                self.slots.len() - 1
            }
            None => {
                let _span = info_span!("stream_wait").entered();
                self.join_oldest(pending)?.ok_or(RenderError::Gpu(wgpu::BufferAsyncError.into()))?
            }
        };
        if self.slots[slot].buffer.size() < bytes {
            self.slots[slot] = Slot::new(gpu, bytes);
        }
        self.slots[slot].busy = true;
        Ok(slot)
    }
}

impl Slot {
    fn new(gpu: &oxygen_gpu::GpuContext, bytes: u64) -> Self {
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stream staging"),
            size: bytes,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Slot { buffer, busy: false }
    }
}

/// Plane buffers of frames handed back ([`Renderer::recycle_streamed`]),
/// for later frames to be cut into: no fresh memory (and its page faults,
/// hundreds of megabytes a frame for a large batch) once a stream runs.
#[derive(Default)]
struct Spare {
    color: Vec<Vec<u8>>,
    depth: Vec<Vec<f32>>,
    instances: Vec<Vec<u32>>,
    semantic: Vec<Vec<u32>>,
    linear_depth: Vec<Vec<f32>>,
}

impl Spare {
    /// Spare buffers kept per plane: enough for the frames in flight and
    /// those being read, not an unbounded pile.
    const KEEP: usize = 8;

    fn keep(&mut self, frame: StreamedFrame) {
        fn put<T>(pile: &mut Vec<Vec<T>>, buffer: Option<Vec<T>>) {
            if let Some(buffer) = buffer
                && pile.len() < Spare::KEEP
            {
                pile.push(buffer);
            }
        }
        put(&mut self.color, frame.color);
        put(&mut self.depth, frame.depth);
        put(&mut self.instances, frame.instances);
        put(&mut self.semantic, frame.semantic);
        put(&mut self.linear_depth, frame.linear_depth);
    }
}

/// A buffer of `len` elements for a plane: a spare one when there is (its
/// old contents are overwritten), else a new one, zeroed by the allocator
/// (`vec!` of zeros asks for zeroed memory: fresh pages, not a fill).
fn plane_buffer<T: Copy + Default>(pile: &mut Vec<Vec<T>>, len: usize) -> Vec<T> {
    match pile.pop() {
        Some(mut buffer) => {
            buffer.resize(len, T::default());
            buffer.truncate(len);
            buffer
        }
        None => vec![T::default(); len],
    }
}

/// The buffers one frame is cut into, taken from the spares.
struct Planes {
    color: Option<Vec<u8>>,
    depth: Option<Vec<f32>>,
    instances: Option<Vec<u32>>,
    semantic: Option<Vec<u32>>,
    linear_depth: Option<Vec<f32>>,
}

impl Planes {
    fn for_layout(layout: &PageLayout, cameras: usize, spare: &mut Spare) -> Self {
        let texels = cameras * layout.tile.0 as usize * layout.tile.1 as usize;
        let label = |l| layout.labels.contains(l);
        Planes {
            color: layout.color.then(|| plane_buffer(&mut spare.color, 4 * texels)),
            depth: layout.depth.then(|| plane_buffer(&mut spare.depth, texels)),
            instances: label(Label::Instance).then(|| plane_buffer(&mut spare.instances, texels)),
            semantic: label(Label::Semantic).then(|| plane_buffer(&mut spare.semantic, texels)),
            linear_depth: label(Label::LinearDepth).then(|| plane_buffer(&mut spare.linear_depth, texels)),
        }
    }

    /// Each streamed plane's bytes, with the plane it is cut from.
    fn bytes_mut(&mut self) -> Vec<(Plane, &mut [u8])> {
        let mut planes: Vec<(Plane, &mut [u8])> = Vec::with_capacity(5);
        if let Some(p) = &mut self.color {
            planes.push((Plane::Color, p.as_mut_slice()));
        }
        if let Some(p) = &mut self.depth {
            planes.push((Plane::Depth, bytemuck::cast_slice_mut(p.as_mut_slice())));
        }
        for (label, plane) in [(Label::Instance, &mut self.instances), (Label::Semantic, &mut self.semantic)] {
            if let Some(p) = plane {
                planes.push((Plane::Label(label), bytemuck::cast_slice_mut(p.as_mut_slice())));
            }
        }
        if let Some(p) = &mut self.linear_depth {
            planes.push((Plane::Label(Label::LinearDepth), bytemuck::cast_slice_mut(p.as_mut_slice())));
        }
        planes
    }
}

/// One cutting thread's share: a run of cameras, and their blocks of each
/// plane.
type CutWork<'a> = (&'a [(ViewId, Tile)], Vec<(Plane, &'a mut [u8])>);

/// Cuts `buffer`'s mapped pages into `planes` (camera after camera, in the
/// order of `content`'s cameras) and unmaps it.
fn cut(
    buffer: &wgpu::Buffer,
    content: SlotContent,
    mut planes: Planes,
    batch: BatchId,
) -> Result<StreamedFrame, RenderError> {
    let _span = info_span!("stream_cut", batch = %batch, cameras = content.cameras.len()).entered();
    {
        let mapped = buffer.slice(..content.layout.bytes()).get_mapped_range().map_err(oxygen_gpu::GpuError::from)?;
        cut_pages(&mapped, &content, &mut planes);
    }
    buffer.unmap();
    Ok(frame_of(content, planes, batch))
}

/// Cuts `mapped` (a staging buffer's pages, laid out as `content.layout`
/// says) into `planes`: camera after camera, in the order of `content`'s
/// cameras.
fn cut_pages(mapped: &[u8], content: &SlotContent, planes: &mut Planes) {
    let layout = content.layout;
    let (w, h) = layout.tile;
    let row = w as usize * 4;
    let camera_bytes = row * h as usize;
    {
        // Copies one camera's rows of one plane into its block.
        let copy = |tile: &Tile, plane: Plane, out: &mut [u8]| {
            let base = layout.offset(tile.page, plane) as usize;
            for (y, out_row) in (tile.y..tile.y + h).zip(out.chunks_exact_mut(row)) {
                let start = base + y as usize * layout.row_bytes as usize + tile.x as usize * 4;
                out_row.copy_from_slice(&mapped[start..start + row]);
            }
        };
        // Many cameras: cut on every core, each thread a run of cameras
        // (their blocks of every plane). A cut cannot panic (its ranges lie
        // inside the mapped pages and the planes by construction); a
        // panicking one is re-raised.
        let cameras = &content.cameras;
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(cameras.len()).max(1);
        let chunk = cameras.len().div_ceil(threads).max(1);
        let mut work: Vec<CutWork<'_>> = cameras.chunks(chunk).map(|part| (part, Vec::new())).collect();
        for (plane, bytes) in planes.bytes_mut() {
            for ((_, parts), out) in work.iter_mut().zip(bytes.chunks_mut(chunk * camera_bytes)) {
                parts.push((plane, out));
            }
        }
        let run = |(part, outs): CutWork<'_>| {
            for (plane, out) in outs {
                for ((_, tile), block) in part.iter().zip(out.chunks_exact_mut(camera_bytes)) {
                    copy(tile, plane, block);
                }
            }
        };
        if work.len() == 1 {
            work.into_iter().for_each(run);
        } else {
            std::thread::scope(|scope| {
                let handles: Vec<_> = work.into_iter().map(|w| scope.spawn(move || run(w))).collect();
                for handle in handles {
                    handle.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
                }
            });
        }
    }
}

/// The frame `content`'s pages were cut into `planes`.
fn frame_of(content: SlotContent, mut planes: Planes, batch: BatchId) -> StreamedFrame {
    // The GPU wrote little-endian words; on a big-endian host they turn round.
    if cfg!(target_endian = "big") {
        for words in [&mut planes.instances, &mut planes.semantic].into_iter().flatten() {
            words.iter_mut().for_each(|w| *w = u32::from_le(*w));
        }
        for floats in [&mut planes.depth, &mut planes.linear_depth].into_iter().flatten() {
            floats.iter_mut().for_each(|f| *f = f32::from_bits(u32::from_le(f.to_bits())));
        }
    }
    StreamedFrame {
        batch,
        frame: content.frame,
        time_seconds: content.time_seconds,
        size: content.layout.tile,
        views: content.cameras.iter().map(|(view, _)| *view).collect(),
        color: planes.color,
        depth: planes.depth,
        instances: planes.instances,
        semantic: planes.semantic,
        linear_depth: planes.linear_depth,
    }
}

impl Renderer {
    /// Streams `batch`'s images back every frame from now on (`None`:
    /// stops, dropping what has not been taken): one copy of its atlas
    /// per frame and output, mapped without waiting; take them with
    /// [`Renderer::take_streamed`]. Fails for an unknown batch or a ring of
    /// no buffers.
    pub fn stream_batch(&mut self, batch: BatchId, options: Option<StreamOptions>) -> Result<(), RenderError> {
        self.views.batch_cameras(batch)?;
        match options {
            Some(options)
                if options.frames_in_flight == 0
                    || !(options.color || options.depth || !options.label_planes().is_empty()) =>
            {
                Err(RenderError::Unsupported(format!("streaming {batch} with {options:?}: no buffer or no image")))
            }
            Some(options)
                if let Some(missing) = {
                    let drawn = self.views.batches.get(&batch).map_or(LabelSet::NONE, |b| b.labels);
                    options.label_planes().iter().find(|l| !drawn.contains(*l))
                } =>
            {
                Err(RenderError::Unsupported(format!(
                    "streaming {batch}'s {} labels: the batch draws none (BatchDesc::with_label_planes)",
                    missing.name()
                )))
            }
            Some(options) => {
                self.streams.rings.insert(batch, Ring::new(options));
                Ok(())
            }
            None => {
                self.streams.rings.remove(&batch);
                Ok(())
            }
        }
    }

    /// The streamed frames that have arrived and been cut into camera
    /// images since the last call, oldest first; never waits (a frame
    /// still being cut comes with a later call). Frames not taken stay (in
    /// memory once their ring needed the buffer), so an application that
    /// takes them less often than every frame loses none.
    pub fn take_streamed(&mut self) -> Result<Vec<StreamedFrame>, RenderError> {
        self.streams.take(&self.gpu, false)
    }

    /// Hands a streamed frame back once read: its buffers take a later
    /// frame of its batch's stream, which is then cut without new memory
    /// (a 1 024-camera batch of 128 × 128 streams about 200 MB a frame).
    /// Frames of a batch no longer streamed are dropped.
    pub fn recycle_streamed(&mut self, frame: StreamedFrame) {
        if let Some(ring) = self.streams.rings.get_mut(&frame.batch) {
            ring.spare.lock().unwrap_or_else(|e| e.into_inner()).keep(frame);
        }
    }

    /// [`Renderer::take_streamed`] after waiting for every frame in flight.
    pub fn wait_streamed(&mut self) -> Result<Vec<StreamedFrame>, RenderError> {
        self.streams.take(&self.gpu, true)
    }

    /// The GPU textures a batch renders into, for interop: its atlas
    /// (colour, depth, HDR when written) and each camera's tile, valid
    /// until the batch's next frame reallocates it (cameras added past its
    /// capacity). `None` before its first frame.
    pub fn batch_atlas(&self, batch: BatchId) -> Option<(&TileAtlas, Vec<(ViewId, Tile)>)> {
        let atlas = self.targets.atlas(batch)?;
        let entry = self.views.batches.get(&batch)?;
        let tiles = entry.slots.iter().enumerate().filter_map(|(i, v)| Some(((*v)?, atlas.tile(i as u32)?))).collect();
        Some((atlas, tiles))
    }
}

#[cfg(test)]
mod tests {
    //! The CPU side of streaming: where a page's planes lie in a staging
    //! buffer, cutting mapped pages into cameras' blocks, the frames'
    //! accessors, and the spare buffers; the copies and mappings are the
    //! GPU tests' (`tests/batch_views.rs`).

    use super::*;

    fn batch() -> BatchId {
        crate::batch::BatchIds::default().allocate()
    }

    /// Two pages of 8 × 4 pixels, tiles of 4 × 2; colour, depth, instance
    /// ids and linear depth streamed.
    fn layout() -> PageLayout {
        PageLayout {
            width: 8,
            height: 4,
            pages: 2,
            tile: (4, 2),
            row_bytes: 256,
            color: true,
            depth: true,
            labels: LabelSet::of(&[Label::LinearDepth, Label::Instance]),
        }
    }

    /// The word the fake staging buffer holds at `page`, plane number
    /// `plane`, row `y`, column `x`.
    fn word(page: u32, plane: u32, y: u32, x: u32) -> u32 {
        (page << 24) | (plane << 16) | (y << 8) | x
    }

    /// A staging buffer as the copies leave it: every texel its own word,
    /// the rows' padding past the page's width left at 0xAB.
    fn mapped(layout: &PageLayout) -> Vec<u8> {
        let mut bytes = vec![0xAB; layout.bytes() as usize];
        for page in 0..layout.pages {
            for (k, plane) in layout.planes().enumerate() {
                let base = layout.offset(page, plane) as usize;
                for y in 0..layout.height {
                    for x in 0..layout.width {
                        let at = base + (y * layout.row_bytes + x * 4) as usize;
                        bytes[at..at + 4].copy_from_slice(&word(page, k as u32, y, x).to_le_bytes());
                    }
                }
            }
        }
        bytes
    }

    fn view(i: u32) -> ViewId {
        oxygen_demo::view_id(i)
    }

    fn tile(page: u32, x: u32, y: u32) -> Tile {
        Tile { x, y, page, index: 0 }
    }

    #[test]
    fn a_page_lays_its_planes_one_after_another_and_pages_follow() {
        let layout = layout();
        let planes: Vec<Plane> = layout.planes().collect();
        assert_eq!(
            planes,
            [Plane::Color, Plane::Depth, Plane::Label(Label::Instance), Plane::Label(Label::LinearDepth)]
        );
        assert_eq!(layout.page_bytes(), 256 * 4);
        assert_eq!(layout.offset(0, Plane::Color), 0);
        assert_eq!(layout.offset(0, Plane::Depth), 1024);
        assert_eq!(layout.offset(0, Plane::Label(Label::LinearDepth)), 3 * 1024);
        assert_eq!(layout.offset(1, Plane::Color), 4 * 1024);
        assert_eq!(layout.offset(1, Plane::Label(Label::Instance)), 6 * 1024);
        assert_eq!(layout.bytes(), 2 * 4 * 1024);
        let depth_only = PageLayout { color: false, labels: LabelSet::NONE, ..layout };
        assert_eq!(depth_only.planes().collect::<Vec<_>>(), [Plane::Depth]);
        assert_eq!(depth_only.offset(1, Plane::Depth), 1024);
        assert_eq!(depth_only.bytes(), 2 * 1024);
    }

    #[test]
    fn mapped_pages_are_cut_into_each_cameras_block_of_each_plane() {
        let layout = layout();
        // Three cameras (two threads' runs on a machine of two cores or
        // more): on page 0 at the corner and in the middle, on page 1.
        let cameras = vec![(view(3), tile(0, 0, 0)), (view(1), tile(0, 4, 2)), (view(2), tile(1, 4, 0))];
        let content = SlotContent { frame: 9, time_seconds: 0.5, layout, cameras: cameras.clone() };
        let mut spare = Spare::default();
        let mut planes = Planes::for_layout(&layout, cameras.len(), &mut spare);
        assert!(planes.semantic.is_none(), "a plane not streamed has no buffer");
        cut_pages(&mapped(&layout), &content, &mut planes);
        let frame = frame_of(content, planes, batch());
        assert_eq!((frame.frame, frame.time_seconds, frame.size), (9, 0.5, (4, 2)));
        assert_eq!(frame.views, [view(3), view(1), view(2)]);
        for (i, (id, t)) in cameras.iter().enumerate() {
            let camera = frame.camera(i).unwrap();
            assert_eq!(camera.view, *id);
            assert_eq!(frame.camera_of(*id), Some(camera));
            let want = |plane: u32| -> Vec<u32> {
                (0..2).flat_map(|y| (0..4).map(move |x| word(t.page, plane, t.y + y, t.x + x))).collect()
            };
            let color: Vec<u32> =
                camera.color.unwrap().chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            assert_eq!(color, want(0), "camera {i}'s colour");
            assert_eq!(camera.depth.unwrap().iter().map(|f| f.to_bits()).collect::<Vec<_>>(), want(1));
            assert_eq!(camera.instances.unwrap(), want(2).as_slice());
            assert_eq!(camera.linear_depth.unwrap().iter().map(|f| f.to_bits()).collect::<Vec<_>>(), want(3));
            assert_eq!(camera.semantic, None);
        }
        assert_eq!(frame.camera(3), None);
        assert_eq!(frame.camera_of(view(7)), None);
        assert_eq!(frame.cameras().map(|c| c.view).collect::<Vec<_>>(), frame.views);
        // Colour, 4 bytes a texel, plus depth, ids and linear depth, 4 each.
        assert_eq!(frame.bytes(), 3 * 8 * 4 * 4);
        let image = frame.camera(1).unwrap().color_image().unwrap();
        assert_eq!(image.dimensions(), (4, 2));
        assert_eq!(image.get_pixel(0, 0).0, word(0, 0, 2, 4).to_le_bytes());
    }

    #[test]
    fn a_frame_counts_the_bytes_of_every_plane_it_holds() {
        let frame = StreamedFrame {
            batch: batch(),
            frame: 1,
            time_seconds: 0.0,
            size: (1, 1),
            views: Vec::new(),
            color: Some(vec![0; 1]),
            depth: Some(vec![0.0; 10]),
            instances: Some(vec![0; 100]),
            semantic: Some(vec![0; 1000]),
            linear_depth: Some(vec![0.0; 10000]),
        };
        assert_eq!(frame.bytes(), 1 + 4 * 11110);
        let none =
            StreamedFrame { color: None, depth: None, instances: None, semantic: None, linear_depth: None, ..frame };
        assert_eq!(none.bytes(), 0);
    }

    #[test]
    fn handed_back_buffers_take_later_frames_up_to_a_bound() {
        let layout = layout();
        let mut spare = Spare::default();
        let frame = |n: usize| StreamedFrame {
            batch: batch(),
            frame: 1,
            time_seconds: 0.0,
            size: (4, 2),
            views: vec![view(0)],
            color: Some(vec![7; n]),
            depth: Some(vec![1.0; n]),
            instances: None,
            semantic: Some(vec![5; n]),
            linear_depth: None,
        };
        for _ in 0..Spare::KEEP + 3 {
            spare.keep(frame(100));
        }
        assert_eq!(
            (spare.color.len(), spare.depth.len(), spare.semantic.len()),
            (Spare::KEEP, Spare::KEEP, Spare::KEEP)
        );
        assert!(spare.instances.is_empty() && spare.linear_depth.is_empty());
        // A spare buffer is cut to the length asked for; with none spare,
        // a fresh zeroed one.
        let planes = Planes::for_layout(&layout, 2, &mut spare);
        assert_eq!(planes.color.as_ref().map(Vec::len), Some(4 * 2 * 8));
        assert_eq!(planes.depth.as_ref().map(Vec::len), Some(2 * 8));
        assert_eq!(planes.instances, Some(vec![0; 16]), "no spare ids: fresh zeros");
        assert_eq!(spare.color.len(), Spare::KEEP - 1, "one spare colour buffer taken");
        let mut pile = vec![vec![3u32; 2]];
        assert_eq!(plane_buffer(&mut pile, 5), [3, 3, 0, 0, 0], "grown with zeros");
        assert!(pile.is_empty());
        assert_eq!(plane_buffer(&mut pile, 2), [0, 0]);
    }

    #[test]
    fn options_name_their_label_planes_and_cameras_cost_their_planes() {
        let options = StreamOptions { instances: true, linear_depth: true, ..StreamOptions::default() };
        assert_eq!(options.label_planes(), LabelSet::of(&[Label::Instance, Label::LinearDepth]));
        assert_eq!(
            StreamOptions { semantic: true, ..Default::default() }.label_planes(),
            LabelSet::of(&[Label::Semantic])
        );
        assert_eq!(StreamOptions::default().label_planes(), LabelSet::NONE);
        let mut streams = Streams::new(&wgpu::DownlevelCapabilities::default());
        let mut ids = crate::batch::BatchIds::default();
        let (streamed, other) = (ids.allocate(), ids.allocate());
        streams.rings.insert(streamed, Ring::new(options));
        // Colour, depth and the ids the batch draws (not linear depth,
        // which it does not): three planes of 4 bytes.
        let drawn = LabelSet::of(&[Label::Instance, Label::Normal]);
        assert_eq!(streams.camera_bytes(streamed, (10, 3), drawn), 3 * 4 * 30);
        assert_eq!(streams.camera_bytes(streamed, (10, 3), LabelSet::NONE), 2 * 4 * 30);
        assert_eq!(streams.camera_bytes(other, (10, 3), drawn), 0, "not streamed");
    }
}
