//! Scene deltas without a GPU: a replica kept in step by deltas (encoded
//! and decoded each time) holds exactly what the source holds — the same
//! slots for every node and asset, the same states — over a long seeded
//! sequence of random edits of every kind; assets travel once per stream;
//! a replica that falls behind the journal, or joins late, gets a snapshot;
//! bad deltas are refused with an error, never a panic.

use std::collections::HashSet;

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use oxygen_core::scene::delta::{
    AssetBody, DeltaError, DeltaOp, DeltaStream, SceneDelta, SceneReplica, scene_difference,
};
use oxygen_core::{
    AlphaMode, Camera, ColorSpace, Geometry, Light, LodLevel, Material, MorphTarget, NodeFlags, NodeKey, Renderable,
    Scene, Skin, TextureImage, Transform, VertexAttributes,
};

/// xorshift64*: the same sequence on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The assets and nodes a random edit picks from.
struct World {
    scene: Scene,
    geometries: Vec<oxygen_core::GeometryHandle>,
    materials: Vec<oxygen_core::MaterialHandle>,
    textures: Vec<oxygen_core::TextureHandle>,
    nodes: Vec<NodeKey>,
}

impl World {
    fn live_nodes(&mut self) -> &[NodeKey] {
        let scene = &self.scene;
        self.nodes.retain(|k| scene.node(*k).is_some());
        &self.nodes
    }
}

/// One geometry of a few kinds: cubes of a size, with vertex attributes,
/// with a morph target.
fn geometry(rng: &mut Rng) -> Geometry {
    let size = 0.5 + rng.below(4) as f32 * 0.5;
    let cube = Geometry::cube(size);
    match rng.below(3) {
        0 => cube,
        1 => {
            let attributes =
                vec![VertexAttributes::new(Vec4::new(rng.unit(), 0.5, 0.2, 1.0), Vec2::ZERO); cube.vertices().len()];
            cube.with_attributes(attributes).unwrap()
        }
        _ => {
            let target = MorphTarget { positions: vec![Vec3::Y * 0.1; cube.vertices().len()], normals: None };
            cube.with_morph_targets(vec![target]).unwrap()
        }
    }
}

