//! Shapes to vertices for one view: every shape becomes triangles in clip
//! space. Screen shapes lie on the near plane (depth 1 in reverse-Z, which
//! passes any depth test); world shapes are projected in `f64`, cut at the
//! near plane and at a guard band around the screen, widened in pixels,
//! and keep their depth (drawn a hair nearer, so a line on a surface is not
//! hidden by it) or go on top.

use glam::{DMat4, DVec3, DVec4, Mat4, UVec2, Vec2};

use crate::canvas::{DepthMode, Grid, Overlay, Shape};
use crate::text::{PlacedGlyph, glyph_rect};

/// What the fragment shader does with a vertex's `local` and `params`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum VertexKind {
    /// The colour as it is.
    Solid = 0,
    /// A line: `local.x` is the distance across it in pixels, `params.x`
    /// half its width; coverage falls off over the last pixel.
    Line = 1,
    /// A disc, ring or arc: `local` is the offset from its centre in
    /// pixels, `params` its outer and inner radius and its start and sweep
    /// in radians.
    Arc = 2,
    /// A texel of the atlas (glyph or image) at `local`, times the colour.
    Atlas = 3,
}

/// One corner of an overlay triangle, as the vertex buffer holds it
/// (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OverlayVertex {
    /// Clip position, `w` = 1 (positions are already divided).
    pub clip: [f32; 4],
    /// Per-kind coordinates (see [`VertexKind`]).
    pub local: [f32; 2],
    /// Per-kind parameters (see [`VertexKind`]).
    pub params: [f32; 4],
    /// sRGB colour, straight alpha.
    pub color: [u8; 4],
    /// A [`VertexKind`].
    pub kind: u32,
}

/// The camera an overlay is drawn for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverlayView {
    /// World (absolute, not relative to a render origin) → clip, reverse-Z.
    pub world_to_clip: DMat4,
    /// The eye in the world (for an orthographic view, its position).
    pub eye: DVec3,
    /// The view's size in pixels.
    pub viewport: UVec2,
}

impl OverlayView {
    /// The camera of a view with this projection, world → view transform
    /// (absolute) and size.
    pub fn new(projection: Mat4, world_to_view: DMat4, viewport: UVec2) -> OverlayView {
        OverlayView {
            world_to_clip: projection.as_dmat4() * world_to_view,
            eye: world_to_view.inverse().w_axis.truncate(),
            viewport,
        }
    }
}

/// A placed glyph and its atlas corners (top-left, bottom-right).
type GlyphUv = (PlacedGlyph, ([f32; 2], [f32; 2]));

/// Depth a tested world shape is drawn nearer by, as a share of its own
/// (reverse-Z: larger is nearer): a line lying on a surface is not hidden
/// by it.
const DEPTH_NUDGE: f64 = 1.0e-4;
/// Segments of each grid line (its fade is linear along each).
const GRID_SEGMENTS: u32 = 16;
/// Widths of the screen around it that world lines are cut to.
const GUARD: f64 = 1.0;

struct Out<'a> {
    vertices: &'a mut Vec<OverlayVertex>,
    size: Vec2,
}

