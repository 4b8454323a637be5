//! The ray-tracing scene ([`RayScene`]) as the path-traced reference reads
//! it: the flattened two-level hierarchy walked on the CPU the way
//! `trace.wgsl` walks it finds what a brute-force test of every drawn
//! triangle finds; its layout, generation, skipped count and posed
//! (skinned, morphed) instances.

use glam::{Mat4, Quat, UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::{
    Camera, Geometry, LookAtResolver, Material, MorphTarget, NodeKey, Renderable, ResolvedView, Scene, Skin,
    SkinWeights, Submesh, Transform, ViewContext, ViewIds, ViewResolver,
};
use oxygen_sceneprep::ray::POSED;
use oxygen_sceneprep::testing::{Bvh, ray_triangle, triangle_boxes};
use oxygen_sceneprep::{RayInstance, RayScene, ScenePrep, ViewPrepOptions, ViewRequest};

fn view_of(scene: &Scene) -> ResolvedView {
    let camera = LookAtResolver {
        camera: Camera::perspective(60f32.to_radians(), 0.1, None),
        eye: Vec3::new(0.0, 0.0, 30.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        viewport: UVec2::new(64, 64),
    };
    camera
        .resolve(&ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 }, scene)
        .unwrap()
}

/// One drawn renderable as the frame collected it.
#[derive(Clone)]
struct Drawn {
    node: NodeKey,
    transform_index: u32,
    world: Mat4,
    mesh: std::sync::Arc<Geometry>,
    /// Per submesh of the mesh: its material id in the frame.
    materials: Vec<u32>,
}

/// A frame with a view that reads the ray scene; what the frame collected.
fn frame(prep: &mut ScenePrep, scene: &Scene, slots: &mut SlotAllocators) -> Vec<Drawn> {
    let collection = prep.begin_frame(scene, slots).unwrap();
    let drawn = collection
        .renderables
        .iter()
        .map(|entry| {
            let (start, count) = entry.submeshes;
            Drawn {
                node: entry.node,
                transform_index: entry.transform_index,
                world: collection.transforms.world[entry.transform_index as usize],
                mesh: scene.geometry(entry.geometry).unwrap().clone(),
                materials: collection.submeshes[start as usize..(start + count) as usize]
                    .iter()
                    .map(|s| s.material)
                    .collect(),
            }
        })
        .collect();
    let view = view_of(scene);
    let options = ViewPrepOptions { ray_scene: true, ..Default::default() };
    prep.prepare_views(scene, &[ViewRequest { view: &view, options }], slots).unwrap();
    drawn
}

/// A hit: the instance's transform index, the triangle, its material, t.
#[derive(Clone, Copy, Debug)]
struct Hit {
    transform_index: u32,
    triangle: u32,
    material: u32,
    t: f32,
}

/// Whether the ray enters the box before `t_max` (a plain slab test,
/// widened a little: the walk only needs to be conservative).
fn enters(min: [f32; 3], max: [f32; 3], origin: Vec3, dir: Vec3, t_max: f32) -> bool {
    let (mut enter, mut exit) = (0.0f32, t_max);
    for axis in 0..3 {
        let pad = 1e-4 * (1.0 + min[axis].abs().max(max[axis].abs()));
        let (lo, hi, o, d) = (min[axis] - pad, max[axis] + pad, origin[axis], dir[axis]);
        if d == 0.0 {
            if o < lo || o > hi {
                return false;
            }
            continue;
        }
        let (a, b) = ((lo - o) / d, (hi - o) / d);
        enter = enter.max(a.min(b));
        exit = exit.min(a.max(b));
    }
    enter <= exit
}

/// The closest hit, found by walking the ray scene's arrays as
/// `trace.wgsl` does: the top level from `tlas_root` over instances (its
/// leaves' words), each instance's tree from `blas_root` in its own space
/// (its leaves' words are triangles), a triangle counting only inside a
/// range of the instance's submesh table. Vertices are the mesh's own, or
/// for a [`POSED`] instance the posed ones from its `vertex_slot`.
fn walk(rs: &RayScene, drawn: &[Drawn], origin: Vec3, dir: Vec3) -> Option<Hit> {
    let root = rs.tlas_root()?;
    let (nodes, words) = (rs.nodes(), rs.words());
    let mut best: Option<Hit> = None;
    let mut stack = vec![root];
    let mut visits = 0;
    while let Some(n) = stack.pop() {
        visits += 1;
        assert!(visits < 100_000, "the top level loops");
        let node = nodes[n as usize];
        if !enters(node.min, node.max, origin, dir, f32::INFINITY) {
            continue;
        }
        if node.count == 0 {
            stack.extend([node.first, node.first + 1]);
            continue;
        }
        for &i in &words[node.first as usize..(node.first + node.count) as usize] {
            let instance: &RayInstance = &rs.instances()[i as usize];
            let r = instance.inverse_rows;
            let inverse = Mat4::from_cols_array_2d(&[r[0], r[1], r[2], [0.0, 0.0, 0.0, 1.0]]).transpose();
            let (o, d) = (inverse.transform_point3(origin), inverse.transform_vector3(dir));
            let mesh = &drawn.iter().find(|x| x.transform_index == instance.transform_index).unwrap().mesh;
            let position = |k: u32| -> Vec3 {
                if instance.flags & POSED != 0 {
                    Vec3::from(rs.posed_vertices()[(instance.vertex_slot + k) as usize].position)
                } else {
                    Vec3::from(mesh.vertices()[k as usize].position)
                }
            };
            let mut local = vec![instance.blas_root];
            while let Some(m) = local.pop() {
                visits += 1;
                assert!(visits < 100_000, "a bottom level loops");
                let node = nodes[m as usize];
                if !enters(node.min, node.max, o, d, f32::INFINITY) {
                    continue;
                }
                if node.count == 0 {
                    local.extend([node.first, node.first + 1]);
                    continue;
                }
                for &triangle in &words[node.first as usize..(node.first + node.count) as usize] {
                    let tri = &mesh.indices()[3 * triangle as usize..3 * triangle as usize + 3];
                    let Some((t, _, _)) =
                        ray_triangle(o, d, position(tri[0]), position(tri[1]), position(tri[2]), 0.0, f32::INFINITY)
                    else {
                        continue;
                    };
                    let table = instance.submesh_first as usize;
                    let entry = (0..instance.submesh_count as usize)
                        .map(|s| &words[table + 3 * s..table + 3 * s + 3])
                        .find(|e| triangle >= e[0] && triangle < e[1]);
                    if let Some(e) = entry
                        && best.is_none_or(|b| t < b.t)
                    {
                        best = Some(Hit { transform_index: instance.transform_index, triangle, material: e[2], t });
                    }
                }
            }
        }
    }
    best
}

/// The closest hit by testing every triangle a submesh draws, in world
/// space (`world_positions` gives a drawn renderable's vertices there).
fn brute(drawn: &[Drawn], world_positions: &dyn Fn(&Drawn) -> Vec<Vec3>, origin: Vec3, dir: Vec3) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for d in drawn {
        let p = world_positions(d);
        for (submesh, &material) in d.mesh.submeshes().iter().zip(&d.materials) {
            for triangle in submesh.first_index / 3..(submesh.first_index + submesh.index_count) / 3 {
                let tri = &d.mesh.indices()[3 * triangle as usize..3 * triangle as usize + 3];
                let hit = ray_triangle(
                    origin,
                    dir,
                    p[tri[0] as usize],
                    p[tri[1] as usize],
                    p[tri[2] as usize],
                    0.0,
                    f32::INFINITY,
                );
                if let Some((t, _, _)) = hit
                    && best.is_none_or(|b| t < b.t)
                {
                    best = Some(Hit { transform_index: d.transform_index, triangle, material, t });
                }
            }
        }
    }
    best
}

