//! Skins on the GPU: a skinned mesh's vertices follow its joints through
//! the bindless buffers (joint matrices among the frame's matrices, joints
//! and weights beside the vertices). Each pose is checked against the same
//! mesh drawn rigidly where the pose should put it: the two pictures must
//! be the same. Culling follows the pose (a bound that covers it).

mod support;

use oxygen::core::NodeKey;
use oxygen::core::{SceneError, Skin, SkinWeights};
use oxygen::glam::{Mat4, Quat, Vec4};
use oxygen::prelude::*;
use support::deform::{assert_same, camera, render, with_sun};

/// A cube drawn rigidly at `transform`.
fn rigid(transform: Transform) -> Scene {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("orange", Vec4::new(0.9, 0.5, 0.1, 1.0)));
    let geometry = scene.add_geometry(Geometry::cube(1.0));
    let node = scene.add_node("rigid", transform);
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    with_sun(&mut scene);
    scene
}

/// The same cube skinned to two joints at `a` and `b`, every vertex
/// weighted `weight_b` to the second; the mesh node itself sits far away
/// at `node_at` (glTF ignores a skinned mesh's own transform).
fn skinned(a: Transform, b: Transform, weight_b: f32, node_at: Vec3) -> (Scene, NodeKey) {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("orange", Vec4::new(0.9, 0.5, 0.1, 1.0)));
    let cube = Geometry::cube(1.0);
    let weights = vec![SkinWeights::new([0, 1, 0, 0], [1.0 - weight_b, weight_b, 0.0, 0.0]); cube.vertices().len()];
    let geometry = scene.add_geometry(cube.with_skin_weights(weights).unwrap());
    let joint_a = scene.add_node("joint a", a);
    let joint_b = scene.add_node("joint b", b);
    let node = scene.add_node("skinned", Transform::from_translation(node_at));
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    let skin = Skin { joints: vec![joint_a, joint_b], inverse_bind_matrices: vec![Mat4::IDENTITY; 2] };
    scene.set_skin(node, Some(skin)).unwrap();
    with_sun(&mut scene);
    (scene, joint_b)
}

#[test]
fn a_skinned_mesh_is_where_its_joints_put_it() {
    let moved = Transform::from_translation(Vec3::new(0.8, 0.2, -0.3)).with_rotation(Quat::from_rotation_y(0.6));
    // All weight on one joint: the joint's transform, rotation included
    // (normals follow: the lighting is the rigid cube's).
    let (scene, _) = skinned(moved, Transform::IDENTITY, 0.0, Vec3::new(50.0, 0.0, 0.0));
    let (expected, _) = render(&rigid(moved), Vec3::ZERO);
    let (actual, draws) = render(&scene, Vec3::ZERO);
    assert_eq!(draws, 1, "the skinned cube is in view wherever its node is");
    assert_same(&actual, &expected, "one joint");
    // Half the weight on each of two translated joints: the cube halfway.
    let (scene, _) = skinned(
        Transform::from_translation(Vec3::new(-1.0, 0.0, 0.0)),
        Transform::from_translation(Vec3::new(1.4, 0.4, 0.0)),
        0.5,
        Vec3::ZERO,
    );
    let (expected, _) = render(&rigid(Transform::from_translation(Vec3::new(0.2, 0.2, 0.0))), Vec3::ZERO);
    let (actual, _) = render(&scene, Vec3::ZERO);
    assert_same(&actual, &expected, "two joints, half each");
}

#[test]
fn culling_follows_the_pose_not_the_mesh_node() {
    // The joint carries the cube 30 units to the side, where the camera
    // looks; the mesh node stays at the origin, out of that view.
    let far = Vec3::new(30.0, 0.0, 0.0);
    let (mut scene, joint_b) = skinned(Transform::IDENTITY, Transform::from_translation(far), 1.0, Vec3::ZERO);
    let (image, draws) = render(&scene, far);
    assert_eq!(draws, 1, "the posed cube must not be culled by its bind-pose bound");
    let (expected, _) = render(&rigid(Transform::from_translation(far)), far);
    assert_same(&image, &expected, "posed far away");
    // Moved out of that view, it is culled.
    scene.set_local_transform(joint_b, Transform::from_translation(Vec3::new(-30.0, 0.0, 0.0))).unwrap();
    let (_, draws) = render(&scene, far);
    assert_eq!(draws, 0, "a pose outside the view is culled");
}