impl Out<'_> {
    fn ndc(&self, p: Vec2) -> [f32; 2] {
        [p.x / self.size.x * 2.0 - 1.0, 1.0 - p.y / self.size.y * 2.0]
    }

    /// Two triangles over corners `p` (in order round the quad), each with
    /// its depth, local coordinates and colour.
    fn quad(
        &mut self,
        p: [Vec2; 4],
        z: [f32; 4],
        local: [Vec2; 4],
        params: [f32; 4],
        color: [[u8; 4]; 4],
        kind: VertexKind,
    ) {
        for i in [0, 1, 2, 0, 2, 3] {
            let [x, y] = self.ndc(p[i]);
            self.vertices.push(OverlayVertex {
                clip: [x, y, z[i], 1.0],
                local: local[i].to_array(),
                params,
                color: color[i],
                kind: kind as u32,
            });
        }
    }

    fn rect(&mut self, min: Vec2, max: Vec2, uv: Option<([f32; 2], [f32; 2])>, color: [u8; 4]) {
        let p = [min, Vec2::new(max.x, min.y), max, Vec2::new(min.x, max.y)];
        let (kind, local) = match uv {
            Some((a, b)) => {
                (VertexKind::Atlas, [Vec2::from(a), Vec2::new(b[0], a[1]), Vec2::from(b), Vec2::new(a[0], b[1])])
            }
            None => (VertexKind::Solid, [Vec2::ZERO; 4]),
        };
        self.quad(p, [1.0; 4], local, [0.0; 4], [color; 4], kind);
    }

    /// A line from `a` to `b` (pixels) at depths `za`, `zb`, coloured `ca`
    /// to `cb`: a quad a pixel wider on each side for the fall-off, and half
    /// its width longer at each end (square ends).
    fn line(&mut self, (a, za, ca): (Vec2, f32, [u8; 4]), (b, zb, cb): (Vec2, f32, [u8; 4]), width: f32) {
        let half = width * 0.5;
        let along = b - a;
        let dir = if along.length_squared() > 1e-12 { along.normalize() } else { Vec2::X };
        let across = dir.perp();
        let reach = half + 1.0;
        let (a, b) = (a - dir * half, b + dir * half);
        let p = [a - across * reach, b - across * reach, b + across * reach, a + across * reach];
        let local = [Vec2::new(-reach, 0.0), Vec2::new(-reach, 0.0), Vec2::new(reach, 0.0), Vec2::new(reach, 0.0)];
        self.quad(p, [za, zb, zb, za], local, [half, 0.0, 0.0, 0.0], [ca, cb, cb, ca], VertexKind::Line);
    }

    fn arc(&mut self, center: Vec2, radius: f32, width: f32, start: f32, sweep: f32, color: [u8; 4]) {
        let (outer, inner) = if width > 0.0 { (radius + width * 0.5, radius - width * 0.5) } else { (radius, -1.0) };
        let r = outer + 1.0;
        let local = [Vec2::new(-r, -r), Vec2::new(r, -r), Vec2::new(r, r), Vec2::new(-r, r)];
        let p = local.map(|l| center + l);
        self.quad(p, [1.0; 4], local, [outer, inner, start, sweep], [color; 4], VertexKind::Arc);
    }

    fn glyphs(&mut self, at: Vec2, z: f32, glyphs: &[GlyphUv], color: [u8; 4]) {
        for (glyph, uv) in glyphs {
            let min = at + glyph.offset;
            let p = [min, min + Vec2::new(glyph.size.x, 0.0), min + glyph.size, min + Vec2::new(0.0, glyph.size.y)];
            let (a, b) = *uv;
            let local = [Vec2::from(a), Vec2::new(b[0], a[1]), Vec2::from(b), Vec2::new(a[0], b[1])];
            self.quad(p, [z; 4], local, [0.0; 4], [color; 4], VertexKind::Atlas);
        }
    }
}

/// Where a world point lands: pixel position and device depth, or `None`
/// behind the near plane.
fn project(view: &OverlayView, size: Vec2, p: DVec3) -> Option<(Vec2, f32)> {
    let c = view.world_to_clip * p.extend(1.0);
    if !(c.w > 0.0 && c.w - c.z >= 0.0) {
        return None;
    }
    Some((to_pixels(c, size), (c.z / c.w) as f32))
}

fn to_pixels(c: DVec4, size: Vec2) -> Vec2 {
    let (x, y) = (c.x / c.w, c.y / c.w);
    Vec2::new(((x + 1.0) * 0.5 * f64::from(size.x)) as f32, ((1.0 - y) * 0.5 * f64::from(size.y)) as f32)
}

