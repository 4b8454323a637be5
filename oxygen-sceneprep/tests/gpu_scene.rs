//! The GPU scene and the plan of a view on a GPU visibility path, without a
//! GPU: how instances are grouped into instanced commands, how much room
//! each group gets, what a static or a moved frame changes, and where the
//! CPU's transparent draws go.

use glam::{Quat, UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{
    AlphaMode, Camera, Geometry, LodLevel, LookAtResolver, Material, NodeFlags, Renderable, ResolvedView, Scene,
    Transform, ViewContext, ViewResolver,
};
use oxygen_sceneprep::{GpuInstance, PassMask, ScenePrep, ViewFilter, ViewPrepOptions, ViewRequest, Visibility};

/// 40 opaque cubes in two materials, 10 of them with a LOD, 6 masked
/// double-sided quads, 4 blended cubes, 3 mirrored cubes.
fn scene() -> Scene {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let coarse = scene.add_geometry(Geometry::cube(1.0));
    let quad = scene.add_geometry(Geometry::quad(1.0));
    let red = scene.add_material(Material::opaque("red", Vec4::new(0.8, 0.1, 0.1, 1.0)));
    let blue = scene.add_material(Material::opaque("blue", Vec4::new(0.1, 0.1, 0.8, 1.0)));
    let leaves = scene.add_material(Material {
        alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
        double_sided: true,
        ..Material::opaque("leaves", Vec4::ONE)
    });
    let glass =
        scene.add_material(Material { alpha_mode: AlphaMode::Blend, ..Material::opaque("glass", Vec4::splat(0.5)) });
    let add = |scene: &mut Scene, name: &str, at: Vec3, scale: Vec3, geometry, material| {
        let node = scene.add_node(name, Transform { translation: at, rotation: Quat::IDENTITY, scale });
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
        node
    };
    let mut with_lod = Vec::new();
    for i in 0..40 {
        let node = add(
            &mut scene,
            "cube",
            Vec3::new(i as f32 * 2.0, 0.0, 0.0),
            Vec3::ONE,
            cube,
            if i % 2 == 0 { red } else { blue },
        );
        if i < 10 {
            with_lod.push(node);
        }
    }
    for i in 0..6 {
        add(&mut scene, "leaf", Vec3::new(i as f32 * 2.0, 3.0, 0.0), Vec3::ONE, quad, leaves);
    }
    for i in 0..4 {
        add(&mut scene, "glass", Vec3::new(i as f32 * 2.0, 6.0, 0.0), Vec3::ONE, cube, glass);
    }
    for i in 0..3 {
        let node =
            add(&mut scene, "mirrored", Vec3::new(i as f32 * 2.0, 9.0, 0.0), Vec3::new(-1.0, 1.0, 1.0), cube, red);
        scene.set_flags(node, NodeFlags::VISIBLE).unwrap();
    }
    for node in with_lod {
        scene.set_lods(node, vec![LodLevel { geometry: coarse, below_screen_fraction: 0.1 }]).unwrap();
    }
    scene
}

fn view(scene: &Scene) -> ResolvedView {
    let camera = LookAtResolver {
        camera: Camera::perspective(60f32.to_radians(), 0.1, None),
        eye: Vec3::new(40.0, 5.0, 60.0),
        target: Vec3::new(40.0, 3.0, 0.0),
        up: Vec3::Y,
        viewport: UVec2::new(320, 200),
    };
    camera.resolve(&ViewContext { view_id: oxygen_demo::view_id(1), frame_index: 1, time_seconds: 0.0 }, scene).unwrap()
}

fn gpu_options() -> ViewPrepOptions {
    ViewPrepOptions { visibility: Visibility::GpuFrustum, ..Default::default() }
}

#[test]
fn instances_group_by_mesh_material_and_mask_with_room_for_every_lod() {
    let scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    prep.prepare(&scene, &[ViewRequest { view: &view, options: gpu_options() }], &mut slots).unwrap();
    let gpu = prep.gpu_scene();
    // Every opaque and masked submesh is an instance; the blended ones are not.
    assert_eq!(gpu.instances().len(), 40 + 6 + 3);
    assert_eq!(gpu.transparent_renderables().len(), 4);
    // Groups: red cube, blue cube, coarse red, coarse blue (LODs), leaf
    // quad, mirrored red cube.
    assert_eq!(gpu.groups().len(), 6, "{:#?}", gpu.groups());
    // Room: every instance once, plus once more per LOD level it may pick.
    assert_eq!(gpu.capacity(), 49 + 10);
    assert_eq!(gpu.groups().iter().map(|g| g.capacity).sum::<u32>(), gpu.capacity());
    // Partitions in the CPU key's order: opaque, opaque mirrored, masked
    // double-sided; each a contiguous run of groups and draw room.
    let masks: Vec<PassMask> = gpu.partitions().iter().map(|p| p.mask).collect();
    assert_eq!(
        masks,
        vec![PassMask::OPAQUE, PassMask::OPAQUE | PassMask::MIRRORED, PassMask::MASKED | PassMask::DOUBLE_SIDED]
    );
    let mut next_group = 0;
    let mut next_draw = 0;
    for p in gpu.partitions() {
        assert_eq!(p.groups.start, next_group);
        assert_eq!(p.draws.start, next_draw);
        for group in &gpu.groups()[p.groups.start as usize..p.groups.end as usize] {
            assert_eq!(PassMask::from_bits_truncate(group.pass_mask) & PassMask::PARTITION_BITS, p.mask);
            assert_eq!(group.command_base, p.groups.start);
        }
        (next_group, next_draw) = (p.groups.end, p.draws.end);
    }
    // Instances name groups of their own partition, LODs too.
    for instance in gpu.instances() {
        let lods = &gpu.lods()[instance.lod_first as usize..(instance.lod_first + instance.lod_count) as usize];
        for group in std::iter::once(instance.group).chain(lods.iter().map(|l| l.group)) {
            assert!((group as usize) < gpu.groups().len());
        }
    }
}

#[test]
fn a_gpu_view_keeps_only_its_transparent_draws_after_the_gpu_room() {
    let scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let frames = prep.prepare(&scene, &[ViewRequest { view: &view, options: gpu_options() }], &mut slots).unwrap();
    let frame = &frames[0];
    let plan = frame.gpu_plan().expect("a GPU view has a plan");
    assert_eq!(plan.visibility, Visibility::GpuFrustum);
    assert!(
        frame.draws().iter().all(|d| d.mask().contains(PassMask::TRANSPARENT)),
        "only transparent draws on the CPU"
    );
    assert_eq!(frame.draws().len(), 4);
    let (gpu_parts, cpu_parts): (Vec<&oxygen_sceneprep::Partition>, Vec<_>) =
        frame.partitions().iter().partition(|p| p.gpu_count.is_some());
    assert_eq!(gpu_parts.len(), 3);
    assert_eq!(cpu_parts.len(), 1);
    let cpu = cpu_parts[0];
    assert_eq!(cpu.begin, plan.cpu_draw_offset(), "the CPU's draws follow the GPU's room");
    assert_eq!(frame.draws_of(cpu).len(), 4);
    assert_eq!(frame.commands_of(cpu)[0].first_instance, plan.cpu_draw_offset());
    // The view's ranges hold the GPU's room and the CPU's draws.
    assert_eq!(frame.slots().draw_metadata.count, plan.capacity + 4);
    assert_eq!(
        frame.slots().indirect_args.count,
        plan.groups + frame.draws().len() as u32,
        "room for a command per draw"
    );
    insta::assert_snapshot!("gpu_view_dump", frame.dump());
}

#[test]
fn occlusion_plans_three_command_lists() {
    let scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let options = ViewPrepOptions { visibility: Visibility::GpuOcclusion, ..Default::default() };
    let frames = prep.prepare(&scene, &[ViewRequest { view: &view, options }], &mut slots).unwrap();
    let plan = frames[0].gpu_plan().unwrap();
    let groups = plan.groups;
    let first = |parts: &[oxygen_sceneprep::Partition]| parts[0].first_command;
    assert_eq!(first(&plan.early_partitions), 0);
    assert_eq!(first(&plan.late_partitions), groups);
    assert_eq!(frames[0].partitions()[0].first_command, 2 * groups, "shading draws list C");
    assert_eq!(plan.counters(), 3 * plan.partitions + 2 * groups);
}

#[test]
fn a_static_frame_rebuilds_nothing_and_a_moved_node_changes_one_instance() {
    let mut scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let request = |view| [ViewRequest { view, options: gpu_options() }];
    prep.prepare(&scene, &request(&view), &mut slots).unwrap();
    assert_eq!(prep.stats().gpu_scene_rebuilds, 1);
    prep.prepare(&scene, &request(&view), &mut slots).unwrap();
    assert_eq!(prep.stats().gpu_scene_rebuilds, 1, "an unchanged scene is not rebuilt");

    let (node, _) = scene.nodes().filter(|(_, n)| n.name == "cube").nth(20).unwrap();
    scene.set_local_transform(node, Transform::from_translation(Vec3::new(40.0, 1.0, 0.5))).unwrap();
    prep.prepare(&scene, &request(&view), &mut slots).unwrap();
    assert_eq!(prep.stats().gpu_scene_rebuilds, 2);
    let changes = prep.gpu_scene().last_changes();
    assert!(!changes.layout, "moving a node keeps the groups");
    assert_eq!(changes.instances, vec![20..21], "only the moved instance changed");
}

#[test]
fn shadow_views_on_the_gpu_path_have_no_cpu_draws() {
    let scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let options = ViewPrepOptions {
        filter: ViewFilter::ShadowCastersOnly,
        depth_only: true,
        visibility: Visibility::GpuFrustum,
        ..Default::default()
    };
    let frames = prep.prepare(&scene, &[ViewRequest { view: &view, options }], &mut slots).unwrap();
    assert!(frames[0].draws().is_empty(), "a depth-only view drops the transparent draws the CPU would keep");
    assert!(frames[0].partitions().iter().all(|p| p.gpu_count.is_some()));
}

/// An uploader compares `rebuilds()` with the rebuild it holds to know
/// whether `last_changes` is enough, so it must count every rebuild and
/// only rebuilds.
#[test]
fn the_gpu_scene_counts_its_rebuilds() {
    let mut scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let request = |view| [ViewRequest { view, options: gpu_options() }];
    assert_eq!(prep.gpu_scene().rebuilds(), 0);
    prep.prepare(&scene, &request(&view), &mut slots).unwrap();
    assert_eq!(prep.gpu_scene().rebuilds(), 1);
    prep.prepare(&scene, &request(&view), &mut slots).unwrap();
    assert_eq!(prep.gpu_scene().rebuilds(), 1, "an unchanged scene is not rebuilt");
    let (node, _) = scene.nodes().find(|(_, n)| n.name == "cube").unwrap();
    scene.set_local_transform(node, Transform::from_translation(Vec3::new(0.0, 1.0, 0.5))).unwrap();
    prep.prepare(&scene, &request(&view), &mut slots).unwrap();
    assert_eq!(prep.gpu_scene().rebuilds(), 2);
    assert_eq!(prep.gpu_scene().rebuilds(), prep.stats().gpu_scene_rebuilds);
}

/// The counters of the three occlusion lists lie one list after another:
/// partition `i` of list `l` is counted by counter `l × partitions + i`, so
/// no two lists share one.
#[test]
fn each_command_list_counts_its_partitions_after_the_previous_lists() {
    let scene = scene();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let options = ViewPrepOptions { visibility: Visibility::GpuOcclusion, ..Default::default() };
    let frames = prep.prepare(&scene, &[ViewRequest { view: &view, options }], &mut slots).unwrap();
    let plan = frames[0].gpu_plan().unwrap();
    // One partition would hide a `/` for the `×` (l / 1 = l × 1).
    assert!(plan.partitions > 1, "the scene has {} partitions", plan.partitions);
    let shading: Vec<_> = frames[0].partitions().iter().filter(|p| p.gpu_count.is_some()).copied().collect();
    for (list, parts) in [&plan.early_partitions, &plan.late_partitions, &shading].into_iter().enumerate() {
        let counters: Vec<Option<u32>> = parts.iter().map(|p| p.gpu_count).collect();
        let expected: Vec<Option<u32>> =
            (0..plan.partitions).map(|i| Some(list as u32 * plan.partitions + i)).collect();
        assert_eq!(counters, expected, "list {list}");
    }
}

/// A GPU instance reads skin weights only when its renderable has joints:
/// the same skinned mesh without a skin is drawn rigid.
#[test]
fn a_gpu_instance_reads_its_skin_only_with_joints() {
    use glam::Mat4;
    use oxygen_core::{Skin, SkinWeights};
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("grey", Vec4::splat(0.5)));
    let quad = Geometry::quad(1.0);
    let n = quad.vertices().len();
    let weights = vec![SkinWeights::new([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]); n];
    let skinned = scene.add_geometry(quad.with_skin_weights(weights).unwrap());
    let add = |scene: &mut Scene, name: &str, x: f32| {
        let node = scene.add_node(name, Transform::from_translation(Vec3::new(x, 0.0, 0.0)));
        scene.set_renderable(node, Renderable { geometry: skinned, materials: vec![material] }).unwrap();
        node
    };
    let with_joints = add(&mut scene, "with joints", 0.0);
    add(&mut scene, "without", 2.0);
    let joints = vec![
        scene.add_node("joint 0", Transform::from_translation(Vec3::ZERO)),
        scene.add_node("joint 1", Transform::from_translation(Vec3::new(0.5, 0.0, 0.0))),
    ];
    scene.set_skin(with_joints, Some(Skin { joints, inverse_bind_matrices: vec![Mat4::IDENTITY; 2] })).unwrap();
    let view = view(&scene);
    let mut prep = ScenePrep::with_threads(1);
    prep.prepare(&scene, &[ViewRequest { view: &view, options: gpu_options() }], &mut SlotAllocators::default())
        .unwrap();
    let invalid = oxygen_bindless::INVALID_SLOT;
    let instances = prep.gpu_scene().instances();
    let (rigid, skinned): (Vec<&GpuInstance>, Vec<_>) = instances.iter().partition(|i| i.joint_base == invalid);
    assert_eq!((rigid.len(), skinned.len()), (1, 1), "{instances:#?}");
    assert_eq!(rigid[0].skin_slot, invalid, "no joints, no skin");
    assert_ne!(skinned[0].skin_slot, invalid, "joints read the mesh's skin weights");
}
