//! The view phase: per view, from the shared renderable list to render items.
//!
//! A chain of small steps over [`FrameCollection::renderables`]:
//! 1. **pre-filter** by the view's [`ViewFilter`] (a shadow view takes
//!    casters only);
//! 2. **visibility** against the view frustum with the view's [`CullBound`]
//!    (both conservative: they may keep an invisible object, never drop a
//!    visible one);
//! 3. **LOD selection** by the projected size of the bounding sphere, where
//!    a renderable has LOD levels (culling always uses the base mesh's bounds);
//! 4. **produce** one [`RenderItem`] per submesh, with its material's
//!    [`PassMask`] and its view depth. A depth-only view drops transparent
//!    submeshes and leaves materials out of the sort key.

use oxygen_core::{GeometryHandle, NodeFlags, ResolvedView, Scene};
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
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewPrepOptions {
    /// Pre-filter.
    pub filter: ViewFilter,
    /// Visibility test bound.
    pub cull: CullBound,
    /// Multiplies the projected size before LOD selection: above 1 keeps
    /// finer meshes longer (accuracy), below 1 switches earlier (speed).
    pub lod_bias: f32,
    /// The view only writes depth (shadow views): transparent submeshes are
    /// dropped and draws sort by pass class and depth only, not by material.
    pub depth_only: bool,
    /// Whether draws of one mesh become one instanced command.
    pub instancing: Instancing,
    /// Where visibility is decided: on the CPU (the reference), or by a
    /// compute shader per view ([`crate::Visibility`]). On a GPU path the
    /// CPU handles only the transparent draws.
    pub visibility: crate::Visibility,
    /// The view reads the ray-tracing scene ([`crate::RayScene`], for the
    /// path-traced reference): ScenePrep keeps it up to date while any
    /// view of the frame asks for it.
    pub ray_scene: bool,
}

impl Default for ViewPrepOptions {
    fn default() -> Self {
        ViewPrepOptions {
            filter: ViewFilter::All,
            cull: CullBound::Aabb,
            lod_bias: 1.0,
            depth_only: false,
            instancing: Instancing::default(),
            visibility: crate::Visibility::Cpu,
            ray_scene: false,
        }
    }
}

/// How a view's draws become draw commands.
///
/// The GPU pays a fixed front-end cost per command. Consecutive draws of a
/// partition that share their geometry (mesh, index range, base vertex)
/// can be one command whose `instance_count` is the run's length; each
/// instance still finds its own `DrawMetadata` through `first_instance +
/// instance_index`, so transforms and materials stay per draw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Instancing {
    /// One command per draw.
    Off,
    /// Runs that the sort already makes adjacent are merged; the draw order
    /// is unchanged.
    #[default]
    Adjacent,
    /// The sort key puts the geometry above the depth for opaque and masked
    /// draws, so every draw of one mesh and material joins one command;
    /// front-to-back order then holds within each mesh only.
    ByGeometry,
}

/// The fraction of the viewport height covered by a sphere's projected
/// diameter (for a perspective view, at the sphere centre's depth).
pub fn projected_screen_fraction(view: &ResolvedView, radius: f32, view_depth: f32) -> f32 {
    // projection.y_axis.y is cot(fov_y / 2) for perspective, 1 / half_height
    // for orthographic; w_axis.w is 0 for perspective, 1 for orthographic.
    let scale = view.projection.y_axis.y;
    if view.projection.w_axis.w == 0.0 { radius * scale / view_depth.max(view.near) } else { radius * scale }
}

/// One submesh of one visible renderable, ready for finalization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderItem {
    /// Index into [`FrameCollection::renderables`].
    pub renderable: u32,
    /// The mesh drawn: the renderable's geometry or one of its LODs.
    pub geometry: GeometryHandle,
    /// Submesh number.
    pub submesh: u32,
    /// Stable material id.
    pub material: u32,
    /// Pass class and variant (plus shadow bit).
    pub pass_mask: PassMask,
    /// Distance of the bound's centre along the view direction.
    pub view_depth: f32,
    /// The renderable's transform index (copied so finalization never
    /// revisits the renderable list in sorted, i.e. random, order).
    pub transform_index: u32,
    /// The renderable's stable node id.
    pub node_id: u32,
    /// First index of the submesh in `geometry`.
    pub first_index: u32,
    /// Index count of the submesh in `geometry`.
    pub index_count: u32,
    /// The renderable's first joint matrix, `INVALID_SLOT` when rigid.
    pub joint_base: u32,
    /// The renderable's morph header, `INVALID_SLOT` without morph targets.
    pub morph_base: u32,
}

/// Runs the view phase for one view, appending to `items` (cleared first):
/// over the renderables `subset` names (indices into
/// [`FrameCollection::renderables`], ascending), or all of them when `None`; with a GPU
/// [`crate::Visibility`] only transparent submeshes become items.
pub fn collect_view_subset(
    scene: &Scene,
    frame: &FrameCollection,
    view: &ResolvedView,
    options: &ViewPrepOptions,
    subset: Option<&[u32]>,
    items: &mut Vec<RenderItem>,
) {
    let _span = info_span!("view_phase", view = %view.view_id).entered();
    items.clear();
    // View-space depth of a world point is -(row 2 of the view matrix) · p.
    let view_row_z = view.view.row(2);
    let transparent_only = options.visibility.on_gpu();
    // One iterator type for both cases, so nothing is boxed per frame.
    let (all, listed) = match subset {
        Some(subset) => (0..0, subset),
        None => (0..frame.renderables.len(), &[][..]),
    };
    for i in all.chain(listed.iter().map(|&i| i as usize)) {
        let Some(entry) = frame.renderables.get(i) else { continue };
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
        let mut lod_geometry = None;
        let (lod_start, lod_count) = entry.lods;
        if lod_count > 0 {
            // The projected diameter's share of the viewport height, as
            // `LodLevel::below_screen_fraction` is documented (it was twice
            // that until the mutation work of issue 27 found it).
            let fraction = projected_screen_fraction(view, entry.world_sphere.radius, view_depth) * options.lod_bias;
            for lod in &frame.lod_levels[lod_start as usize..(lod_start + lod_count) as usize] {
                if fraction < lod.below_screen_fraction {
                    lod_geometry = Some(lod.geometry);
                }
            }
        }
        // Submesh data was cached by the frame phase, so the view phase reads
        // only the frame's contiguous arrays, never the scene; a LOD only
        // swaps the index ranges.
        let lod_mesh = lod_geometry.and_then(|g| scene.geometry(g).map(|m| (g, m)));
        let (start, count) = entry.submeshes;
        for (submesh, cached) in frame.submeshes[start as usize..(start + count) as usize].iter().enumerate() {
            let transparent = cached.pass_mask.contains(PassMask::TRANSPARENT);
            if (options.depth_only && transparent) || (transparent_only && !transparent) {
                continue;
            }
            let (geometry, first_index, index_count) = match &lod_mesh {
                Some((handle, mesh)) => {
                    let range = mesh.submeshes()[submesh];
                    (*handle, range.first_index, range.index_count)
                }
                None => (entry.geometry, cached.first_index, cached.index_count),
            };
            items.push(RenderItem {
                renderable: i as u32,
                geometry,
                submesh: submesh as u32,
                material: cached.material,
                pass_mask: cached.pass_mask,
                view_depth,
                transform_index: entry.transform_index,
                node_id: entry.node_id,
                first_index,
                index_count,
                joint_base: entry.joint_base,
                morph_base: entry.morph_base,
            });
        }
    }
}