/// One random edit of `world` (every kind the scene has).
fn edit(world: &mut World, rng: &mut Rng) {
    let nodes = world.live_nodes().to_vec();
    let pick = |rng: &mut Rng| nodes.get(rng.below(nodes.len())).copied();
    let scene = &mut world.scene;
    match rng.below(20) {
        0 => world.geometries.push(scene.add_geometry(geometry(rng))),
        1 => {
            let side = 1 + rng.below(4) as u32;
            let pixels = (0..side * side * 4).map(|i| (i * 37 % 251) as u8).collect();
            let texture = TextureImage::new("t", side, side, ColorSpace::Srgb, pixels).unwrap();
            world.textures.push(scene.add_texture(texture));
        }
        2 => {
            let alpha_mode = [AlphaMode::Opaque, AlphaMode::Mask { cutoff: 0.5 }, AlphaMode::Blend][rng.below(3)];
            let texture = (!world.textures.is_empty() && rng.below(2) == 0)
                .then(|| world.textures[rng.below(world.textures.len())]);
            let material = Material {
                alpha_mode,
                base_color_texture: texture,
                double_sided: rng.below(2) == 0,
                ..Material::opaque("m", Vec4::new(rng.unit(), rng.unit(), rng.unit(), 1.0))
            };
            world.materials.push(scene.add_material(material));
        }
        3 if !world.materials.is_empty() => {
            let handle = world.materials[rng.below(world.materials.len())];
            let material = Material { roughness: rng.unit(), ..scene.material(handle).unwrap().clone() };
            scene.set_material(handle, material).unwrap();
        }
        4..=6 => {
            let at = Transform::from_translation(Vec3::new(rng.unit() * 10.0, rng.unit(), rng.unit() * 10.0));
            let key = match pick(rng).filter(|_| rng.below(2) == 0) {
                Some(parent) => scene.add_child(parent, "child", at).unwrap(),
                None => scene.add_node("root", at),
            };
            world.nodes.push(key);
        }
        7 => {
            if let Some(key) = pick(rng) {
                scene.remove_node(key).unwrap();
            }
        }
        8..=9 => {
            if let Some(key) = pick(rng) {
                let t = Transform {
                    translation: Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 8.0,
                    rotation: Quat::from_rotation_y(rng.unit() * 6.0),
                    scale: Vec3::splat(0.5 + rng.unit()),
                };
                scene.set_local_transform(key, t).unwrap();
            }
        }
        10 => {
            if let Some(key) = pick(rng) {
                let flags = [NodeFlags::VISIBLE, NodeFlags::VISIBLE | NodeFlags::CASTS_SHADOWS, NodeFlags::empty()];
                scene.set_flags(key, flags[rng.below(3)]).unwrap();
            }
        }
        11..=12 => {
            if let (Some(key), false, false) = (pick(rng), world.geometries.is_empty(), world.materials.is_empty()) {
                let geometry = world.geometries[rng.below(world.geometries.len())];
                let material = world.materials[rng.below(world.materials.len())];
                scene.set_renderable(key, Renderable { geometry, materials: vec![material] }).unwrap();
            }
        }
        13 => {
            if let (Some(key), false) = (pick(rng), world.geometries.is_empty()) {
                let geometry = world.geometries[rng.below(world.geometries.len())];
                let lods = vec![LodLevel { geometry, below_screen_fraction: 0.05 + rng.unit() * 0.2 }];
                // Refused without a renderable: a refused edit changes nothing.
                let _ = scene.set_lods(key, lods);
            }
        }
        14 => {
            if let Some(key) = pick(rng) {
                let light = match rng.below(3) {
                    0 => None,
                    1 => Some(Light::directional(rng.unit() * 3.0)),
                    _ => Some(Light::point(rng.unit() * 10.0, Some(5.0))),
                };
                scene.set_light(key, light).unwrap();
            }
        }
        15 => {
            if let Some(key) = pick(rng) {
                let camera = (rng.below(2) == 0).then(|| Camera::perspective(1.0, 0.1, Some(50.0)));
                scene.set_camera(key, camera).unwrap();
            }
        }
        16 => {
            if let Some(key) = pick(rng) {
                scene.set_morph_weights(key, vec![rng.unit()]).unwrap();
                scene.set_semantic_class(key, rng.below(9) as u32).unwrap();
            }
        }
        17 => {
            if let (Some(child), Some(parent)) = (pick(rng), pick(rng)) {
                // Refused when it would make a cycle: nothing changes then.
                let _ = scene.set_parent(child, (rng.below(4) != 0).then_some(parent));
            }
        }
        18 => {
            if let (Some(key), Some(joint)) = (pick(rng), pick(rng)) {
                let skin = Skin { joints: vec![joint], inverse_bind_matrices: vec![Mat4::IDENTITY] };
                scene.set_skin(key, (rng.below(2) == 0).then_some(skin)).unwrap();
            }
        }
        _ => {
            // The same geometry content again: its body travels once.
            if let Some(&handle) = world.geometries.first() {
                let same = (**scene.geometry(handle).unwrap()).clone();
                world.geometries.push(scene.add_geometry(same));
            }
        }
    }
}

fn new_world() -> World {
    World {
        scene: Scene::new(),
        geometries: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
        nodes: Vec::new(),
    }
}

