//! The frame's shadow casters, as the frame phase reports them each frame:
//! which spot and point lights got which atlas tiles, and which directional
//! light the shading pass gives its cascades to. All on the CPU: the frame
//! phase runs through `begin_frame`, with no view and no GPU.

use glam::Vec3;
use oxygen_bindless::{INVALID_SLOT, SlotAllocators};
use oxygen_core::{Light, Mobility, NodeFlags, NodeKey, Scene, Transform};
use oxygen_sceneprep::{FrameCollection, LocalShadowCaster, LocalShadowKind, MAX_SHADOW_TILES, ScenePrep};

/// A node at `x` carrying `light`.
fn light_node(scene: &mut Scene, name: &str, x: f32, light: Light) -> NodeKey {
    let node = scene.add_node(name, Transform::from_translation(Vec3::new(x, 2.0, 0.0)));
    scene.set_light(node, Some(light)).expect("the node was just added");
    node
}

fn spot() -> Light {
    Light::spot(1.0, None, 0.2, 0.3)
}

fn point() -> Light {
    Light::point(1.0, None)
}

fn not_casting(light: Light) -> Light {
    Light { casts_shadows: false, ..light }
}

/// Runs the frame phase of `scene` on `prep` and returns its collection.
fn collect<'a>(prep: &'a mut ScenePrep, scene: &Scene, slots: &mut SlotAllocators) -> &'a FrameCollection {
    prep.begin_frame(scene, slots).expect("the frame phase of a small scene cannot run out of slots")
}

/// `(node, kind, first tile, tile count)` of each local shadow caster.
fn casters(frame: &FrameCollection) -> Vec<(NodeKey, LocalShadowKind, u32, u32)> {
    frame.local_shadow_casters.iter().map(|c| (c.node, c.kind, c.first_tile, c.tile_count)).collect()
}

#[test]
fn spot_and_point_lights_that_cast_shadows_are_listed_in_node_order_with_their_tiles() {
    let mut scene = Scene::new();
    let a = light_node(&mut scene, "point", 0.0, point());
    let b = light_node(&mut scene, "spot", 1.0, spot());
    light_node(&mut scene, "unshadowed spot", 2.0, not_casting(spot()));
    let c = light_node(&mut scene, "second spot", 3.0, spot());
    let mut prep = ScenePrep::new();
    let frame = collect(&mut prep, &scene, &mut SlotAllocators::default());
    use LocalShadowKind::{Point, Spot};
    assert_eq!(casters(frame), vec![(a, Point, 0, 6), (b, Spot, 6, 1), (c, Spot, 7, 1)]);
}

#[test]
fn each_caster_names_the_light_record_that_holds_its_first_tile() {
    let mut scene = Scene::new();
    light_node(&mut scene, "unshadowed point", 0.0, not_casting(point()));
    light_node(&mut scene, "spot", 1.0, spot());
    light_node(&mut scene, "point", 2.0, point());
    let mut prep = ScenePrep::new();
    let frame = collect(&mut prep, &scene, &mut SlotAllocators::default());
    assert_eq!(frame.local_shadow_casters.len(), 2);
    for caster in &frame.local_shadow_casters {
        let record = &frame.positional_lights[caster.light_index as usize];
        assert_eq!(record.shadow_slot, caster.first_tile);
        assert_eq!(record.flags & 1, 1, "the record casts shadows");
    }
    let with_tiles = frame.positional_lights.iter().filter(|l| l.shadow_slot != INVALID_SLOT).count();
    assert_eq!(with_tiles, frame.local_shadow_casters.len(), "every record with tiles is listed");
}

