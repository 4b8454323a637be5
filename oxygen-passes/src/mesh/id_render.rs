//! An ID render: a view's opaque and masked draws drawn once more, depth
//! and (when asked) the instance ids only, into targets of their own. It is
//! how a view that draws no instance labels — it did not ask for them, or
//! it is multisampled, where labels are refused — still answers "which
//! node is at this pixel" ([`region_camera`] narrows the camera to one
//! pixel, so the render is one pixel), has its selection outlined, and
//! gives the overlay a single-sampled depth to test world shapes against.
//!
//! A single-sampled view of its own targets needs no second depth: its
//! ids are drawn over the depth its passes left ([`ids_over_depth`]).
//!
//! The draws are the view's own from its last prepared frame: the same
//! partitions, the same GPU-culled commands. A rectangle of the image sees
//! a part of the view's frustum, so nothing the view drew there is
//! missing, and what the view culled was not visible there either. The
//! passes are [`MeshPass::depth_pre_pass`] and [`MeshPass::labels`], so a
//! pixel's id is that of the nearest opaque or masked surface, as in the
//! labels a view draws with its shading.

use glam::{Mat4, Vec4};
use oxygen_bindless::{CameraConstants, SceneConstantsBuffer};
use oxygen_core::ResolvedView;
use oxygen_gpu::{Label, LabelSet, LabelTargets, ViewTargets};
use tracing::Instrument;

use super::MeshPass;
use crate::{CommandRecorder, PassError, RenderContext, RenderPass};

/// The label planes an ID render draws.
pub const ID_LABELS: LabelSet = LabelSet::NONE.with(Label::Instance);

/// Targets for an ID render of `width × height` pixels: a depth of their
/// own and, with `ids`, an instance plane ([`ID_LABELS`]).
pub fn id_targets(device: &wgpu::Device, width: u32, height: u32, ids: bool, label: &str) -> ViewTargets {
    let targets = ViewTargets::depth_only(device, width, height, label);
    if ids { targets.with_labels(device, ID_LABELS, label) } else { targets }
}

/// The camera of `view` seeing only the rectangle `[x, y, width, height]`
/// of its image (pixels, from the top-left corner): the projection is
/// followed by the scale and offset that stretch that rectangle over the
/// whole clip space, so a target of `width × height` pixels shows exactly
/// those pixels of the view, each at its own pixel centre. `None` for an
/// empty rectangle or one outside the view.
pub fn region_camera(view: &ResolvedView, [x, y, width, height]: [u32; 4]) -> Option<CameraConstants> {
    let (w, h) = (view.viewport.x, view.viewport.y);
    if width == 0 || height == 0 || x.checked_add(width)? > w || y.checked_add(height)? > h {
        return None;
    }
    // The rectangle in normalised device coordinates (y up).
    let (w, h) = (w as f32, h as f32);
    let (left, right) = (2.0 * x as f32 / w - 1.0, 2.0 * (x + width) as f32 / w - 1.0);
    let (top, bottom) = (1.0 - 2.0 * y as f32 / h, 1.0 - 2.0 * (y + height) as f32 / h);
    let (sx, sy) = (2.0 / (right - left), 2.0 / (top - bottom));
    let (cx, cy) = ((left + right) * 0.5, (top + bottom) * 0.5);
    // Clip space: x' = sx (x − cx w), so x'/w = sx (x/w − cx); depth kept.
    let narrow = Mat4::from_cols(
        Vec4::new(sx, 0.0, 0.0, 0.0),
        Vec4::new(0.0, sy, 0.0, 0.0),
        Vec4::Z,
        Vec4::new(-sx * cx, -sy * cy, 0.0, 1.0),
    );
    let projection = narrow * view.projection;
    let view_projection = narrow * view.view_projection;
    let inverse = view_projection.inverse();
    inverse
        .is_finite()
        .then(|| CameraConstants::new(view.view, projection, view_projection, inverse, view.camera_position))
}

/// Targets for the ids of a single-sampled view of its own targets (not
/// a batch's camera), drawn over the depth it already has: its depth
/// shared, `ids` (of its size, [`ID_LABELS`]) as the label planes. `None`
/// for a multisampled view or a camera of a batch, whose depth does not
/// match an image of the view's size; those need an ID render of their own.
pub fn ids_over_depth(view: &ViewTargets, ids: &LabelTargets) -> Option<ViewTargets> {
    if view.msaa.is_some() || view.tile.is_some() {
        return None;
    }
    Some(ViewTargets {
        color: None,
        depth: view.depth.clone(),
        depth_view: view.depth_view.clone(),
        depth_layer: view.depth_layer,
        owns_depth: false,
        width: view.width,
        height: view.height,
        msaa: None,
        tile: None,
        labels: Some(ids.clone()),
        page_kept: false,
        deferred: None,
    })
}