#[test]
fn a_replica_kept_in_step_by_deltas_holds_what_the_source_holds() {
    let mut rng = Rng(0x5EED_0FDE_17A5);
    let mut world = new_world();
    let mut stream = DeltaStream::new();
    let mut replica = SceneReplica::new();
    let (mut deltas, mut bytes, mut bodies) = (0, 0, Vec::new());
    for step in 0..3000 {
        edit(&mut world, &mut rng);
        // Deltas at irregular intervals, some after one edit, some after many.
        if rng.below(7) == 0 || step == 2999 {
            let delta = stream.next(&world.scene);
            bodies.extend(delta.assets.iter().map(|(hash, _)| *hash));
            let encoded = delta.encode();
            bytes += encoded.len();
            let decoded = SceneDelta::decode(&encoded).unwrap();
            assert_eq!(decoded, delta);
            replica.apply(&decoded).unwrap_or_else(|e| panic!("step {step}: {e}"));
            if let Some(difference) = scene_difference(&world.scene, replica.scene()) {
                panic!("step {step}: the replica differs after {deltas} deltas: {difference}");
            }
            assert_eq!(replica.revision(), Some(world.scene.revision()));
            deltas += 1;
        }
    }
    assert!(world.scene.node_count() > 20, "{} nodes at the end", world.scene.node_count());
    assert!(deltas > 300, "{deltas} deltas");
    // Every asset body travelled once, though the same content was added
    // under several handles.
    let distinct: HashSet<_> = bodies.iter().collect();
    assert_eq!(distinct.len(), bodies.len(), "an asset body travelled twice");
    eprintln!("{deltas} deltas, {bytes} bytes, {} asset bodies", bodies.len());
}

#[test]
fn a_replica_that_falls_behind_the_journal_or_joins_late_gets_a_snapshot() {
    let mut rng = Rng(42);
    let mut world = new_world();
    let mut stream = DeltaStream::new();
    let mut replica = SceneReplica::new();
    for _ in 0..200 {
        edit(&mut world, &mut rng);
    }
    replica.apply(&stream.next(&world.scene)).unwrap();
    for _ in 0..200 {
        edit(&mut world, &mut rng);
    }
    // The journal no longer reaches the stream's revision: a snapshot,
    // whose assets the replica already holds travel by hash.
    world.scene.trim_journal(world.scene.revision());
    edit(&mut world, &mut rng);
    let delta = stream.next(&world.scene);
    assert!(delta.is_snapshot());
    replica.apply(&delta).unwrap();
    assert_eq!(scene_difference(&world.scene, replica.scene()), None);
    // A replica joining now: a new stream, a snapshot with every body.
    let mut late = SceneReplica::new();
    let mut late_stream = DeltaStream::new();
    let first = late_stream.next(&world.scene);
    let geometries = first.ops.iter().filter(|op| matches!(op, DeltaOp::AddGeometry { .. })).count();
    let bodies = first.assets.iter().filter(|(_, body)| matches!(body, AssetBody::Geometry(_))).count();
    assert!(bodies >= 1 && bodies <= geometries, "{bodies} bodies for {geometries} geometries");
    late.apply(&first).unwrap();
    assert_eq!(scene_difference(&world.scene, late.scene()), None);
}