fn rigid(d: &Drawn) -> Vec<Vec3> {
    d.mesh.vertices().iter().map(|v| d.world.transform_point3(Vec3::from(v.position))).collect()
}

/// SplitMix64, for reproducible rays.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn in_box(&mut self, half: Vec3) -> Vec3 {
        Vec3::new(self.unit() * 2.0 - 1.0, self.unit() * 2.0 - 1.0, self.unit() * 2.0 - 1.0) * half
    }
}

/// Casts `rays` rays from a sphere of radius 40 at points inside `half`
/// (around the origin) or near the instances' origins and asserts the walk and the brute force agree on
/// every one: the same instance and material at the same distance (the
/// triangle too, unless two are hit at that distance, on a shared edge).
/// Returns the hits.
fn agree(
    rs: &RayScene,
    drawn: &[Drawn],
    world_positions: &dyn Fn(&Drawn) -> Vec<Vec3>,
    half: Vec3,
    rays: usize,
) -> Vec<Hit> {
    let mut rng = Rng(27);
    let mut hits = Vec::new();
    // Half the rays aimed near an instance, half anywhere in the box.
    let centres: Vec<Vec3> = drawn.iter().map(|d| d.world.w_axis.truncate()).collect();
    for i in 0..rays {
        let origin = rng.in_box(Vec3::ONE).normalize_or(Vec3::Z) * 40.0;
        let target = if i % 2 == 0 && !centres.is_empty() {
            centres[i / 2 % centres.len()] + rng.in_box(Vec3::splat(1.5))
        } else {
            rng.in_box(half)
        };
        let dir = (target - origin).normalize();
        let expected = brute(drawn, world_positions, origin, dir);
        let found = walk(rs, drawn, origin, dir);
        match (expected, found) {
            (None, None) => {}
            (Some(e), Some(f)) => {
                assert!(
                    e.transform_index == f.transform_index
                        && e.material == f.material
                        && (e.t - f.t).abs() <= 1e-4 * e.t
                        && (e.triangle == f.triangle || (e.t - f.t).abs() <= 1e-5 * e.t),
                    "ray {i} from {origin} along {dir}: expected {e:?}, walked to {f:?}"
                );
                hits.push(f);
            }
            (e, f) => panic!("ray {i} from {origin} along {dir}: expected {e:?}, walked to {f:?}"),
        }
    }
    hits
}