#[test]
fn bad_skins_are_refused_or_skipped_with_a_reason() {
    let (mut scene, joint) = skinned(Transform::IDENTITY, Transform::IDENTITY, 0.5, Vec3::ZERO);
    let node = scene.nodes().find(|(_, n)| n.name == "skinned").map(|(k, _)| k).unwrap();
    let mismatched = Skin { joints: vec![joint], inverse_bind_matrices: vec![] };
    assert!(matches!(scene.set_skin(node, Some(mismatched)), Err(SceneError::BadSkin { .. })));
    let nan = Skin { joints: vec![joint], inverse_bind_matrices: vec![Mat4::NAN] };
    assert!(matches!(scene.set_skin(node, Some(nan)), Err(SceneError::BadSkin { .. })));
    // One joint where the vertices name two: the frame skips the mesh and says why.
    scene.set_skin(node, Some(Skin { joints: vec![joint], inverse_bind_matrices: vec![Mat4::IDENTITY] })).unwrap();
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(camera(Vec3::ZERO), standard_render_graph).unwrap();
    let report = renderer.render_frame(&scene).unwrap();
    assert_eq!(report.views.iter().find(|v| v.view == view).map(|v| v.draws), Some(0));
    assert!(report.warnings.iter().any(|w| format!("{w:?}").contains("joint past the skin")), "{:?}", report.warnings);
}

/// Found in review: a skinned mesh took its winding and its visibility from
/// its node's transform, which skinning ignores. A mirrored or collapsed
/// mesh node must not change the skinned picture.
#[test]
fn the_mesh_nodes_own_transform_does_not_touch_a_skinned_mesh() {
    let moved = Transform::from_translation(Vec3::new(0.3, 0.0, 0.0));
    let (reference, _) = skinned(moved, Transform::IDENTITY, 0.0, Vec3::ZERO);
    let (expected, _) = render(&reference, Vec3::ZERO);
    for (what, node_transform) in [
        ("mirrored", Transform::IDENTITY.with_scale(Vec3::new(-1.0, 1.0, 1.0))),
        ("collapsed", Transform::IDENTITY.with_scale(Vec3::ZERO)),
    ] {
        let (mut scene, _) = skinned(moved, Transform::IDENTITY, 0.0, Vec3::ZERO);
        let node = scene.nodes().find(|(_, n)| n.name == "skinned").map(|(k, _)| k).unwrap();
        scene.set_local_transform(node, node_transform).unwrap();
        let (actual, draws) = render(&scene, Vec3::ZERO);
        assert_eq!(draws, 1, "{what}: the skinned cube must still be drawn");
        assert_same(&actual, &expected, what);
    }
}

/// Found by mutation testing (sceneprep shard 4): the upload writes the skin
/// records at offset `skin - start` of the mesh's vertex range, and every test above
/// puts the skinned mesh at the start of the vertex buffer, where
/// `skin + start` is the same place. Here a rigid cube is drawn first and
/// takes the buffer's start; the skinned cube must still be where its
/// joint puts it.
#[test]
fn a_skinned_mesh_after_other_geometry_reads_its_own_weights() {
    let moved = Transform::from_translation(Vec3::new(0.6, 0.1, 0.0));
    let grey = Vec4::new(0.5, 0.5, 0.5, 1.0);
    // The small cube's node comes first, so its geometry is placed first.
    let first_a_small_cube = |scene: &mut Scene| {
        let material = scene.add_material(Material::opaque("grey", grey));
        let geometry = scene.add_geometry(Geometry::cube(0.4));
        let node = scene.add_node("first", Transform::from_translation(Vec3::new(-1.3, -0.5, 0.0)));
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    };
    let mut expected_scene = Scene::new();
    first_a_small_cube(&mut expected_scene);
    let material = expected_scene.add_material(Material::opaque("orange", Vec4::new(0.9, 0.5, 0.1, 1.0)));
    let geometry = expected_scene.add_geometry(Geometry::cube(1.0));
    let node = expected_scene.add_node("rigid", moved);
    expected_scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    with_sun(&mut expected_scene);

    let mut scene = Scene::new();
    first_a_small_cube(&mut scene);
    let material = scene.add_material(Material::opaque("orange", Vec4::new(0.9, 0.5, 0.1, 1.0)));
    let cube = Geometry::cube(1.0);
    let weights = vec![SkinWeights::new([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]); cube.vertices().len()];
    let geometry = scene.add_geometry(cube.with_skin_weights(weights).unwrap());
    let joint = scene.add_node("joint", moved);
    let node = scene.add_node("skinned", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    scene.set_skin(node, Some(Skin { joints: vec![joint], inverse_bind_matrices: vec![Mat4::IDENTITY] })).unwrap();
    with_sun(&mut scene);

    let (expected, expected_draws) = render(&expected_scene, Vec3::ZERO);
    assert_eq!(expected_draws, 2, "both cubes are in view");
    let (actual, draws) = render(&scene, Vec3::ZERO);
    assert_eq!(draws, 2, "both cubes are in view");
    assert_same(&actual, &expected, "a skinned mesh placed second");
}