/// The part of a world segment in front of the near plane, then inside the
/// guard band, as pixel positions, depths and how far along the segment
/// (0 at `a`, 1 at `b`, for its colours) at its ends.
fn project_segment(view: &OverlayView, size: Vec2, a: DVec3, b: DVec3) -> Option<[(Vec2, f64, f64); 2]> {
    let (mut ca, mut cb) = (view.world_to_clip * a.extend(1.0), view.world_to_clip * b.extend(1.0));
    // Reverse-Z: in front of the near plane where w − z ≥ 0.
    let (da, db) = (ca.w - ca.z, cb.w - cb.z);
    if !(da >= 0.0 || db >= 0.0) {
        return None;
    }
    let (mut ta, mut tb) = (0.0, 1.0);
    if da < 0.0 {
        ta = da / (da - db);
        ca = ca + (cb - ca) * ta;
    } else if db < 0.0 {
        tb = da / (da - db);
        cb = ca + (cb - ca) * tb;
    }
    if !(ca.w > 0.0 && cb.w > 0.0) {
        return None;
    }
    let (pa, pb) = (to_pixels(ca, size).as_dvec2(), to_pixels(cb, size).as_dvec2());
    let (za, zb) = (ca.z / ca.w, cb.z / cb.w);
    // Liang–Barsky against the screen widened by GUARD screens each way:
    // depth is affine across the screen, so it is cut with the position.
    let (w, h) = (f64::from(size.x), f64::from(size.y));
    let (lo, hi) = (glam::DVec2::new(-GUARD * w, -GUARD * h), glam::DVec2::new((1.0 + GUARD) * w, (1.0 + GUARD) * h));
    let d = pb - pa;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-d.x, pa.x - lo.x), (d.x, hi.x - pa.x), (-d.y, pa.y - lo.y), (d.y, hi.y - pa.y)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0.is_nan() || t1.is_nan() || t0 > t1 {
        return None;
    }
    // Colours are interpolated across the screen: linear in `t` here, and
    // in the world between the near-plane cut's ends.
    let at = |t: f64| ((pa + d * t).as_vec2(), za + (zb - za) * t, ta + (tb - ta) * t);
    Some([at(t0), at(t1)])
}

fn shape_depth(z: f64, depth: DepthMode) -> f32 {
    match depth {
        DepthMode::Tested => (z * (1.0 + DEPTH_NUDGE)).min(1.0) as f32,
        DepthMode::OnTop => 1.0,
    }
}

impl Overlay {
    /// Every shape of both canvases as triangles for `view`: one vertex
    /// list, whatever the number of shapes. Places the glyphs and images
    /// the shapes show in the atlas first (emptying it once, when it is
    /// full, and placing this frame's again; what still does not fit is
    /// left out with a warning).
    pub fn tessellate(&mut self, view: &OverlayView) -> Vec<OverlayVertex> {
        let mut vertices = Vec::new();
        self.tessellate_into(view, &mut vertices);
        vertices
    }

    /// [`Overlay::tessellate`] into `vertices` (emptied first): a list kept
    /// from frame to frame keeps its memory, so a large overlay does not
    /// allocate, and fault in, megabytes of fresh pages every frame.
    pub fn tessellate_into(&mut self, view: &OverlayView, vertices: &mut Vec<OverlayVertex>) {
        let _span = tracing::info_span!("overlay_tessellate", shapes = self.shape_count()).entered();
        let shapes = self.split_for_tessellation();
        for attempt in 0..2 {
            vertices.clear();
            match self.tessellate_shapes(view, shapes.0.iter().chain(&shapes.1), vertices, attempt == 1) {
                Ok(()) => break,
                Err(()) => self.atlas.clear(),
            }
        }
        self.restore_after_tessellation(shapes);
    }

