//! Morph targets on the GPU: each vertex adds its targets' displacements,
//! weighted by the node's morph weights (carried with the frame's
//! matrices), before skinning. Checked against the same mesh drawn rigidly
//! where the weights should put it; culling follows the weights; glTF's
//! SimpleMorph animates its weights.

mod support;

use std::path::PathBuf;

use oxygen::core::{MaterialHandle, NodeKey};
use oxygen::core::{MorphTarget, Skin, SkinWeights, Vertex};
use oxygen::glam::{Mat4, Quat, Vec4};
use oxygen::prelude::*;
use support::deform::{assert_same, render, with_sun};
use support::golden::{Tolerance, assert_golden, compare};

fn material(scene: &mut Scene) -> MaterialHandle {
    scene.add_material(Material::opaque("teal", Vec4::new(0.1, 0.6, 0.6, 1.0)))
}

fn rigid(at: Vec3) -> Scene {
    let mut scene = Scene::new();
    let m = material(&mut scene);
    let geometry = scene.add_geometry(Geometry::cube(1.0));
    let node = scene.add_node("rigid", Transform::from_translation(at));
    scene.set_renderable(node, Renderable { geometry, materials: vec![m] }).unwrap();
    with_sun(&mut scene);
    scene
}

/// A unit cube at the origin whose targets move every vertex by each of
/// `displacements`, posed with `weights`.
fn morphed(displacements: &[Vec3], weights: Vec<f32>) -> (Scene, NodeKey) {
    let mut scene = Scene::new();
    let m = material(&mut scene);
    let cube = Geometry::cube(1.0);
    let n = cube.vertices().len();
    let targets = displacements.iter().map(|d| MorphTarget { positions: vec![*d; n], normals: None }).collect();
    let geometry = scene.add_geometry(cube.with_morph_targets(targets).unwrap());
    let node = scene.add_node("morphed", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry, materials: vec![m] }).unwrap();
    scene.set_morph_weights(node, weights).unwrap();
    with_sun(&mut scene);
    (scene, node)
}

#[test]
fn weighted_targets_move_the_mesh_where_the_weights_say() {
    let (scene, _) = morphed(&[Vec3::X, Vec3::Y], vec![0.8, 0.5]);
    let (expected, _) = render(&rigid(Vec3::new(0.8, 0.5, 0.0)), Vec3::ZERO);
    let (actual, _) = render(&scene, Vec3::ZERO);
    assert_same(&actual, &expected, "two targets");
    // Weights of zero: the base shape.
    let (scene, _) = morphed(&[Vec3::X, Vec3::Y], vec![0.0, 0.0]);
    let (expected, _) = render(&rigid(Vec3::ZERO), Vec3::ZERO);
    assert_same(&render(&scene, Vec3::ZERO).0, &expected, "zero weights");
}

#[test]
fn culling_follows_the_weights() {
    let far = Vec3::new(30.0, 0.0, 0.0);
    let (mut scene, node) = morphed(&[far], vec![1.0]);
    let (image, draws) = render(&scene, far);
    assert_eq!(draws, 1, "the morphed cube must not be culled by its base bound");
    assert_same(&image, &render(&rigid(far), far).0, "morphed far away");
    scene.set_morph_weights(node, vec![0.0]).unwrap();
    assert_eq!(render(&scene, far).1, 0, "back at the origin it is out of that view");
}

#[test]
fn morphing_comes_before_skinning() {
    let (mut scene, node) = morphed(&[Vec3::Y], vec![1.0]);
    // Replace the geometry by a skinned one with the same target.
    let cube = Geometry::cube(1.0);
    let n = cube.vertices().len();
    let geometry = cube
        .with_morph_targets(vec![MorphTarget { positions: vec![Vec3::Y; n], normals: None }])
        .unwrap()
        .with_skin_weights(vec![SkinWeights::new([0; 4], [1.0, 0.0, 0.0, 0.0]); n])
        .unwrap();
    let geometry = scene.add_geometry(geometry);
    let materials = scene.node(node).unwrap().renderable.clone().unwrap().materials;
    scene.set_renderable(node, Renderable { geometry, materials }).unwrap();
    // The joint turns the morphed cube a quarter turn about Z: +Y becomes -X.
    let joint =
        scene.add_node("joint", Transform::IDENTITY.with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)));
    scene.set_skin(node, Some(Skin { joints: vec![joint], inverse_bind_matrices: vec![Mat4::IDENTITY] })).unwrap();
    let expected = {
        let mut s = Scene::new();
        let m = material(&mut s);
        let g = s.add_geometry(Geometry::cube(1.0));
        let r = s.add_node(
            "rigid",
            Transform::from_translation(Vec3::new(-1.0, 0.0, 0.0))
                .with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
        );
        s.set_renderable(r, Renderable { geometry: g, materials: vec![m] }).unwrap();
        with_sun(&mut s);
        render(&s, Vec3::ZERO).0
    };
    assert_same(&render(&scene, Vec3::ZERO).0, &expected, "morph then skin");
}

