//! Procedural scenes shared by Oxygen's examples, tests and benchmarks, so
//! that each of them builds "the multi-view scene" in one line and they all
//! agree on it. A development crate (`publish = false`), not part of the
//! library's public surface.

#![warn(missing_docs)]

pub mod record;
pub mod span_times;

use glam::{DVec3, Quat, UVec2, Vec3, Vec4};

use oxygen_core::{
    AlphaMode, Camera, DAabb, DLookAtResolver, Geometry, Light, LookAtResolver, Material, NodeKey, Renderable, Scene,
    Transform,
};

/// The scene of the `multi_view` example and the walking-skeleton tests.
pub struct DemoScene {
    /// The scene.
    pub scene: Scene,
    /// The ground plane (20 × 20, at y = 0).
    pub ground: NodeKey,
    /// The 3 × 3 grid of unit cubes, row-major from (−3, −3) to (3, 3) in XZ.
    pub cubes: Vec<NodeKey>,
    /// The masked, double-sided quad standing at z = 4.5.
    pub masked_quad: NodeKey,
    /// The directional light.
    pub sun: NodeKey,
}

/// Direction the demo sun shines along (towards −Y, from +X +Z).
pub const SUN_DIRECTION: Vec3 = Vec3::new(-0.4, -0.8, -0.45);

/// A ground plane, a 3 × 3 grid of coloured cubes, one masked double-sided
/// quad, and one directional light.
pub fn multi_view_scene() -> DemoScene {
    let mut scene = Scene::new();
    let plane = scene.add_geometry(Geometry::plane(20.0));
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let quad = scene.add_geometry(Geometry::quad(2.0));

    let ground_material = scene.add_material(Material::opaque("ground", Vec4::new(0.45, 0.45, 0.42, 1.0)));
    let cube_colors = [Vec4::new(0.8, 0.1, 0.1, 1.0), Vec4::new(0.1, 0.7, 0.15, 1.0), Vec4::new(0.1, 0.2, 0.85, 1.0)];
    let cube_materials: Vec<_> = cube_colors
        .iter()
        .enumerate()
        .map(|(i, c)| scene.add_material(Material::opaque(format!("cube{i}"), *c)))
        .collect();
    let quad_material = scene.add_material(Material {
        roughness: 0.5,
        alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
        double_sided: true,
        ..Material::opaque("masked quad", Vec4::new(0.95, 0.8, 0.1, 1.0))
    });

    // Construction cannot fail: every handle was just created above.
    let attach = |scene: &mut Scene, node, geometry, material| {
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).expect("demo handles are valid")
    };
    let ground = scene.add_node("ground", Transform::IDENTITY);
    attach(&mut scene, ground, plane, ground_material);
    let mut cubes = Vec::new();
    for row in 0..3 {
        for col in 0..3 {
            let position = Vec3::new((col as f32 - 1.0) * 3.0, 0.5, (row as f32 - 1.0) * 3.0);
            let node = scene.add_node(format!("cube {row},{col}"), Transform::from_translation(position));
            attach(&mut scene, node, cube, cube_materials[(row + col) % 3]);
            cubes.push(node);
        }
    }
    let masked_quad = scene.add_node("masked quad", Transform::from_translation(Vec3::new(0.0, 1.0, 4.5)));
    attach(&mut scene, masked_quad, quad, quad_material);

    let sun_rotation = Quat::from_rotation_arc(Vec3::NEG_Z, SUN_DIRECTION.normalize());
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(sun_rotation));
    scene.set_light(sun, Some(Light::directional(3.0))).expect("the sun node was just created");
    DemoScene { scene, ground, cubes, masked_quad, sun }
}

/// The demo's main camera: high, in front, looking at the grid.
pub fn main_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver {
        camera: Camera::perspective(50f32.to_radians(), 0.1, None),
        eye: Vec3::new(6.0, 7.0, 12.0),
        target: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Y,
        viewport,
    }
}

