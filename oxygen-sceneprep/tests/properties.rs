//! Property tests with a seeded generator (SplitMix64): random scenes and
//! cameras, checked against the contracts of culling, sorting and
//! partitioning. A failure prints the seed that reproduces it.

use glam::{Quat, UVec2, Vec3, Vec4};
use oxygen_bindless::SlotAllocators;
use oxygen_core::scene::node_index;
use oxygen_core::{
    AlphaMode, Camera, Geometry, LookAtResolver, Material, Renderable, ResolvedView, Scene, Transform, ViewContext,
    ViewResolver,
};
use oxygen_sceneprep::testing::sort_key;
use oxygen_sceneprep::{CullBound, PassMask, PreparedSceneFrame, ScenePrep, ViewPrepOptions, ViewRequest};

struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
    fn vec3(&mut self, extent: f32) -> Vec3 {
        Vec3::new(self.range(-extent, extent), self.range(-extent, extent), self.range(-extent, extent))
    }
}

/// A scene of `n` boxes with random positions, rotations, scales and one of
/// six materials covering every alpha class and sidedness.
fn random_scene(rng: &mut Rng, n: usize) -> Scene {
    let mut scene = Scene::new();
    let cube = scene.add_geometry(Geometry::cube(1.0));
    let modes = [AlphaMode::Opaque, AlphaMode::Mask { cutoff: 0.5 }, AlphaMode::Blend];
    let materials: Vec<_> = (0..6)
        .map(|i| {
            scene.add_material(Material {
                alpha_mode: modes[i % 3],
                double_sided: i >= 3,
                ..Material::opaque(format!("m{i}"), Vec4::ONE)
            })
        })
        .collect();
    for i in 0..n {
        let rotation =
            Quat::from_euler(glam::EulerRot::XYZ, rng.range(0.0, 6.3), rng.range(0.0, 6.3), rng.range(0.0, 6.3));
        let scale = Vec3::new(rng.range(0.1, 4.0), rng.range(0.1, 4.0), rng.range(0.1, 4.0));
        let t = Transform { translation: rng.vec3(60.0), rotation, scale };
        let node = scene.add_node(format!("n{i}"), t);
        let material = materials[rng.below(6) as usize];
        scene.set_renderable(node, Renderable { geometry: cube, materials: vec![material] }).unwrap();
    }
    scene
}

fn random_view(rng: &mut Rng, scene: &Scene, id: u32) -> ResolvedView {
    loop {
        let eye = rng.vec3(50.0);
        let target = rng.vec3(50.0);
        let far = if rng.below(2) == 0 { None } else { Some(rng.range(20.0, 200.0)) };
        let camera = if rng.below(4) == 0 {
            Camera::orthographic(rng.range(2.0, 40.0), rng.range(-10.0, 1.0), rng.range(20.0, 200.0))
        } else {
            Camera::perspective(rng.range(0.2, 2.5), rng.range(0.01, 1.0), far)
        };
        let viewport = UVec2::new(1 + rng.below(1920) as u32, 1 + rng.below(1080) as u32);
        let resolver = LookAtResolver { camera, eye, target, up: Vec3::Y, viewport };
        let ctx = ViewContext { view_id: oxygen_demo::view_id(id), frame_index: 1, time_seconds: 0.0 };
        if let Ok(v) = resolver.resolve(&ctx, scene) {
            return v;
        }
    }
}

/// A ScenePrep that has prepared `views`; read them with `.frames()`.
fn prepare(scene: &Scene, views: &[ResolvedView], cull: CullBound) -> ScenePrep {
    let options = ViewPrepOptions { cull, ..Default::default() };
    let requests: Vec<_> = views.iter().map(|view| ViewRequest { view, options }).collect();
    let mut prep = ScenePrep::new();
    prep.prepare(scene, &requests, &mut SlotAllocators::default()).unwrap();
    prep
}

/// True when some corner of the node's world box projects inside the clip volume.
fn has_corner_inside(view: &ResolvedView, scene: &Scene, node: oxygen_core::NodeKey) -> bool {
    let n = scene.node(node).unwrap();
    let world = n.local.to_mat4();
    let local = scene.geometry(n.renderable.as_ref().unwrap().geometry).unwrap().local_aabb();
    local.corners().iter().any(|c| {
        let clip = view.view_projection * world.transform_point3(*c).extend(1.0);
        clip.w > 0.0 && clip.x.abs() <= clip.w && clip.y.abs() <= clip.w && clip.z >= 0.0 && clip.z <= clip.w
    })
}

