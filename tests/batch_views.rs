//! Batches of cameras ([`oxygen::batch`]): every camera of a batch renders
//! the image the same camera renders registered alone, its depth reads
//! back as the distance of what it sees, cameras come and go between
//! frames without disturbing the others, and what a batch cannot hold is
//! refused with a reason.

mod support;

use oxygen::batch::{BatchDesc, standard_batch_graph};
use oxygen::glam::Vec4;
use oxygen::gpu::{Label, LabelSet};
use oxygen::graph::StandardGraph;
use oxygen::image::RgbaImage;
use oxygen::prelude::*;
use oxygen::{FrameWarning, RenderError, ViewRole};
use support::golden::compare;

/// The standard graph as a lone view records what the batch graph records
/// for each camera: no pre-pass, no sun cascades.
fn lone_graph() -> StandardGraph {
    StandardGraph::new(standard_batch_graph.lit.clone())
}

/// A ring of `n` cameras of `size` around the demo's cubes, each at its own
/// angle and height.
fn ring(n: usize, size: UVec2) -> Vec<LookAtResolver> {
    (0..n)
        .map(|i| {
            let angle = i as f32 / n as f32 * std::f32::consts::TAU;
            let eye = Vec3::new(7.0 * angle.cos(), 2.0 + i as f32 * 0.5, 7.0 * angle.sin());
            LookAtResolver::new(Camera::perspective(55f32.to_radians(), 0.1, None), eye, Vec3::ZERO, size)
                .expect("ring cameras are valid")
        })
        .collect()
}

/// The largest channel error and the pixels differing by more than 2
/// levels between a batch camera's image and the lone view's.
fn difference(a: &RgbaImage, b: &RgbaImage) -> (u8, usize) {
    let c = compare(a, b, 2);
    (c.worst, c.differing)
}

/// Renders `cameras` registered alone, one renderer each, with `options`.
fn alone(scene: &Scene, cameras: &[LookAtResolver], options: RendererOptions) -> Vec<RgbaImage> {
    cameras
        .iter()
        .map(|camera| {
            let mut renderer = support::gpu_renderer_with(options);
            let view = renderer.register_view(*camera, lone_graph()).unwrap();
            // The batch graph records an ordinary view too, as the
            // standard graph with its settings does.
            let by_batch_graph = renderer.register_view(*camera, standard_batch_graph).unwrap();
            renderer.render_frame(scene).unwrap();
            let image = renderer.read_color(view).unwrap();
            assert!(renderer.read_color(by_batch_graph).unwrap() == image, "a view recorded by the batch graph");
            image
        })
        .collect()
}

fn assert_same_pictures(batch: &[RgbaImage], lone: &[RgbaImage], what: &str) {
    for (i, (a, b)) in batch.iter().zip(lone).enumerate() {
        let (worst, differing) = difference(a, b);
        // Same draws, same shaders, same pixels: only the viewport's offset
        // in the atlas differs, which moves no sample. Measured: 0 and 0.
        assert!(
            differing == 0 && worst <= 2,
            "{what}: camera {i} differs from its lone render: {differing} pixels, worst {worst}"
        );
        // And the picture is not empty: the cubes are in every camera.
        assert!(a.pixels().any(|p| p.0 != b.get_pixel(0, 0).0), "{what}: camera {i} shows nothing");
    }
}

#[test]
fn every_camera_of_a_batch_renders_what_it_renders_alone() {
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(64, 48);
    let cameras = ring(5, size);
    for keep_hdr in [true, false] {
        let options = RendererOptions { keep_hdr, ..Default::default() };
        let mut renderer = support::gpu_renderer_with(options);
        let batch = renderer.register_batch(BatchDesc::new("ring", size)).unwrap();
        let ids: Vec<ViewId> = cameras.iter().map(|c| renderer.add_camera(batch, *c).unwrap()).collect();
        let report = renderer.render_frame(&demo.scene).unwrap();
        // The five cameras record the render passes one camera alone
        // records (their atlas is one page), not five times as many.
        let passes: u32 = report.views.iter().map(|v| v.recorded.render_passes).sum();
        let mut one = support::gpu_renderer_with(options);
        one.register_view(cameras[0], lone_graph()).unwrap();
        let one_passes = one.render_frame(&demo.scene).unwrap().views[0].recorded.render_passes;
        assert_eq!(passes, one_passes, "keep_hdr {keep_hdr}: render passes of the batch");
        assert!(report.views.iter().all(|v| v.role == ViewRole::BatchCamera { batch }));
        let batch_images: Vec<RgbaImage> = ids.iter().map(|id| renderer.read_color(*id).unwrap()).collect();
        assert_same_pictures(&batch_images, &alone(&demo.scene, &cameras, options), &format!("keep_hdr {keep_hdr}"));
        // The HDR image (written: the demo scene blends) is each camera's
        // own tile of the HDR page: the radiance the lone camera's holds.
        let hdr = renderer.read_hdr(ids[4]).unwrap();
        support::assert_hdr_image_finite(&hdr, "a batch camera's HDR tile");
        let lone = one.register_view(cameras[4], lone_graph()).unwrap();
        one.render_frame(&demo.scene).unwrap();
        let lone_hdr = one.read_hdr(lone).unwrap();
        assert_eq!((hdr.width, hdr.height), (64, 48));
        assert_eq!(hdr.pixels, lone_hdr.pixels, "keep_hdr {keep_hdr}: the tile's HDR radiance is the lone camera's");
    }
}

