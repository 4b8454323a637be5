//! The view phase: per view, from the shared renderable list to render items.
//!
//! A chain of small steps over [`FrameCollection::renderables`]:
//! 1. **pre-filter** by the view's [`ViewFilter`] (a shadow view takes
//!    casters only);
//! 2. **visibility** against the view frustum with the view's [`CullBound`]
//!    (both conservative: they may keep an invisible object, never drop a
//!    visible one);
//! 3. **produce** one [`RenderItem`] per submesh, with its material's
//!    [`PassMask`] and its view depth.

use oxygen_core::scene::material_index;
use oxygen_core::{NodeFlags, ResolvedView, Scene};
use tracing::info_span;

use crate::{FrameCollection, PassMask};

/// Which renderables a view wants at all.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ViewFilter {
    /// Every visible renderable.
    #[default]
    All,
    /// Only shadow casters (shadow views).
    ShadowCastersOnly,
}

/// The bound tested against the frustum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CullBound {
    /// World AABB by the p-vertex method: tighter.
    #[default]
    Aabb,
    /// Bounding sphere: cheaper, looser.
    Sphere,
}

/// Per-view choices for ScenePrep.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ViewPrepOptions {
    /// Pre-filter.
    pub filter: ViewFilter,
    /// Visibility test bound.
    pub cull: CullBound,
}

/// One submesh of one visible renderable, ready for finalization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderItem {
    /// Index into [`FrameCollection::renderables`].
    pub renderable: u32,
    /// Submesh number.
    pub submesh: u32,
    /// Stable material id.
    pub material: u32,
    /// Pass class and variant (plus shadow bit).
    pub pass_mask: PassMask,
    /// Distance of the bound's centre along the view direction.
    pub view_depth: f32,
}

/// Runs the view phase for one view, appending to `items` (cleared first).
pub fn collect_view(
    scene: &Scene,
    frame: &FrameCollection,
    view: &ResolvedView,
    options: &ViewPrepOptions,
    items: &mut Vec<RenderItem>,
) {
    let _span = info_span!("view_phase", view = %view.view_id).entered();
    items.clear();
    // View-space depth of a world point is -(row 2 of the view matrix) · p.
    let view_row_z = view.view.row(2);
    for (i, entry) in frame.renderables.iter().enumerate() {
        if options.filter == ViewFilter::ShadowCastersOnly && !entry.flags.contains(NodeFlags::CASTS_SHADOWS) {
            continue;
        }
        let visible = match options.cull {
            CullBound::Aabb => view.frustum.intersects_aabb(&entry.world_aabb),
            CullBound::Sphere => view.frustum.intersects_sphere(&entry.world_sphere),
        };
        if !visible {
            continue;
        }
        let center = entry.world_sphere.center;
        let view_depth = -(view_row_z.truncate().dot(center) + view_row_z.w);
        // The node was checked in the frame phase; a renderable always exists.
        let Some(renderable) = scene.node(entry.node).and_then(|n| n.renderable.as_ref()) else { continue };
        for (submesh, material_handle) in renderable.materials.iter().enumerate() {
            let Some(material) = scene.material(*material_handle) else { continue };
            let mut pass_mask = PassMask::for_material(material.alpha_mode, material.double_sided);
            if entry.flags.contains(NodeFlags::CASTS_SHADOWS) {
                pass_mask |= PassMask::CASTS_SHADOWS;
            }
            items.push(RenderItem {
                renderable: i as u32,
                submesh: submesh as u32,
                material: material_index(*material_handle),
                pass_mask,
                view_depth,
            });
        }
    }
}