#[test]
fn tiles_stop_when_the_atlas_is_used_up_and_a_later_smaller_light_may_still_fit() {
    let mut scene = Scene::new();
    let first = light_node(&mut scene, "point 1", 0.0, point()); // 0..6
    let second = light_node(&mut scene, "point 2", 1.0, point()); // 6..12
    light_node(&mut scene, "point 3", 2.0, point()); // 12 + 6 > 16: none
    let spots: Vec<NodeKey> = (0..6).map(|i| light_node(&mut scene, "spot", 3.0 + i as f32, spot())).collect();
    let mut prep = ScenePrep::new();
    let frame = collect(&mut prep, &scene, &mut SlotAllocators::default());
    let listed: Vec<NodeKey> = frame.local_shadow_casters.iter().map(|c| c.node).collect();
    assert_eq!(listed, vec![first, second, spots[0], spots[1], spots[2], spots[3]], "the last two spots find no tile");
    let used: u32 = frame.local_shadow_casters.iter().map(|c| c.tile_count).sum();
    assert_eq!(used, MAX_SHADOW_TILES);
    let tiles: Vec<u32> = frame.local_shadow_casters.iter().flat_map(LocalShadowCaster::tiles).collect();
    assert_eq!(tiles, (0..MAX_SHADOW_TILES).collect::<Vec<_>>(), "tiles are handed out once each, in order");
}

#[test]
fn adding_removing_and_toggling_lights_between_frames_changes_the_list() {
    let mut scene = Scene::new();
    let mut slots = SlotAllocators::default();
    let mut prep = ScenePrep::new();
    let lamp = light_node(&mut scene, "lamp", 0.0, point());
    let nodes = |frame: &FrameCollection| frame.local_shadow_casters.iter().map(|c| c.node).collect::<Vec<_>>();
    assert_eq!(nodes(collect(&mut prep, &scene, &mut slots)), vec![lamp]);

    let torch = light_node(&mut scene, "torch", 1.0, spot());
    let frame = collect(&mut prep, &scene, &mut slots);
    assert_eq!(casters(frame), vec![(lamp, LocalShadowKind::Point, 0, 6), (torch, LocalShadowKind::Spot, 6, 1)]);

    scene.set_light(lamp, Some(not_casting(point()))).expect("the lamp exists");
    let frame = collect(&mut prep, &scene, &mut slots);
    assert_eq!(casters(frame), vec![(torch, LocalShadowKind::Spot, 0, 1)], "the torch moves up to tile 0");

    scene.set_flags(torch, NodeFlags::VISIBLE).expect("the torch exists");
    assert_eq!(nodes(collect(&mut prep, &scene, &mut slots)), vec![], "a node that casts no shadows");

    scene.set_flags(torch, NodeFlags::VISIBLE | NodeFlags::CASTS_SHADOWS).expect("the torch exists");
    scene.set_light(lamp, Some(point())).expect("the lamp exists");
    assert_eq!(nodes(collect(&mut prep, &scene, &mut slots)), vec![lamp, torch]);

    scene.remove_node(lamp).expect("the lamp exists");
    let frame = collect(&mut prep, &scene, &mut slots);
    assert_eq!(casters(frame), vec![(torch, LocalShadowKind::Spot, 0, 1)]);
}

#[test]
fn an_unchanged_scene_keeps_its_shadow_casters_when_the_frame_phase_is_reused() {
    let mut scene = Scene::new();
    let lamp = light_node(&mut scene, "lamp", 0.0, point());
    let sun = light_node(&mut scene, "sun", 0.0, Light::directional(3.0));
    let mut slots = SlotAllocators::default();
    let mut prep = ScenePrep::new();
    collect(&mut prep, &scene, &mut slots);
    let frame = collect(&mut prep, &scene, &mut slots);
    assert!(frame.reused_last());
    assert_eq!(casters(frame), vec![(lamp, LocalShadowKind::Point, 0, 6)]);
    assert_eq!(frame.shadow_sun, Some(sun));
}