#[test]
fn a_batch_of_many_pages_renders_every_camera() {
    // Pages of 100 pixels hold one column of two 64 × 48 cameras: five
    // cameras take three pages, each recording the passes of one camera.
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(64, 48);
    let cameras = ring(5, size);
    let options = RendererOptions::default();
    let mut renderer = support::gpu_renderer_with(options);
    let desc = BatchDesc::new("pages", size).with_max_page_side(100);
    let batch = renderer.register_batch(desc).unwrap();
    let ids: Vec<ViewId> = cameras.iter().map(|c| renderer.add_camera(batch, *c).unwrap()).collect();
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let passes: u32 = report.views.iter().map(|v| v.recorded.render_passes).sum();
    let mut one = support::gpu_renderer_with(options);
    one.register_view(cameras[0], lone_graph()).unwrap();
    let one_passes = one.render_frame(&demo.scene).unwrap().views[0].recorded.render_passes;
    assert_eq!(passes, 3 * one_passes, "three pages, each with the passes of one camera");
    let images: Vec<RgbaImage> = ids.iter().map(|id| renderer.read_color(*id).unwrap()).collect();
    assert_same_pictures(&images, &alone(&demo.scene, &cameras, options), "pages");
    let refused = renderer.register_batch(BatchDesc::new("tiny pages", size).with_max_page_side(50));
    assert!(matches!(refused, Err(RenderError::InvalidBatch { .. })), "{refused:?}");
}

#[test]
fn depth_reads_back_as_the_distance_of_a_plane() {
    // Cameras 6 units above a ground plane look straight down: the plane's
    // linear depth is 6 at every pixel, for batch cameras and a lone view
    // alike; under the camera at x = 3 stands a unit box whose top is 4
    // units away, so a tile read from the wrong place of the atlas shows.
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("ground", Vec4::splat(0.5)));
    let plane = scene.add_geometry(Geometry::plane(100.0));
    let ground = scene.add_node("ground", Transform::IDENTITY);
    scene.set_renderable(ground, Renderable { geometry: plane, materials: vec![grey] }).unwrap();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let post = scene.add_node("box", Transform::from_translation(Vec3::new(3.0, 1.5, 0.0)));
    scene.set_renderable(post, Renderable { geometry: cube, materials: vec![grey] }).unwrap();
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(1.0))).unwrap();
    let size = UVec2::new(40, 30);
    let down = |x: f32| {
        LookAtResolver::new(
            Camera::perspective(50f32.to_radians(), 0.1, None),
            Vec3::new(x, 6.0, 0.0),
            Vec3::new(x, 0.0, 0.0),
            size,
        )
        .unwrap()
        .with_up(Vec3::Z)
        .unwrap()
    };
    let mut renderer = support::gpu_renderer();
    let batch = renderer.register_batch(BatchDesc::new("down", size)).unwrap();
    let over_ground = renderer.add_camera(batch, down(-2.0)).unwrap();
    let over_box = renderer.add_camera(batch, down(3.0)).unwrap();
    let lone = renderer.register_view(down(-4.0), lone_graph()).unwrap();
    renderer.render_frame(&scene).unwrap();
    for view in [over_ground, lone] {
        let depth = renderer.read_depth(view).unwrap();
        assert_eq!((depth.width, depth.height), (40, 30));
        let worst = depth.linear().iter().map(|d| (d - 6.0).abs()).fold(0.0f32, f32::max);
        // Depth32Float at 6 units under reverse-Z keeps about 7 digits:
        // measured worst 0 (lavapipe) and 5.7e-6 (GL, through its depth
        // copy pass); bound 1.5 × that.
        assert!(worst < 8.5e-6, "{view}: linear depth strays {worst} from 6");
        // Device depth: near / distance for an infinite reverse-Z projection.
        let device = depth.get(20, 15);
        assert!((device - 0.1 / 6.0).abs() < 1e-6, "{view}: device depth {device}");
    }
    let depth = renderer.read_depth(over_box).unwrap();
    let linear = depth.linear();
    let at = |x: u32, y: u32| linear[(y * depth.width + x) as usize];
    assert!((at(20, 15) - 4.0).abs() < 8.5e-6, "the box top is 4 units away, read {}", at(20, 15));
    assert!((at(0, 0) - 6.0).abs() < 8.5e-6, "the ground is 6 units away at the corner, read {}", at(0, 0));
}

/// A batch's cameras keep their constants in one uniform buffer, each at
/// its own offset (written with one upload a frame), and still render what
/// they render alone, also after the batch grows past its buffer's slots;
/// a lone view has a buffer of its own.
#[test]
fn a_batchs_cameras_share_one_constants_buffer() {
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(40, 30);
    let cameras = ring(6, size);
    let options = RendererOptions::default();
    let lone = alone(&demo.scene, &cameras, options);
    let mut renderer = support::gpu_renderer_with(options);
    let batch = renderer.register_batch(BatchDesc::new("shared", size)).unwrap();
    let mut ids: Vec<ViewId> = cameras[..2].iter().map(|c| renderer.add_camera(batch, *c).unwrap()).collect();
    let other = renderer.register_view(cameras[0], lone_graph()).unwrap();
    for frame in 0..2 {
        renderer.render_frame(&demo.scene).unwrap();
        let homes: Vec<(wgpu::Buffer, u64)> =
            ids.iter().map(|id| renderer.view_constants(*id).map(|(b, o)| (b.clone(), o)).unwrap()).collect();
        assert!(homes.iter().all(|(buffer, _)| *buffer == homes[0].0), "frame {frame}: one buffer for the batch");
        let mut offsets: Vec<u64> = homes.iter().map(|(_, offset)| *offset).collect();
        offsets.sort_unstable();
        offsets.dedup();
        assert_eq!(offsets.len(), ids.len(), "frame {frame}: each camera at its own offset");
        let (lone_buffer, lone_offset) = renderer.view_constants(other).unwrap();
        assert!(*lone_buffer != homes[0].0 && lone_offset == 0, "a lone view's constants are its own");
        let images: Vec<RgbaImage> = ids.iter().map(|id| renderer.read_color(*id).unwrap()).collect();
        assert_same_pictures(&images, &lone[..ids.len()], &format!("frame {frame}"));
        // More cameras than the first buffer had slots for.
        for camera in &cameras[ids.len()..] {
            ids.push(renderer.add_camera(batch, *camera).unwrap());
        }
    }
}