#[test]
fn culling_never_drops_an_object_with_a_corner_inside_the_frustum() {
    for seed in 0..40 {
        let mut rng = Rng(seed);
        let scene = random_scene(&mut rng, 300);
        let view = random_view(&mut rng, &scene, 0);
        for cull in [CullBound::Aabb, CullBound::Sphere] {
            let prep = prepare(&scene, std::slice::from_ref(&view), cull);
            let frame = &prep.frames()[0];
            let drawn: std::collections::HashSet<u32> = frame.draws().iter().map(|d| d.node_id).collect();
            for (key, _) in scene.nodes() {
                if has_corner_inside(&view, &scene, key) {
                    assert!(drawn.contains(&node_index(key)), "seed {seed}, {cull:?}: visible node {key:?} was culled");
                }
            }
        }
    }
}

#[test]
fn partitions_cover_every_draw_once_in_order_with_one_mask() {
    for seed in 0..40 {
        let mut rng = Rng(1000 + seed);
        let scene = random_scene(&mut rng, 200);
        let view = random_view(&mut rng, &scene, 0);
        let prep = prepare(&scene, &[view], CullBound::Aabb);
        let frame = &prep.frames()[0];
        let mut next = 0;
        for p in frame.partitions() {
            assert_eq!(p.begin, next, "seed {seed}: gap or overlap before {p:?}");
            assert!(p.end > p.begin, "seed {seed}: empty partition");
            for d in &frame.draws()[p.range()] {
                assert_eq!(d.mask() & PassMask::PARTITION_BITS, p.mask, "seed {seed}: draw in wrong partition");
            }
            next = p.end;
        }
        assert_eq!(next as usize, frame.draws().len(), "seed {seed}: draws past the last partition");
        // Maximal runs: neighbours always differ.
        for w in frame.partitions().windows(2) {
            assert_ne!(w[0].mask, w[1].mask, "seed {seed}: adjacent partitions share a mask");
        }
    }
}

#[test]
fn draws_are_ordered_by_key_then_node_then_submesh_and_keys_match_their_definition() {
    for seed in 0..40 {
        let mut rng = Rng(2000 + seed);
        let scene = random_scene(&mut rng, 200);
        let view = random_view(&mut rng, &scene, 0);
        let prep = prepare(&scene, &[view], CullBound::Aabb);
        let frame = &prep.frames()[0];
        let view_row_z = view.view.row(2);
        for (d, key) in frame.draws().iter().zip(frame.sort_keys()) {
            // Recompute the key from the definition: mask, material, depth of the bound's centre.
            let node = scene.nodes().find(|(k, _)| node_index(*k) == d.node_id).unwrap().1;
            let local = scene.geometry(node.renderable.as_ref().unwrap().geometry).unwrap().local_aabb();
            let center = local.transformed(&node.local.to_mat4()).center();
            let depth = -(view_row_z.truncate().dot(center) + view_row_z.w);
            let mask = d.mask() & !PassMask::CASTS_SHADOWS;
            assert_eq!(*key, sort_key(mask, d.material_handle, depth), "seed {seed}");
        }
        let order: Vec<_> =
            frame.draws().iter().zip(frame.sort_keys()).map(|(d, k)| (*k, d.node_id, d.submesh)).collect();
        assert!(order.windows(2).all(|w| w[0] < w[1]), "seed {seed}: draws not strictly ordered");
    }
}

/// Draw bytes, partitions and draw slots of every view, for comparisons.
fn fingerprint(frames: &[PreparedSceneFrame]) -> Vec<(Vec<u8>, Vec<oxygen_sceneprep::Partition>, u32)> {
    frames
        .iter()
        .map(|f| {
            (bytemuck::cast_slice::<_, u8>(f.draws()).to_vec(), f.partitions().to_vec(), f.slots().draw_metadata.start)
        })
        .collect()
}

#[test]
fn the_same_scene_and_views_give_byte_identical_draws_twice_in_a_row_and_across_thread_counts() {
    for seed in 0..10 {
        let mut rng = Rng(3000 + seed);
        let scene = random_scene(&mut rng, 300);
        let views: Vec<_> = (0..5).map(|i| random_view(&mut rng, &scene, i)).collect();
        let requests: Vec<_> = views.iter().map(|view| ViewRequest { view, options: Default::default() }).collect();
        let mut reference = None;
        for threads in [1, 2, 3, 8] {
            let mut prep = ScenePrep::with_threads(threads);
            let mut slots = SlotAllocators::default();
            let first = fingerprint(prep.prepare(&scene, &requests, &mut slots).unwrap());
            let second = fingerprint(prep.prepare(&scene, &requests, &mut slots).unwrap());
            assert_eq!(first, second, "seed {seed}, {threads} threads: second frame differs");
            match &reference {
                None => reference = Some(first),
                Some(r) => assert_eq!(r, &first, "seed {seed}: {threads} threads differ from 1 thread"),
            }
        }
    }
}