/// A cube whose submeshes cover part of its triangles, out of order:
/// triangles 6 to 9 (indices 18..30) first, then 0 to 4 (0..15); triangles
/// 5, 10 and 11 belong to no submesh and are never hit.
fn patchy_cube(size: f32) -> Geometry {
    let cube = Geometry::cube(size);
    Geometry::new(
        "patchy cube",
        cube.vertices().to_vec(),
        cube.indices().to_vec(),
        vec![Submesh { first_index: 18, index_count: 12 }, Submesh { first_index: 0, index_count: 15 }],
    )
    .unwrap()
}

/// Seven instances of two meshes (rotated, scaled unevenly, spread out).
fn scattered_scene() -> Scene {
    let mut scene = Scene::new();
    let patchy = scene.add_geometry(patchy_cube(2.0));
    let plain = scene.add_geometry(Geometry::cube(1.5));
    let red = scene.add_material(Material::opaque("red", Vec4::new(1.0, 0.0, 0.0, 1.0)));
    let green = scene.add_material(Material::opaque("green", Vec4::new(0.0, 1.0, 0.0, 1.0)));
    let blue = scene.add_material(Material::opaque("blue", Vec4::new(0.0, 0.0, 1.0, 1.0)));
    for i in 0..7 {
        let angle = i as f32 * 0.9;
        let transform = Transform {
            translation: Vec3::new(angle.cos() * 6.0, angle.sin() * 6.0, (i as f32 - 3.0) * 1.5),
            rotation: Quat::from_euler(glam::EulerRot::XYZ, angle, 0.3 * i as f32, 0.7),
            scale: Vec3::new(1.0 + 0.2 * i as f32, 1.0, 0.6 + 0.1 * i as f32),
        };
        let node = scene.add_node(format!("instance {i}"), transform);
        let renderable = if i % 2 == 0 {
            Renderable { geometry: patchy, materials: vec![red, green] }
        } else {
            Renderable { geometry: plain, materials: vec![blue] }
        };
        scene.set_renderable(node, renderable).unwrap();
    }
    scene
}

/// Every ray finds through the flattened arrays what testing every drawn
/// triangle finds: the top level's nodes and leaf words, each instance's
/// tree (rebased into the shared arrays), its inverse matrix and its
/// submesh table (out-of-order submeshes, triangles in no submesh not hit).
#[test]
fn walking_the_ray_scene_finds_what_every_triangle_finds() {
    let scene = scattered_scene();
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    let drawn = frame(&mut prep, &scene, &mut slots);
    let rs = prep.ray_scene();
    assert_eq!(rs.instances().len(), 7);
    assert_eq!(rs.tlas_root(), Some(0));
    let hits = agree(rs, &drawn, &rigid, Vec3::splat(8.0), 1500);
    assert!(hits.len() > 500, "only {} of 1500 rays hit", hits.len());
    // Every instance and both submeshes of the patchy cubes are hit.
    for d in &drawn {
        for material in &d.materials {
            assert!(
                hits.iter().any(|h| h.transform_index == d.transform_index && h.material == *material),
                "instance {} never hit with material {material}",
                d.transform_index
            );
        }
    }
}