/// The demo's second camera: a low close-up from the left with a narrow
/// field of view and a finite far plane, so it culls part of the grid.
pub fn side_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver {
        camera: Camera::perspective(40f32.to_radians(), 0.05, Some(60.0)),
        eye: Vec3::new(-7.0, 2.0, 6.0),
        target: Vec3::new(-2.0, 0.5, 0.0),
        up: Vec3::Y,
        viewport,
    }
}

/// A square field of `count` boxes of varied heights (0.8 × 0.8, 2 apart,
/// starting at the origin along +X and +Z) on a ground plane, cycling
/// through `box_colors`, under a sun: the scene of the shadow and
/// recording benchmarks. Returns the scene and the field's side length.
pub fn field_of_boxes(count: usize, box_colors: &[Vec4]) -> (Scene, f32) {
    let mut scene = Scene::new();
    let side = (count as f32).sqrt().ceil() as usize;
    let ground_material = scene.add_material(Material::opaque("ground", Vec4::splat(0.6)));
    let ground_mesh = scene.add_geometry(Geometry::plane(side as f32 * 2.0 + 10.0));
    let ground = scene.add_node("ground", Transform::from_translation(Vec3::new(side as f32, 0.0, side as f32)));
    scene
        .set_renderable(ground, Renderable { geometry: ground_mesh, materials: vec![ground_material] })
        .expect("the ground's handles were just created");
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let materials: Vec<_> = box_colors.iter().map(|c| scene.add_material(Material::opaque("box", *c))).collect();
    for i in 0..count {
        let (x, z) = ((i % side) as f32 * 2.0, (i / side) as f32 * 2.0);
        let height = 0.5 + ((i * 7919) % 13) as f32 * 0.25;
        let transform =
            Transform::from_translation(Vec3::new(x, height * 0.5, z)).with_scale(Vec3::new(0.8, height, 0.8));
        let node = scene.add_node("box", transform);
        let material = materials[i % materials.len().max(1)];
        scene
            .set_renderable(node, Renderable { geometry: cube, materials: vec![material] })
            .expect("the box's handles were just created");
    }
    let sun_rotation = Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(0.6, -0.5, 0.4).normalize());
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(sun_rotation));
    scene.set_light(sun, Some(Light::directional(3.0))).expect("the sun node was just created");
    (scene, side as f32 * 2.0)
}

/// A 40 × 40 grey floor (`roughness`) with a unit box on it at
/// (1.5, 0.5, −1), lit by a low sun: the scene of the HDR-format bench and
/// the frame-economy tests.
pub fn floor_with_box(roughness: f32) -> Scene {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material { roughness, ..Material::opaque("grey", Vec4::new(0.7, 0.7, 0.7, 1.0)) });
    let floor = scene.add_geometry(Geometry::plane(40.0));
    let node = scene.add_node("floor", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: floor, materials: vec![grey] }).expect("valid handles");
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let node = scene.add_node("box", Transform::from_translation(Vec3::new(1.5, 0.5, -1.0)));
    scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).expect("valid handles");
    let sun_rotation = Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::new(1.0, -0.2, -0.3).normalize());
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(sun_rotation));
    scene.set_light(sun, Some(Light::directional(0.6))).expect("a node");
    scene
}

/// The benches' camera of [`floor_with_box`]: 3 m up, 5 m back, looking
/// down past the box at 60° vertical field of view; refuses a viewport
/// the camera cannot use (an empty one).
pub fn floor_with_box_camera(viewport: UVec2) -> Result<LookAtResolver, oxygen_core::CameraError> {
    LookAtResolver::new(
        Camera::perspective(60f32.to_radians(), 0.1, None),
        Vec3::new(0.0, 3.0, 5.0),
        Vec3::new(0.0, 0.0, -1.0),
        viewport,
    )
}