/// Records an ID render of `ctx`'s view into `targets` (from
/// [`id_targets`]) with the camera in `constants` (the view's own, or
/// [`region_camera`] for a part of it): the depth of the opaque and masked
/// draws, cleared first, then, when the targets have an instance plane,
/// the id of the node nearest at each pixel plus one (0: none).
pub async fn record_id_render(
    ctx: &RenderContext<'_>,
    targets: &ViewTargets,
    constants: &SceneConstantsBuffer,
    rec: &mut CommandRecorder,
) -> Result<(), PassError> {
    let span =
        tracing::info_span!("id_render", view = %ctx.view.view_id, width = targets.width, height = targets.height);
    let ctx = ctx.drawing_into(targets, constants);
    async {
        MeshPass::depth_pre_pass().named("id render (depth)").run(&ctx, rec).await?;
        if targets.labels.is_some() {
            MeshPass::labels().named("id render").run(&ctx, rec).await?;
        }
        Ok(())
    }
    .instrument(span)
    .await
}

/// Records the ids of `ctx`'s view over the depth its passes left (into
/// `targets` from [`ids_over_depth`]): only the labels pass, each pixel's
/// id that of the surface the view shows there (as labels drawn with the
/// shading would be). Half an ID render's work.
pub async fn record_ids_over_depth(
    ctx: &RenderContext<'_>,
    targets: &ViewTargets,
    rec: &mut CommandRecorder,
) -> Result<(), PassError> {
    let span = tracing::info_span!("ids_over_depth", view = %ctx.view.view_id);
    let ctx = ctx.drawing_into(targets, ctx.scene_constants);
    MeshPass::labels().named("ids over depth").run(&ctx, rec).instrument(span).await
}

#[cfg(test)]
mod tests {
    use glam::{UVec2, Vec3};
    use oxygen_core::{Camera, ViewIds};

    use super::*;

    fn view() -> ResolvedView {
        view_of(Camera::perspective(1.0, 0.1, Some(100.0)))
    }

    fn view_of(camera: Camera) -> ResolvedView {
        let eye = Vec3::new(0.0, 1.0, 5.0);
        let world_to_view = Mat4::look_at_rh(eye, Vec3::ZERO, Vec3::Y);
        let viewport = UVec2::new(64, 48);
        let projection = camera.projection_matrix(viewport.x as f32 / viewport.y as f32).unwrap();
        ResolvedView::new(ViewIds::default().allocate(), world_to_view, projection, viewport, 0.1, 100.0).unwrap()
    }

    /// A world point seen at pixel (px, py) of the view lands at the centre
    /// of the one-pixel camera of that pixel, and at the same depth.
    #[test]
    fn a_pixels_camera_centres_what_the_view_shows_there() {
        for view in [view(), view_of(Camera::orthographic(3.0, 0.1, 50.0))] {
            centres_each_pixel(&view);
        }
    }

    fn centres_each_pixel(view: &ResolvedView) {
        for (px, py) in [(0u32, 0u32), (10, 20), (63, 47), (31, 24)] {
            // The ray through the pixel's centre, 7 m deep.
            let ndc = glam::Vec2::new((px as f32 + 0.5) / 64.0 * 2.0 - 1.0, 1.0 - (py as f32 + 0.5) / 48.0 * 2.0);
            let near = view.inverse_view_projection.project_point3(ndc.extend(1.0));
            let far = view.inverse_view_projection.project_point3(ndc.extend(0.01));
            let point = near + (far - near).normalize() * 7.0;
            let camera = region_camera(view, [px, py, 1, 1]).unwrap();
            let narrow = Mat4::from_cols_array_2d(&camera.view_projection);
            let seen = narrow.project_point3(point);
            let full = view.view_projection.project_point3(point);
            assert!(seen.x.abs() < 1e-3 && seen.y.abs() < 1e-3, "pixel ({px}, {py}): {seen}");
            assert!((seen.z - full.z).abs() < 1e-6, "depth changed: {} against {}", seen.z, full.z);
            // Its inverse undoes it.
            let back = Mat4::from_cols_array_2d(&camera.inverse_view_projection).project_point3(seen);
            assert!((back - point).length() < 1e-3 * point.length(), "{back} against {point}");
        }
        // The whole image is the view itself.
        let whole = region_camera(view, [0, 0, 64, 48]).unwrap();
        let vp = Mat4::from_cols_array_2d(&whole.view_projection);
        assert!(vp.abs_diff_eq(view.view_projection, 1e-6));
    }

    #[test]
    fn a_rectangle_outside_the_view_or_empty_has_no_camera() {
        let view = view();
        assert!(region_camera(&view, [64, 0, 1, 1]).is_none());
        assert!(region_camera(&view, [0, 47, 1, 2]).is_none());
        assert!(region_camera(&view, [3, 3, 0, 1]).is_none());
        assert!(region_camera(&view, [u32::MAX, 0, 2, 1]).is_none());
    }
}