#[test]
fn cameras_come_and_go_between_frames() {
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(48, 36);
    let cameras = ring(4, size);
    let options = RendererOptions::default();
    let lone = alone(&demo.scene, &cameras, options);
    let mut renderer = support::gpu_renderer_with(options);
    let batch = renderer.register_batch(BatchDesc::new("changing", size)).unwrap();
    let a = renderer.add_camera(batch, cameras[0]).unwrap();
    let b = renderer.add_camera(batch, cameras[1]).unwrap();
    let c = renderer.add_camera(batch, cameras[2]).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    assert_same_pictures(&[renderer.read_color(b).unwrap()], &lone[1..2], "b, frame 1");

    // b goes, d comes (into b's tile); a and c keep their tiles and images.
    renderer.unregister_view(b).unwrap();
    let d = renderer.add_camera(batch, cameras[3]).unwrap();
    assert_eq!(renderer.batch_cameras(batch).unwrap(), vec![a, d, c]);
    let report = renderer.render_frame(&demo.scene).unwrap();
    assert_eq!(report.views.len(), 3);
    assert!(matches!(renderer.read_color(b), Err(RenderError::NoSuchView(_))));
    let images: Vec<RgbaImage> = [a, c, d].iter().map(|v| renderer.read_color(*v).unwrap()).collect();
    assert_same_pictures(&images, &[lone[0].clone(), lone[2].clone(), lone[3].clone()], "frame 2");

    // The whole batch goes.
    renderer.unregister_batch(batch).unwrap();
    assert!(renderer.render_frame(&demo.scene).unwrap().views.is_empty());
    assert!(matches!(renderer.add_camera(batch, cameras[0]), Err(RenderError::NoSuchBatch(_))));
}

#[test]
fn what_a_batch_cannot_hold_is_refused_with_a_reason() {
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(32, 32);
    let camera = ring(1, size).remove(0);
    let mut renderer = support::gpu_renderer();
    let empty = renderer.register_batch(BatchDesc::new("empty", UVec2::new(0, 32)));
    assert!(matches!(empty, Err(RenderError::InvalidBatch { .. })), "{empty:?}");
    let batch = renderer.register_batch(BatchDesc::new("rig", size)).unwrap();
    let msaa = renderer.add_camera(batch, ViewDesc::new(camera).with_msaa(oxygen::gpu::Msaa::X4));
    let message = msaa.expect_err("MSAA is refused").to_string();
    assert!(message.contains("rig") && message.contains("MSAA"), "{message}");
    let shadows = renderer.add_camera(batch, ViewDesc::new(camera).with_sun_shadows(Default::default()));
    assert!(matches!(shadows, Err(RenderError::InvalidBatch { .. })));

    // An atlas past the target budget: the batch's cameras are skipped
    // with the reason, the frame goes on.
    let mut small = support::gpu_renderer_with(RendererOptions { target_budget_bytes: 4096, ..Default::default() });
    let batch = small.register_batch(BatchDesc::new("too big", size)).unwrap();
    let view = small.add_camera(batch, camera).unwrap();
    let report = small.render_frame(&demo.scene).unwrap();
    let reason = report.warnings.iter().find_map(|w| match w {
        FrameWarning::ViewSkipped { view: v, reason, .. } if *v == view => Some(reason.clone()),
        _ => None,
    });
    let reason = reason.expect("the camera is skipped");
    assert!(reason.contains("too big") && reason.contains("budget"), "{reason}");
}

