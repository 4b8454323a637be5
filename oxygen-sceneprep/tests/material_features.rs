//! The material table reports what the scene's materials need of a shading
//! pipeline (textures, UV transforms) while it syncs, so the renderer never
//! walks the materials a second time to specialise its shaders.

use glam::Vec4;
use oxygen_bindless::SlotAllocators;
use oxygen_core::{Material, Scene, TextureImage};
use oxygen_sceneprep::{MaterialFeatures, ScenePrep};

fn features(scene: &Scene) -> MaterialFeatures {
    let mut prep = ScenePrep::with_threads(1);
    prep.begin_frame(scene, &mut SlotAllocators::default()).expect("begin_frame");
    prep.material_features()
}

#[test]
fn plain_materials_need_neither_textures_nor_uv_transforms() {
    let mut scene = Scene::new();
    scene.add_material(Material::opaque("plain", Vec4::ONE));
    assert_eq!(features(&scene), MaterialFeatures::default());
}

#[test]
fn one_textured_material_and_one_transformed_one_need_both() {
    let mut scene = Scene::new();
    scene.add_material(Material::opaque("plain", Vec4::ONE));
    let checker = scene.add_texture(TextureImage::checker("checker", 8, 2, [255; 4], [0, 0, 0, 255]));
    let textured = Material { base_color_texture: Some(checker), ..Material::opaque("textured", Vec4::ONE) };
    let handle = scene.add_material(textured);
    assert_eq!(features(&scene), MaterialFeatures { textures: true, uv_transforms: false });
    let mut moved = scene.material(handle).expect("just added").clone();
    moved.uvs.emissive.uv_set = 1;
    scene.set_material(handle, moved).expect("the material exists");
    assert_eq!(features(&scene), MaterialFeatures::ALL);
}