/// A grey box of `size` standing on the origin of a 16 m grey floor, no
/// light: the pole of the shadow scenes below.
fn grey_pole_on_floor(size: Vec3) -> Scene {
    let mut scene = Scene::new();
    let grey = scene.add_material(Material::opaque("grey", Vec4::new(0.7, 0.7, 0.7, 1.0)));
    let floor = scene.add_geometry(Geometry::plane(16.0));
    let node = scene.add_node("floor", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: floor, materials: vec![grey] }).expect("valid handles");
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let pole = Transform::from_translation(Vec3::new(0.0, size.y * 0.5, 0.0)).with_scale(size);
    let node = scene.add_node("pole", pole);
    scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).expect("valid handles");
    scene
}

/// A pole 3 m tall and 0.5 m wide on a 16 m grey floor under a sun of
/// angular radius `sun_degrees` (`Light::source_radius`), low enough that
/// the pole's shadow runs several metres: a contact edge at its foot and a
/// penumbra widening towards its tip. The scene of soft shadows' test and
/// accuracy stage, seen by [`pole_camera`].
pub fn pole_under_sun(sun_degrees: f32) -> Scene {
    let mut scene = grey_pole_on_floor(Vec3::new(0.5, 3.0, 0.5));
    let travel = Vec3::new(0.9, -0.7, 0.25).normalize();
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travel)));
    let light = Light { source_radius: sun_degrees.to_radians(), ..Light::directional(3.0) };
    scene.set_light(sun, Some(light)).expect("a node");
    scene
}

/// Radiance above this is clamped before [`radiance_rmse`]: the sun's
/// highlight on a near-mirror reaches tens of thousands in one pixel, and
/// one such pixel would outweigh every other difference in the image.
pub const RADIANCE_RMSE_CLAMP: f64 = 4.0;

/// RMSE of two images' linear radiance (RGB of each pixel, each channel
/// clamped to [`RADIANCE_RMSE_CLAMP`]): how the accuracy atlas and the
/// tests against the path-traced reference measure a picture's error.
pub fn radiance_rmse(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let clamp = |x: f32| f64::from(x).clamp(0.0, RADIANCE_RMSE_CLAMP);
    let sum: f64 = a.iter().zip(b).map(|(p, q)| (0..3).map(|c| (clamp(p[c]) - clamp(q[c])).powi(2)).sum::<f64>()).sum();
    (sum / (a.len().max(1) * 3) as f64).sqrt()
}

/// A pole on a floor under a spot light of `radius` metres
/// (`Light::source_radius`): the pole 0.3 m across and 2 m tall, the spot
/// 5 m up and 3 m aside pointing at the pole's foot, no other light. Soft
/// spot shadows' scene, seen by [`pole_spot_camera`].
pub fn pole_under_spot(radius: f32) -> Scene {
    let mut scene = grey_pole_on_floor(Vec3::new(0.3, 2.0, 0.3));
    let at = Vec3::new(-3.0, 5.0, -1.0);
    let axis = (Vec3::new(0.5, 0.0, 0.2) - at).normalize();
    let spot = scene
        .add_node("spot", Transform::from_translation(at).with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, axis)));
    let light = Light { source_radius: radius, ..Light::spot(60.0, None, 0.5, 0.7) };
    scene.set_light(spot, Some(light)).expect("a node");
    scene
}

/// The camera of [`pole_under_spot`]: above the floor beyond the pole,
/// looking at its shadow.
pub fn pole_spot_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(0.9, 0.1, None),
        Vec3::new(3.5, 5.0, 3.0),
        Vec3::new(1.5, 0.0, 0.5),
        viewport,
    )
    .expect("a valid camera")
}

/// The camera of [`pole_under_sun`]: above and beside the pole, looking at
/// its shadow.
pub fn pole_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(0.9, 0.1, None),
        Vec3::new(1.5, 7.0, 5.5),
        Vec3::new(2.2, 0.0, 0.6),
        viewport,
    )
    .expect("a valid camera")
}

