//! The bindless heap on a real device: domains grow with their live data
//! copied, stale and out-of-range writes are errors.

mod support;

use oxygen::bindless::{BindlessError, BindlessHeap, DomainKind, SlotError, TexturePath};
use oxygen::gpu::{GpuContext, GpuOptions};

fn read_buffer(gpu: &GpuContext, buffer: &wgpu::Buffer, bytes: u64) -> Vec<u8> {
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("test readback"),
        size: bytes,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, bytes);
    gpu.queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |r| r.expect("map"));
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).expect("poll");
    let data = staging.slice(..).get_mapped_range().expect("mapped").to_vec();
    staging.unmap();
    data
}

/// Words in one material record.
const WORDS: usize = DomainKind::Materials.record_size() as usize / 4;

/// A material-sized record whose words all equal `value`.
fn record(value: u32) -> [u32; WORDS] {
    [value; WORDS]
}

#[test]
fn a_domain_grows_and_keeps_its_live_records() {
    let gpu = GpuContext::new_headless(&GpuOptions::default()).expect("test adapter");
    let mut heap = BindlessHeap::new(&gpu.device, &gpu.queue, TexturePath::GroupedArrays);
    let first = heap.slots.allocate(DomainKind::Materials, 10).unwrap();
    assert!(!heap.ensure_capacity(&gpu.device, &gpu.queue), "10 records fit the initial buffer");
    let first_records: Vec<_> = (0..10).map(|i| record(1000 + i)).collect();
    heap.write(&gpu.queue, &first, 0, &first_records).unwrap();

    let initial = heap.capacity(DomainKind::Materials);
    let second = heap.slots.allocate(DomainKind::Materials, 5000).unwrap();
    // Writing before growing is refused, not silently dropped.
    assert!(matches!(heap.write(&gpu.queue, &second, 4999, &[record(7)]), Err(BindlessError::BeyondCapacity { .. })));
    assert!(heap.ensure_capacity(&gpu.device, &gpu.queue), "5010 records need a bigger buffer");
    assert!(heap.capacity(DomainKind::Materials) >= 5010 && heap.capacity(DomainKind::Materials) > initial);
    assert_eq!(heap.growth_count(), 1);
    let second_records: Vec<_> = (0..5000).map(|i| record(50_000 + i)).collect();
    heap.write(&gpu.queue, &second, 0, &second_records).unwrap();

    let bytes = read_buffer(&gpu, heap.buffer(DomainKind::Materials), 5010 * DomainKind::Materials.record_size());
    let words: &[[u32; WORDS]] = bytemuck::cast_slice(&bytes);
    assert_eq!(&words[first.start as usize..first.end() as usize], &first_records[..], "copied across growth");
    assert_eq!(&words[second.start as usize..second.end() as usize], &second_records[..]);

    // A freed range's handle is stale: writing through it is an error.
    heap.slots.free(first).unwrap();
    assert!(matches!(
        heap.write(&gpu.queue, &first, 0, &[record(1)]),
        Err(BindlessError::Slot(SlotError::Stale { .. }))
    ));
    // Records of the wrong size are refused.
    assert!(matches!(heap.write(&gpu.queue, &second, 0, &[0u32; 4]), Err(BindlessError::RecordSize { .. })));
}

#[test]
fn a_long_run_of_view_and_node_churn_keeps_gpu_memory_bounded() {
    use oxygen::glam::Vec4;
    use oxygen::prelude::*;
    // keep_hdr: the churn reads every HDR target to check it is finite.
    let mut renderer =
        Renderer::new_headless_with(RendererOptions { keep_hdr: true, ..Default::default() }).expect("test adapter");
    let mut demo = oxygen_demo::multi_view_scene();
    let cube = demo.scene.add_geometry(Geometry::cube(0.5));
    let material = demo.scene.add_material(Material::opaque("churn", Vec4::ONE));
    let mut extra = Vec::new();
    let mut views = Vec::new();
    let mut bytes_after_warm_up = 0;
    for frame in 0..600u32 {
        if frame % 3 == 0 {
            let node = demo
                .scene
                .add_node("churn", Transform::from_translation(Vec3::new((frame % 7) as f32 - 3.0, 2.0, 0.0)));
            demo.scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
            extra.push(node);
        }
        if extra.len() > 8 {
            demo.scene.remove_node(extra.remove(0)).unwrap();
        }
        if frame % 5 == 0 && views.len() < 4 {
            views.push(
                renderer.register_view(oxygen_demo::main_camera(UVec2::new(16, 16)), standard_render_graph).unwrap(),
            );
        } else if frame % 7 == 0 && views.len() > 1 {
            renderer.unregister_view(views.remove(0)).unwrap();
        }
        renderer.render_frame(&demo.scene).unwrap();
        if frame % 100 == 0 {
            for &view in &views {
                support::assert_hdr_finite(&renderer, view);
            }
        }
        if frame == 100 {
            bytes_after_warm_up = renderer.internals().heap.gpu_bytes();
        }
    }
    assert!(bytes_after_warm_up > 0);
    assert_eq!(renderer.internals().heap.gpu_bytes(), bytes_after_warm_up, "the heap kept growing under steady churn");
    for view in views {
        renderer.unregister_view(view).unwrap();
    }
    for kind in [DomainKind::DrawMetadata, DomainKind::IndirectArgs] {
        assert_eq!(renderer.internals().heap.slots.get(kind).live_allocations(), 0, "{kind:?} leaked");
    }
}