/// The documented layout: the top level's nodes first, then one tree per
/// mesh however many instances draw it (instances of a mesh share its
/// root); the words are the top level's leaf order (one per instance),
/// each mesh's triangle order once, then 3 words per submesh per instance.
#[test]
fn a_mesh_drawn_by_several_instances_is_stored_once() {
    let scene = scattered_scene();
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    let drawn = frame(&mut prep, &scene, &mut slots);
    let rs = prep.ray_scene();
    // The top level's nodes: those reachable from the root.
    let mut top = 0;
    let mut stack = vec![0u32];
    while let Some(n) = stack.pop() {
        top += 1;
        let node = rs.nodes()[n as usize];
        if node.count == 0 {
            stack.extend([node.first, node.first + 1]);
        }
    }
    let mut meshes: Vec<&Geometry> = Vec::new();
    for d in &drawn {
        if !meshes.iter().any(|m| std::ptr::eq(*m, &*d.mesh)) {
            meshes.push(&d.mesh);
        }
    }
    assert_eq!(meshes.len(), 2);
    let tree = |m: &Geometry| {
        let positions: Vec<[f32; 3]> = m.vertices().iter().map(|v| v.position).collect();
        Bvh::build(&triangle_boxes(&positions, m.indices()), 4)
    };
    let mesh_nodes: usize = meshes.iter().map(|m| tree(m).nodes.len()).sum();
    let triangles: usize = meshes.iter().map(|m| m.indices().len() / 3).sum();
    let submeshes: usize = drawn.iter().map(|d| d.mesh.submeshes().len()).sum();
    assert_eq!(rs.nodes().len(), top + mesh_nodes);
    assert_eq!(rs.words().len(), drawn.len() + triangles + 3 * submeshes);
    for a in rs.instances() {
        for b in rs.instances() {
            let mesh =
                |i: &RayInstance| drawn.iter().find(|d| d.transform_index == i.transform_index).unwrap().mesh.clone();
            assert_eq!(a.blas_root == b.blas_root, std::sync::Arc::ptr_eq(&mesh(a), &mesh(b)));
        }
    }
}

/// Nothing to hit: no root, no instances.
#[test]
fn an_empty_scene_has_no_top_level_root() {
    let scene = Scene::new();
    let mut prep = ScenePrep::new();
    frame(&mut prep, &scene, &mut SlotAllocators::default());
    let rs = prep.ray_scene();
    assert_eq!(rs.tlas_root(), None);
    assert!(rs.instances().is_empty() && rs.nodes().is_empty());
    assert_eq!(rs.generation(), 1);
}

/// The generation, which the tracer restarts its samples on, counts the
/// rebuilds: one per frame whose collection changed, none for a frame
/// that reuses the last one's.
#[test]
fn the_generation_counts_rebuilds() {
    let mut scene = scattered_scene();
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    assert_eq!(prep.ray_scene().generation(), 0);
    frame(&mut prep, &scene, &mut slots);
    assert_eq!(prep.ray_scene().generation(), 1);
    frame(&mut prep, &scene, &mut slots);
    assert_eq!(prep.ray_scene().generation(), 1, "nothing changed: not rebuilt");
    let node = scene.nodes().next().unwrap().0;
    scene.set_local_transform(node, Transform::from_translation(Vec3::new(0.0, 0.0, 9.0))).unwrap();
    frame(&mut prep, &scene, &mut slots);
    assert_eq!(prep.ray_scene().generation(), 2);
    scene.set_local_transform(node, Transform::from_translation(Vec3::new(0.0, 0.0, 8.0))).unwrap();
    frame(&mut prep, &scene, &mut slots);
    assert_eq!(prep.ray_scene().generation(), 3);
}