/// A thin pole on the ground under a sun: a pole 4 cm across and 1.5 m
/// tall on a grey floor, a sun 40° above the horizon and no disc. Its
/// shadow is about a texel of a coarse shadow map wide, which the map's
/// filter and biases wash out near the pole's foot: contact shadows'
/// test and accuracy stage, seen by [`thin_pole_camera`].
pub fn thin_pole_under_sun() -> Scene {
    let mut scene = grey_pole_on_floor(Vec3::new(0.04, 1.5, 0.04));
    let elevation = 40f32.to_radians();
    let travel = Vec3::new(0.9 * elevation.cos(), -elevation.sin(), 0.44 * elevation.cos()).normalize();
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, travel)));
    scene.set_light(sun, Some(Light::directional(3.0))).expect("a node");
    scene
}

/// The camera of [`thin_pole_under_sun`]: close to the pole's foot, looking
/// along its shadow.
pub fn thin_pole_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(0.8, 0.05, None),
        Vec3::new(-0.4, 1.3, 2.0),
        Vec3::new(0.7, 0.1, 0.3),
        viewport,
    )
    .expect("a valid camera")
}

/// A corner and a crevice under nothing but the ambient light: a floor
/// and two walls meeting at a right angle (4 m each way), a box leaning
/// into the corner and a second box on the floor with a 5 cm gap beside a
/// third; no lights. The scene of ambient occlusion's test and accuracy
/// stage, seen by [`corner_camera`]: every pixel shows a surface, so the
/// background of a raster view and its reference never differ.
pub fn corner_and_crevice() -> Scene {
    let mut scene = Scene::new();
    let grey =
        scene.add_material(Material { roughness: 0.8, ..Material::opaque("grey", Vec4::new(0.8, 0.8, 0.8, 1.0)) });
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let mut block = |name: &str, at: Vec3, size: Vec3| {
        let node = scene.add_node(name, Transform::from_translation(at).with_scale(size));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![grey] }).expect("valid handles");
    };
    // Floor, back wall (−Z) and left wall (−X), thick enough to be solid.
    block("floor", Vec3::new(0.0, -0.1, 0.0), Vec3::new(8.0, 0.2, 8.0));
    block("back wall", Vec3::new(0.0, 2.0, -2.1), Vec3::new(8.0, 4.0, 0.2));
    block("left wall", Vec3::new(-2.1, 2.0, 0.0), Vec3::new(0.2, 4.0, 8.0));
    block("corner box", Vec3::new(-1.5, 0.5, -1.5), Vec3::new(1.0, 1.0, 1.0));
    block("crevice left", Vec3::new(0.2, 0.4, 0.2), Vec3::new(0.8, 0.8, 0.8));
    block("crevice right", Vec3::new(1.05, 0.4, 0.2), Vec3::new(0.8, 0.8, 0.8));
    scene
}

/// The camera of [`corner_and_crevice`]: in front of the corner, looking
/// into it from above.
pub fn corner_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(1.0, 0.1, None),
        Vec3::new(1.6, 2.4, 2.6),
        Vec3::new(-0.4, 0.6, -0.6),
        viewport,
    )
    .expect("a valid camera")
}

/// Where the sunlight of [`glossy_floor_with_objects`] travels: from above
/// and behind its camera, so the sun's own highlight on the floor lies out
/// of the picture and its reflections show the lit faces.
pub const GLOSSY_FLOOR_SUN: Vec3 = Vec3::new(0.35, -0.75, -0.55);