    /// `Err` when the atlas ran out of room and `last_try` is false.
    fn tessellate_shapes<'s>(
        &mut self,
        view: &OverlayView,
        shapes: impl Iterator<Item = &'s Shape>,
        vertices: &mut Vec<OverlayVertex>,
        last_try: bool,
    ) -> Result<(), ()> {
        let size = view.viewport.max(UVec2::ONE).as_vec2();
        let mut glyph_uvs = Vec::new();
        for shape in shapes {
            match shape {
                Shape::Rect { min, max, color } => Out { vertices, size }.rect(*min, *max, None, *color),
                Shape::Image { image, .. } if !self.has_image(*image) => {
                    tracing::warn!(image, "an image id of another overlay: left out");
                }
                Shape::Image { min, max, image, tint } => match self.image_rect(*image) {
                    Some(rect) => Out { vertices, size }.rect(*min, *max, Some(rect.uv_inset()), *tint),
                    None if last_try => tracing::warn!(image, "an overlay image has no room in the atlas: left out"),
                    None => return Err(()),
                },
                Shape::Line { a, b, width, color } => {
                    Out { vertices, size }.line((*a, 1.0, *color), (*b, 1.0, *color), *width)
                }
                Shape::Arc { center, radius, width, start, sweep, color } => {
                    Out { vertices, size }.arc(*center, *radius, *width, *start, *sweep, *color)
                }
                Shape::Text { at, glyphs, color } => {
                    self.glyph_uvs(glyphs, &mut glyph_uvs, last_try)?;
                    Out { vertices, size }.glyphs(*at, 1.0, &glyph_uvs, *color);
                }
                Shape::WorldLine { a, b, width, color, depth } => {
                    if let Some([(pa, za, _), (pb, zb, _)]) = project_segment(view, size, *a, *b) {
                        let (za, zb) = (shape_depth(za, *depth), shape_depth(zb, *depth));
                        Out { vertices, size }.line((pa, za, *color), (pb, zb, *color), *width);
                    }
                }
                Shape::WorldText { anchor, offset, glyphs, color, depth } => {
                    if let Some((at, z)) = project(view, size, *anchor) {
                        self.glyph_uvs(glyphs, &mut glyph_uvs, last_try)?;
                        let at = (at + *offset).round();
                        Out { vertices, size }.glyphs(at, shape_depth(f64::from(z), *depth), &glyph_uvs, *color);
                    }
                }
                Shape::Grid(grid) => grid_lines(view, size, grid, &mut Out { vertices, size }),
            }
        }
        Ok(())
    }

    /// The atlas rectangles of `glyphs` into `out`.
    fn glyph_uvs(&mut self, glyphs: &[PlacedGlyph], out: &mut Vec<GlyphUv>, last_try: bool) -> Result<(), ()> {
        out.clear();
        for glyph in glyphs {
            match glyph_rect(&mut self.atlas, &self.fonts, glyph) {
                Some(rect) => out.push((*glyph, rect.uv())),
                None if last_try => tracing::warn!("a glyph has no room in the overlay's atlas: left out"),
                None => return Err(()),
            }
        }
        Ok(())
    }
}