/// A batch streamed back: every frame arrives once, in order, tagged with
/// its number; each camera's images are what `read_color` and `read_depth`
/// read after that frame; a change made before frame k shows in frame k's
/// images and not in frame k − 1's; frames not taken wait, none is lost.
#[test]
fn streamed_frames_arrive_tagged_in_order_without_an_off_by_one() {
    use oxygen::batch::StreamOptions;
    let mut demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(48, 36);
    let cameras = ring(3, size);
    let mut renderer = support::gpu_renderer_with(RendererOptions::default());
    let batch = renderer.register_batch(BatchDesc::new("streamed", size).with_labels()).unwrap();
    let ids: Vec<ViewId> = cameras.iter().map(|c| renderer.add_camera(batch, *c).unwrap()).collect();
    let options = StreamOptions {
        frames_in_flight: 1,
        instances: true,
        semantic: true,
        linear_depth: true,
        ..Default::default()
    };
    renderer.stream_batch(batch, Some(options)).unwrap();

    // Frames 1 and 2 as they are; frame 3 after a cube moved away.
    let mut expected = Vec::new();
    for frame in 1..=3u64 {
        if frame == 3 {
            let moved = Transform::from_translation(Vec3::new(0.0, 40.0, 0.0));
            for cube in &demo.cubes {
                demo.scene.set_local_transform(*cube, moved).unwrap();
            }
        }
        let report = renderer.render_frame(&demo.scene).unwrap();
        assert_eq!(report.frame_index, frame);
        // Each camera's report says what it streams back (five planes of
        // 4 bytes a texel) and what its batch holds (at its first camera).
        let camera_reports: Vec<_> =
            ids.iter().map(|id| report.views.iter().find(|v| v.view == *id).unwrap()).collect();
        assert!(camera_reports.iter().all(|v| v.streamed_bytes == 5 * 4 * 48 * 36), "streamed bytes a camera");
        let atlas_bytes = renderer.batch_atlas(batch).map(|(atlas, _)| atlas.bytes()).unwrap();
        assert_eq!(camera_reports.iter().map(|v| v.target_bytes).collect::<Vec<_>>(), [atlas_bytes, 0, 0]);
        let images: Vec<(RgbaImage, Vec<f32>, oxygen::LabelImage)> = ids
            .iter()
            .map(|id| {
                let color = renderer.read_color(*id).unwrap();
                (color, renderer.read_depth(*id).unwrap().depth, renderer.read_labels(*id).unwrap())
            })
            .collect();
        expected.push(images);
    }
    // One buffer, three frames, nothing taken until now: none is lost.
    let streamed = renderer.wait_streamed().unwrap();
    assert_eq!(streamed.iter().map(|f| f.frame).collect::<Vec<_>>(), [1, 2, 3]);
    for (frame, want) in streamed.iter().zip(&expected) {
        assert_eq!(frame.batch, batch);
        assert_eq!(frame.size, (48, 36));
        assert_eq!(frame.views, ids);
        assert_eq!(frame.cameras().count(), ids.len());
        for (camera, (color, depth, labels)) in frame.cameras().zip(want) {
            let (f, v) = (frame.frame, camera.view);
            assert_eq!(camera.color_image().as_ref(), Some(color), "frame {f}: {v} colour");
            assert_eq!(camera.depth, Some(depth.as_slice()), "frame {f}: {v} depth");
            assert_eq!(camera.instances, Some(labels.instances.as_slice()), "frame {f}: {v} instances");
            assert_eq!(camera.semantic, Some(labels.classes.as_slice()), "frame {f}: {v} classes");
            assert_eq!(camera.linear_depth, Some(labels.linear_depth.as_slice()), "frame {f}: {v} linear depth");
            assert_eq!(frame.camera_of(v), Some(camera));
        }
    }
    // The move shows in frame 3 and not in frame 2.
    let moved = |f: usize| streamed[f].camera(0).and_then(|c| c.color_image()).unwrap();
    assert_eq!(moved(0), moved(1), "nothing moved between frames 1 and 2");
    assert_ne!(moved(1), moved(2), "the cubes moved before frame 3");
    assert!(renderer.take_streamed().unwrap().is_empty(), "each frame arrives once");
    // Frames handed back lend their buffers to later frames, which arrive
    // whole all the same (every byte of every plane overwritten: the
    // recycled frames hold other pictures).
    // Marked by a capacity no fresh buffer has (the allocator may hand a
    // freed block's address out again, so addresses prove nothing).
    let marked = 3 * 48 * 36 * 4 * 4;
    for mut frame in streamed {
        if let Some(color) = &mut frame.color {
            color.reserve_exact(marked - color.len());
        }
        renderer.recycle_streamed(frame);
    }
    demo.scene.set_local_transform(demo.cubes[0], Transform::from_translation(Vec3::new(0.0, 1.0, 0.0))).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    let again = renderer.wait_streamed().unwrap();
    assert_eq!(again.len(), 1);
    let capacity = again[0].color.as_ref().map_or(0, Vec::capacity);
    assert!(capacity >= marked, "the new frame was cut into a recycled buffer (capacity {capacity})");
    for (camera, id) in again[0].cameras().zip(&ids) {
        assert_eq!(camera.color_image(), Some(renderer.read_color(*id).unwrap()), "{id}: a recycled frame's colour");
        let labels = renderer.read_labels(*id).unwrap();
        assert_eq!(camera.instances, Some(labels.instances.as_slice()), "{id}: a recycled frame's instances");
        assert_eq!(camera.depth, Some(renderer.read_depth(*id).unwrap().depth.as_slice()), "{id}: recycled depth");
    }
    // A batch without labels has none to stream.
    let plain = renderer.register_batch(BatchDesc::new("plain", size)).unwrap();
    let refused = renderer.stream_batch(plain, Some(StreamOptions { instances: true, ..Default::default() }));
    assert!(matches!(refused, Err(RenderError::Unsupported(_))), "{refused:?}");
    // Nor one that draws other planes the planes it lacks.
    let depths = renderer
        .register_batch(BatchDesc::new("depths", size).with_label_planes(LabelSet::of(&[Label::LinearDepth])))
        .unwrap();
    let refused = renderer.stream_batch(depths, Some(StreamOptions { semantic: true, ..Default::default() }));
    assert!(matches!(&refused, Err(RenderError::Unsupported(m)) if m.contains("semantic")), "{refused:?}");
    renderer.stream_batch(depths, Some(StreamOptions { linear_depth: true, ..Default::default() })).unwrap();
    renderer.stream_batch(depths, None).unwrap();
    renderer.stream_batch(batch, None).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    assert!(renderer.wait_streamed().unwrap().is_empty(), "stopped");
}

/// Three rows of three boxes seen from above, each box's semantic class
/// its row, with labels: a batch camera and a lone view.
fn labelled_boxes() -> (Scene, Vec<(oxygen::core::NodeKey, Vec3)>) {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("grey", Vec4::splat(0.6)));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let mut boxes = Vec::new();
    for row in 0..3 {
        for column in 0..3 {
            let at = Vec3::new(column as f32 * 2.0 - 2.0, 0.5, row as f32 * 2.0 - 2.0);
            let node = scene.add_node("box", Transform::from_translation(at));
            scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).unwrap();
            scene.set_semantic_class(node, row + 1).unwrap();
            boxes.push((node, at));
        }
    }
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(1.0))).unwrap();
    (scene, boxes)
}