/// A polished metal floor (`roughness`; 30 m across) with objects standing
/// on it: a red box, a tall green box and a wide blue slab, under a sun
/// ([`GLOSSY_FLOOR_SUN`]). Light it with the sky matched to that sun
/// (`Environment::sky_for_sun(GLOSSY_FLOOR_SUN)`): the floor then reflects
/// the objects where a probe or the environment would show the sky. The
/// scene of screen-space reflections' test and accuracy stage, seen by
/// [`glossy_floor_camera`].
pub fn glossy_floor_with_objects(roughness: f32) -> Scene {
    let mut scene = Scene::new();
    let metal = scene.add_material(Material {
        metallic: 1.0,
        roughness,
        ..Material::opaque("polished floor", Vec4::new(0.9, 0.9, 0.9, 1.0))
    });
    let floor = scene.add_geometry(Geometry::plane(30.0));
    let node = scene.add_node("floor", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: floor, materials: vec![metal] }).expect("valid handles");
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let mut block = |name: &str, color: Vec4, at: Vec3, size: Vec3| {
        let material = scene.add_material(Material { roughness: 0.6, ..Material::opaque(name, color) });
        let transform = Transform::from_translation(at + Vec3::Y * size.y * 0.5).with_scale(size);
        let node = scene.add_node(name, transform);
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).expect("valid handles");
    };
    block("red box", Vec4::new(0.8, 0.15, 0.1, 1.0), Vec3::new(-1.3, 0.0, -1.5), Vec3::splat(1.0));
    block("green tower", Vec4::new(0.15, 0.7, 0.2, 1.0), Vec3::new(0.6, 0.0, -3.0), Vec3::new(0.8, 2.4, 0.8));
    block("blue slab", Vec4::new(0.15, 0.3, 0.8, 1.0), Vec3::new(2.2, 0.0, -1.0), Vec3::new(1.6, 0.5, 1.0));
    let rotation = Quat::from_rotation_arc(Vec3::NEG_Z, GLOSSY_FLOOR_SUN.normalize());
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(rotation));
    scene.set_light(sun, Some(Light::directional(3.0))).expect("a node");
    scene
}

/// The camera of [`glossy_floor_with_objects`]: low in front of the
/// objects, looking across the floor at them and their reflections.
pub fn glossy_floor_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(1.0, 0.1, None),
        Vec3::new(0.3, 1.3, 3.5),
        Vec3::new(0.4, 0.3, -1.8),
        viewport,
    )
    .expect("a valid camera")
}

/// A street of `lamps` lights: a 200 m road along −Z (12 m wide) between
/// two rows of buildings (boxes of varied heights every 8 m), its lamps in
/// two rows 4.5 m up, alternating point lights and downward spots, each of
/// a warm or cool white and a range of 7 m, and one unbounded point light
/// high above the far end; no sun. The scene of clustered light culling's
/// test, benchmark and accuracy stage (a street with 1 000 lamps), seen by
/// [`lamp_street_camera`].
pub fn lamp_street(lamps: usize) -> Scene {
    let mut scene = Scene::new();
    let ground_material =
        scene.add_material(Material { roughness: 0.7, ..Material::opaque("road", Vec4::new(0.5, 0.5, 0.52, 1.0)) });
    let ground = scene.add_geometry(Geometry::plane(240.0));
    let node = scene.add_node("road", Transform::from_translation(Vec3::new(0.0, 0.0, -100.0)));
    scene
        .set_renderable(node, Renderable { geometry: ground, materials: vec![ground_material] })
        .expect("valid handles");
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let walls = [Vec4::new(0.75, 0.6, 0.5, 1.0), Vec4::new(0.55, 0.6, 0.7, 1.0), Vec4::new(0.7, 0.7, 0.65, 1.0)];
    let walls: Vec<_> =
        walls.iter().map(|c| scene.add_material(Material { roughness: 0.6, ..Material::opaque("wall", *c) })).collect();
    for i in 0..25 {
        for side in [-1.0f32, 1.0] {
            let height = 6.0 + ((i * 7 + usize::from(side > 0.0) * 3) % 5) as f32 * 3.0;
            let at = Vec3::new(side * 11.0, height * 0.5, -4.0 - i as f32 * 8.0);
            let node =
                scene.add_node("building", Transform::from_translation(at).with_scale(Vec3::new(8.0, height, 6.5)));
            let material = walls[(i + usize::from(side > 0.0)) % walls.len()];
            scene
                .set_renderable(node, Renderable { geometry: cube, materials: vec![material] })
                .expect("valid handles");
        }
    }
    let down = Quat::from_rotation_arc(Vec3::NEG_Z, Vec3::NEG_Y);
    let spacing = 200.0 / (lamps.div_ceil(2).max(1)) as f32;
    for i in 0..lamps {
        let side = if i % 2 == 0 { -1.0 } else { 1.0 };
        let at = Vec3::new(side * 5.0, 4.5, -1.0 - (i / 2) as f32 * spacing);
        let warm = (i / 2) % 3 != 0;
        let color = if warm { Vec3::new(1.0, 0.8, 0.55) } else { Vec3::new(0.7, 0.85, 1.0) };
        let light = if (i / 2) % 2 == 0 {
            Light { color, casts_shadows: false, ..Light::point(30.0, Some(7.0)) }
        } else {
            Light { color, casts_shadows: false, ..Light::spot(60.0, Some(7.0), 0.5, 0.9) }
        };
        let node = scene.add_node("lamp", Transform::from_translation(at).with_rotation(down));
        scene.set_light(node, Some(light)).expect("a node");
    }
    let moon = scene.add_node("moon", Transform::from_translation(Vec3::new(0.0, 60.0, -220.0)));
    scene
        .set_light(
            moon,
            Some(Light { color: Vec3::new(0.6, 0.7, 1.0), casts_shadows: false, ..Light::point(800.0, None) }),
        )
        .expect("a node");
    scene
}

