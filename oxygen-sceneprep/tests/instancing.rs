//! Instanced draw commands: runs of consecutive draws of a partition that
//! share a mesh become one command, every draw is still drawn exactly once
//! through `first_instance + instance_index`, and grouping by geometry only
//! reorders draws within a material.

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{
    Camera, Geometry, LookAtResolver, Material, Renderable, ResolvedView, Scene, Transform, ViewContext, ViewIds,
    ViewResolver,
};
use oxygen_sceneprep::{Instancing, PreparedSceneFrame, ScenePrep, ViewPrepOptions, ViewRequest};

/// A grid of `n` objects alternating between a cube and a sphere (two
/// meshes), with two materials, seen from above.
fn mixed_grid(n: usize) -> (Scene, ResolvedView) {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(0.8));
    let sphere = scene.add_geometry(Geometry::uv_sphere(0.4, 8, 6));
    let materials = [Vec4::new(0.8, 0.2, 0.2, 1.0), Vec4::new(0.2, 0.2, 0.8, 1.0)]
        .map(|c| scene.add_material(Material::opaque("m", c)));
    let side = (n as f32).sqrt().ceil() as usize;
    for i in 0..n {
        let at = Vec3::new((i % side) as f32 * 2.0, 0.0, (i / side) as f32 * 2.0);
        let node = scene.add_node("o", Transform::from_translation(at));
        let geometry = if (i / 3) % 2 == 0 { cube } else { sphere };
        scene.set_renderable(node, Renderable { geometry, materials: vec![materials[i % 2]] }).unwrap();
    }
    let centre = Vec3::new(side as f32, 0.0, side as f32);
    let camera = LookAtResolver {
        camera: Camera::perspective(60f32.to_radians(), 0.5, None),
        eye: centre + Vec3::new(0.0, side as f32 * 2.0, side as f32 * 0.5),
        target: centre,
        up: Vec3::Y,
        viewport: UVec2::new(256, 256),
    };
    let view = camera
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, &scene)
        .unwrap();
    (scene, view)
}

fn prepare(scene: &Scene, view: &ResolvedView, instancing: Instancing) -> (ScenePrep, SlotAllocators) {
    let mut prep = ScenePrep::with_threads(1);
    let mut slots = SlotAllocators::default();
    let options = ViewPrepOptions { instancing, ..Default::default() };
    prep.prepare(scene, &[ViewRequest { view, options }], &mut slots).unwrap();
    (prep, slots)
}

/// Every draw of every partition is covered by exactly one instance of one
/// of the partition's commands, and a command's instances share its mesh.
fn assert_commands_cover_draws(frame: &PreparedSceneFrame) {
    let commands = frame.indirect_args();
    let mut covered = vec![0u32; frame.draws().len()];
    for partition in frame.partitions() {
        for command in &commands[partition.commands()] {
            for draw_index in command.first_instance..command.first_instance + command.instance_count {
                assert!(partition.range().contains(&(draw_index as usize)), "a command leaves its partition");
                let draw = &frame.draws()[draw_index as usize];
                assert_eq!(command.index_count, draw.index_count);
                assert_eq!(command.first_index, draw.index_slot + draw.first_index);
                assert_eq!(command.base_vertex, draw.absolute_base_vertex());
                covered[draw_index as usize] += 1;
            }
        }
    }
    assert!(covered.iter().all(|c| *c == 1), "every draw exactly once: {covered:?}");
}

#[test]
fn off_gives_one_command_per_draw() {
    let (scene, view) = mixed_grid(60);
    let (prep, _) = prepare(&scene, &view, Instancing::Off);
    let frame = &prep.frames()[0];
    assert_eq!(frame.indirect_args().len(), frame.draws().len());
    assert!(frame.indirect_args().iter().all(|c| c.instance_count == 1));
    assert_commands_cover_draws(frame);
}

#[test]
fn adjacent_runs_merge_without_changing_the_order() {
    let (scene, view) = mixed_grid(60);
    let (off, _) = prepare(&scene, &view, Instancing::Off);
    let (adjacent, _) = prepare(&scene, &view, Instancing::Adjacent);
    let (off, adjacent) = (&off.frames()[0], &adjacent.frames()[0]);
    assert_eq!(off.dump(), adjacent.dump(), "the draws and their order are the same");
    assert!(adjacent.indirect_args().len() < off.indirect_args().len(), "some adjacent draws share a mesh");
    assert_commands_cover_draws(adjacent);
}

#[test]
fn grouping_by_geometry_gives_one_command_per_mesh_and_material() {
    let (scene, view) = mixed_grid(60);
    let (grouped, _) = prepare(&scene, &view, Instancing::ByGeometry);
    let frame = &grouped.frames()[0];
    assert_commands_cover_draws(frame);
    // Two materials × two meshes, all opaque and single-sided (one
    // partition): at most one command per (material, mesh).
    assert!(frame.indirect_args().len() <= 4, "{} commands for 2 materials x 2 meshes", frame.indirect_args().len());
    let (adjacent, _) = prepare(&scene, &view, Instancing::Adjacent);
    let adjacent = &adjacent.frames()[0];
    assert_eq!(frame.draws().len(), adjacent.draws().len());
    let materials = |f: &PreparedSceneFrame| f.draws().iter().map(|d| d.material_handle).collect::<Vec<_>>();
    assert_eq!(materials(frame), materials(adjacent), "materials keep their order");
}

#[test]
fn a_single_mesh_scene_draws_each_partition_with_one_command() {
    let demo = oxygen_demo::multi_view_scene();
    let camera = oxygen_demo::main_camera(UVec2::new(320, 240));
    let view = camera
        .resolve(
            &ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 },
            &demo.scene,
        )
        .unwrap();
    let (prep, _) = prepare(&demo.scene, &view, Instancing::ByGeometry);
    let frame = &prep.frames()[0];
    assert_commands_cover_draws(frame);
    for partition in frame.partitions() {
        assert!(partition.command_count <= partition.len());
    }
}
