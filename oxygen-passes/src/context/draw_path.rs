//! How a partition's draws are submitted: one call per draw, or one
//! multi-draw per partition where the device allows it.

/// How a partition's draws are submitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DrawPath {
    /// One `draw_indexed` per draw; works on every backend.
    Direct,
    /// One `multi_draw_indexed_indirect` per partition over the indirect
    /// arguments ScenePrep wrote; needs `DownlevelFlags::INDIRECT_EXECUTION`
    /// and `Features::INDIRECT_FIRST_INSTANCE`.
    MultiDrawIndirect,
}

impl DrawPath {
    /// The fastest path the device supports.
    pub fn best_for(features: wgpu::Features, downlevel: &wgpu::DownlevelCapabilities) -> Self {
        if Self::MultiDrawIndirect.is_supported(features, downlevel) {
            DrawPath::MultiDrawIndirect
        } else {
            DrawPath::Direct
        }
    }

    /// Whether the device can use this path.
    pub fn is_supported(self, features: wgpu::Features, downlevel: &wgpu::DownlevelCapabilities) -> bool {
        match self {
            DrawPath::Direct => true,
            DrawPath::MultiDrawIndirect => {
                features.contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
                    && downlevel.flags.contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
            }
        }
    }
}