/// The camera of [`lamp_street`]: at the near end of the road, 1.7 m up,
/// looking down the street (perspective, 60°, near plane 0.1).
pub fn lamp_street_camera(viewport: UVec2) -> LookAtResolver {
    LookAtResolver::new(
        Camera::perspective(60f32.to_radians(), 0.1, None),
        Vec3::new(0.0, 1.7, 4.0),
        Vec3::new(0.0, 2.5, -60.0),
        viewport,
    )
    .expect("a valid camera")
}

/// Six inward-facing unlit walls, each its own colour, closing the cube
/// of half-size `half_size` around the origin: surroundings that lie
/// exactly on a box (the reflection probes' parallax box is measured on
/// them, `tests/probes.rs` and the accuracy atlas).
pub fn add_room_walls(scene: &mut Scene, half_size: f32) {
    let wall = scene.add_geometry(Geometry::quad(2.0 * half_size));
    let h = half_size;
    let quarter = std::f32::consts::FRAC_PI_2;
    for (name, at, rotation, color) in [
        ("back", Vec3::new(0.0, 0.0, -h), Quat::IDENTITY, Vec4::new(0.8, 0.1, 0.1, 1.0)),
        ("front", Vec3::new(0.0, 0.0, h), Quat::from_rotation_y(2.0 * quarter), Vec4::new(0.1, 0.8, 0.1, 1.0)),
        ("left", Vec3::new(-h, 0.0, 0.0), Quat::from_rotation_y(quarter), Vec4::new(0.1, 0.1, 0.8, 1.0)),
        ("right", Vec3::new(h, 0.0, 0.0), Quat::from_rotation_y(-quarter), Vec4::new(0.8, 0.8, 0.1, 1.0)),
        ("floor", Vec3::new(0.0, -h, 0.0), Quat::from_rotation_x(-quarter), Vec4::new(0.5, 0.5, 0.5, 1.0)),
        ("ceiling", Vec3::new(0.0, h, 0.0), Quat::from_rotation_x(quarter), Vec4::new(0.8, 0.3, 0.8, 1.0)),
    ] {
        let material =
            scene.add_material(Material { unlit: true, double_sided: true, ..Material::opaque(name, color) });
        let node = scene.add_node(name, Transform::from_translation(at).with_rotation(rotation));
        scene.set_renderable(node, Renderable { geometry: wall, materials: vec![material] }).expect("valid handles");
    }
}

