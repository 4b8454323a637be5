//! The headless GPU: adapter and device selection, offscreen targets and
//! readback into images.

mod context;
mod readback;
mod target;

pub use context::{GpuContext, GpuError, GpuOptions};
pub use readback::{HdrImage, f16_to_f32, unpack_rg11b10_ufloat};
pub use target::{ColorTargets, HdrFormat, Msaa, MsaaTargets, ViewTargets};