/// A grid's lines for `view`, each cut in segments whose ends fade with
/// their distance along the plane from the point under the eye.
fn grid_lines(view: &OverlayView, size: Vec2, grid: &Grid, out: &mut Out<'_>) {
    let foot = DVec3::new(view.eye.x, grid.height, view.eye.z);
    let snap = |v: f64| (v / grid.spacing).round() * grid.spacing;
    let (cx, cz) = (snap(foot.x), snap(foot.z));
    let reach = f64::from(grid.lines) * grid.spacing;
    let alpha = |p: DVec3| {
        if grid.fade <= 0.0 {
            return grid.color;
        }
        let d = (p - foot).length() / grid.fade;
        // 1 until half the fade distance, then down to 0 at it.
        let f = ((1.0 - d) * 2.0).clamp(0.0, 1.0);
        let mut c = grid.color;
        c[3] = (f64::from(c[3]) * f).round() as u8;
        c
    };
    let lines = i64::from(grid.lines);
    for i in -lines..=lines {
        let offset = i as f64 * grid.spacing;
        for along_x in [true, false] {
            let point = |t: f64| {
                if along_x {
                    DVec3::new(cx - reach + t * 2.0 * reach, grid.height, cz + offset)
                } else {
                    DVec3::new(cx + offset, grid.height, cz - reach + t * 2.0 * reach)
                }
            };
            for s in 0..GRID_SEGMENTS {
                let (a, b) = (
                    point(f64::from(s) / f64::from(GRID_SEGMENTS)),
                    point(f64::from(s + 1) / f64::from(GRID_SEGMENTS)),
                );
                let (ca, cb) = (alpha(a), alpha(b));
                if ca[3] == 0 && cb[3] == 0 {
                    continue;
                }
                if let Some([(pa, za, ta), (pb, zb, tb)]) = project_segment(view, size, a, b) {
                    let (za, zb) = (shape_depth(za, DepthMode::Tested), shape_depth(zb, DepthMode::Tested));
                    // The colours where the segment was cut.
                    let mix = |t: f64| {
                        let mut c = ca;
                        c[3] = (f64::from(ca[3]) + (f64::from(cb[3]) - f64::from(ca[3])) * t).round() as u8;
                        c
                    };
                    out.line((pa, za, mix(ta)), (pb, zb, mix(tb)), grid.width);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Rgba, canvas::frustum_corners};
    use oxygen_core::ResolvedView;

    fn view_at(eye: DVec3, target: DVec3, viewport: UVec2) -> OverlayView {
        let projection = Mat4::perspective_infinite_reverse_rh(1.0, viewport.x as f32 / viewport.y as f32, 0.1);
        OverlayView::new(projection, DMat4::look_at_rh(eye, target, DVec3::Y), viewport)
    }

    fn pixel(v: &OverlayVertex, size: Vec2) -> Vec2 {
        Vec2::new((v.clip[0] + 1.0) * 0.5 * size.x, (1.0 - v.clip[1]) * 0.5 * size.y)
    }

    /// A kept vertex list is emptied, then filled as a fresh one would be.
    #[test]
    fn a_kept_list_gives_what_a_fresh_one_gives() {
        let mut overlay = Overlay::new();
        overlay.immediate().rect(Vec2::new(1.0, 2.0), Vec2::new(9.0, 8.0), Rgba::WHITE);
        overlay.retained().line(Vec2::ZERO, Vec2::new(30.0, 10.0), 2.0, Rgba::BLACK);
        let view = view_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, UVec2::new(100, 80));
        let fresh = overlay.tessellate(&view);
        let mut kept = vec![fresh[0]; 1000];
        overlay.tessellate_into(&view, &mut kept);
        assert_eq!(bytemuck::cast_slice::<_, u8>(&kept), bytemuck::cast_slice::<_, u8>(&fresh));
        assert!(kept.capacity() >= 1000, "the list's memory was not kept");
    }

    #[test]
    fn screen_shapes_land_on_their_pixels_at_the_near_plane() {
        let mut overlay = Overlay::new();
        overlay.immediate().rect(Vec2::new(10.0, 20.0), Vec2::new(30.0, 60.0), Rgba::WHITE);
        let view = view_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, UVec2::new(100, 80));
        let v = overlay.tessellate(&view);
        assert_eq!(v.len(), 6);
        let size = Vec2::new(100.0, 80.0);
        assert!(pixel(&v[0], size).abs_diff_eq(Vec2::new(10.0, 20.0), 1e-4), "{:?}", v[0]);
        assert!(pixel(&v[2], size).abs_diff_eq(Vec2::new(30.0, 60.0), 1e-4), "{:?}", v[2]);
        assert!(v.iter().all(|v| v.clip[2] == 1.0 && v.kind == VertexKind::Solid as u32));
        // Cleared after the frame; the retained canvas stays.
        overlay.retained().circle(Vec2::new(50.0, 40.0), 5.0, Rgba::BLACK);
        overlay.end_frame();
        assert_eq!(overlay.shape_count(), 1);
        assert_eq!(overlay.tessellate(&view).len(), 6);
    }

    #[test]
    fn a_world_point_projects_where_the_camera_sees_it_far_from_the_origin() {
        for base in [DVec3::ZERO, DVec3::new(1.0e6, 0.0, -2.0e6)] {
            let view = view_at(base + DVec3::new(0.0, 0.0, 10.0), base, UVec2::new(200, 100));
            let mut overlay = Overlay::new();
            overlay.immediate().world_line(
                base,
                base + DVec3::new(0.001, 0.0, 0.0),
                2.0,
                Rgba::WHITE,
                DepthMode::Tested,
            );
            let v = overlay.tessellate(&view);
            assert_eq!(v.len(), 6);
            // The centre of the view, to a hundredth of a pixel at a million units.
            let centre = v.iter().map(|v| pixel(v, Vec2::new(200.0, 100.0))).sum::<Vec2>() / 6.0;
            assert!((centre - Vec2::new(100.0, 50.0)).length() < 0.05, "{centre} at {base}");
            assert!(v.iter().all(|v| v.clip[2] > 0.0 && v.clip[2] < 1.0), "depth-tested lines keep their depth");
        }
    }

    #[test]
    fn world_lines_are_cut_at_the_near_plane_and_behind_the_eye_vanish() {
        let view = view_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, UVec2::new(100, 100));
        let mut overlay = Overlay::new();
        // Wholly behind the eye: nothing.
        overlay.immediate().world_line(
            DVec3::new(0.0, 0.0, 6.0),
            DVec3::new(1.0, 0.0, 9.0),
            1.0,
            Rgba::WHITE,
            DepthMode::OnTop,
        );
        assert!(overlay.tessellate(&view).is_empty());
        overlay.end_frame();
        // Through the eye's plane: cut, every vertex finite and in front.
        overlay.immediate().world_line(
            DVec3::new(0.2, 0.0, 0.0),
            DVec3::new(0.2, 0.0, 20.0),
            1.0,
            Rgba::WHITE,
            DepthMode::Tested,
        );
        let v = overlay.tessellate(&view);
        assert_eq!(v.len(), 6);
        assert!(v.iter().all(|v| v.clip.iter().all(|c| c.is_finite()) && v.clip[2] <= 1.0 && v.clip[2] > 0.0), "{v:?}");
    }

    #[test]
    fn a_frustum_drawn_from_a_views_camera_meets_the_corners_of_its_image() {
        let eye = DVec3::new(3.0, 2.0, 4.0);
        let world_to_view = DMat4::look_at_rh(eye, DVec3::ZERO, DVec3::Y);
        let projection = Mat4::perspective_infinite_reverse_rh(0.8, 1.5, 0.1);
        let viewport = UVec2::new(150, 100);
        let id = oxygen_core::ViewIds::default().allocate();
        let resolved = ResolvedView::new_f64(id, world_to_view, projection, viewport, 0.1, f32::INFINITY).unwrap();
        let corners = frustum_corners(&resolved, 50.0).unwrap();
        // Seen by the same camera, each far corner lands on a corner of its
        // image (the near ones too, at the near plane itself).
        let view = OverlayView::new(projection, world_to_view, viewport);
        for (i, c) in corners.iter().enumerate().skip(4) {
            let (p, _) = project(&view, viewport.as_vec2(), *c).unwrap();
            let want = Vec2::new(if i & 1 == 0 { 0.0 } else { 150.0 }, if i & 2 == 0 { 100.0 } else { 0.0 });
            assert!((p - want).length() < 1e-3, "corner {i}: {p} against {want}");
        }
        // The far corners are 50 in front of the eye.
        let forward = (DVec3::ZERO - eye).normalize();
        assert!(((corners[7] - eye).dot(forward) - 50.0).abs() < 1e-6);
    }

    #[test]
    fn shapes_that_are_not_finite_are_dropped_and_counted() {
        let mut overlay = Overlay::new();
        overlay.immediate().line(Vec2::NAN, Vec2::ONE, 1.0, Rgba::WHITE).circle(Vec2::ONE, f32::INFINITY, Rgba::WHITE);
        overlay.immediate().world_line(DVec3::NAN, DVec3::ONE, 1.0, Rgba::WHITE, DepthMode::Tested);
        overlay.immediate().grid(0.0, 0.0, 10, 1.0, Rgba::WHITE, 10.0);
        assert_eq!((overlay.shape_count(), overlay.dropped()), (0, 4));
        let view = view_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, UVec2::new(10, 10));
        assert!(overlay.tessellate(&view).is_empty());
    }

    #[test]
    fn the_grid_stays_on_the_worlds_multiples_and_fades_with_distance() {
        let viewport = UVec2::new(160, 90);
        let eye = DVec3::new(1.0e6 + 0.37, 3.0, -2.0e6 + 0.81);
        let view = view_at(eye, eye + DVec3::new(0.0, -3.0, -6.0), viewport);
        let mut overlay = Overlay::new();
        overlay.immediate().grid(0.0, 1.0, 10, 1.0, Rgba::WHITE, 8.0);
        let v = overlay.tessellate(&view);
        assert!(!v.is_empty());
        // Faded: no vertex brighter than the colour, some fully faded out.
        assert!(v.iter().any(|v| v.color[3] == 255) && v.iter().any(|v| v.color[3] < 128));
        assert!(v.iter().all(|v| v.clip.iter().all(|c| c.is_finite())));

        // Orthographic, straight down from 50 m (reverse-Z: near and far
        // swapped): the lines under the eye land a whole number of metres
        // apart, 8 pixels a metre, and keep a depth inside the range.
        let projection = Mat4::orthographic_rh(-10.0, 10.0, -5.625, 5.625, 100.0, 0.1);
        let eye = DVec3::new(1.0e6 + 0.37, 50.0, -2.0e6);
        let world_to_view = DMat4::look_at_rh(eye, eye - DVec3::Y, DVec3::NEG_Z);
        let view = OverlayView::new(projection, world_to_view, viewport);
        let v = overlay.tessellate(&view);
        assert!(!v.is_empty());
        assert!(v.iter().all(|v| v.clip[2] > 0.0 && v.clip[2] <= 1.0), "depths outside the range");
        // A vertical grid line's centre (the mean of its quad's x) lies on
        // whole metres: 8 pixels each from the centre (the eye is 0.37 m
        // off a line in x).
        let xs: Vec<f32> = v
            .chunks(6)
            .filter(|q| (pixel(&q[0], viewport.as_vec2()).x - pixel(&q[2], viewport.as_vec2()).x).abs() < 4.0)
            .map(|q| q.iter().map(|v| pixel(v, viewport.as_vec2()).x).sum::<f32>() / 6.0)
            .collect();
        assert!(!xs.is_empty());
        for x in xs {
            let metres = (x - 80.0) / 8.0 + 0.37;
            assert!((metres - metres.round()).abs() < 0.02, "a line at {x} px, {metres} m");
        }
    }

    #[test]
    fn text_and_images_sample_the_atlas() {
        let mut overlay = Overlay::new();
        let image = overlay.add_image(2, 2, vec![255; 16]).unwrap();
        assert!(overlay.add_image(2, 2, vec![255; 15]).is_err());
        overlay.immediate().image(Vec2::ZERO, Vec2::splat(8.0), image, Rgba::WHITE);
        let extent = overlay.immediate().text(Vec2::new(4.0, 4.0), 16.0, Rgba::WHITE, "Ab");
        assert!(extent.x > 10.0);
        let view = view_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, UVec2::new(64, 64));
        let v = overlay.tessellate(&view);
        assert_eq!(v.len(), 18);
        assert!(v.iter().all(|v| v.kind == VertexKind::Atlas as u32));
        assert!(v.iter().all(|v| v.local.iter().all(|c| (0.0..=1.0).contains(c))));
        assert_eq!(overlay.atlas().len(), 3);
    }
}