#[test]
fn golden_simple_morph_at_two_times() {
    let mut scene = Scene::new();
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/SimpleMorph/SimpleMorph.gltf");
    let import = import_gltf(&mut scene, file, &SceneChoice::Default).unwrap();
    assert!(!import.warnings.iter().any(|w| w.contains("morph")), "{:?}", import.warnings);
    with_sun(&mut scene);
    let animation = &import.animations[0];
    let resolver = support::model_camera(Vec3::new(0.5, 0.6, 3.2), Vec3::new(0.5, 0.5, 0.0), UVec2::new(160, 120));
    let images: Vec<_> = [0.5f32, 1.5]
        .iter()
        .map(|t| {
            animation.apply(&mut scene, *t).unwrap();
            render_with(&scene, resolver)
        })
        .collect();
    let c = compare(&images[0], &images[1], 10);
    assert!(c.differing > c.total / 100, "the weights must change the shape: {} of {} differ", c.differing, c.total);
    assert_golden("simple_morph_t50", &images[0], Tolerance::default());
    assert_golden("simple_morph_t150", &images[1], Tolerance::default());
}

fn render_with(scene: &Scene, resolver: LookAtResolver) -> image::RgbaImage {
    let mut renderer = support::gpu_renderer();
    let view = renderer.register_view(resolver, standard_render_graph).unwrap();
    renderer.render_frame(scene).unwrap();
    support::read_lit_color(&renderer, view)
}

/// Tangents follow the morph: the renderer derives each pixel's tangent
/// frame from the surface's positions and UVs (it reads no vertex tangents,
/// so there are no tangent displacements to apply), so a morph that turns a
/// normal-mapped quad a quarter turn in its plane shades it exactly as the
/// quad turned rigidly by its node: the map's lean turns with it. Lit from
/// the side the turned lean faces, the picture also differs from the
/// unmorphed quad's.
#[test]
fn a_normal_mapped_surface_s_tangents_follow_its_morph() {
    let enc = |v: f32| ((v * 0.5 + 0.5) * 255.0).round() as u8;
    // Tangent-space (0.6, 0, 0.8): leaning towards +u.
    let texel = [enc(0.6), enc(0.0), enc(0.8), 255];
    let quarter = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let scene = |weight: Option<f32>| {
        let mut scene = Scene::new();
        let map = scene.add_texture(
            oxygen::core::TextureImage::new("lean", 4, 4, oxygen::core::ColorSpace::Linear, texel.repeat(16)).unwrap(),
        );
        let material =
            scene.add_material(Material { normal_texture: Some(map), ..Material::opaque("grey", Vec4::splat(0.7)) });
        let quad = Geometry::quad(2.0);
        let (geometry, rotation) = match weight {
            Some(_) => {
                let turn: Vec<Vec3> =
                    quad.vertices().iter().map(|v| quarter * Vec3::from(v.position) - Vec3::from(v.position)).collect();
                let target = MorphTarget { positions: turn, normals: None };
                (scene.add_geometry(quad.with_morph_targets(vec![target]).unwrap()), Quat::IDENTITY)
            }
            None => (scene.add_geometry(quad), quarter),
        };
        let node = scene.add_node("quad", Transform::IDENTITY.with_rotation(rotation));
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
        if let Some(w) = weight {
            scene.set_morph_weights(node, vec![w]).unwrap();
        }
        // Light from +y (where the turned lean points) and the front.
        let sun = scene.add_node(
            "sun",
            Transform::IDENTITY
                .with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -Vec3::new(0.0, 1.0, 0.5).normalize())),
        );
        scene.set_light(sun, Some(Light::directional(2.0))).unwrap();
        render(&scene, Vec3::ZERO).0
    };
    let morphed = scene(Some(1.0));
    let turned = scene(None);
    let unmorphed = scene(Some(0.0));
    assert_same(&morphed, &turned, "the morph's quarter turn against the node's");
    let c = compare(&morphed, &unmorphed, 8);
    assert!(
        c.differing > c.total / 20,
        "the turned lean must shade differently: {} of {} differ",
        c.differing,
        c.total
    );
}

/// Normal displacements: a target that leaves the positions where they are
/// and leans every normal towards +Y shades the quad at full weight as a
/// quad whose own normals lean so (the vertex shader adds the weighted
/// displacement and normalises), and differently from the unmorphed quad.
#[test]
fn normal_displacements_shade_the_morphed_surface() {
    let lean = Vec3::new(0.0, 0.6, 0.8);
    let scene = |geometry: Geometry, weight: Option<f32>| {
        let mut scene = Scene::new();
        let m = material(&mut scene);
        let geometry = scene.add_geometry(geometry);
        let node = scene.add_node("quad", Transform::IDENTITY);
        scene.set_renderable(node, Renderable { geometry, materials: vec![m] }).unwrap();
        if let Some(w) = weight {
            scene.set_morph_weights(node, vec![w]).unwrap();
        }
        with_sun(&mut scene);
        render(&scene, Vec3::ZERO).0
    };
    let quad = Geometry::quad(2.0);
    let n = quad.vertices().len();
    let target = MorphTarget { positions: vec![Vec3::ZERO; n], normals: Some(vec![lean - Vec3::Z; n]) };
    let morphable = || quad.clone().with_morph_targets(vec![target.clone()]).unwrap();
    let leaning: Vec<Vertex> = quad.vertices().iter().map(|v| Vertex { normal: lean.to_array(), ..*v }).collect();
    let leaning = Geometry::new("leaning", leaning, quad.indices().to_vec(), quad.submeshes().to_vec()).unwrap();
    let morphed = scene(morphable(), Some(1.0));
    assert_same(&morphed, &scene(leaning, None), "normals morphed against normals leaning");
    let c = compare(&morphed, &scene(morphable(), Some(0.0)), 8);
    assert!(
        c.differing > c.total / 20,
        "the leaning normals must shade differently: {} of {} differ",
        c.differing,
        c.total
    );
}
