//! Frame-phase rules: work done once and reused, degenerate transforms
//! skipped, geometry only for what some view draws, view filters.

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::scene::node_index;
use oxygen_core::{
    Camera, Geometry, LookAtResolver, Material, NodeFlags, NodeKey, Renderable, ResolvedView, Scene, Transform,
    ViewContext, ViewIds, ViewResolver,
};
use oxygen_sceneprep::{ScenePrep, ViewFilter, ViewPrepOptions, ViewRequest};

fn view(scene: &Scene) -> ResolvedView {
    let camera = LookAtResolver {
        camera: Camera::perspective(1.2, 0.1, Some(100.0)),
        eye: Vec3::new(0.0, 0.0, 10.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(64, 64),
    };
    camera
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, scene)
        .unwrap()
}

fn cube_node(scene: &mut Scene, name: &str, t: Transform) -> NodeKey {
    let geometry = scene.add_geometry(Geometry::cube(1.0));
    let material = scene.add_material(Material::opaque(name, Vec4::ONE));
    let node = scene.add_node(name, t);
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    node
}

/// A ScenePrep that has prepared `scene` through [`view`] once.
fn prepared_with_one_view(scene: &Scene) -> ScenePrep {
    let mut prep = ScenePrep::new();
    let view = view(scene);
    let request = ViewRequest { view: &view, options: ViewPrepOptions::default() };
    prep.prepare(scene, &[request], &mut SlotAllocators::default()).unwrap();
    prep
}

fn drawn(prep: &ScenePrep) -> Vec<u32> {
    prep.frames()[0].draws().iter().map(|d| d.node_id).collect()
}

#[test]
fn an_unchanged_scene_reuses_the_frame_phase_and_an_edit_redoes_it() {
    let mut scene = Scene::new();
    let node = cube_node(&mut scene, "cube", Transform::IDENTITY);
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    let v = view(&scene);
    let request = [ViewRequest { view: &v, options: Default::default() }];
    prep.prepare(&scene, &request, &mut slots).unwrap();
    prep.prepare(&scene, &request, &mut slots).unwrap();
    assert_eq!(prep.stats().frame_phase_reuses, 1);

    scene.set_local_transform(node, Transform::from_translation(Vec3::X)).unwrap();
    prep.prepare(&scene, &request, &mut slots).unwrap();
    assert_eq!(prep.stats().frame_phase_reuses, 1, "an edit must be collected");
    assert_eq!(prep.frames()[0].transforms().world[0].w_axis.truncate(), Vec3::X);
}

