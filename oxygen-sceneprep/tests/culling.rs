//! Culling through the whole view phase: objects fully outside any one
//! frustum plane are dropped; objects straddling a plane are kept.

use glam::{UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::scene::node_index;
use oxygen_core::{
    Camera, Geometry, LookAtResolver, Material, Renderable, Scene, Transform, ViewContext, ViewIds, ViewResolver,
};
use oxygen_sceneprep::{CullBound, ScenePrep, ViewPrepOptions, ViewRequest};

/// A 90° camera at the origin looking down −Z with near 1 and far 50: at
/// depth d the side planes are at ±d.
fn camera() -> LookAtResolver {
    LookAtResolver {
        camera: Camera::perspective(90f32.to_radians(), 1.0, Some(50.0)),
        eye: Vec3::ZERO,
        target: Vec3::NEG_Z,
        up: Vec3::Y,
        viewport: UVec2::new(64, 64),
    }
}

/// Unit cubes at the given centres; returns the scene and the node ids.
fn cubes_at(centres: &[Vec3]) -> (Scene, Vec<u32>) {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let ids = centres
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let node = scene.add_node(format!("cube{i}"), Transform::from_translation(*c));
            scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
            node_index(node)
        })
        .collect();
    (scene, ids)
}

fn visible_nodes(scene: &Scene, cull: CullBound) -> Vec<u32> {
    let view = camera()
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, scene)
        .unwrap();
    let mut prep = ScenePrep::new();
    let frames = prep
        .prepare(
            scene,
            &[ViewRequest { view: &view, options: ViewPrepOptions { cull, ..Default::default() } }],
            &mut SlotAllocators::default(),
        )
        .unwrap();
    let mut ids: Vec<u32> = frames[0].draws().iter().map(|d| d.node_id).collect();
    ids.sort();
    ids
}

#[test]
fn culling_drops_objects_fully_outside_each_plane() {
    let outside = [
        Vec3::new(-12.0, 0.0, -10.0), // left
        Vec3::new(12.0, 0.0, -10.0),  // right
        Vec3::new(0.0, -12.0, -10.0), // bottom
        Vec3::new(0.0, 12.0, -10.0),  // top
        Vec3::new(0.0, 0.0, 0.0),     // between the eye and the near plane (z in -0.5..0.5)
        Vec3::new(0.0, 0.0, -52.0),   // beyond the far plane
    ];
    let (scene, _) = cubes_at(&outside);
    for cull in [CullBound::Aabb, CullBound::Sphere] {
        // The sphere is looser: it may keep a cube near a frustum corner, but
        // these are far enough outside for both.
        assert_eq!(visible_nodes(&scene, cull), Vec::<u32>::new(), "{cull:?}");
    }
}

#[test]
fn culling_keeps_objects_straddling_a_plane() {
    let straddling = [
        Vec3::new(-10.0, 0.0, -10.0), // centred on the left plane
        Vec3::new(10.0, 0.0, -10.0),
        Vec3::new(0.0, -10.0, -10.0),
        Vec3::new(0.0, 10.0, -10.0),
        Vec3::new(0.0, 0.0, -1.0),  // on the near plane
        Vec3::new(0.0, 0.0, -50.0), // on the far plane
        Vec3::new(0.0, 0.0, -20.0), // fully inside
    ];
    let (scene, ids) = cubes_at(&straddling);
    for cull in [CullBound::Aabb, CullBound::Sphere] {
        assert_eq!(visible_nodes(&scene, cull), ids, "{cull:?}");
    }
}

/// Property (seeded): ten million units out, where f32 steps by a whole
/// unit, a cube with any corner strictly inside the frustum (computed here
/// in f64 from the eye and the target, independently of ScenePrep) is never
/// culled: world bounds are composed in f64 and rounded outward.
#[test]
fn culling_never_drops_a_visible_cube_ten_million_units_out() {
    use glam::DVec3;
    use oxygen_core::DLookAtResolver;
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let origin = DVec3::new(1.0e7, -1.0e7, 1.0e7);
    let mut checked = 0;
    for _ in 0..12 {
        let mut scene = Scene::new();
        let root = scene.add_node("far", Transform::from_translation(origin.as_vec3()));
        let cube = scene.add_geometry(Geometry::cube(0.3));
        let material = scene.add_material(Material::opaque("m", Vec4::ONE));
        let mut centres = Vec::new();
        for i in 0..400 {
            let offset = Vec3::new(next() as f32 * 30.0, next() as f32 * 30.0, next() as f32 * 30.0);
            let node = scene.add_child(root, format!("c{i}"), Transform::from_translation(offset)).unwrap();
            scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
            centres.push((node_index(node), origin + offset.as_dvec3()));
        }
        let eye = origin + DVec3::new(next() * 5.0, next() * 5.0, next() * 5.0);
        let target = origin + DVec3::new(next() * 20.0, next() * 20.0, next() * 20.0);
        let resolver = DLookAtResolver {
            camera: Camera::perspective(90f32.to_radians(), 0.5, Some(80.0)),
            eye,
            target,
            up: Vec3::Y,
            viewport: UVec2::new(64, 64),
        };
        let view = resolver
            .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, &scene)
            .unwrap();
        let mut prep = ScenePrep::new();
        let frames = prep
            .prepare(
                &scene,
                &[ViewRequest { view: &view, options: ViewPrepOptions::default() }],
                &mut SlotAllocators::default(),
            )
            .unwrap();
        let kept: std::collections::HashSet<u32> = frames[0].draws().iter().map(|d| d.node_id).collect();
        // The frustum in f64: 90° both ways, near 0.5, far 80.
        let forward = (target - eye).normalize();
        let right = forward.cross(DVec3::Y).normalize();
        let up = right.cross(forward);
        let inside = |p: DVec3| {
            let d = p - eye;
            let (x, y, z) = (d.dot(right), d.dot(up), d.dot(forward));
            let margin = 1e-4;
            z > 0.5 + margin && z < 80.0 - margin && x.abs() < z - margin && y.abs() < z - margin
        };
        for (id, centre) in centres {
            let corners = (0..8).map(|k| {
                centre
                    + DVec3::new(
                        if k & 1 == 0 { -0.15 } else { 0.15 },
                        if k & 2 == 0 { -0.15 } else { 0.15 },
                        if k & 4 == 0 { -0.15 } else { 0.15 },
                    )
            });
            if corners.clone().any(inside) {
                checked += 1;
                assert!(kept.contains(&id), "cube {id} at {centre:?} is visible from {eye:?} but was culled");
            }
        }
    }
    assert!(checked > 200, "only {checked} visible cubes checked");
}