#[test]
fn bad_deltas_are_refused_with_a_reason() {
    let mut rng = Rng(7);
    let mut world = new_world();
    for _ in 0..100 {
        edit(&mut world, &mut rng);
    }
    let mut stream = DeltaStream::new();
    let snapshot = stream.next(&world.scene);
    edit(&mut world, &mut rng);
    let next = stream.next(&world.scene);

    // Out of step: a delta for a revision the replica does not hold.
    let mut replica = SceneReplica::new();
    assert!(matches!(replica.apply(&next), Err(DeltaError::OutOfStep { .. })));
    // Garbage and other formats.
    assert!(matches!(SceneDelta::decode(&[1, 2, 3]), Err(DeltaError::Format(_))));
    let mut other = snapshot.clone();
    other.format = 99;
    assert!(matches!(SceneDelta::decode(&other.encode()), Err(DeltaError::Format(_))));
    // An asset whose content does not match its hash.
    if let Some((_, AssetBody::Geometry(record))) = snapshot.assets.first() {
        let mut tampered = snapshot.clone();
        let mut record = record.clone();
        record.name.push('!');
        tampered.assets[0].1 = AssetBody::Geometry(record);
        assert!(matches!(replica.apply(&tampered), Err(DeltaError::HashMismatch(_))));
    }
    // A record naming a slot that does not exist.
    let mut dangling = snapshot.clone();
    if let Some(node) = dangling.nodes.first_mut() {
        node.parent = Some(1_000_000);
        assert!(matches!(replica.apply(&dangling), Err(DeltaError::BadSlot(_))));
        assert_eq!(replica.revision(), None, "a failed apply waits for a snapshot");
    }
    // Two records that make each other's parent: a cycle, refused.
    let mut cyclic = snapshot.clone();
    if let [a, b, ..] = cyclic.nodes.as_mut_slice() {
        (a.parent, b.parent) = (Some(b.index), Some(a.index));
        let refused = SceneReplica::new().apply(&cyclic);
        assert!(
            matches!(refused, Err(DeltaError::BadNode { source: oxygen_core::SceneError::Cycle { .. }, .. })),
            "{refused:?}"
        );
    }
    // Every byte of a real delta flipped in turn: an error or a replica,
    // never a panic.
    let bytes = snapshot.encode();
    for i in (0..bytes.len()).step_by(bytes.len() / 200 + 1) {
        let mut flipped = bytes.clone();
        flipped[i] ^= 0x5A;
        if let Ok(delta) = SceneDelta::decode(&flipped) {
            let _ = SceneReplica::new().apply(&delta);
        }
    }
    // And the real ones still apply.
    replica.apply(&snapshot).unwrap();
    replica.apply(&next).unwrap();
    assert_eq!(scene_difference(&world.scene, replica.scene()), None);
}

#[test]
fn edge_cases_a_review_found_replicate() {
    let mut scene = Scene::new();
    let mut stream = DeltaStream::new();
    let mut replica = SceneReplica::new();
    replica.apply(&stream.next(&scene)).unwrap();
    // A material added, then a texture, then the material set to it, all
    // in one delta's window.
    let material = scene.add_material(Material::opaque("m", Vec4::ONE));
    let texture = TextureImage::new("t", 1, 1, ColorSpace::Srgb, vec![9, 9, 9, 255]).unwrap();
    let texture = scene.add_texture(texture);
    let textured = Material { base_color_texture: Some(texture), ..scene.material(material).unwrap().clone() };
    scene.set_material(material, textured).unwrap();
    // LODs set against one mesh stay when the renderable changes to a mesh
    // of another submesh count (the scene allows it).
    let one = scene.add_geometry(Geometry::cube(1.0));
    let sphere = Geometry::uv_sphere(0.5, 9, 7);
    let two = Geometry::new(
        "two",
        sphere.vertices().to_vec(),
        [sphere.indices(), sphere.indices()].concat(),
        vec![
            oxygen_core::Submesh { first_index: 0, index_count: sphere.indices().len() as u32 },
            oxygen_core::Submesh {
                first_index: sphere.indices().len() as u32,
                index_count: sphere.indices().len() as u32,
            },
        ],
    )
    .unwrap();
    let two = scene.add_geometry(two);
    let node = scene.add_node("n", Transform::IDENTITY);
    scene.set_renderable(node, Renderable { geometry: one, materials: vec![material] }).unwrap();
    scene.set_lods(node, vec![LodLevel { geometry: one, below_screen_fraction: 0.1 }]).unwrap();
    scene.set_renderable(node, Renderable { geometry: two, materials: vec![material, material] }).unwrap();
    replica.apply(&stream.next(&scene)).unwrap();
    assert_eq!(scene_difference(&scene, replica.scene()), None);
    // Geometry rebuilt from its record has the source's bits (normals not
    // normalised a second time).
    let (source, copy) = (scene.geometry(two).unwrap(), replica.scene().geometry(two).unwrap());
    assert!(source.vertices() == copy.vertices(), "the replica's vertices differ from the source's");
    // Another scene on the same stream: a snapshot, not a delta on top.
    let mut other = Scene::new();
    other.add_node("elsewhere", Transform::IDENTITY);
    let delta = stream.next(&other);
    assert!(delta.is_snapshot());
    replica.apply(&delta).unwrap();
    assert_eq!(scene_difference(&other, replica.scene()), None);
}