#[test]
fn singular_and_non_finite_transforms_are_skipped_and_never_drawn() {
    let mut scene = Scene::new();
    let good = cube_node(&mut scene, "good", Transform::IDENTITY);
    cube_node(&mut scene, "flat", Transform::IDENTITY.with_scale(Vec3::new(1.0, 0.0, 1.0)));
    cube_node(&mut scene, "nan", Transform::from_translation(Vec3::new(f32::NAN, 0.0, 0.0)));
    cube_node(&mut scene, "infinite", Transform::IDENTITY.with_scale(Vec3::splat(f32::INFINITY)));
    let mut prep = ScenePrep::new();
    let v = view(&scene);
    prep.prepare(&scene, &[ViewRequest { view: &v, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    assert_eq!(drawn(&prep), vec![node_index(good)]);
    assert_eq!(prep.frame_collection().skipped_nodes, 3);
    let transforms = prep.frames()[0].transforms();
    assert!(transforms.world.iter().all(|m| m.is_finite()));
    assert!(transforms.normal.iter().all(|n| n.matrix().is_finite()));
}

#[test]
fn tiny_but_valid_scales_are_kept() {
    let mut scene = Scene::new();
    let tiny = cube_node(&mut scene, "tiny", Transform::IDENTITY.with_scale(Vec3::splat(1e-4)));
    let mut prep = ScenePrep::new();
    let v = view(&scene);
    prep.prepare(&scene, &[ViewRequest { view: &v, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    assert_eq!(drawn(&prep), vec![node_index(tiny)]);
}

#[test]
fn a_mesh_no_view_draws_gets_no_slots() {
    let mut scene = Scene::new();
    cube_node(&mut scene, "seen", Transform::IDENTITY);
    cube_node(&mut scene, "behind the camera", Transform::from_translation(Vec3::new(0.0, 0.0, 50.0)));
    let mut prep = ScenePrep::new();
    let v = view(&scene);
    prep.prepare(&scene, &[ViewRequest { view: &v, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    assert_eq!(prep.resident_geometry(), 1);
}

#[test]
fn a_shadow_view_takes_shadow_casters_only() {
    let mut scene = Scene::new();
    let caster = cube_node(&mut scene, "caster", Transform::IDENTITY);
    let receiver = cube_node(&mut scene, "receiver only", Transform::from_translation(Vec3::X * 2.0));
    scene.set_flags(receiver, NodeFlags::VISIBLE).unwrap();
    let mut prep = ScenePrep::new();
    let v = view(&scene);
    let options = ViewPrepOptions { filter: ViewFilter::ShadowCastersOnly, ..Default::default() };
    prep.prepare(&scene, &[ViewRequest { view: &v, options }], &mut SlotAllocators::default()).unwrap();
    assert_eq!(drawn(&prep), vec![node_index(caster)]);
}

/// Shadow-casting local lights get atlas tiles in node order: one per spot,
/// six per point light, while the 16 tiles last; a light that no longer fits
/// is lit unshadowed, and a later, smaller one may still fit.
#[test]
fn local_lights_get_shadow_atlas_tiles_in_node_order() {
    use oxygen_core::Light;
    let mut scene = Scene::new();
    let lights = [
        Light::point(1.0, None),                                            // tiles 0..6
        Light::spot(1.0, None, 0.2, 0.3),                                   // tile 6
        Light { casts_shadows: false, ..Light::spot(1.0, None, 0.2, 0.3) }, // none
        Light::point(1.0, None),                                            // tiles 7..13
        Light::point(1.0, None),                                            // 13 + 6 > 16: none
        Light::spot(1.0, None, 0.2, 0.3),                                   // tile 13
        Light::directional(1.0),                                            // directional lights have no tile
    ];
    for (i, light) in lights.into_iter().enumerate() {
        let node = scene.add_node(format!("light {i}"), Transform::from_translation(Vec3::new(i as f32, 2.0, 0.0)));
        scene.set_light(node, Some(light)).unwrap();
    }
    // A light whose node does not cast shadows gets no tile either.
    let off = scene.add_node("no shadows", Transform::IDENTITY);
    scene.set_light(off, Some(Light::spot(1.0, None, 0.2, 0.3))).unwrap();
    scene.set_flags(off, NodeFlags::VISIBLE).unwrap();
    let prep = prepared_with_one_view(&scene);
    let none = oxygen_bindless::INVALID_SLOT;
    let slots: Vec<u32> = prep.frame_collection().positional_lights.iter().map(|l| l.shadow_slot).collect();
    assert_eq!(slots, vec![0, 6, none, 7, none, 13, none]);
}

/// A light with a NaN colour or cone angle never reaches the GPU (skipped
/// with a warning); a NaN or negative intensity is clamped to zero and a
/// negative colour to black, so no light record holds a non-finite number.
#[test]
fn lights_with_non_finite_parameters_are_skipped_or_clamped() {
    use oxygen_core::{Light, LightKind};
    let mut scene = Scene::new();
    let lights = [
        Light { color: Vec3::new(f32::NAN, 1.0, 1.0), ..Light::point(1.0, None) },
        Light::spot(1.0, None, f32::NAN, 0.3),
        Light {
            kind: LightKind::Spot { range: None, inner_cone: 0.1, outer_cone: f32::INFINITY },
            ..Light::point(1.0, None)
        },
        Light::point(f32::NAN, Some(f32::NAN)),
        Light { color: Vec3::new(-1.0, 0.5, 0.5), ..Light::directional(-3.0) },
    ];
    for (i, light) in lights.into_iter().enumerate() {
        let node = scene.add_node(format!("light {i}"), Transform::IDENTITY);
        scene.set_light(node, Some(light)).unwrap();
    }
    let prep = prepared_with_one_view(&scene);
    let frame = prep.frame_collection();
    assert_eq!(frame.positional_lights.len(), 1, "only the point light with a NaN intensity and range is kept");
    assert_eq!(frame.directional_lights.len(), 1);
    let p = &frame.positional_lights[0];
    assert_eq!((p.intensity, p.range), (0.0, 0.0));
    let d = &frame.directional_lights[0];
    assert_eq!(d.intensity, 0.0);
    assert_eq!(d.color, [0.0, 0.5, 0.5]);
    assert!(
        p.position.iter().chain(&p.direction).chain(&p.color).chain(&[p.cos_inner, p.cos_outer]).all(|v| v.is_finite())
    );
}

/// World-space normal and tangent of a local pair, through the frame's own
/// world and normal matrices.
fn transformed_pair(prep: &ScenePrep, transform_index: usize, normal: Vec3, tangent: Vec3) -> (Vec3, Vec3) {
    let transforms = prep.frames()[0].transforms();
    let world = transforms.world[transform_index];
    let normal_matrix = transforms.normal[transform_index].matrix();
    ((normal_matrix * normal).normalize(), world.transform_vector3(tangent).normalize())
}

#[test]
fn normals_stay_perpendicular_to_tangents_under_a_rotated_non_uniform_scale() {
    // A parent stretched 3× along X, a child turned 40° about Z and 25° about
    // Y below it: the stretch is no longer along the child's axes, so the
    // world matrix's upper 3×3 would tilt normals off their surfaces.
    let mut scene = Scene::new();
    let parent = scene.add_node("stretch", Transform::IDENTITY.with_scale(Vec3::new(3.0, 1.0, 1.0)));
    let geometry = scene.add_geometry(Geometry::cube(1.0));
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let rotation = glam::Quat::from_rotation_z(40f32.to_radians()) * glam::Quat::from_rotation_y(25f32.to_radians());
    let child = scene.add_child(parent, "turned", Transform::IDENTITY.with_rotation(rotation)).unwrap();
    scene.set_renderable(child, Renderable { geometry, materials: vec![material] }).unwrap();
    let prep = prepared_with_one_view(&scene);
    let pairs = [
        (Vec3::X, Vec3::Y),
        (Vec3::X, Vec3::Z),
        (Vec3::Y, Vec3::Z),
        (Vec3::Y, Vec3::X),
        (Vec3::Z, Vec3::X),
        (Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(1.0, -1.0, 0.0).normalize()),
        (Vec3::new(0.0, 1.0, 1.0).normalize(), Vec3::new(0.0, 1.0, -1.0).normalize()),
    ];
    for (normal, tangent) in pairs {
        let (n, t) = transformed_pair(&prep, 0, normal, tangent);
        assert!(
            n.dot(t).abs() < 1e-5,
            "normal {normal} / tangent {tangent}: world dot {} (n = {n}, t = {t})",
            n.dot(t)
        );
    }
    // And the test can tell: the plain upper 3×3 breaks perpendicularity here.
    let world = prep.frames()[0].transforms().world[0];
    let wrong = world.transform_vector3(Vec3::X).normalize();
    let tangent = world.transform_vector3(Vec3::Y).normalize();
    assert!(wrong.dot(tangent).abs() > 0.1, "the scene must be one where the upper 3x3 fails");
}

#[test]
fn light_positions_are_rebased_on_the_render_origin_in_f64() {
    use oxygen_core::Light;
    let far = glam::DVec3::new(1.0e6 + 3.25, 2.5, -1.0e6 + 0.125);
    let mut scene = Scene::new();
    cube_node(&mut scene, "anchor", Transform::IDENTITY);
    let lamp = scene.add_node("lamp", Transform::from_translation(far.as_vec3()));
    scene.set_light(lamp, Some(Light::point(10.0, Some(50.0)))).unwrap();
    let mut prep = ScenePrep::new();
    prep.set_render_origin(glam::DVec3::new(1.0e6, 0.0, -1.0e6));
    let v = view(&scene);
    prep.prepare(&scene, &[ViewRequest { view: &v, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    let lights = &prep.frame_collection().positional_lights;
    assert_eq!(lights.len(), 1);
    // The f32 translation of the node rounds 1e6 + 3.25 to a multiple of
    // 1/16; the rebased position must be that value minus the origin, exact.
    let stored = far.as_vec3().as_dvec3() - glam::DVec3::new(1.0e6, 0.0, -1.0e6);
    assert_eq!(glam::Vec3::from(lights[0].position), stored.as_vec3());
    assert!((glam::Vec3::from(lights[0].position) - Vec3::new(3.25, 2.5, 0.125)).length() < 0.07);
}

/// The positional light record of a scene holding `light` alone.
fn positional_record(light: oxygen_core::Light) -> oxygen_sceneprep::PositionalLightRecord {
    let mut scene = Scene::new();
    let node = scene.add_node("light", Transform::IDENTITY);
    scene.set_light(node, Some(light)).unwrap();
    let prep = prepared_with_one_view(&scene);
    let lights = &prep.frame_collection().positional_lights;
    assert_eq!(lights.len(), 1);
    lights[0]
}

/// A spot light whose inner cone is not inside its outer one (as wide, or
/// wider) gets an inner cone 1e-4 rad inside the outer one, so its falloff
/// band keeps a width (`cos_inner > cos_outer`): the shader's smooth edge
/// never runs backwards or collapses.
#[test]
fn a_spot_lights_inner_cone_is_kept_inside_its_outer_cone() {
    for inner in [0.5f32, 0.8] {
        let p = positional_record(oxygen_core::Light::spot(1.0, None, inner, 0.5));
        assert_eq!(p.cos_outer, 0.5f32.cos(), "inner cone {inner}");
        assert_eq!(p.cos_inner, (0.5f32 - 1e-4).cos(), "inner cone {inner}");
        assert!(p.cos_inner > p.cos_outer, "inner cone {inner}");
    }
}

/// A point or spot light's range bounds it only when positive and finite;
/// a negative, zero (of either sign), infinite or NaN range means
/// unbounded, which the record writes as +0 (what the shader reads as "no
/// cut-off"), bit for bit: `-0` would print as such in `dump_lights`, so
/// two unbounded lights would not dump alike.
#[test]
fn only_a_positive_finite_range_bounds_a_light() {
    let unbounded = [None, Some(-5.0), Some(0.0), Some(-0.0), Some(f32::INFINITY), Some(f32::NAN)];
    let cases = unbounded.map(|range| (range, 0.0)).into_iter().chain([(Some(5.0), 5.0)]);
    for (range, expected) in cases {
        for light in [oxygen_core::Light::point(1.0, range), oxygen_core::Light::spot(1.0, range, 0.2, 0.4)] {
            let written = positional_record(light).range;
            assert_eq!(written.to_bits(), f32::to_bits(expected), "range {range:?} written as {written}");
        }
    }
}

/// A renderable of `geometry` under a new node at `t`.
fn mesh_node(scene: &mut Scene, name: &str, t: Transform, geometry: oxygen_core::GeometryHandle) -> NodeKey {
    let material = scene.add_material(Material::opaque(name, Vec4::ONE));
    let node = scene.add_node(name, t);
    scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).expect("a renderable on a new node");
    node
}

/// A one-unit quad whose every vertex is weighed half to joint 0, half to
/// joint 1 (so its vertices name two joints).
fn two_joint_quad(scene: &mut Scene) -> oxygen_core::GeometryHandle {
    let quad = Geometry::quad(1.0);
    let weights = vec![oxygen_core::SkinWeights::new([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]); quad.vertices().len()];
    scene.add_geometry(quad.with_skin_weights(weights).expect("one weight record per vertex"))
}

/// Gives `node` a skin over new joint nodes at `joints`, identity bind matrices.
fn skin_on(scene: &mut Scene, node: NodeKey, joints: &[Transform]) {
    let joints: Vec<NodeKey> = joints.iter().map(|t| scene.add_node("joint", *t)).collect();
    let binds = vec![glam::Mat4::IDENTITY; joints.len()];
    scene
        .set_skin(node, Some(oxygen_core::Skin { joints, inverse_bind_matrices: binds }))
        .expect("joints of this scene, one bind matrix each");
}

/// The frame's entry of renderable `node`.
fn renderable(prep: &ScenePrep, node: NodeKey) -> &oxygen_sceneprep::RenderableEntry {
    let entries = &prep.frame_collection().renderables;
    entries.iter().find(|e| e.node == node).expect("the node is among the frame's renderables")
}

/// What the frame skipped: each node with its reason.
fn skipped(prep: &ScenePrep) -> Vec<(NodeKey, &'static str)> {
    prep.frame_collection().skipped.iter().map(|s| (s.node, s.reason)).collect()
}

/// A morphed renderable's header among the frame's matrices is its vertex
/// count, its target count, then one weight per target, zeros after, 16
/// floats a matrix, in as many matrices as those 2 + targets floats need
/// (its world matrix follows). The scene keeps weights past the targets:
/// two extra non-zero ones here must not leak into the padding (1 target:
/// the float after its weight; 15: the one after the second matrix's
/// first), and 14 targets fill exactly one matrix (16 floats, not 2 × 14).
#[test]
fn a_morph_header_holds_the_counts_then_one_weight_per_target() {
    for targets in [1usize, 14, 15] {
        let mut scene = Scene::new();
        let quad = Geometry::quad(1.0);
        let vertices = quad.vertices().len();
        let morphs = (0..targets)
            .map(|_| oxygen_core::MorphTarget { positions: vec![Vec3::Z * 0.01; vertices], normals: None })
            .collect();
        let geometry = scene.add_geometry(quad.with_morph_targets(morphs).expect("a few finite targets"));
        let node = mesh_node(&mut scene, "morphed", Transform::IDENTITY, geometry);
        let weights: Vec<f32> = (1..=targets + 2).map(|i| i as f32 / 64.0).collect();
        scene.set_morph_weights(node, weights.clone()).expect("weights of a node of the scene");
        let prep = prepared_with_one_view(&scene);
        let entry = renderable(&prep, node);
        let matrices = (2 + targets).div_ceil(16);
        assert_eq!(entry.transform_index, entry.morph_base + matrices as u32, "{targets} targets");
        let world = &prep.frame_collection().transforms.world;
        let header: Vec<f32> = world[entry.morph_base as usize..entry.transform_index as usize]
            .iter()
            .flat_map(|m| m.to_cols_array())
            .collect();
        let mut expected = vec![vertices as f32, targets as f32];
        expected.extend_from_slice(&weights[..targets]);
        expected.resize(16 * matrices, 0.0);
        assert_eq!(header, expected, "{targets} targets");
    }
}

/// A renderable's world matrix reaches the GPU relative to the render
/// origin: its translation minus the origin, its axes unchanged. The cube
/// sits 3.25, 2.5 and 0.125 from the origin, not 2e6 away (where adding the
/// origin would put it).
#[test]
fn a_renderables_world_matrix_is_rebased_on_the_render_origin() {
    let origin = glam::DVec3::new(1.0e6, 0.0, -1.0e6);
    let mut scene = Scene::new();
    // Both coordinates are f32 numbers (multiples of 1/16 near 1e6).
    let node = cube_node(&mut scene, "far", Transform::from_translation(Vec3::new(1.0e6 + 3.25, 2.5, -1.0e6 + 0.125)));
    let mut prep = ScenePrep::new();
    prep.set_render_origin(origin);
    let v = view(&scene);
    prep.prepare(&scene, &[ViewRequest { view: &v, options: Default::default() }], &mut SlotAllocators::default())
        .expect("a frame of one cube");
    let world = prep.frame_collection().transforms.world[renderable(&prep, node).transform_index as usize];
    assert_eq!(world, glam::Mat4::from_translation(Vec3::new(3.25, 2.5, 0.125)));
}

/// A finite scale whose determinant overflows `f32` (1e13 per axis: 1e39)
/// has no normal matrix: its inverse would round to zero, a matrix that
/// turns every normal into nothing, so the node is skipped like a singular
/// one rather than drawn unlit.
#[test]
fn a_transform_whose_determinant_overflows_is_skipped() {
    let mut scene = Scene::new();
    let huge = cube_node(&mut scene, "huge", Transform::IDENTITY.with_scale(Vec3::splat(1.0e13)));
    let prep = prepared_with_one_view(&scene);
    assert!(prep.frame_collection().renderables.is_empty());
    assert_eq!(skipped(&prep), vec![(huge, "non-finite or singular world transform")]);
}

/// A singular node transform hides a mesh unless a skin places it: a
/// skinned mesh with its skin is kept (its joints place it, the node's
/// transform is unused), but a rigid mesh under a skin, or a skinned mesh
/// without one, is drawn with its node's flat transform, so each of those
/// is skipped. One of the two conditions alone must not be enough.
#[test]
fn a_singular_transform_hides_a_mesh_unless_its_skin_places_it() {
    let mut scene = Scene::new();
    let flat = Transform::IDENTITY.with_scale(Vec3::new(1.0, 0.0, 1.0));
    let skinned = two_joint_quad(&mut scene);
    let rigid = scene.add_geometry(Geometry::quad(1.0));
    let placed = mesh_node(&mut scene, "skinned mesh, skin", flat, skinned);
    skin_on(&mut scene, placed, &[Transform::IDENTITY; 2]);
    let rigid_under_skin = mesh_node(&mut scene, "rigid mesh, skin", flat, rigid);
    skin_on(&mut scene, rigid_under_skin, &[Transform::IDENTITY; 2]);
    let no_skin = mesh_node(&mut scene, "skinned mesh, no skin", flat, skinned);
    let prep = prepared_with_one_view(&scene);
    let kept: Vec<NodeKey> = prep.frame_collection().renderables.iter().map(|e| e.node).collect();
    assert_eq!(kept, vec![placed]);
    let reason = "non-finite or singular world transform";
    assert_eq!(skipped(&prep), vec![(rigid_under_skin, reason), (no_skin, reason)]);
}

/// A skinned or a morphed renderable is drawn with its base mesh, so its
/// LODs are left out of the frame (their vertices carry no skin or morph
/// records); a rigid one keeps its LOD. Each deformation alone is enough:
/// the skinned quad has no morph targets, the morphed one no skin.
#[test]
fn a_skinned_or_morphed_renderable_is_drawn_without_its_lods() {
    let mut scene = Scene::new();
    let coarse = scene.add_geometry(Geometry::quad(1.0));
    let lod = [oxygen_core::LodLevel { geometry: coarse, below_screen_fraction: 0.1 }];
    let rigid = scene.add_geometry(Geometry::quad(1.0));
    let skinned = two_joint_quad(&mut scene);
    let quad = Geometry::quad(1.0);
    let morph = oxygen_core::MorphTarget { positions: vec![Vec3::Z * 0.1; quad.vertices().len()], normals: None };
    let morphed = scene.add_geometry(quad.with_morph_targets(vec![morph]).expect("one finite target"));
    let mut nodes = Vec::new();
    for (name, geometry) in [("rigid", rigid), ("skinned", skinned), ("morphed", morphed)] {
        let node = mesh_node(&mut scene, name, Transform::IDENTITY, geometry);
        scene.set_lods(node, lod.to_vec()).expect("a one-submesh LOD of a one-submesh mesh");
        nodes.push(node);
    }
    skin_on(&mut scene, nodes[1], &[Transform::IDENTITY; 2]);
    let prep = prepared_with_one_view(&scene);
    let lod_counts: Vec<u32> = nodes.iter().map(|n| renderable(&prep, *n).lods.1).collect();
    assert_eq!(lod_counts, vec![1, 0, 0], "rigid, skinned, morphed");
}

/// A skin may have more joints than its mesh's vertices name (the spare
/// one moves nothing), but a mesh naming a joint past the skin's joints
/// (here joint 1 of a one-joint skin) is skipped with that reason.
#[test]
fn a_skin_may_have_spare_joints_but_none_missing() {
    let mut scene = Scene::new();
    let skinned = two_joint_quad(&mut scene);
    let spare = mesh_node(&mut scene, "three joints", Transform::IDENTITY, skinned);
    skin_on(&mut scene, spare, &[Transform::IDENTITY; 3]);
    let missing = mesh_node(&mut scene, "one joint", Transform::IDENTITY, skinned);
    skin_on(&mut scene, missing, &[Transform::IDENTITY]);
    let prep = prepared_with_one_view(&scene);
    let kept: Vec<NodeKey> = prep.frame_collection().renderables.iter().map(|e| e.node).collect();
    assert_eq!(kept, vec![spare]);
    assert_eq!(skipped(&prep), vec![(missing, "a vertex names a joint past the skin's joints")]);
}

/// A skinned mesh's winding follows its first joint, not its node: a
/// first joint scaled by -1 along X (determinant -1) draws it mirrored
/// under an unmirrored node, and plain joints draw it unmirrored under a
/// mirrored node.
#[test]
fn a_skinned_mesh_is_mirrored_by_its_first_joint() {
    let mut scene = Scene::new();
    let skinned = two_joint_quad(&mut scene);
    let mirror = Transform::IDENTITY.with_scale(Vec3::new(-1.0, 1.0, 1.0));
    let by_joint = mesh_node(&mut scene, "mirrored joint", Transform::IDENTITY, skinned);
    skin_on(&mut scene, by_joint, &[mirror, Transform::IDENTITY]);
    let by_node = mesh_node(&mut scene, "mirrored node", mirror, skinned);
    skin_on(&mut scene, by_node, &[Transform::IDENTITY; 2]);
    let prep = prepared_with_one_view(&scene);
    let mirrored = |node| {
        let (first, count) = renderable(&prep, node).submeshes;
        assert_eq!(count, 1);
        prep.frame_collection().submeshes[first as usize].pass_mask.contains(oxygen_sceneprep::PassMask::MIRRORED)
    };
    assert!(mirrored(by_joint), "a mirroring first joint");
    assert!(!mirrored(by_node), "plain joints under a mirroring node");
}
