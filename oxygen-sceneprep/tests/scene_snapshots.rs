//! Snapshots of ScenePrep output for scenes that exercise one rule each:
//! every alpha class × sidedness, and every light type × gating rule.

use glam::{Mat4, Quat, UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::light::Mobility;
use oxygen_core::{
    AlphaMode, Camera, Geometry, Light, LookAtResolver, Material, NodeFlags, Renderable, Scene, Transform, ViewContext,
    ViewIds, ViewResolver,
};
use oxygen_sceneprep::{ScenePrep, ViewRequest};

fn view_of(scene: &Scene) -> oxygen_core::ResolvedView {
    let camera = LookAtResolver {
        camera: Camera::perspective(70f32.to_radians(), 0.1, Some(100.0)),
        eye: Vec3::new(0.0, 2.0, 12.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(320, 200),
    };
    camera
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, scene)
        .unwrap()
}

#[test]
fn every_alpha_class_and_sidedness_gets_its_own_partition_in_pass_order() {
    let mut scene = Scene::new();
    let quad = scene.add_geometry(Geometry::quad(1.0));
    let modes = [("blend", AlphaMode::Blend), ("mask", AlphaMode::Mask { cutoff: 0.3 }), ("opaque", AlphaMode::Opaque)];
    // Created in reverse pass order so that the sort, not creation order, decides.
    for (name, mode) in modes {
        for double_sided in [true, false] {
            let material = scene.add_material(Material {
                alpha_mode: mode,
                double_sided,
                ..Material::opaque(format!("{name} double_sided={double_sided}"), Vec4::new(1.0, 1.0, 1.0, 0.5))
            });
            // Two quads per material at different depths: opaque and masked
            // must come out front-to-back, blended back-to-front.
            for z in [-4.0, 2.0] {
                let node = scene.add_node(
                    format!("{name} {double_sided} z={z}"),
                    Transform::from_translation(Vec3::new(0.0, 0.0, z)),
                );
                scene.set_renderable(node, Renderable { geometry: quad, materials: vec![material] }).unwrap();
            }
        }
    }
    let view = view_of(&scene);
    let mut prep = ScenePrep::new();
    let frames = prep
        .prepare(&scene, &[ViewRequest { view: &view, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    insta::assert_snapshot!(frames[0].dump());
}

#[test]
fn every_light_type_and_gating_rule() {
    let mut scene = Scene::new();
    let aim = |dir: Vec3| Quat::from_rotation_arc(Vec3::NEG_Z, dir.normalize());
    let add = |scene: &mut Scene, name: &str, at: Vec3, dir: Vec3, light: Light, flags: NodeFlags| {
        let node = scene.add_node(name, Transform::from_translation(at).with_rotation(aim(dir)));
        scene.set_light(node, Some(light)).unwrap();
        scene.set_flags(node, flags).unwrap();
        node
    };
    let both = NodeFlags::VISIBLE | NodeFlags::CASTS_SHADOWS;
    add(&mut scene, "sun (kept, shadows)", Vec3::ZERO, Vec3::new(0.0, -1.0, -1.0), Light::directional(3.0), both);
    add(&mut scene, "point (kept)", Vec3::new(1.0, 2.0, 3.0), Vec3::NEG_Y, Light::point(50.0, Some(10.0)), both);
    let spot = Light::spot(80.0, None, 0.2, 0.5);
    add(&mut scene, "spot (kept)", Vec3::new(-2.0, 4.0, 0.0), Vec3::NEG_Y, spot, both);
    let baked = Light { mobility: Mobility::Baked, ..Light::point(10.0, None) };
    add(&mut scene, "baked (excluded)", Vec3::X, Vec3::NEG_Y, baked, both);
    let realtime = Light { mobility: Mobility::Realtime, ..Light::point(11.0, None) };
    add(&mut scene, "realtime (kept)", Vec3::Y, Vec3::NEG_Y, realtime, both);
    let dark = Light { affects_world: false, ..Light::point(12.0, None) };
    add(&mut scene, "affects nothing (excluded)", Vec3::Z, Vec3::NEG_Y, dark, both);
    add(&mut scene, "invisible (excluded)", Vec3::ONE, Vec3::NEG_Y, Light::point(13.0, None), NodeFlags::CASTS_SHADOWS);
    let parent = scene.add_node("hidden parent", Transform::IDENTITY);
    scene.set_flags(parent, NodeFlags::empty()).unwrap();
    let child = scene.add_child(parent, "child of hidden (excluded)", Transform::IDENTITY).unwrap();
    scene.set_light(child, Some(Light::point(14.0, None))).unwrap();
    add(&mut scene, "node says no shadows", Vec3::NEG_X, Vec3::NEG_Y, Light::point(15.0, None), NodeFlags::VISIBLE);
    let no_shadow = Light { casts_shadows: false, ..Light::directional(1.5) };
    add(&mut scene, "light says no shadows", Vec3::ZERO, Vec3::NEG_X, no_shadow, both);

    let view = view_of(&scene);
    let mut prep = ScenePrep::new();
    prep.prepare(&scene, &[ViewRequest { view: &view, options: Default::default() }], &mut SlotAllocators::default())
        .unwrap();
    let lights = prep.frame_collection().dump_lights();
    let frames = prep.frames();
    insta::assert_snapshot!(format!("{lights}\n{}", frames[0].dump()));
}

/// A skinned mesh, a morphed one and one with vertex colours: their draws
/// name their skin records, joint matrices, morph header and attribute
/// records, and the dump is the same for the same construction.
#[test]
fn skinned_morphed_and_coloured_meshes() {
    use oxygen_core::{MorphTarget, Skin, SkinWeights, VertexAttributes};
    let build = || {
        let mut scene = Scene::new();
        let material = scene.add_material(Material::opaque("grey", Vec4::splat(0.5)));
        let quad = Geometry::quad(1.0);
        let n = quad.vertices().len();
        let skinned =
            quad.clone().with_skin_weights(vec![SkinWeights::new([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]); n]).unwrap();
        let morphed = quad
            .clone()
            .with_morph_targets(vec![MorphTarget { positions: vec![Vec3::Y; n], normals: None }; 2])
            .unwrap();
        let coloured = quad.with_attributes(vec![VertexAttributes::default(); n]).unwrap();
        let add = |scene: &mut Scene, name: &str, geometry: Geometry, z: f32| {
            let geometry = scene.add_geometry(geometry);
            let node = scene.add_node(name, Transform::from_translation(Vec3::new(0.0, 0.0, z)));
            scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
            node
        };
        let skin_node = add(&mut scene, "skinned", skinned, -2.0);
        let morph_node = add(&mut scene, "morphed", morphed, -3.0);
        add(&mut scene, "coloured", coloured, -4.0);
        let joints = vec![
            scene.add_node("joint 0", Transform::from_translation(Vec3::new(0.0, 0.0, -2.0))),
            scene.add_node("joint 1", Transform::from_translation(Vec3::new(0.5, 0.0, -2.0))),
        ];
        scene.set_skin(skin_node, Some(Skin { joints, inverse_bind_matrices: vec![Mat4::IDENTITY; 2] })).unwrap();
        scene.set_morph_weights(morph_node, vec![0.25, 0.5]).unwrap();
        scene
    };
    let dump = |scene: &Scene| {
        let view = view_of(scene);
        let mut prep = ScenePrep::new();
        let frames = prep
            .prepare(scene, &[ViewRequest { view: &view, options: Default::default() }], &mut SlotAllocators::default())
            .unwrap();
        frames[0].dump()
    };
    let first = dump(&build());
    assert_eq!(first, dump(&build()), "the same construction must dump the same");
    for field in ["skin@", "joints@", "morph@", "attributes@"] {
        assert!(first.contains(field), "{field} missing:\n{first}");
    }
    insta::assert_snapshot!(first);
}
