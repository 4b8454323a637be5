//! Keeps the GPU busy for a chosen time: a compute pass of spin loops,
//! calibrated once. The benchmarks use it as a control. After a long GPU
//! frame the CPU waits, and the next frame's CPU work is slower on some
//! drivers whatever the scene (`indirect_count_cost` measures how much), so
//! a small scene is compared with a large one only after the same GPU time.

use std::time::Instant;

use oxygen::gpu::GpuContext;

const SHADER: &str = r#"
@group(0) @binding(0) var<storage, read_write> sink: array<u32>;
@group(0) @binding(1) var<uniform> iterations: vec4<u32>;
@compute @workgroup_size(64)
fn spin(@builtin(global_invocation_id) id: vec3<u32>) {
    var x = id.x;
    for (var i = 0u; i < iterations.x; i++) {
        x = x * 1664525u + 1013904223u;
    }
    sink[id.x] = x;
}
"#;

const GROUPS: u32 = 1024;

/// A calibrated spin pass.
pub struct GpuSpin {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    iterations: wgpu::Buffer,
    ms_per_iteration: f64,
}

impl GpuSpin {
    /// Builds the pass and measures how long one loop iteration takes.
    pub fn new(gpu: &GpuContext) -> Result<GpuSpin, Box<dyn std::error::Error>> {
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gpu spin"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("gpu spin"),
            layout: None,
            module: &module,
            entry_point: Some("spin"),
            compilation_options: Default::default(),
            cache: None,
        });
        let sink = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("gpu spin sink"),
            size: u64::from(GROUPS) * 64 * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let iterations = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("gpu spin iterations"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gpu spin"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: sink.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: iterations.as_entire_binding() },
            ],
        });
        let mut spin = GpuSpin { pipeline, bind_group, iterations, ms_per_iteration: 0.0 };
        spin.run(gpu, 1 << 10)?;
        let big = 1u32 << 16;
        let (small_ms, big_ms) = (spin.run(gpu, 1 << 12)?, spin.run(gpu, big)?);
        spin.ms_per_iteration = ((big_ms - small_ms) / f64::from(big - (1 << 12))).max(1e-9);
        Ok(spin)
    }

    /// Keeps the GPU busy for about `ms` and waits for it; returns the
    /// waited time in milliseconds.
    pub fn busy(&self, gpu: &GpuContext, ms: f64) -> Result<f64, Box<dyn std::error::Error>> {
        if ms <= 0.0 {
            return Ok(0.0);
        }
        self.run(gpu, (ms / self.ms_per_iteration).round().min(f64::from(u32::MAX)) as u32)
    }

    fn run(&self, gpu: &GpuContext, iterations: u32) -> Result<f64, Box<dyn std::error::Error>> {
        gpu.queue.write_buffer(&self.iterations, 0, &[iterations, 0, 0, 0].map(u32::to_le_bytes).concat());
        let start = Instant::now();
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(GROUPS, 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        gpu.device.poll(wgpu::PollType::wait_indefinitely())?;
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }
}
