//! A scene replicated by deltas renders what the original renders, bit for
//! bit (the deterministic mode): two renderers, one on the source scene and
//! one on a replica kept in step by encoded deltas, over a long seeded
//! sequence of random edits (nodes added, moved, re-parented, removed;
//! meshes, materials, textures and lights added and changed), compared on
//! colour, depth and the instance and class planes of two views after
//! every few deltas. The replica's renderer culls on the GPU where the
//! adapter can (the source's on the CPU): the deltas, not one path, carry
//! the equality.

mod support;

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};

use oxygen::core::scene::delta::{DeltaStream, SceneDelta, SceneReplica};
use oxygen::core::{AlphaMode, ColorSpace, NodeFlags, TextureImage};
use oxygen::glam::{Quat, Vec4};
use oxygen::prelude::*;
use oxygen::sceneprep::Visibility;
use support::rng::Rng;

/// Every output of `view`, hashed bit for bit.
fn fingerprint(renderer: &Renderer, view: ViewId) -> u64 {
    let mut hasher = DefaultHasher::new();
    renderer.read_color(view).unwrap().as_raw().hash(&mut hasher);
    let depth: Vec<u32> = renderer.read_depth(view).unwrap().depth.iter().map(|d| d.to_bits()).collect();
    depth.hash(&mut hasher);
    let labels = renderer.read_labels(view).unwrap();
    labels.instances.hash(&mut hasher);
    labels.classes.hash(&mut hasher);
    hasher.finish()
}