/// The interactive viewer's orbit camera (`examples/viewer.rs`), here so
/// that a test renders headlessly exactly the view the viewer presents.
/// The target is an f64 world position, so that the framing does not
/// depend on where the scene sits (thirty million units out an f32 target
/// is two units off).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point orbited.
    pub target: DVec3,
    /// Angle around +Y, radians.
    pub yaw: f32,
    /// Angle above the horizon, radians.
    pub pitch: f32,
    /// Distance from the target.
    pub distance: f32,
    /// Near plane.
    pub near: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl OrbitCamera {
    /// A camera framing `bounds` from above and to the side.
    pub fn framing(bounds: &DAabb) -> Self {
        let radius = (bounds.half_extents().length() as f32).max(1e-3);
        OrbitCamera {
            target: bounds.center(),
            yaw: -1.2,
            pitch: 0.35,
            distance: radius * 2.5,
            near: radius * 0.01,
            fov_y: 0.87,
        }
    }

    /// The unit direction the camera looks along.
    pub fn forward(&self) -> Vec3 {
        Vec3::new(self.yaw.cos() * self.pitch.cos(), self.pitch.sin(), self.yaw.sin() * self.pitch.cos())
    }

    /// Where the eye is.
    pub fn eye(&self) -> DVec3 {
        self.target - (self.forward() * self.distance).as_dvec3()
    }

    /// A look-at resolver of `viewport` for this camera.
    pub fn resolver(&self, viewport: UVec2) -> DLookAtResolver {
        DLookAtResolver {
            camera: Camera::perspective(self.fov_y, self.near, None),
            eye: self.eye(),
            target: self.target,
            up: Vec3::Y,
            viewport,
        }
    }
}

/// The axes of an editor's orthographic views, as (looking from, up):
/// front (+Z), side (+X) and top (+Y).
pub const EDITOR_AXES: [(Vec3, Vec3); 3] = [(Vec3::Z, Vec3::Y), (Vec3::X, Vec3::Y), (Vec3::Y, Vec3::NEG_Z)];

/// An orthographic view of `bounds` from `from` (a direction, the side the
/// eye is on), as a modelling tool's front, side and top views: the
/// bounding sphere fills the view's height and lies between its near and
/// far planes. The viewport is a placeholder; a view shown in a window
/// takes its rectangle's size.
pub fn editor_axis_view(bounds: &DAabb, from: Vec3, up: Vec3) -> DLookAtResolver {
    let radius = (bounds.half_extents().length() as f32).max(1e-3);
    let center = bounds.center();
    DLookAtResolver {
        camera: Camera::orthographic(radius * 1.05, radius * 0.01, radius * 4.5),
        eye: center + (from.normalize_or(Vec3::Z) * radius * 2.2).as_dvec3(),
        target: center,
        up,
        viewport: UVec2::new(16, 9),
    }
}

/// Adds the viewers' default sun to a scene that has no light.
pub fn add_default_sun(scene: &mut Scene) {
    let direction = Vec3::new(-0.3, -0.8, -0.5).normalize();
    let sun = scene
        .add_node("default sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, direction)));
    scene.set_light(sun, Some(Light::directional(2.5))).expect("the sun node was just created");
}

/// A `width` × `height` panorama with structure at every scale: a sky
/// gradient from blue above to a dark ground, faint stripes in longitude,
/// a bright warm blob up and towards +X. Smooth enough that the CPU
/// prefilter (which point-samples the image) converges on it: the
/// environment the GPU prefilter is tested and measured against.
pub fn structured_panorama(width: u32, height: u32) -> oxygen_core::Environment {
    let (width, height) = (width.max(1), height.max(1));
    let texels = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let u = (x as f32 + 0.5) / width as f32;
            let v = (y as f32 + 0.5) / height as f32;
            let sky = Vec3::new(0.2, 0.3, 0.6).lerp(Vec3::new(0.05, 0.04, 0.03), v);
            let stripe = if ((u * 16.0) as u32).is_multiple_of(2) { 0.05 } else { 0.0 };
            // The blob around longitude 90° (+X), latitude 45° up.
            let (du, dv) = (u - 0.75, v - 0.25);
            let blob = (-(du * du + dv * dv) / 0.004).exp() * 6.0;
            sky + Vec3::splat(stripe) + Vec3::new(1.0, 0.8, 0.5) * blob
        })
        .collect();
    let image = oxygen_core::EquirectImage::new(width, height, texels).expect("width × height texels");
    oxygen_core::Environment::Image(image)
}