/// The cost of the cheaper sphere bound: it keeps every draw the AABB test
/// keeps (the sphere contains the box) plus some invisible ones. Reports the
/// extra fraction over the random scenes.
#[test]
fn sphere_culling_keeps_a_superset_of_aabb_culling_and_reports_its_extra_draws() {
    let (mut aabb_total, mut sphere_total) = (0usize, 0usize);
    for seed in 0..40 {
        let mut rng = Rng(4000 + seed);
        let scene = random_scene(&mut rng, 300);
        let view = random_view(&mut rng, &scene, 0);
        let aabb = prepare(&scene, std::slice::from_ref(&view), CullBound::Aabb);
        let sphere = prepare(&scene, std::slice::from_ref(&view), CullBound::Sphere);
        let kept =
            |p: &ScenePrep| p.frames()[0].draws().iter().map(|d| d.node_id).collect::<std::collections::HashSet<_>>();
        let (a, s) = (kept(&aabb), kept(&sphere));
        assert!(a.is_subset(&s), "seed {seed}: the sphere dropped a draw the box kept");
        aabb_total += a.len();
        sphere_total += s.len();
    }
    let extra = (sphere_total - aabb_total) as f64 / aabb_total.max(1) as f64;
    eprintln!("sphere culling kept {sphere_total} draws vs {aabb_total} for AABB: {:.1} % extra", extra * 100.0);
    assert!(sphere_total >= aabb_total);
}

/// The indirect arguments are safe to hand to `multi_draw_indexed_indirect`
/// without wgpu's indirect validation (`GpuOptions::trust_indirect_args`):
/// each one is its draw's, reads the draw's own `DrawMetadata` (first
/// instance = its position in the view's array, to which the shader adds the
/// view's draw-metadata slot), and stays inside its geometry's index range, whose
/// indices stay inside its vertex range. Meshes of different sizes, so a
/// range that spilled into a neighbour would show.
#[test]
fn indirect_arguments_stay_inside_their_geometry() {
    let mut rng = Rng(0x1d1_4ec7);
    let mut scene = Scene::new();
    let meshes = [
        scene.add_geometry(Geometry::cube(1.0)),
        scene.add_geometry(Geometry::uv_sphere(0.5, 12, 8)),
        scene.add_geometry(Geometry::plane(2.0)),
        scene.add_geometry(Geometry::quad(1.0)),
    ];
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    for i in 0..400 {
        let node = scene.add_node(format!("n{i}"), Transform::from_translation(rng.vec3(40.0)));
        let geometry = meshes[rng.below(meshes.len() as u64) as usize];
        scene.set_renderable(node, Renderable { geometry, materials: vec![material] }).unwrap();
    }
    let geometry_of: std::collections::HashMap<u32, &std::sync::Arc<Geometry>> = scene
        .nodes()
        .filter_map(|(key, node)| Some((node_index(key), scene.geometry(node.renderable.as_ref()?.geometry)?)))
        .collect();
    let views: Vec<_> = (0..4).map(|i| random_view(&mut rng, &scene, i)).collect();
    let prep = prepare(&scene, &views, CullBound::Aabb);
    let mut checked = 0;
    for frame in prep.frames() {
        // One instance per draw, in draw order: a draw read through another
        // draw's metadata, or twice, or never, would show here. (Runs of
        // draws sharing a mesh are one instanced command.)
        let instances: Vec<u32> = frame
            .indirect_args()
            .iter()
            .flat_map(|args| args.first_instance..args.first_instance + args.instance_count)
            .collect();
        assert_eq!(instances, (0..frame.draws().len() as u32).collect::<Vec<_>>());
        for args in frame.indirect_args() {
            for i in args.first_instance..args.first_instance + args.instance_count {
                let i = i as usize;
                let draw = &frame.draws()[i];
                let geometry = geometry_of[&draw.node_id];
                let indices = draw.index_slot as usize..draw.index_slot as usize + geometry.indices().len();
                let range = args.first_index as usize..(args.first_index + args.index_count) as usize;
                assert!(
                    range.start >= indices.start && range.end <= indices.end,
                    "draw {i}: {range:?} outside {indices:?}"
                );
                let local = &geometry.indices()[range.start - indices.start..range.end - indices.start];
                let highest = local.iter().max().copied().unwrap_or(0) as i64 + args.base_vertex as i64;
                let lowest = local.iter().min().copied().unwrap_or(0) as i64 + args.base_vertex as i64;
                let vertices = draw.vertex_slot as i64..draw.vertex_slot as i64 + geometry.vertices().len() as i64;
                assert!(
                    vertices.contains(&lowest) && vertices.contains(&highest),
                    "draw {i} reads outside its vertices"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "only {checked} draws checked");
}