/// `write_runs` writes what one `write` per run would, adjacent runs as
/// one staging copy, gaps untouched; it checks every run before writing
/// anything and refuses runs of two domains.
#[test]
fn runs_are_written_as_one_write_each_would_write_them() {
    let gpu = GpuContext::new_headless(&GpuOptions::default()).expect("test adapter");
    let mut heap = BindlessHeap::new(&gpu.device, &gpu.queue, TexturePath::GroupedArrays);
    // Three adjacent ranges, then a gap (a range left unwritten), then one more.
    let ranges: Vec<_> =
        [4, 3, 5, 2, 6].iter().map(|n| heap.slots.allocate(DomainKind::Materials, *n).unwrap()).collect();
    heap.ensure_capacity(&gpu.device, &gpu.queue);
    let sentinel: Vec<_> = (0..2).map(|_| record(0xdead)).collect();
    heap.write(&gpu.queue, &ranges[3], 0, &sentinel).unwrap();
    let contents: Vec<Vec<[u32; WORDS]>> =
        ranges.iter().enumerate().map(|(r, a)| (0..a.count).map(|i| record(100 * r as u32 + i)).collect()).collect();
    // Run 1 skips its first record (an offset); the runs come out of order.
    let runs = [
        (&ranges[4], 0, &contents[4][..]),
        (&ranges[0], 0, &contents[0][..]),
        (&ranges[2], 0, &contents[2][..]),
        (&ranges[1], 1, &contents[1][1..]),
    ];
    let before = heap.bytes_written();
    heap.write_runs(&gpu.queue, &runs).unwrap();
    let record_size = DomainKind::Materials.record_size();
    assert_eq!(heap.bytes_written() - before, (4 + 2 + 5 + 6) * record_size, "the runs' records, no more");

    let end = ranges.iter().map(|a| a.end()).max().unwrap() as u64;
    let bytes = read_buffer(&gpu, heap.buffer(DomainKind::Materials), end * record_size);
    let words: &[[u32; WORDS]] = bytemuck::cast_slice(&bytes);
    let at = |a: &oxygen::bindless::Allocation| &words[a.start as usize..a.end() as usize];
    assert_eq!(at(&ranges[0]), &contents[0][..]);
    assert_eq!(&at(&ranges[1])[1..], &contents[1][1..], "written from its offset");
    assert_eq!(at(&ranges[2]), &contents[2][..]);
    assert_eq!(at(&ranges[3]), &sentinel[..], "a range no run names keeps what it held");
    assert_eq!(at(&ranges[4]), &contents[4][..]);

    // A run past its range is refused before anything is written.
    let too_long: Vec<_> = (0..3).map(|_| record(7)).collect();
    let refused = heap.write_runs(&gpu.queue, &[(&ranges[0], 0, &contents[0][..]), (&ranges[3], 0, &too_long[..])]);
    assert!(matches!(refused, Err(BindlessError::Slot(SlotError::WriteTooLarge { .. }))), "{refused:?}");
    // Runs of two domains are refused (one call writes one domain's buffer).
    let transforms = heap.slots.allocate(DomainKind::WorldTransforms, 1).unwrap();
    heap.ensure_capacity(&gpu.device, &gpu.queue);
    let mixed = heap.write_runs(&gpu.queue, &[(&ranges[0], 0, &contents[0][..1]), (&transforms, 0, &contents[0][..1])]);
    assert!(matches!(mixed, Err(BindlessError::MixedDomains { .. })), "{mixed:?}");
    // Nothing of a refused call was written.
    let bytes = read_buffer(&gpu, heap.buffer(DomainKind::Materials), end * record_size);
    let words: &[[u32; WORDS]] = bytemuck::cast_slice(&bytes);
    assert_eq!(&words[ranges[3].start as usize..ranges[3].end() as usize], &sentinel[..]);
}
