//! `CommandRecorder`: the encoder a view's passes record into, and what
//! they recorded.

/// Counts of what a view's passes recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// wgpu render passes begun.
    pub render_passes: u32,
    /// Pipelines set (one per partition drawn).
    pub pipeline_binds: u32,
    /// Draw calls recorded (a multi-draw counts once).
    pub draw_calls: u32,
    /// Draw commands the GPU executes (each command of a multi-draw counts;
    /// an instanced run counts once).
    pub draw_commands: u32,
    /// Shading tone-mapped in place and wrote the display colour: the HDR
    /// image was not written this frame.
    pub tone_mapped_in_pass: bool,
    /// Light-cluster jobs recorded (one per clustered view a frame, however
    /// many of its passes shade).
    pub light_cluster_jobs: u32,
    /// Vertices the overlay pass drew (0 without an overlay).
    pub overlay_vertices: u64,
    /// Cameras shaded by deferred shading's compute pass
    /// ([`crate::DeferredShading`]; 0 when the job shaded forward).
    pub deferred_views: u32,
}

/// The command encoder of one view plus counters.
pub struct CommandRecorder {
    encoder: wgpu::CommandEncoder,
    /// What was recorded so far.
    pub stats: RecordStats,
}

impl CommandRecorder {
    /// A recorder with a fresh encoder.
    pub fn new(device: &wgpu::Device, label: &str) -> Self {
        CommandRecorder {
            encoder: device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) }),
            stats: RecordStats::default(),
        }
    }

    /// The encoder.
    pub fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        &mut self.encoder
    }

    /// Finishes recording.
    pub fn finish(self) -> (wgpu::CommandBuffer, RecordStats) {
        (self.encoder.finish(), self.stats)
    }
}