/// A renderable whose world matrix cannot be inverted (a determinant not
/// above the smallest normal `f32`) is left out and counted; one just above
/// that is traced. (A scale of zero never gets here: the frame skips it.)
#[test]
fn renderables_with_a_singular_world_matrix_are_skipped_and_counted() {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    // Determinants 2^-126 (f32::MIN_POSITIVE exactly), 2^-127 (subnormal,
    // its reciprocal still finite, so the frame keeps it) and 2^-123.
    let (a, b, c) = (2f32.powi(-41), 2f32.powi(-42), 2f32.powi(-43));
    let scales = [Vec3::splat(b), Vec3::new(b, b, c), Vec3::splat(a), Vec3::ONE];
    for (i, scale) in scales.into_iter().enumerate() {
        let transform = Transform { scale, ..Transform::from_translation(Vec3::new(3.0 * i as f32, 0.0, 0.0)) };
        let node = scene.add_node(format!("scaled {i}"), transform);
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
    }
    let mut prep = ScenePrep::new();
    let drawn = frame(&mut prep, &scene, &mut SlotAllocators::default());
    assert_eq!(drawn.len(), 4, "the frame collects every one");
    let rs = prep.ray_scene();
    assert_eq!(rs.skipped(), 2);
    let kept: Vec<u32> = rs.instances().iter().map(|i| i.transform_index).collect();
    let expected: Vec<u32> = drawn[2..].iter().map(|d| d.transform_index).collect();
    assert_eq!(kept, expected);
}

/// Another scene's mesh under the same geometry id (and index count) gets
/// a tree of its own: the first scene's is forgotten.
#[test]
fn another_scenes_mesh_under_the_same_id_gets_its_own_tree() {
    let one_cube = |size: f32| {
        let mut scene = Scene::new();
        let cube = scene.add_geometry(Geometry::cube(size));
        let material = scene.add_material(Material::opaque("m", Vec4::ONE));
        let node = scene.add_node("cube", Transform::IDENTITY);
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
        scene
    };
    let (small, large) = (one_cube(1.0), one_cube(6.0));
    let mut prep = ScenePrep::new();
    let mut slots = SlotAllocators::default();
    frame(&mut prep, &small, &mut slots);
    let drawn = frame(&mut prep, &large, &mut slots);
    let hits = agree(prep.ray_scene(), &drawn, &rigid, Vec3::splat(3.0), 300);
    assert!(hits.len() > 100, "only {} of 300 rays hit", hits.len());
    // A ray the small cube's tree would not let reach the large cube.
    let hit = walk(prep.ray_scene(), &drawn, Vec3::new(2.5, 0.3, 10.0), Vec3::NEG_Z).expect("the large cube is hit");
    assert!((hit.t - 7.0).abs() < 1e-4, "{hit:?}");
}

/// A quad in the XY plane, 2 × 2, centred on the origin.
fn quad_vertices() -> Vec<oxygen_core::Vertex> {
    Geometry::quad(2.0).vertices().to_vec()
}