#[test]
fn a_replica_kept_in_step_by_deltas_renders_the_same_pixels() {
    let mut rng = Rng(0xDE17A);
    let mut scene = Scene::new();
    let mut geometries = vec![scene.add_geometry(Geometry::cube(1.0)), scene.add_geometry(Geometry::cube(0.7))];
    let texture = TextureImage::new(
        "checker",
        2,
        2,
        ColorSpace::Srgb,
        vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255],
    )
    .unwrap();
    let texture = scene.add_texture(texture);
    let mut materials: Vec<_> = (0..4)
        .map(|i| {
            let material = Material {
                base_color_texture: (i == 3).then_some(texture),
                alpha_mode: if i == 2 { AlphaMode::Mask { cutoff: 0.5 } } else { AlphaMode::Opaque },
                ..Material::opaque(format!("m{i}"), Vec4::new(0.2 + 0.2 * i as f32, 0.5, 0.8 - 0.2 * i as f32, 1.0))
            };
            scene.add_material(material)
        })
        .collect();
    let sun = scene.add_node("sun", Transform::IDENTITY.with_rotation(Quat::from_rotation_x(-0.9)));
    scene.set_light(sun, Some(Light::directional(3.0))).unwrap();
    let floor = scene.add_node(
        "floor",
        Transform::from_translation(Vec3::new(0.0, -1.0, 0.0)).with_scale(Vec3::new(12.0, 0.2, 12.0)),
    );
    scene.set_renderable(floor, Renderable { geometry: geometries[0], materials: vec![materials[0]] }).unwrap();
    let mut nodes = Vec::new();

    let size = UVec2::new(64, 48);
    let camera = |eye| support::looking_at_origin(60.0, eye, size);
    let views = [Vec3::new(0.0, 6.0, 10.0), Vec3::new(-9.0, 4.0, -3.0)];
    let mut source = support::gpu_renderer_with(RendererOptions {
        deterministic: true,
        visibility: Some(Visibility::Cpu),
        ..Default::default()
    });
    let replica_visibility = if source.gpu_visibility_supported() { Visibility::GpuFrustum } else { Visibility::Cpu };
    let mut mirror = support::gpu_renderer_with(RendererOptions {
        deterministic: true,
        visibility: Some(replica_visibility),
        prep_threads: Some(2),
        ..Default::default()
    });
    let register = |renderer: &mut Renderer| -> Vec<ViewId> {
        views
            .iter()
            .map(|eye| {
                renderer.register_view(ViewDesc::new(camera(*eye)).with_labels(), standard_render_graph).unwrap()
            })
            .collect()
    };
    let (source_views, mirror_views) = (register(&mut source), register(&mut mirror));

    let mut stream = DeltaStream::new();
    let mut replica = SceneReplica::new();
    let (mut compared, mut wire) = (0, 0usize);
    for round in 0..40 {
        for _ in 0..1 + rng.below(12) {
            nodes.retain(|k| scene.node(*k).is_some());
            let pick = |rng: &mut Rng| nodes.get(rng.below(nodes.len())).copied();
            match rng.below(10) {
                0..=2 => {
                    let at = Vec3::new(rng.unit() * 8.0 - 4.0, rng.unit(), rng.unit() * 8.0 - 4.0);
                    let key = match pick(&mut rng).filter(|_| rng.below(3) == 0) {
                        Some(parent) => {
                            scene.add_child(parent, "part", Transform::from_translation(Vec3::Y * 1.2)).unwrap()
                        }
                        None => scene.add_node("box", Transform::from_translation(at)),
                    };
                    let geometry = geometries[rng.below(geometries.len())];
                    let material = materials[rng.below(materials.len())];
                    scene.set_renderable(key, Renderable { geometry, materials: vec![material] }).unwrap();
                    scene.set_semantic_class(key, 1 + rng.below(5) as u32).unwrap();
                    nodes.push(key);
                }
                3 => {
                    if let Some(key) = pick(&mut rng) {
                        scene.remove_node(key).unwrap();
                    }
                }
                4..=5 => {
                    if let Some(key) = pick(&mut rng) {
                        let at = Vec3::new(rng.unit() * 8.0 - 4.0, rng.unit(), rng.unit() * 8.0 - 4.0);
                        let t = Transform {
                            translation: at,
                            rotation: Quat::from_rotation_y(rng.unit() * 6.0),
                            scale: Vec3::ONE,
                        };
                        scene.set_local_transform(key, t).unwrap();
                    }
                }
                6 => {
                    let handle = materials[rng.below(materials.len())];
                    let material = Material {
                        base_color: Vec4::new(rng.unit(), rng.unit(), rng.unit(), 1.0),
                        ..scene.material(handle).unwrap().clone()
                    };
                    scene.set_material(handle, material).unwrap();
                }
                7 => {
                    if rng.below(2) == 0 {
                        geometries.push(scene.add_geometry(Geometry::uv_sphere(0.6, 12, 8)));
                    } else {
                        materials
                            .push(scene.add_material(Material::opaque("new", Vec4::new(rng.unit(), 0.3, 0.3, 1.0))));
                    }
                }
                8 => {
                    if let (Some(child), Some(parent)) = (pick(&mut rng), pick(&mut rng)) {
                        let _ = scene.set_parent(child, Some(parent));
                    }
                }
                _ => {
                    if let Some(key) = pick(&mut rng) {
                        let flags = if rng.below(3) == 0 {
                            NodeFlags::VISIBLE
                        } else {
                            NodeFlags::VISIBLE | NodeFlags::CASTS_SHADOWS
                        };
                        scene.set_flags(key, flags).unwrap();
                    }
                }
            }
        }
        let bytes = stream.next(&scene).encode();
        wire += bytes.len();
        replica.apply(&SceneDelta::decode(&bytes).unwrap()).unwrap();
        // Both render every round (each keeps its own history); the
        // pictures are compared every other round.
        source.render_frame(&scene).unwrap();
        mirror.render_frame(replica.scene()).unwrap();
        if round % 2 == 1 {
            for (view, (a, b)) in source_views.iter().zip(&mirror_views).enumerate() {
                assert_eq!(
                    fingerprint(&source, *a),
                    fingerprint(&mirror, *b),
                    "round {round}, view {view}: the replica's picture differs"
                );
            }
            compared += 1;
        }
    }
    eprintln!("{compared} comparisons, {} nodes at the end, {wire} bytes of deltas", scene.node_count());
    assert!(scene.node_count() > 10);
}
