//! Adapter and device selection for headless rendering.
//!
//! The context honours `WGPU_BACKEND` (e.g. `vulkan`, `gl`) and
//! `OXYGEN_ADAPTER` (a case-insensitive substring of the adapter name) so a
//! test run can be pointed at lavapipe, llvmpipe or a real GPU. Without them
//! it prefers a discrete GPU, then integrated, then a CPU rasterizer, and
//! Vulkan over GL among equals.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use thiserror::Error;
use tracing::{info, info_span};

/// Why no device could be created.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No adapter was found, or none had the required features.
    #[error(
        "no usable GPU adapter (tried: {tried}).\n\
         On a machine without a GPU, install Mesa's lavapipe Vulkan driver (Mesa >= 25): \
         run `scripts/ensure-gpu.sh` as root, or see README.md"
    )]
    NoAdapter {
        /// Adapters seen and why each was rejected.
        tried: String,
    },
    /// The adapter refused to create a device.
    #[error("adapter '{adapter}' could not create a device: {source}")]
    RequestDevice {
        /// Adapter name.
        adapter: String,
        /// wgpu's reason.
        source: wgpu::RequestDeviceError,
    },
    /// Waiting for the GPU failed (device lost, timeout).
    #[error("waiting for the GPU failed: {0}")]
    Poll(#[from] wgpu::PollError),
    /// Mapping a readback buffer failed.
    #[error("mapping a readback buffer failed: {0}")]
    Map(#[from] wgpu::BufferAsyncError),
    /// A mapped buffer range could not be accessed.
    #[error("accessing a mapped readback buffer failed: {0}")]
    MapRange(#[from] wgpu::MapRangeError),
    /// A texture cannot be read back by this path.
    #[error("cannot read back texture of format {0:?} (only RGBA8 unorm or sRGB, and Rgba16Float)")]
    UnsupportedReadbackFormat(wgpu::TextureFormat),
    /// A mip level or array layer the texture does not have.
    #[error("texture has {levels} mip levels and {layers} layers; asked for level {level}, layer {layer}")]
    NoSuchSubresource {
        /// Level asked for.
        level: u32,
        /// Layer asked for.
        layer: u32,
        /// Levels the texture has.
        levels: u32,
        /// Layers the texture has.
        layers: u32,
    },
    /// A rectangle that is empty or reaches past the texture's edge.
    #[error("the {size:?} rectangle at {origin:?} is empty or outside the {texture_size:?} texture")]
    RegionOutside {
        /// Its top-left corner.
        origin: (u32, u32),
        /// Its size.
        size: (u32, u32),
        /// The texture's size (at the level asked for).
        texture_size: (u32, u32),
    },
}

/// What the application needs from the device.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Features the device must have; adapters without them are skipped.
    pub required_features: wgpu::Features,
    /// Features enabled when present, reported in [`GpuContext::features`].
    pub optional_features: wgpu::Features,
    /// Skip wgpu's validation of indirect draw arguments.
    ///
    /// By default wgpu checks every draw inside a `multi_draw_indexed_indirect`
    /// on the CPU while recording and again in a compute pass before it runs,
    /// so that a bad argument becomes a no-op rather than an out-of-bounds
    /// read. Oxygen writes its indirect arguments itself, from geometry
    /// ranges it allocated (`indirect_arguments_stay_inside_their_geometry`
    /// checks they stay in bounds), so it may skip that work: the time saved
    /// is measured by the `draw_path_bench` example (docs/performance.md).
    /// Leave it off when the application writes indirect arguments of its own
    /// into Oxygen's passes.
    pub trust_indirect_args: bool,
}

/// A wgpu instance, adapter, device and queue, created without a window.
pub struct GpuContext {
    /// The instance.
    pub instance: wgpu::Instance,
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Name, backend and driver of the adapter.
    pub adapter_info: wgpu::AdapterInfo,
    /// The features actually enabled on `device`.
    pub features: wgpu::Features,
}

fn rank(info: &wgpu::AdapterInfo) -> u32 {
    let device = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    device * 2 + backend
}

/// How many shared wgpu instances this process has created (see
/// [`GpuContext::instances_created`]).
static INSTANCES_CREATED: AtomicUsize = AtomicUsize::new(0);

/// The process's wgpu instance for `descriptor`'s backends and flags,
/// created the first time it is asked for and shared by every context
/// after that.
///
/// Each `wgpu::Instance` is a driver instance (a `VkInstance`), and the
/// NVIDIA driver (580, H100) stops listing adapters after some twenty
/// instances have been created in one process, even when every earlier one
/// and its device were dropped ("no adapters at all" from the 21st
/// context, whether or not it rendered). Benches, test suites and
/// applications that recreate their renderer make contexts one after
/// another; one instance serves them all, and each context still gets a
/// device of its own. (A context on a GL adapter then makes an instance of
/// its own: see [`GpuContext::new_headless_async`].)
fn shared_instance(descriptor: wgpu::InstanceDescriptor) -> wgpu::Instance {
    static INSTANCES: Mutex<Vec<((u32, u32), wgpu::Instance)>> = Mutex::new(Vec::new());
    let key = (descriptor.backends.bits(), descriptor.flags.bits());
    // The list is only ever pushed to, so a panic elsewhere leaves it whole.
    let mut instances = INSTANCES.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((_, instance)) = instances.iter().find(|(k, _)| *k == key) {
        return instance.clone();
    }
    let instance = wgpu::Instance::new(descriptor);
    INSTANCES_CREATED.fetch_add(1, Ordering::Relaxed);
    instances.push((key, instance.clone()));
    instance
}

/// The best adapter of `instance` that `OXYGEN_ADAPTER` (lowercased in
/// `wanted_name`) allows and that has the required features, by [`rank`];
/// the error lists what was tried and why each was passed over.
async fn pick_adapter(
    instance: &wgpu::Instance,
    backends: wgpu::Backends,
    options: &GpuOptions,
    wanted_name: Option<&str>,
) -> Result<(wgpu::Adapter, wgpu::AdapterInfo), GpuError> {
    let mut tried = Vec::new();
    let mut candidates = Vec::new();
    for adapter in instance.enumerate_adapters(backends).await {
        let info = adapter.get_info();
        let label = format!("{} ({:?})", info.name, info.backend);
        if let Some(wanted) = wanted_name
            && !info.name.to_lowercase().contains(wanted)
        {
            tried.push(format!("{label}: not matching OXYGEN_ADAPTER"));
            continue;
        }
        let missing = options.required_features - adapter.features();
        if !missing.is_empty() {
            tried.push(format!("{label}: lacks {missing:?}"));
            continue;
        }
        candidates.push((rank(&info), adapter, info));
    }
    candidates.sort_by_key(|(r, _, _)| *r);
    match candidates.into_iter().next() {
        Some((_, adapter, info)) => Ok((adapter, info)),
        None => {
            let tried = if tried.is_empty() { "no adapters at all".to_owned() } else { tried.join("; ") };
            Err(GpuError::NoAdapter { tried })
        }
    }
}

impl GpuContext {
    /// How many shared wgpu instances (driver instances) this process has
    /// created: one per backend set and instance flags, however many
    /// contexts were made ([`Self::new_headless`] shares them). GL's
    /// instances are not shared and not counted: each context whose
    /// backends include GL makes one of its own for its GL adapters.
    pub fn instances_created() -> usize {
        INSTANCES_CREATED.load(Ordering::Relaxed)
    }

    /// Picks an adapter and creates a device; blocks until done.
    pub fn new_headless(options: &GpuOptions) -> Result<Self, GpuError> {
        futures::executor::block_on(Self::new_headless_async(options))
    }

    /// Async form of [`Self::new_headless`].
    pub async fn new_headless_async(options: &GpuOptions) -> Result<Self, GpuError> {
        let _span = info_span!("gpu_context").entered();
        let descriptor = |backends: Option<wgpu::Backends>| {
            let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if options.trust_indirect_args {
                descriptor.flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
            }
            if let Some(backends) = backends {
                descriptor.backends = backends;
            }
            descriptor
        };
        let wanted_name = std::env::var("OXYGEN_ADAPTER").ok().map(|s| s.to_lowercase());
        let backends = descriptor(None).backends;
        // Every backend but GL from the process's shared instance. GL
        // adapters come from an instance of this context's own: a GL
        // instance has one EGL context, which every adapter and device made
        // from it uses, and two threads using it at once fail in EGL's
        // make_current (wgpu panics, even when an unused GL adapter is only
        // dropped). Private GL instances are what every context had before
        // instances were shared; the driver limit that made them shared is
        // NVIDIA's Vulkan one.
        let shared_backends = backends - wgpu::Backends::GL;
        let mut picks = Vec::new();
        let mut tried = Vec::new();
        if !shared_backends.is_empty() {
            let instance = shared_instance(descriptor(Some(shared_backends)));
            match pick_adapter(&instance, shared_backends, options, wanted_name.as_deref()).await {
                Ok((adapter, info)) => picks.push((instance, adapter, info)),
                Err(GpuError::NoAdapter { tried: why }) => tried.push(why),
                Err(e) => return Err(e),
            }
        }
        if backends.contains(wgpu::Backends::GL) {
            let own = wgpu::Instance::new(descriptor(Some(wgpu::Backends::GL)));
            match pick_adapter(&own, wgpu::Backends::GL, options, wanted_name.as_deref()).await {
                Ok((adapter, info)) => picks.push((own, adapter, info)),
                Err(GpuError::NoAdapter { tried: why }) => tried.push(why),
                Err(e) => return Err(e),
            }
        }
        // The best of the two by the same ranking as one enumeration of
        // every backend (a tie keeps the shared instance's adapter).
        let Some((instance, adapter, adapter_info)) = picks.into_iter().min_by_key(|(_, _, info)| rank(info)) else {
            return Err(GpuError::NoAdapter { tried: tried.join("; ") });
        };

        let features = options.required_features | (options.optional_features & adapter.features());
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("oxygen device"),
                required_features: features,
                required_limits: adapter.limits(),
                ..Default::default()
            })
            .await
            .map_err(|source| GpuError::RequestDevice { adapter: adapter_info.name.clone(), source })?;
        info!(
            adapter = %adapter_info.name,
            backend = ?adapter_info.backend,
            driver = %adapter_info.driver_info,
            "GPU adapter selected"
        );
        Ok(GpuContext { instance, adapter, device, queue, adapter_info, features })
    }

    /// `count` contexts for a group of renderers ([`Self::new_headless`]
    /// picks the first): one device on each adapter of the first's kind
    /// (device type and backend: the machine's GPUs), then more devices on
    /// the same adapters in turn when there are fewer adapters than
    /// `count` (a machine with one GPU gets `count` devices of it). GL
    /// adapters come from an instance of each context's own, as in
    /// [`Self::new_headless`].
    pub fn new_headless_many(options: &GpuOptions, count: usize) -> Result<Vec<Self>, GpuError> {
        Self::new_headless_group(options, count, true)
    }

    /// As [`Self::new_headless_many`], with `spread` false: every device on
    /// the one adapter [`Self::new_headless`] picks, however many GPUs the
    /// machine has (what a group gains from its CPU threads alone).
    pub fn new_headless_group(options: &GpuOptions, count: usize, spread: bool) -> Result<Vec<Self>, GpuError> {
        let _span = info_span!("gpu_contexts", count, spread).entered();
        let first = Self::new_headless(options)?;
        if count <= 1 {
            return Ok(vec![first]);
        }
        if first.adapter_info.backend == wgpu::Backend::Gl {
            let mut contexts = vec![first];
            for _ in 1..count {
                contexts.push(Self::new_headless(options)?);
            }
            return Ok(contexts);
        }
        let wanted_name = std::env::var("OXYGEN_ADAPTER").ok().map(|s| s.to_lowercase());
        let backends = wgpu::Backends::from(first.adapter_info.backend);
        // Every adapter of the first's kind, the first's own first.
        let mut adapters = vec![first.adapter.clone()];
        let others =
            if spread { futures::executor::block_on(first.instance.enumerate_adapters(backends)) } else { Vec::new() };
        for adapter in others {
            let info = adapter.get_info();
            let same_kind = rank(&info) == rank(&first.adapter_info)
                && wanted_name.as_deref().is_none_or(|w| info.name.to_lowercase().contains(w))
                && (options.required_features - adapter.features()).is_empty();
            let is_first =
                info == first.adapter_info && (info.device_pci_bus_id == first.adapter_info.device_pci_bus_id);
            if same_kind && !is_first {
                adapters.push(adapter);
            }
        }
        let mut contexts = vec![first];
        for i in 1..count {
            let adapter = adapters[i % adapters.len()].clone();
            let adapter_info = adapter.get_info();
            let features = options.required_features | (options.optional_features & adapter.features());
            let (device, queue) = futures::executor::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("oxygen device"),
                required_features: features,
                required_limits: adapter.limits(),
                ..Default::default()
            }))
            .map_err(|source| GpuError::RequestDevice { adapter: adapter_info.name.clone(), source })?;
            info!(adapter = %adapter_info.name, device = i, "GPU device for a group member");
            let instance = contexts[0].instance.clone();
            contexts.push(GpuContext { instance, adapter, device, queue, adapter_info, features });
        }
        Ok(contexts)
    }

    /// One line naming the adapter, backend and driver, for logs and test output.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            self.adapter_info.name,
            self.adapter_info.backend,
            self.adapter_info.device_type,
            self.adapter_info.driver,
            self.adapter_info.driver_info
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::{AdapterInfo, Backend, DeviceType};

    #[test]
    fn adapters_rank_by_device_type_then_backend() {
        // Best first: each kind of device before the next, and within a kind
        // a native backend (Vulkan, Metal, Dx12) before the rest.
        let order = [
            (DeviceType::DiscreteGpu, Backend::Vulkan),
            (DeviceType::DiscreteGpu, Backend::Gl),
            (DeviceType::IntegratedGpu, Backend::Metal),
            (DeviceType::IntegratedGpu, Backend::Gl),
            (DeviceType::VirtualGpu, Backend::Dx12),
            (DeviceType::VirtualGpu, Backend::BrowserWebGpu),
            (DeviceType::Cpu, Backend::Vulkan),
            (DeviceType::Cpu, Backend::Gl),
            (DeviceType::Other, Backend::Vulkan),
            (DeviceType::Other, Backend::Noop),
        ];
        let ranks = order.map(|(device, backend)| rank(&AdapterInfo::new(device, backend)));
        for (pair, ranks) in order.windows(2).zip(ranks.windows(2)) {
            assert!(
                ranks[0] < ranks[1],
                "{:?} ranked {} should beat {:?} ranked {}",
                pair[0],
                ranks[0],
                pair[1],
                ranks[1]
            );
        }
    }

    #[test]
    fn native_backends_of_one_device_type_rank_alike() {
        // `new_headless_many` groups adapters of equal rank as one kind.
        for device in [DeviceType::DiscreteGpu, DeviceType::IntegratedGpu, DeviceType::Cpu] {
            let native = [Backend::Vulkan, Backend::Metal, Backend::Dx12].map(|b| rank(&AdapterInfo::new(device, b)));
            assert!(native.iter().all(|r| *r == native[0]), "{device:?}: {native:?}");
            let other =
                [Backend::Gl, Backend::BrowserWebGpu, Backend::Noop].map(|b| rank(&AdapterInfo::new(device, b)));
            assert!(other.iter().all(|r| *r == other[0] && *r > native[0]), "{device:?}: {other:?} after {native:?}");
        }
    }
}