#[test]
fn hidden_and_gated_out_local_lights_are_not_shadow_casters() {
    let mut scene = Scene::new();
    let hidden_parent = scene.add_node("hidden parent", Transform::IDENTITY);
    scene.set_flags(hidden_parent, NodeFlags::CASTS_SHADOWS).expect("the node was just added");
    let under_hidden = scene.add_child(hidden_parent, "under a hidden parent", Transform::IDENTITY).expect("parent");
    scene.set_light(under_hidden, Some(spot())).expect("the node was just added");
    light_node(&mut scene, "baked", 1.0, Light { mobility: Mobility::Baked, ..point() });
    light_node(&mut scene, "not affecting the world", 2.0, Light { affects_world: false, ..spot() });
    let kept = light_node(&mut scene, "kept", 3.0, spot());
    let mut prep = ScenePrep::new();
    let frame = collect(&mut prep, &scene, &mut SlotAllocators::default());
    assert_eq!(casters(frame), vec![(kept, LocalShadowKind::Spot, 0, 1)]);
}

/// The shading pass gives its cascades to the first directional light
/// record whose shadow flag is set: there is a shadow sun exactly when the
/// shader has such a record (the tests pin which light it is).
fn assert_sun_is_the_shaders(frame: &FrameCollection) {
    let shaded = frame.directional_lights.iter().position(|l| l.flags & 1 != 0);
    assert_eq!(frame.shadow_sun.is_some(), shaded.is_some(), "shadow_sun and the shader's pick disagree");
}

#[test]
fn the_shadow_sun_is_the_first_shadow_casting_directional_light_the_shader_sees() {
    let mut scene = Scene::new();
    light_node(&mut scene, "moon without shadows", 0.0, not_casting(Light::directional(0.1)));
    let node_off = light_node(&mut scene, "node casts no shadows", 0.0, Light::directional(1.0));
    scene.set_flags(node_off, NodeFlags::VISIBLE).expect("the node exists");
    light_node(&mut scene, "baked sun", 0.0, Light { mobility: Mobility::Baked, ..Light::directional(1.0) });
    light_node(&mut scene, "sun off world", 0.0, Light { affects_world: false, ..Light::directional(1.0) });
    let hidden_parent = scene.add_node("hidden parent", Transform::IDENTITY);
    scene.set_flags(hidden_parent, NodeFlags::CASTS_SHADOWS).expect("the node exists");
    let hidden = scene.add_child(hidden_parent, "sun under a hidden parent", Transform::IDENTITY).expect("parent");
    scene.set_light(hidden, Some(Light::directional(1.0))).expect("the node exists");
    let sun = light_node(&mut scene, "sun", 0.0, Light::directional(2.0));
    let second = light_node(&mut scene, "second sun", 0.0, Light::directional(2.0));
    let mut slots = SlotAllocators::default();
    let mut prep = ScenePrep::new();
    let frame = collect(&mut prep, &scene, &mut slots);
    assert_eq!(frame.shadow_sun, Some(sun));
    assert_sun_is_the_shaders(frame);
    let first_flagged = frame.directional_lights.iter().position(|l| l.flags & 1 != 0);
    assert_eq!(first_flagged, Some(2), "records: moon, node without shadows, sun, second sun");
    assert!(frame.local_shadow_casters.is_empty(), "directional lights take no atlas tiles");

    scene.remove_node(sun).expect("the sun exists");
    let frame = collect(&mut prep, &scene, &mut slots);
    assert_eq!(frame.shadow_sun, Some(second), "the next shadow-casting sun takes over");
    assert_sun_is_the_shaders(frame);
}

#[test]
fn no_shadow_casting_directional_light_means_no_shadow_sun() {
    let mut scene = Scene::new();
    let mut slots = SlotAllocators::default();
    let mut prep = ScenePrep::new();
    assert_eq!(collect(&mut prep, &scene, &mut slots).shadow_sun, None, "an empty scene");

    let sun = light_node(&mut scene, "sun", 0.0, Light::directional(1.0));
    light_node(&mut scene, "lamp", 1.0, point());
    assert_eq!(collect(&mut prep, &scene, &mut slots).shadow_sun, Some(sun));

    scene.set_light(sun, Some(not_casting(Light::directional(1.0)))).expect("the sun exists");
    let frame = collect(&mut prep, &scene, &mut slots);
    assert_eq!(frame.shadow_sun, None);
    assert_sun_is_the_shaders(frame);
}