/// Skinned and morphed renderables are posed on the CPU in their node's
/// space as the raster's vertex shader poses them (positions and normals:
/// morph targets by their weights, then each joint's matrix by its
/// weight; a zero weight's joint is ignored, even one past the skin's
/// joints), flagged [`POSED`] and traced through their posed vertices
/// (each instance its own run of them and its own tree); a rigid one is not.
#[test]
fn skinned_and_morphed_instances_are_traced_as_posed() {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let quad = Geometry::quad(2.0);
    // A quarter on joint 0, three quarters on joint 1; joint 1000, weighed
    // 0, is no joint of the skin.
    let weights = vec![SkinWeights::new([0, 1, 1000, 0], [0.25, 0.75, 0.0, 0.0]); 4];
    let skinned = scene.add_geometry(quad.clone().with_skin_weights(weights).unwrap());
    let morph = MorphTarget { positions: vec![Vec3::new(0.0, 0.0, 2.0); 4], normals: Some(vec![Vec3::X; 4]) };
    let morphed = scene.add_geometry(quad.clone().with_morph_targets(vec![morph]).unwrap());
    let rigid_quad = scene.add_geometry(quad.clone());
    let add = |scene: &mut Scene, name: &str, at: Vec3, geometry| {
        let node = scene.add_node(name, Transform::from_translation(at));
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
        node
    };
    // Joint 0 at y = 2; joint 1 at z = 3, turned a quarter about X.
    let joints = [
        Transform::from_translation(Vec3::new(0.0, 2.0, 0.0)),
        Transform {
            rotation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            ..Transform::from_translation(Vec3::Z * 3.0)
        },
    ];
    let joint_nodes: Vec<NodeKey> = joints.iter().map(|t| scene.add_node("joint", *t)).collect();
    let joint_world: Vec<Mat4> =
        joints.iter().map(|t| Mat4::from_scale_rotation_translation(t.scale, t.rotation, t.translation)).collect();
    // The skin gives world space: the node's own place (x = 5) is ignored.
    let skin_node = add(&mut scene, "skinned", Vec3::new(5.0, 0.0, 0.0), skinned);
    let binds = [Mat4::IDENTITY, Mat4::IDENTITY];
    scene
        .set_skin(skin_node, Some(Skin { joints: joint_nodes.clone(), inverse_bind_matrices: binds.to_vec() }))
        .unwrap();
    // A second skinned quad, on the same joints, moved by its bind matrices.
    let skin_node_2 = add(&mut scene, "skinned 2", Vec3::new(-5.0, 0.0, 0.0), skinned);
    let binds_2 =
        [Mat4::from_translation(Vec3::new(-4.0, 0.0, -1.0)), Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0))];
    scene.set_skin(skin_node_2, Some(Skin { joints: joint_nodes, inverse_bind_matrices: binds_2.to_vec() })).unwrap();
    // The morphed quad at y = -4, pushed 1 towards +Z by half its target,
    // its normals tilted towards +X by half the target's.
    let morph_node = add(&mut scene, "morphed", Vec3::new(0.0, -4.0, 0.0), morphed);
    scene.set_morph_weights(morph_node, vec![0.5]).unwrap();
    let rigid_node = add(&mut scene, "rigid", Vec3::new(4.0, -4.0, 0.0), rigid_quad);

    let mut prep = ScenePrep::new();
    let drawn = frame(&mut prep, &scene, &mut SlotAllocators::default());
    let rs = prep.ray_scene();
    assert_eq!(rs.skipped(), 0);
    assert_eq!(rs.instances().len(), 4);
    // Where each vertex should be in the world, with its normal there.
    let posed_world = |d: &Drawn| -> Vec<(Vec3, Vec3)> {
        let skin = |binds: &[Mat4; 2], v: Vec3, n: Vec3| {
            let mut out = (Vec3::ZERO, Vec3::ZERO);
            for (k, weight) in [(0, 0.25), (1, 0.75)] {
                let m = joint_world[k] * binds[k];
                out.0 += weight * m.transform_point3(v);
                out.1 += weight * (glam::Mat3::from_mat4(m).inverse().transpose() * n);
            }
            out
        };
        quad_vertices()
            .iter()
            .map(|v| {
                let (p, n) = (Vec3::from(v.position), Vec3::from(v.normal));
                if d.node == skin_node {
                    skin(&binds, p, n)
                } else if d.node == skin_node_2 {
                    skin(&binds_2, p, n)
                } else if d.node == morph_node {
                    (d.world.transform_point3(p + Vec3::Z), d.world.transform_vector3(n + 0.5 * Vec3::X))
                } else {
                    (d.world.transform_point3(p), n)
                }
            })
            .collect()
    };
    let world_of = |d: &Drawn| -> Vec<Vec3> { posed_world(d).into_iter().map(|(p, _)| p).collect() };
    let mut runs = Vec::new();
    for d in &drawn {
        let instance = rs.instances().iter().find(|i| i.transform_index == d.transform_index).unwrap();
        if d.node == rigid_node {
            assert_eq!(instance.flags, 0);
            continue;
        }
        assert_eq!(instance.flags, POSED, "{}", d.mesh.name());
        let start = instance.vertex_slot as usize;
        runs.push(start);
        let posed = &rs.posed_vertices()[start..start + 4];
        for (p, (position, normal)) in posed.iter().zip(posed_world(d)) {
            let expected = d.world.inverse().transform_point3(position);
            let name = d.mesh.name();
            assert!(Vec3::from(p.position).abs_diff_eq(expected, 1e-5), "{name}: {:?} != {expected}", p.position);
            // The normal's direction, as the node's normal matrix takes it
            // back to the world.
            let normal_matrix = glam::Mat3::from_mat4(d.world).inverse().transpose();
            let back = (normal_matrix * Vec3::from(p.normal)).normalize();
            assert!(back.abs_diff_eq(normal.normalize(), 1e-5), "{name}: normal {back} != {}", normal.normalize());
        }
    }
    runs.sort_unstable();
    assert_eq!(runs, [0, 4, 8], "one run of 4 vertices per posed instance");
    assert_eq!(rs.posed_vertices().len(), 12);
    let hits = agree(rs, &drawn, &world_of, Vec3::new(7.0, 6.0, 3.0), 1500);
    for d in &drawn {
        assert!(hits.iter().any(|h| h.transform_index == d.transform_index), "{} never hit", d.mesh.name());
    }
}