fn looking_down(size: UVec2) -> LookAtResolver {
    LookAtResolver::new(Camera::perspective(60f32.to_radians(), 0.1, None), Vec3::new(0.0, 9.0, 0.0), Vec3::ZERO, size)
        .unwrap()
        .with_up(Vec3::NEG_Z)
        .unwrap()
}

#[test]
fn instance_labels_name_the_drawn_objects_and_their_classes() {
    let (scene, boxes) = labelled_boxes();
    let size = UVec2::new(64, 64);
    let mut renderer = support::gpu_renderer();
    let batch = renderer.register_batch(BatchDesc::new("labelled", size).with_labels()).unwrap();
    let camera = renderer.add_camera(batch, looking_down(size)).unwrap();
    let lone = renderer.register_view(ViewDesc::new(looking_down(size)).with_labels(), standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    for view in [camera, lone] {
        let labels = renderer.read_labels(view).unwrap();
        assert_eq!((labels.width, labels.height), (64, 64));
        // Every label names a node the view's prepared frame draws.
        let drawn: std::collections::BTreeSet<u32> =
            renderer.prepared_frame(view).unwrap().draws().iter().map(|d| d.node_id + 1).collect();
        let seen: std::collections::BTreeSet<u32> = labels.instances.iter().copied().filter(|l| *l != 0).collect();
        assert!(seen.is_subset(&drawn), "{view}: labels {seen:?} outside the drawn {drawn:?}");
        assert!(labels.instances.contains(&0), "{view}: the background is 0");
        // Every box covers the pixel its top's centre projects to, and is
        // named there, with its class in the segmentation image.
        let context = oxygen::views::ViewContext { view_id: view, frame_index: 1, time_seconds: 0.0 };
        let resolved = looking_down(size).resolve(&context, &scene).unwrap();
        let semantic = labels.semantic(&scene);
        // The GPU's class plane is the CPU's lookup, pixel for pixel.
        assert_eq!(labels.classes, semantic, "{view}: the GPU's classes");
        // The GPU's linear depth is the device depth's linearised where a
        // box is seen, and 0 where none is.
        let linear = renderer.read_depth(view).unwrap().linear();
        let mut worst = 0.0f32;
        for ((gpu, cpu), instance) in labels.linear_depth.iter().zip(&linear).zip(&labels.instances) {
            if *instance == 0 {
                assert_eq!(*gpu, 0.0, "{view}: linear depth where nothing was drawn");
            } else {
                worst = worst.max((gpu - cpu).abs() / cpu);
            }
        }
        // Both in f32 from the same surface, one through the rasterised
        // depth, one through the interpolated position: measured 2.2e-7
        // relative on lavapipe, 9.5e-7 on GL (through its depth copy pass);
        // bound 1.5 × the worst.
        assert!(worst < 1.43e-6, "{view}: linear depth strays {worst} (relative) from the linearised device depth");
        for (i, (node, at)) in boxes.iter().enumerate() {
            let (x, y) = support::pixel_of(&resolved, *at + Vec3::new(0.0, 0.5, 0.0));
            assert_eq!(labels.node(&scene, x, y), Some(*node), "{view}: box {i} at pixel ({x}, {y})");
            assert_eq!(semantic[(y * 64 + x) as usize], i as u32 / 3 + 1, "{view}: class of box {i}");
            // Its top faces up.
            let n = labels.normals[(y * 64 + x) as usize];
            assert!((n[1] - 1.0).abs() < 1e-3 && n[0].abs() < 1e-3 && n[2].abs() < 1e-3, "{view}: normal {n:?}");
        }
    }
    let unlabelled = renderer.register_view(looking_down(size), standard_render_graph).unwrap();
    let mut scene = scene;
    // A class set between frames is the next frame's, on the GPU.
    scene.set_semantic_class(boxes[4].0, 42).unwrap();
    renderer.render_frame(&scene).unwrap();
    assert!(matches!(renderer.read_labels(unlabelled), Err(RenderError::Unsupported(_))));
    let context = oxygen::views::ViewContext { view_id: camera, frame_index: 2, time_seconds: 0.0 };
    let resolved = looking_down(size).resolve(&context, &scene).unwrap();
    let (x, y) = support::pixel_of(&resolved, boxes[4].1 + Vec3::new(0.0, 0.5, 0.0));
    for view in [camera, lone] {
        let labels = renderer.read_labels(view).unwrap();
        assert_eq!(labels.classes[(y * 64 + x) as usize], 42, "{view}: the new class");
        assert_eq!(labels.classes, labels.semantic(&scene), "{view}: the GPU's classes after the change");
    }
}

/// A view reads another view's semantic-class and linear-depth planes
/// through the typed outputs (here: a graph that copies a batch camera's
/// tile of each into buffers of its own), after that view drew them.
#[test]
fn a_linked_view_reads_semantic_classes_and_linear_depth() {
    use oxygen::graph::RenderGraph;
    use oxygen::passes::{CommandRecorder, PassError, RenderContext};
    use std::sync::Arc;
    let (scene, _) = labelled_boxes();
    let size = UVec2::new(64, 64);
    let mut renderer = support::gpu_renderer();
    let planes = LabelSet::of(&[Label::Semantic, Label::LinearDepth]);
    let batch = renderer.register_batch(BatchDesc::new("sources", size).with_label_planes(planes)).unwrap();
    // The source is the second camera: its tile is not at the atlas's corner.
    renderer.add_camera(batch, ring(1, size)[0]).unwrap();
    let source = renderer.add_camera(batch, looking_down(size)).unwrap();
    let device = renderer.gpu().device.clone();
    let buffer = |name| {
        Arc::new(device.create_buffer(&oxygen::wgpu::BufferDescriptor {
            label: Some(name),
            size: 64 * 64 * 4,
            usage: oxygen::wgpu::BufferUsages::COPY_DST | oxygen::wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        }))
    };
    let (classes, depths) = (buffer("classes"), buffer("depths"));
    let graph = {
        let (classes, depths) = (Arc::clone(&classes), Arc::clone(&depths));
        async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| -> Result<(), PassError> {
            lone_graph().record(ctx, rec).await?;
            let semantic = ctx.input(source.semantic_classes()).await?;
            let linear = ctx.input(source.linear_depth()).await?;
            for (image, buffer, format) in [
                (&semantic, &classes, oxygen::wgpu::TextureFormat::R32Uint),
                (&linear, &depths, oxygen::wgpu::TextureFormat::R32Uint),
            ] {
                let texture = image.image.texture();
                assert_eq!(texture.format(), format);
                let [x, y, w, h] = image.rect;
                rec.encoder().copy_texture_to_buffer(
                    oxygen::wgpu::TexelCopyTextureInfo {
                        texture,
                        mip_level: 0,
                        origin: oxygen::wgpu::Origin3d { x, y, z: 0 },
                        aspect: oxygen::wgpu::TextureAspect::All,
                    },
                    oxygen::wgpu::TexelCopyBufferInfo {
                        buffer,
                        layout: oxygen::wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(w * 4),
                            rows_per_image: Some(h),
                        },
                    },
                    oxygen::wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                );
            }
            Ok(())
        }
    };
    let desc = ViewDesc::new(looking_down(size)).reads(source.semantic_classes()).reads(source.linear_depth());
    renderer.register_view(desc, graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    let want = renderer.read_labels(source).unwrap();
    assert_eq!(want.planes, planes);
    assert!(want.instances.is_empty() && want.normals.is_empty(), "planes the batch does not draw");
    let read = |buffer: &oxygen::wgpu::Buffer| -> Vec<u32> {
        buffer.slice(..).map_async(oxygen::wgpu::MapMode::Read, |r| r.unwrap());
        device.poll(oxygen::wgpu::PollType::wait_indefinitely()).unwrap();
        let words = bytemuck::cast_slice(&buffer.slice(..).get_mapped_range().unwrap()).to_vec();
        buffer.unmap();
        words
    };
    assert_eq!(read(&classes), want.classes, "the linked semantic classes");
    assert!(want.classes.contains(&3), "the source sees the third row");
    let linked: Vec<f32> = read(&depths).into_iter().map(f32::from_bits).collect();
    assert_eq!(linked, want.linear_depth, "the linked linear depth");
    // A view that does not draw a plane has no such output to link.
    let unlinked = ViewDesc::new(looking_down(size)).reads(source.normals());
    let id = renderer.register_view(unlinked, async move |ctx: &RenderContext<'_>, _rec: &mut CommandRecorder| {
        ctx.input(source.normals()).await.map(|_| ())
    });
    let refused = id.and_then(|_| renderer.render_frame(&scene).map(|_| ()));
    assert!(refused.is_err(), "linking a plane the source does not draw: {refused:?}");
}

