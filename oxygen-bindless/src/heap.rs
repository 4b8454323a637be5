//! The GPU side of the heap: one buffer per domain, grown on demand, and the
//! bind group every pass sets once.
//!
//! Allocation is CPU-only ([`SlotAllocators`]), so ScenePrep can assign slots
//! without a device. Before writing, the renderer calls
//! [`BindlessHeap::ensure_capacity`], which grows each buffer that its
//! allocator has outgrown: a new buffer (at least double, at most the
//! adapter's `max_storage_buffer_binding_size`), a GPU copy of the old
//! contents, and a new bind group. The bind-group *layout* never changes, so
//! cached pipelines stay valid across growth.

use bytemuck::Pod;
use oxygen_gpu::bindings::{self, LayoutEntries};
use thiserror::Error;
use tracing::{debug, info_span};

use crate::textures::{TextureHeap, TextureUpload};
use crate::{Allocation, DomainKind, SlotAllocators, SlotError, TexturePath};

/// Smallest buffer, in records: a binding must never be empty.
const MIN_RECORDS: u64 = 64;

/// A heap operation that cannot be done.
#[derive(Debug, Error, PartialEq)]
pub enum BindlessError {
    /// A slot handle was stale, or a domain is full.
    #[error(transparent)]
    Slot(#[from] SlotError),
    /// Records of the wrong size were written to a domain.
    #[error("{domain} records are {expected} bytes, got {got}-byte records")]
    RecordSize {
        /// Domain name.
        domain: &'static str,
        /// Expected bytes per record.
        expected: u64,
        /// Given bytes per record.
        got: u64,
    },
    /// More textures than the chosen texture path can hold.
    #[error("texture slot {slot} is beyond the texture path's capacity of {limit}")]
    TooManyTextures {
        /// The slot asked for.
        slot: u32,
        /// How many fit.
        limit: u32,
    },
    /// A texture upload was given a slot of another domain.
    #[error("texture uploads need a texture-locations slot, got a {domain} slot")]
    NotATextureSlot {
        /// The domain the allocation belongs to.
        domain: &'static str,
    },
    /// One [`BindlessHeap::write_runs`] was given runs of two domains.
    #[error("one write of runs took {first} and {other} records: a write of runs covers one domain")]
    MixedDomains {
        /// The first run's domain.
        first: &'static str,
        /// The domain of the run that differs.
        other: &'static str,
    },
    /// A write reached past the GPU buffer: `ensure_capacity` was not called.
    #[error("{domain} write reaches slot {end}, buffer holds {capacity}: call ensure_capacity after allocating")]
    BeyondCapacity {
        /// Domain name.
        domain: &'static str,
        /// One past the last slot written.
        end: u64,
        /// Records the buffer holds.
        capacity: u64,
    },
}

/// The bindless heap: slot allocators plus the GPU buffers behind them.
pub struct BindlessHeap {
    /// CPU-side allocators, one per domain.
    pub slots: SlotAllocators,
    buffers: Vec<wgpu::Buffer>,
    capacities: Vec<u64>,
    domain_layout: wgpu::BindGroupLayout,
    scene_constants_layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    max_binding_bytes: u64,
    growths: u64,
    textures: TextureHeap,
    /// Bytes written by `write` (atomic: `write` takes `&self`).
    bytes_written: std::sync::atomic::AtomicU64,
}

impl BindlessHeap {
    /// Creates every domain at its minimum size on `device`, with textures
    /// bound the way `texture_path` says.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, texture_path: TexturePath) -> Self {
        let max_binding_bytes = device.limits().max_storage_buffer_binding_size;
        // Indices and indirect arguments have no binding in group 0: gaps.
        let domain_layout = DomainKind::ALL
            .iter()
            .filter_map(|k| k.binding().map(|b| (b, k.visibility())))
            .fold(LayoutEntries::new(wgpu::ShaderStages::NONE), |entries, (binding, visibility)| {
                entries.at(binding).visibility(visibility).push(bindings::storage_read_only())
            })
            .create_layout(device, "bindless domains");
        let scene_constants_layout =
            LayoutEntries::new(wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE)
                .push(bindings::dynamic_uniform_of::<crate::SceneConstants>())
                .create_layout(device, "scene constants");
        let capacities: Vec<u64> = DomainKind::ALL.iter().map(|_| MIN_RECORDS).collect();
        let buffers: Vec<_> =
            DomainKind::ALL.iter().zip(&capacities).map(|(k, c)| create_domain_buffer(device, *k, *c)).collect();
        let bind_group = create_bind_group(device, &domain_layout, &buffers);
        BindlessHeap {
            slots: SlotAllocators::new(max_binding_bytes),
            buffers,
            capacities,
            domain_layout,
            scene_constants_layout,
            bind_group,
            max_binding_bytes,
            growths: 0,
            textures: TextureHeap::new(device, queue, texture_path),
            bytes_written: std::sync::atomic::AtomicU64::new(0),
        }
    }