/// A morph target past the fourteenth takes its weight from the second
/// matrix of the frame's morph header (16 floats a matrix: the vertex and
/// target counts, then 14 weights in the first).
#[test]
fn the_fifteenth_morph_targets_weight_poses_the_mesh() {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let targets =
        (0..15).map(|t| MorphTarget { positions: vec![Vec3::Z * (t + 1) as f32; 4], normals: None }).collect();
    let morphed = scene.add_geometry(Geometry::quad(2.0).with_morph_targets(targets).unwrap());
    let node = scene.add_node("morphed", Transform::from_translation(Vec3::new(1.0, 2.0, 3.0)));
    scene.set_renderable(node, Renderable { geometry: morphed, materials: vec![material] }).unwrap();
    let mut weights = vec![0.0; 15];
    weights[14] = 0.5;
    scene.set_morph_weights(node, weights).unwrap();
    let mut prep = ScenePrep::new();
    frame(&mut prep, &scene, &mut SlotAllocators::default());
    let rs = prep.ray_scene();
    assert_eq!((rs.skipped(), rs.instances().len()), (0, 1));
    for (posed, v) in rs.posed_vertices().iter().zip(quad_vertices()) {
        let expected = Vec3::from(v.position) + Vec3::Z * 7.5;
        assert!(Vec3::from(posed.position).abs_diff_eq(expected, 1e-5), "{:?} != {expected}", posed.position);
    }
}

/// A morphed renderable whose posed normal is not finite (a finite target
/// normal of 3e38 at weight 2) is left out and counted, though its
/// positions are finite.
#[test]
fn a_morph_that_poses_a_normal_out_of_range_is_skipped_and_counted() {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let morph = MorphTarget { positions: vec![Vec3::Z; 4], normals: Some(vec![Vec3::X * 3e38; 4]) };
    let morphed = scene.add_geometry(Geometry::quad(2.0).with_morph_targets(vec![morph]).unwrap());
    let node = scene.add_node("morphed", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: morphed, materials: vec![material] }).unwrap();
    scene.set_morph_weights(node, vec![2.0]).unwrap();
    let mut prep = ScenePrep::new();
    let drawn = frame(&mut prep, &scene, &mut SlotAllocators::default());
    assert_eq!(drawn.len(), 1, "the frame draws it");
    let rs = prep.ray_scene();
    assert_eq!((rs.skipped(), rs.instances().len()), (1, 0));
}

/// A skinned renderable whose posed vertices are not finite (its joint
/// scales it by 1e36, its node's inverse by 2^40: past `f32::MAX`) is
/// left out of the ray scene and counted; the same on a tame joint is traced.
#[test]
fn a_skinned_renderable_that_poses_out_of_range_is_skipped_and_counted() {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let weights = vec![SkinWeights::new([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]); 4];
    let skinned = scene.add_geometry(Geometry::quad(2.0).with_skin_weights(weights).unwrap());
    let mut nodes = Vec::new();
    for joint_scale in [1e36, 1.0] {
        let small = Transform { scale: Vec3::splat(2f32.powi(-40)), ..Transform::IDENTITY };
        let node = scene.add_node("skinned", small);
        scene.set_renderable(node, Renderable { geometry: skinned, materials: vec![material] }).unwrap();
        let joint = scene.add_node("joint", Transform { scale: Vec3::splat(joint_scale), ..Transform::IDENTITY });
        let skin = Skin { joints: vec![joint], inverse_bind_matrices: vec![Mat4::IDENTITY] };
        scene.set_skin(node, Some(skin)).unwrap();
        nodes.push(node);
    }
    let mut prep = ScenePrep::new();
    let drawn = frame(&mut prep, &scene, &mut SlotAllocators::default());
    assert_eq!(drawn.len(), 2, "the frame draws both");
    let rs = prep.ray_scene();
    assert_eq!(rs.skipped(), 1);
    let tame = drawn.iter().find(|d| d.node == nodes[1]).unwrap();
    assert_eq!(rs.instances().len(), 1);
    assert_eq!(rs.instances()[0].transform_index, tame.transform_index);
    assert_eq!(rs.posed_vertices().len(), 4);
}