#[test]
fn normal_labels_of_a_sphere_match_its_analytic_normals() {
    // A unit sphere at the origin seen from 4 units away: at every pixel
    // labelled with it, the normal is the direction from the centre to the
    // point the depth puts there.
    let mut scene = Scene::new();
    let white = scene.add_material(Material::opaque("white", Vec4::ONE));
    let mesh = scene.add_geometry(Geometry::uv_sphere(1.0, 48, 24));
    let sphere = scene.add_node("sphere", Transform::IDENTITY);
    scene.set_renderable(sphere, Renderable { geometry: mesh, materials: vec![white] }).unwrap();
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(1.0))).unwrap();
    let size = UVec2::new(48, 48);
    let eye = Vec3::new(1.0, 1.5, 3.5);
    let camera =
        LookAtResolver::new(Camera::perspective(40f32.to_radians(), 0.1, None), eye, Vec3::ZERO, size).unwrap();
    let mut renderer = support::gpu_renderer();
    let batch = renderer.register_batch(BatchDesc::new("sphere", size).with_labels()).unwrap();
    let view = renderer.add_camera(batch, camera).unwrap();
    renderer.render_frame(&scene).unwrap();
    let labels = renderer.read_labels(view).unwrap();
    let depth = renderer.read_depth(view).unwrap();
    let inverse = depth.view.inverse_view_projection;
    let mut worst = 0.0f32;
    let mut counted = 0;
    for y in 0..48 {
        for x in 0..48 {
            let i = (y * 48 + x) as usize;
            if labels.instances[i] == 0 {
                continue;
            }
            assert_eq!(labels.node(&scene, x, y), Some(sphere));
            let ndc = Vec4::new((x as f32 + 0.5) / 24.0 - 1.0, 1.0 - (y as f32 + 0.5) / 24.0, depth.depth[i], 1.0);
            let p = inverse * ndc;
            // Relative to the render origin, which the camera's grid cell puts at the world origin.
            let point = p.truncate() / p.w;
            let analytic = point.normalize();
            let n = Vec3::from(labels.normals[i]);
            worst = worst.max(n.angle_between(analytic).to_degrees());
            counted += 1;
        }
    }
    assert!(counted > 300, "the sphere covers {counted} pixels");
    // The normal is interpolated between vertex normals that are exact,
    // and the point unprojected from depth lies on the facet between them:
    // measured worst 0.028° on lavapipe and on GL; bound 1.5 × that. (A
    // flat-shaded normal would stray up to half a facet, 3.75°.)
    assert!(worst < 0.042, "normals stray up to {worst}° from the analytic ones");
}