/// The interactive viewer's default environment: the procedural sky matched
/// to the scene's first directional light (the default sun's direction when
/// it has none).
pub fn viewer_environment(scene: &Scene) -> oxygen_core::Environment {
    let sun = scene.nodes().find_map(|(key, node)| {
        let light = node.light.as_ref()?;
        matches!(light.kind, oxygen_core::LightKind::Directional).then_some(key)
    });
    let direction = sun
        .and_then(|key| scene.world_transform(key))
        .map(|world| world.as_mat4().transform_vector3(Vec3::NEG_Z))
        .and_then(|d| d.try_normalize())
        .unwrap_or(Vec3::new(-0.3, -0.8, -0.5).normalize());
    oxygen_core::Environment::sky_for_sun(direction)
}

/// The interactive viewer's default sun-shadow cascades for its main view.
pub fn viewer_cascades() -> oxygen_core::CascadeSettings {
    oxygen_core::CascadeSettings { count: 4, resolution: 1024, ..Default::default() }
}

/// The id the view registered `index`-th (from 0) gets from a fresh registry
/// (`view#{index}`), for tests and benchmarks that drive ScenePrep without
/// a renderer and name their views by position.
pub fn view_id(index: u32) -> oxygen_core::ViewId {
    let mut ids = oxygen_core::ViewIds::default();
    for _ in 0..index {
        ids.allocate();
    }
    ids.allocate()
}

/// The view benches' scene (`batch_bench`, `group_bench`, `node_bench`):
/// `count` unit boxes on a square grid of spacing 2 centred on the origin
/// (four colours in turn), one sun without shadows.
pub struct BoxGrid {
    /// The scene.
    pub scene: Scene,
    /// The grid's side length (rows × 2).
    pub side: f32,
    /// The first box (the one the benches move each frame), or the sun when
    /// `count` is 0.
    pub first_box: NodeKey,
}

/// The grid of `count` boxes ([`BoxGrid`]).
pub fn box_grid(count: usize) -> BoxGrid {
    let mut scene = Scene::new();
    let per_row = (count as f32).sqrt().ceil().max(1.0) as usize;
    let half = (per_row - 1) as f32;
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let colors = [[0.8, 0.2, 0.2], [0.2, 0.7, 0.3], [0.2, 0.3, 0.8], [0.8, 0.7, 0.2]];
    let materials: Vec<_> =
        colors.iter().map(|&[r, g, b]| scene.add_material(Material::opaque("box", Vec4::new(r, g, b, 1.0)))).collect();
    let mut first = None;
    for i in 0..count {
        let (x, z) = ((i % per_row) as f32 * 2.0 - half, (i / per_row) as f32 * 2.0 - half);
        let node = scene.add_node("box", Transform::from_translation(Vec3::new(x, 0.5, z)));
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![materials[i % 4]] }).ok();
        first.get_or_insert(node);
    }
    let sun_direction = Vec3::new(0.6, -0.5, 0.4).normalize();
    let sun =
        scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, sun_direction)));
    scene.set_light(sun, Some(Light { casts_shadows: false, ..Light::directional(3.0) })).ok();
    BoxGrid { scene, side: per_row as f32 * 2.0, first_box: first.unwrap_or(sun) }
}

/// Where camera `i` of `n` of the benches' ring sits around a [`BoxGrid`]
/// of side `side`: on a circle of radius 0.65 × side at height 0.35 ×
/// side, at angle i / n of a turn (they look at the origin, 60° vertical
/// field of view).
pub fn ring_eye(i: usize, n: usize, side: f32) -> Vec3 {
    let angle = i as f32 / n.max(1) as f32 * std::f32::consts::TAU;
    Vec3::new(angle.cos() * 0.65 * side, 0.35 * side, angle.sin() * 0.65 * side)
}

/// The probes' page size argument `WxH`: both positive, `W` a multiple of
/// 64 (a row of 4-byte texels is then whole 256-byte copy rows).
pub fn probe_page_size(arg: &str) -> Result<(u32, u32), String> {
    arg.split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|(w, h)| *w > 0 && *h > 0 && w % 64 == 0)
        .ok_or_else(|| format!("{arg}: the size is WxH, W a multiple of 64"))
}