/// The top level's root box is the union of the instances' world boxes
/// (each mesh's box carried by its world matrix, every corner counted),
/// rounded outward by a few units in the last place: strictly larger, so
/// that rounding elsewhere never makes it smaller than what it bounds, and
/// only that, so that rays are not sent into instances they cannot hit.
#[test]
fn the_top_level_box_is_the_instances_world_boxes_within_a_few_ulps() {
    let scene = scattered_scene();
    let mut prep = ScenePrep::new();
    let drawn = frame(&mut prep, &scene, &mut SlotAllocators::default());
    let rs = prep.ray_scene();
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for instance in rs.instances() {
        let world = drawn.iter().find(|d| d.transform_index == instance.transform_index).unwrap().world;
        let local = rs.nodes()[instance.blas_root as usize];
        for i in 0..8 {
            let pick = |bit: usize, axis: usize| if i & bit == 0 { local.min[axis] } else { local.max[axis] };
            let corner = world.transform_point3(Vec3::new(pick(1, 0), pick(2, 1), pick(4, 2)));
            (min, max) = (min.min(corner), max.max(corner));
        }
    }
    let root = rs.nodes()[rs.tlas_root().unwrap() as usize];
    let slack = 16.0 * f32::EPSILON * min.abs().max(max.abs());
    for axis in 0..3 {
        assert!(root.min[axis] < min[axis] && root.min[axis] >= min[axis] - slack[axis], "{:?} vs {min}", root.min);
        assert!(root.max[axis] > max[axis] && root.max[axis] <= max[axis] + slack[axis], "{:?} vs {max}", root.max);
    }
}

/// A posed mesh of more triangles than a leaf holds (a morphed cube: its
/// tree has interior nodes) is walked through its own tree, rebased into
/// the shared arrays like a rigid mesh's, beside a rigid cube and a triangle.
#[test]
fn a_posed_mesh_with_a_deep_tree_is_traced_through_it() {
    let mut scene = Scene::new();
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let cube = Geometry::cube(2.0);
    let morph = MorphTarget { positions: vec![Vec3::Z; cube.vertices().len()], normals: None };
    let morphed = scene.add_geometry(cube.clone().with_morph_targets(vec![morph]).unwrap());
    let rigid_cube = scene.add_geometry(cube);
    let morph_node = scene.add_node("morphed", Transform::from_translation(Vec3::new(-2.0, 0.0, 0.0)));
    scene.set_renderable(morph_node, Renderable { geometry: morphed, materials: vec![material] }).unwrap();
    scene.set_morph_weights(morph_node, vec![1.0]).unwrap();
    let rigid_node = scene.add_node("rigid", Transform::from_translation(Vec3::new(2.0, 0.0, 0.0)));
    scene.set_renderable(rigid_node, Renderable { geometry: rigid_cube, materials: vec![material] }).unwrap();
    // A triangle too, so that the posed tree's first node (after the top
    // level's, the cube's and the triangle's) and its first word differ.
    let vertices = Geometry::quad(2.0).vertices()[..3].to_vec();
    let triangle = Geometry::new("triangle", vertices, vec![0, 1, 2], vec![Submesh { first_index: 0, index_count: 3 }]);
    let triangle = scene.add_geometry(triangle.unwrap());
    let triangle_node = scene.add_node("triangle", Transform::from_translation(Vec3::new(0.0, 3.0, 0.0)));
    scene.set_renderable(triangle_node, Renderable { geometry: triangle, materials: vec![material] }).unwrap();
    let mut prep = ScenePrep::new();
    let drawn = frame(&mut prep, &scene, &mut SlotAllocators::default());
    let rs = prep.ray_scene();
    assert_eq!(rs.instances().len(), 3);
    let posed = rs.instances().iter().find(|i| i.flags == POSED).unwrap();
    assert_eq!(rs.nodes()[posed.blas_root as usize].count, 0, "the posed tree's root is an interior node");
    let first_word = rs.nodes()[posed.blas_root as usize..].iter().filter(|n| n.count > 0).map(|n| n.first).min();
    assert_ne!(Some(posed.blas_root), first_word, "the posed tree's first node and first word differ");
    let world_of = |d: &Drawn| -> Vec<Vec3> {
        let shift = if d.node == morph_node { Vec3::Z } else { Vec3::ZERO };
        d.mesh.vertices().iter().map(|v| d.world.transform_point3(Vec3::from(v.position) + shift)).collect()
    };
    let hits = agree(rs, &drawn, &world_of, Vec3::new(4.0, 2.0, 3.0), 800);
    for d in &drawn {
        assert!(hits.iter().any(|h| h.transform_index == d.transform_index), "{} never hit", d.mesh.name());
    }
}
