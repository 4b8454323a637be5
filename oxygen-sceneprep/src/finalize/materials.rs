//! The material table: one record per material id, uploaded only on change.
//!
//! Material ids are the scene's stable material slot indices, so a draw's
//! `material_handle` indexes this table directly.

use oxygen_bindless::{Allocation, DomainKind, SlotAllocators, SlotError};
use oxygen_core::Scene;
use oxygen_core::scene::material_index;

use crate::MaterialRecord;
use crate::finalize::texture_cache::TextureCache;

/// What the scene's materials need of a shading pipeline, found while the
/// table is synced (the one walk over the materials a frame makes), so that
/// shaders can leave out what no material uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaterialFeatures {
    /// Some material names a texture (whether or not the scene holds it:
    /// the pipeline keeps the sampling path and reads the absent slot).
    pub textures: bool,
    /// Some material reads a second UV set or has a texture transform.
    pub uv_transforms: bool,
}

impl MaterialFeatures {
    /// Every feature: what a pipeline must carry before the scene is known.
    pub const ALL: MaterialFeatures = MaterialFeatures { textures: true, uv_transforms: true };

    /// The features `material` needs.
    pub fn of(material: &oxygen_core::Material) -> Self {
        MaterialFeatures {
            textures: [
                material.base_color_texture,
                material.metallic_roughness_texture,
                material.normal_texture,
                material.emissive_texture,
                material.occlusion_texture,
            ]
            .iter()
            .any(Option::is_some),
            uv_transforms: !material.uvs.is_identity(),
        }
    }

    /// What either needs.
    pub fn union(self, other: MaterialFeatures) -> Self {
        MaterialFeatures {
            textures: self.textures || other.textures,
            uv_transforms: self.uv_transforms || other.uv_transforms,
        }
    }
}

/// The CPU copy of the material domain range and whether the GPU is behind.
pub struct MaterialTable {
    records: Vec<MaterialRecord>,
    features: MaterialFeatures,
    scratch: Vec<MaterialRecord>,
    allocation: Allocation,
    dirty: bool,
}

impl Default for MaterialTable {
    fn default() -> Self {
        MaterialTable {
            records: Vec::new(),
            features: MaterialFeatures::default(),
            scratch: Vec::new(),
            allocation: Allocation::empty(DomainKind::Materials),
            dirty: false,
        }
    }
}

fn placeholder() -> MaterialRecord {
    MaterialRecord::from_material(&oxygen_core::Material::opaque("", glam::Vec4::ONE))
}

impl MaterialTable {
    /// Rebuilds the records from the scene; marks the table dirty only when
    /// something differs, and re-allocates only when it grew or shrank.
    pub fn sync(
        &mut self,
        scene: &Scene,
        slots: &mut SlotAllocators,
        textures: &mut TextureCache,
    ) -> Result<(), SlotError> {
        self.scratch.clear();
        let mut features = MaterialFeatures::default();
        for (handle, material) in scene.materials() {
            features = features.union(MaterialFeatures::of(material));
            let i = material_index(handle) as usize;
            if self.scratch.len() <= i {
                self.scratch.resize(i + 1, placeholder());
            }
            let mut record = MaterialRecord::from_material(material);
            let mut resolve = |texture: Option<oxygen_core::TextureHandle>, what: &str| -> Result<u32, SlotError> {
                let Some(texture) = texture else { return Ok(oxygen_bindless::INVALID_SLOT) };
                match scene.texture(texture) {
                    Some(image) => textures.resolve(texture, image, slots),
                    None => {
                        tracing::warn!(material = %material.name, "{what} texture missing; ignored");
                        Ok(oxygen_bindless::INVALID_SLOT)
                    }
                }
            };
            record.base_color_texture = resolve(material.base_color_texture, "base-colour")?;
            record.metallic_roughness_texture = resolve(material.metallic_roughness_texture, "metallic-roughness")?;
            record.normal_texture = resolve(material.normal_texture, "normal")?;
            record.emissive_texture = resolve(material.emissive_texture, "emissive")?;
            record.occlusion_texture = resolve(material.occlusion_texture, "occlusion")?;
            self.scratch[i] = record;
        }
        self.features = features;
        if self.scratch != self.records {
            std::mem::swap(&mut self.scratch, &mut self.records);
            self.dirty = true;
        }
        if self.allocation.count as usize != self.records.len() {
            slots.free(self.allocation)?;
            self.allocation = Allocation::empty(DomainKind::Materials);
            self.allocation = slots.allocate(DomainKind::Materials, self.records.len() as u32)?;
            self.dirty = true;
        }
        Ok(())
    }

    /// The records, indexed by material id.
    pub fn records(&self) -> &[MaterialRecord] {
        &self.records
    }

    /// What the scene's materials need of a shading pipeline, as of the
    /// last sync.
    pub fn features(&self) -> MaterialFeatures {
        self.features
    }

    /// Where the table lives.
    pub fn allocation(&self) -> Allocation {
        self.allocation
    }

    /// True when the GPU copy is out of date.
    pub fn is_dirty(&self) -> bool {
        self.dirty
    }

    /// Marks the GPU copy current.
    pub fn mark_uploaded(&mut self) {
        self.dirty = false;
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec4;
    use oxygen_core::Material;

    use super::*;

    /// The table holds one record per material, at the material's id, built
    /// from the material as the scene holds it: what the upload writes to
    /// the material range.
    #[test]
    fn records_are_the_scenes_materials_by_id() -> Result<(), SlotError> {
        let mut scene = Scene::new();
        let red = scene.add_material(Material::opaque("red", Vec4::new(1.0, 0.0, 0.0, 1.0)));
        let blue = scene.add_material(Material::opaque("blue", Vec4::new(0.0, 0.0, 1.0, 1.0)));
        let mut table = MaterialTable::default();
        table.sync(&scene, &mut SlotAllocators::default(), &mut TextureCache::default())?;
        let records = table.records();
        assert_eq!(records.len() as u32, table.allocation().count);
        for handle in [red, blue] {
            let expected = scene.material(handle).map(MaterialRecord::from_material);
            assert_eq!(records.get(material_index(handle) as usize), expected.as_ref());
        }
        Ok(())
    }

    /// The table is dirty (its GPU copy out of date) after a sync that
    /// found new or changed materials, and clean once uploaded until the
    /// scene's materials change again: an unchanged scene is not uploaded
    /// every frame, a changed one always is.
    #[test]
    fn the_table_is_dirty_exactly_until_uploaded_after_a_change() -> Result<(), Box<dyn std::error::Error>> {
        let mut scene = Scene::new();
        let material = scene.add_material(Material::opaque("m", Vec4::ONE));
        let mut slots = SlotAllocators::default();
        let mut textures = TextureCache::default();
        let mut table = MaterialTable::default();
        table.sync(&scene, &mut slots, &mut textures)?;
        assert!(table.is_dirty(), "new materials");
        table.mark_uploaded();
        assert!(!table.is_dirty(), "uploaded");
        table.sync(&scene, &mut slots, &mut textures)?;
        assert!(!table.is_dirty(), "nothing changed");
        scene.set_material(material, Material::opaque("m", Vec4::new(0.5, 0.5, 0.5, 1.0)))?;
        table.sync(&scene, &mut slots, &mut textures)?;
        assert!(table.is_dirty(), "a changed material");
        table.mark_uploaded();
        scene.add_material(Material::opaque("another", Vec4::ONE));
        table.sync(&scene, &mut slots, &mut textures)?;
        assert!(table.is_dirty(), "a new material");
        Ok(())
    }
}