/// A view's final image is a linkable output: a composition pass draws a
/// batch camera's tile into a rectangle of another view (picture in
/// picture), whole at the same size, and scaled into a corner.
#[test]
fn a_linked_final_image_is_composed_into_a_rectangle_of_another_view() {
    use oxygen::graph::RenderGraph;
    use oxygen::passes::{CommandRecorder, CompositePass, PassError, RenderContext, RenderPass};
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(64, 48);
    let cameras = ring(3, size);
    let mut renderer = support::gpu_renderer_with(RendererOptions::default());
    let batch = renderer.register_batch(BatchDesc::new("sources", size)).unwrap();
    // The source is the second camera: its tile is not at the atlas's corner.
    renderer.add_camera(batch, cameras[0]).unwrap();
    let source = renderer.add_camera(batch, cameras[1]).unwrap();
    let composed = |rect: [f32; 4]| {
        async move |ctx: &RenderContext<'_>, rec: &mut CommandRecorder| -> Result<(), PassError> {
            lone_graph().record(ctx, rec).await?;
            CompositePass::new(source.color(), rect).run(ctx, rec).await
        }
    };
    let whole = renderer
        .register_view(ViewDesc::new(cameras[2]).reads(source.color()), composed([0.0, 0.0, 1.0, 1.0]))
        .unwrap();
    let inset = renderer
        .register_view(ViewDesc::new(cameras[2]).reads(source.color()), composed([0.5, 0.0, 0.5, 0.5]))
        .unwrap();
    let plain = renderer.register_view(cameras[2], lone_graph()).unwrap();
    renderer.render_frame(&demo.scene).unwrap();
    let source_image = renderer.read_color(source).unwrap();

    // The whole rectangle at the same size: the source, texel for texel.
    let (worst, differing) = difference(&renderer.read_color(whole).unwrap(), &source_image);
    assert!(differing == 0, "the composed image differs from its source: {differing} pixels, worst {worst}");

    // The top-right quarter: the source halved (each pixel the mean of a
    // 2 × 2 block, which linear filtering at the block's centre gives);
    // the rest: the view's own picture.
    let image = renderer.read_color(inset).unwrap();
    let own = renderer.read_color(plain).unwrap();
    let decode = |v: u8| {
        let c = f64::from(v) / 255.0;
        if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
    };
    let mut worst = 0i32;
    for y in 0..48 {
        for x in 0..64 {
            let got = image.get_pixel(x, y).0;
            let want = if x >= 32 && y < 24 {
                let (sx, sy) = ((x - 32) * 2, y * 2);
                let mean = |c: usize| {
                    let sum: f64 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                        .iter()
                        .map(|(dx, dy)| decode(source_image.get_pixel(sx + dx, sy + dy).0[c]))
                        .sum();
                    support::linear_to_srgb8(sum / 4.0)
                };
                [mean(0), mean(1), mean(2), 255]
            } else {
                own.get_pixel(x, y).0
            };
            for c in 0..3 {
                worst = worst.max((i32::from(got[c]) - i32::from(want[c])).abs());
            }
        }
    }
    // Rounding of the filter and the sRGB encode: measured 1 level at
    // worst on lavapipe and on GL.
    assert!(worst <= 1, "the inset strays {worst} levels from the halved source");
}

/// Batch cameras on the GPU frustum path: the batch's cameras are culled
/// in one dispatch (each with its own parameters and counters, in the
/// batch's command buffer), and each draws what the same camera on the CPU
/// path (the exact reference) draws: the same draws, the same picture.
#[test]
fn batch_cameras_on_the_gpu_path_draw_what_the_cpu_path_draws() {
    use oxygen::sceneprep::Visibility;
    let demo = oxygen_demo::multi_view_scene();
    let size = UVec2::new(64, 48);
    let cameras = ring(4, size);
    let mut renderer = support::gpu_renderer_with(RendererOptions::default());
    if !renderer.gpu_visibility_supported() {
        support::skip::skip(format_args!(
            "{} cannot run GPU visibility (needs multi-draw-indirect with counts)",
            renderer.gpu().describe()
        ));
        return;
    }
    let cpu = renderer.register_batch(BatchDesc::new("cpu", size)).unwrap();
    let gpu = renderer.register_batch(BatchDesc::new("gpu", size)).unwrap();
    let mut pairs = Vec::new();
    for camera in &cameras {
        let on_cpu = renderer.add_camera(cpu, ViewDesc::new(*camera).with_visibility(Visibility::Cpu)).unwrap();
        let on_gpu = renderer.add_camera(gpu, ViewDesc::new(*camera).with_visibility(Visibility::GpuFrustum)).unwrap();
        pairs.push((on_cpu, on_gpu));
    }
    for frame in 0..2 {
        let report = renderer.render_frame(&demo.scene).unwrap();
        for (on_cpu, on_gpu) in &pairs {
            let of = |view: ViewId| report.views.iter().find(|v| v.view == view).map(|v| v.visibility);
            assert_eq!((of(*on_cpu), of(*on_gpu)), (Some(Visibility::Cpu), Some(Visibility::GpuFrustum)));
            // The batch's four cameras are culled in one dispatch.
            let together = renderer.gpu_visibility().and_then(|v| v.culled_together(*on_gpu));
            assert_eq!(together, Some(cameras.len()), "frame {frame}: {on_gpu} culled with its batch");
            assert_eq!(
                renderer.view_draws(*on_gpu).unwrap(),
                renderer.view_draws(*on_cpu).unwrap(),
                "frame {frame}: {on_gpu} draws what {on_cpu} draws"
            );
            let (worst, differing) =
                difference(&renderer.read_color(*on_gpu).unwrap(), &renderer.read_color(*on_cpu).unwrap());
            assert!(differing == 0, "frame {frame}: {differing} pixels differ (worst {worst})");
        }
    }
}