    /// Grows every buffer whose allocator's high-water mark exceeds it,
    /// copying live contents. Returns whether anything grew. Submits its own
    /// copy commands right away, so that later `queue.write_buffer` calls land
    /// after the copy.
    pub fn ensure_capacity(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) -> bool {
        let _span = info_span!("bindless_ensure_capacity").entered();
        let mut encoder: Option<wgpu::CommandEncoder> = None;
        for kind in DomainKind::ALL {
            let i = kind.index();
            let needed = self.slots.get(kind).high_water() as u64;
            if needed <= self.capacities[i] {
                continue;
            }
            // Allocators never exceed the binding limit, so this fits.
            let max_records = self.max_binding_bytes / kind.record_size();
            let new_capacity = needed.max(self.capacities[i] * 2).min(max_records);
            let new_buffer = create_domain_buffer(device, kind, new_capacity);
            let encoder = encoder.get_or_insert_with(|| device.create_command_encoder(&Default::default()));
            encoder.copy_buffer_to_buffer(&self.buffers[i], 0, &new_buffer, 0, self.capacities[i] * kind.record_size());
            debug!(domain = kind.name(), from = self.capacities[i], to = new_capacity, "bindless domain grown");
            self.buffers[i] = new_buffer;
            self.capacities[i] = new_capacity;
            self.growths += 1;
        }
        match encoder {
            Some(encoder) => {
                queue.submit([encoder.finish()]);
                self.bind_group = create_bind_group(device, &self.domain_layout, &self.buffers);
                true
            }
            None => false,
        }
    }

    /// Writes `records` starting `offset` records into `allocation`.
    pub fn write<T: Pod>(
        &self,
        queue: &wgpu::Queue,
        allocation: &Allocation,
        offset: u32,
        records: &[T],
    ) -> Result<(), BindlessError> {
        let Some((first, _)) = self.checked_range(allocation, offset, records)? else { return Ok(()) };
        let kind = allocation.domain();
        let record_size = kind.record_size();
        queue.write_buffer(&self.buffers[kind.index()], first * record_size, bytemuck::cast_slice(records));
        self.bytes_written.fetch_add(records.len() as u64 * record_size, std::sync::atomic::Ordering::Relaxed);
        Ok(())
    }

    /// Writes many runs of records of one domain, `(allocation, offset,
    /// records)` each, as [`BindlessHeap::write`] would write them one by
    /// one, but with one staging copy per stretch of runs that end where
    /// the next begins. A thousand views' draws are a thousand writes;
    /// wgpu makes a staging buffer per write, which cost more than the
    /// copying (issue 29). Every run is checked before anything is written.
    pub fn write_runs<T: Pod>(
        &self,
        queue: &wgpu::Queue,
        runs: &[(&Allocation, u32, &[T])],
    ) -> Result<(), BindlessError> {
        let mut ranges: Vec<(u64, u64, &[T])> = Vec::with_capacity(runs.len());
        let mut kind = None;
        for (allocation, offset, records) in runs {
            if kind.is_some_and(|k| k != allocation.domain()) {
                return Err(BindlessError::MixedDomains {
                    first: kind.map_or("", DomainKind::name),
                    other: allocation.domain().name(),
                });
            }
            kind = Some(allocation.domain());
            if let Some((first, end)) = self.checked_range(allocation, *offset, records)? {
                ranges.push((first, end, records));
            }
        }
        let Some(kind) = kind else { return Ok(()) };
        ranges.sort_by_key(|r| r.0);
        let record_size = kind.record_size();
        let buffer = &self.buffers[kind.index()];
        let mut at = 0;
        while at < ranges.len() {
            // The stretch [at, next): each run begins where the last ended.
            let mut next = at + 1;
            while next < ranges.len() && ranges[next].0 == ranges[next - 1].1 {
                next += 1;
            }
            let (first, end) = (ranges[at].0, ranges[next - 1].1);
            let bytes = (end - first) * record_size;
            // Runs of `Pod` records of a domain's size: whole multiples of
            // 4 bytes at 4-byte offsets, as wgpu asks; a refused view falls
            // back to one write per run.
            let view = wgpu::BufferSize::new(bytes)
                .and_then(|size| queue.write_buffer_with(buffer, first * record_size, size));
            match view {
                Some(mut view) => {
                    for (start, _, records) in &ranges[at..next] {
                        let from = ((start - first) * record_size) as usize;
                        let records: &[u8] = bytemuck::cast_slice(records);
                        view.slice(from..from + records.len()).copy_from_slice(records);
                    }
                }
                None => {
                    for (start, _, records) in &ranges[at..next] {
                        queue.write_buffer(buffer, start * record_size, bytemuck::cast_slice(records));
                    }
                }
            }
            self.bytes_written.fetch_add(bytes, std::sync::atomic::Ordering::Relaxed);
            at = next;
        }
        Ok(())
    }