/// A batch camera is a view for the snapshot tools too: `Views::prepare`
/// gives, without a GPU, the prepared frame the renderer prepares for it
/// (at the batch's size, whatever its resolver's viewport says), and the
/// same draws a lone view of that camera at that size gets.
#[test]
fn a_batch_camera_prepares_without_a_gpu_as_the_renderer_does() {
    use oxygen::views::Views;
    // The boxes seen from above: a camera wide enough sees all nine, one
    // as narrow as the batch's cameras (16 × 64) loses the outer columns.
    let (scene, _) = labelled_boxes();
    let size = UVec2::new(16, 64);
    // The resolver asks for a wide image: the batch's size wins.
    let mut views = Views::new();
    let batch = views.register_batch(BatchDesc::new("snapshots", size)).unwrap();
    let id = views.add_camera(batch, looking_down(UVec2::new(480, 100))).unwrap();
    let cpu = views.prepare(&scene, id).unwrap();
    let (cpu_dump, cpu_draws) = (cpu.dump(), cpu.canonical_draws());
    let options = oxygen::gpu::GpuOptions { optional_features: Renderer::OPTIONAL_FEATURES, ..Default::default() };
    let gpu = oxygen::gpu::GpuContext::new_headless(&options).unwrap();
    let mut renderer = Renderer::with_views(gpu, RendererOptions::default(), views).unwrap();
    renderer.render_frame(&scene).unwrap();
    assert_eq!(renderer.prepared_frame(id).unwrap().dump(), cpu_dump);
    assert_eq!(renderer.read_color(id).unwrap().dimensions(), (16, 64));
    let mut lone = Views::new();
    let alone = lone.register(looking_down(size), standard_render_graph).unwrap();
    assert_eq!(lone.prepare(&scene, alone).unwrap().canonical_draws(), cpu_draws);
    let drawn: usize = cpu_draws.iter().map(|(_, d)| d.len()).sum();
    assert!(drawn < 9, "the narrow camera draws {drawn} of the nine boxes");
}

/// The back of a double-sided surface is labelled with the normal that
/// faces the camera (as shading lights it), the front with its own.
#[test]
fn normal_labels_of_a_double_sided_surface_face_the_camera() {
    let mut scene = Scene::new();
    let card = scene.add_material(Material { double_sided: true, ..Material::opaque("card", Vec4::ONE) });
    let plane = scene.add_geometry(Geometry::plane(20.0));
    let node = scene.add_node("card", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: plane, materials: vec![card] }).unwrap();
    let sun = scene.add_node("sun", Transform::IDENTITY);
    scene.set_light(sun, Some(Light::directional(1.0))).unwrap();
    let size = UVec2::new(16, 16);
    let at = |y: f32| {
        LookAtResolver::new(
            Camera::perspective(40f32.to_radians(), 0.1, None),
            Vec3::new(0.0, y, 0.0),
            Vec3::ZERO,
            size,
        )
        .unwrap()
        .with_up(Vec3::Z)
        .unwrap()
    };
    let mut renderer = support::gpu_renderer();
    let above = renderer.register_view(ViewDesc::new(at(3.0)).with_labels(), standard_render_graph).unwrap();
    let below = renderer.register_view(ViewDesc::new(at(-3.0)).with_labels(), standard_render_graph).unwrap();
    renderer.render_frame(&scene).unwrap();
    for (view, up) in [(above, 1.0), (below, -1.0)] {
        let labels = renderer.read_labels(view).unwrap();
        assert_eq!(labels.node(&scene, 8, 8), Some(node));
        let n = labels.normals[8 * 16 + 8];
        assert!((n[1] - up).abs() < 1e-3, "{view}: normal {n:?}, expected y = {up}");
    }
}

/// Found in review: a batch whose cameras did not all cull on the GPU (one
/// on the CPU path among GPU-culled ones) drew wrong images: the GPU
/// cameras nothing (their one batch dispatch was skipped), the CPU camera
/// the wrong draws. A batch's cameras now share one visibility path, and a
/// camera asking for another is refused with the reason, before any frame.
#[test]
fn a_batch_refuses_a_camera_on_another_visibility_path() {
    use oxygen::sceneprep::Visibility;
    use oxygen::views::Views;
    let size = UVec2::new(64, 48);
    let cameras = ring(3, size);
    let mut views = Views::new();
    let batch = views.register_batch(BatchDesc::new("rig", size)).unwrap();
    views.add_camera(batch, ViewDesc::new(cameras[0]).with_visibility(Visibility::GpuFrustum)).unwrap();
    views.add_camera(batch, ViewDesc::new(cameras[1]).with_visibility(Visibility::GpuFrustum)).unwrap();
    for other in [ViewDesc::new(cameras[2]).with_visibility(Visibility::Cpu), ViewDesc::new(cameras[2])] {
        let error = views.add_camera(batch, other).expect_err("another visibility path is refused");
        let text = error.to_string();
        assert!(text.contains("share one visibility path") && text.contains("GpuFrustum"), "{text}");
    }
    // The same path is taken.
    views.add_camera(batch, ViewDesc::new(cameras[2]).with_visibility(Visibility::GpuFrustum)).unwrap();
}