    /// Checks a write of `records` at `offset` into `allocation` and
    /// returns the records it covers in the domain's buffer, `first..end`;
    /// `None` for no records.
    fn checked_range<T: Pod>(
        &self,
        allocation: &Allocation,
        offset: u32,
        records: &[T],
    ) -> Result<Option<(u64, u64)>, BindlessError> {
        let kind = allocation.domain();
        self.slots.get(kind).validate(allocation)?;
        let record_size = std::mem::size_of::<T>() as u64;
        if record_size != kind.record_size() {
            return Err(BindlessError::RecordSize {
                domain: kind.name(),
                expected: kind.record_size(),
                got: record_size,
            });
        }
        if records.is_empty() {
            return Ok(None);
        }
        if offset as u64 + records.len() as u64 > allocation.count as u64 {
            return Err(SlotError::WriteTooLarge {
                domain: kind.name(),
                records: records.len() + offset as usize,
                count: allocation.count,
            }
            .into());
        }
        let first = allocation.start as u64 + offset as u64;
        let end = first + records.len() as u64;
        if end > self.capacities[kind.index()] {
            return Err(BindlessError::BeyondCapacity {
                domain: kind.name(),
                end,
                capacity: self.capacities[kind.index()],
            });
        }
        Ok(Some((first, end)))
    }

    /// Bytes [`BindlessHeap::write`] has sent to the GPU so far (buffer
    /// records; textures and growth copies not included): the renderer
    /// reports the difference per frame.
    pub fn bytes_written(&self) -> u64 {
        self.bytes_written.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Uploads a texture for a `TextureLocations` slot and records where it
    /// lives and which sampler-table entry samples it.
    pub fn upload_texture(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        slot: &Allocation,
        texture: &TextureUpload<'_>,
    ) -> Result<(), BindlessError> {
        if slot.domain() != DomainKind::TextureLocations {
            return Err(BindlessError::NotATextureSlot { domain: slot.domain().name() });
        }
        self.slots.get(DomainKind::TextureLocations).validate(slot)?;
        let location = self.textures.upload(device, queue, slot.start, texture)?;
        self.write(queue, slot, 0, &[location])?;
        self.textures.refresh(device);
        Ok(())
    }

    /// How textures are bound.
    pub fn texture_path(&self) -> TexturePath {
        self.textures.path()
    }

    /// Layout of group 2 (textures and sampler).
    pub fn texture_layout(&self) -> &wgpu::BindGroupLayout {
        self.textures.layout()
    }

    /// Bind group 2 (textures and sampler).
    pub fn texture_bind_group(&self) -> &wgpu::BindGroup {
        self.textures.bind_group()
    }

    /// Textures uploaded so far.
    pub fn texture_uploads(&self) -> u64 {
        self.textures.uploads()
    }

    /// The bind group of all domains (group 0).
    pub fn bind_group(&self) -> &wgpu::BindGroup {
        &self.bind_group
    }

    /// Layout of group 0 (domains); stable for the heap's lifetime.
    pub fn domain_layout(&self) -> &wgpu::BindGroupLayout {
        &self.domain_layout
    }

    /// Layout of group 3 (a view's `SceneConstants`).
    pub fn scene_constants_layout(&self) -> &wgpu::BindGroupLayout {
        &self.scene_constants_layout
    }

    /// The shared index buffer (the `Indices` domain).
    pub fn index_buffer(&self) -> &wgpu::Buffer {
        &self.buffers[DomainKind::Indices.index()]
    }

    /// The GPU buffer of a domain.
    pub fn buffer(&self, kind: DomainKind) -> &wgpu::Buffer {
        &self.buffers[kind.index()]
    }

    /// Records the GPU buffer of `kind` can hold.
    pub fn capacity(&self, kind: DomainKind) -> u64 {
        self.capacities[kind.index()]
    }

    /// Total bytes of all domain buffers.
    pub fn gpu_bytes(&self) -> u64 {
        DomainKind::ALL.iter().map(|k| self.capacities[k.index()] * k.record_size()).sum()
    }

    /// How many times a domain buffer has been grown.
    pub fn growth_count(&self) -> u64 {
        self.growths
    }
}

fn create_domain_buffer(device: &wgpu::Device, kind: DomainKind, records: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(kind.name()),
        size: records * kind.record_size(),
        usage: kind.usages() | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

fn create_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffers: &[wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<_> = DomainKind::ALL
        .iter()
        .filter_map(|k| k.binding().map(|b| (b, &buffers[k.index()])))
        .map(|(binding, buffer)| wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("bindless domains"), layout, entries: &entries })
}
