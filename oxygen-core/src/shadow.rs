//! Cascaded shadow maps for a directional light: where the cascades split the
//! camera's depth range, and the orthographic view that covers each slice.
//!
//! * **Splits** follow the practical scheme: a blend, by `lambda`, of the
//!   logarithmic split (even precision per depth octave) and the uniform one.
//! * **Fitting**: each slice's eight corners are enclosed in a sphere, and the
//!   cascade's orthographic box is that sphere's square. A sphere does not
//!   change size as the camera turns, so the map's texel size stays constant.
//! * **Texel snapping**: the box's centre is snapped, in light space, to whole
//!   texels, so the map's texel grid stays fixed in the world while the camera
//!   moves and shadow edges do not swim.
//!
//! [`CascadeResolver`] turns this into a registered view: a shadow view is
//! just another view, culled by the same ScenePrep (casters only, depth only).

use std::sync::Arc;

use glam::{DMat4, DVec3, Mat4, UVec2, Vec3};

use crate::math::projection::reverse_z_orthographic;
use crate::{NodeKey, ResolvedView, Scene, ViewContext, ViewError, ViewResolver};

/// How a directional light's cascades are laid out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CascadeSettings {
    /// Number of cascades, 1 to 4.
    pub count: u32,
    /// 0 = uniform splits, 1 = logarithmic; 0.5–0.8 is the usual compromise.
    pub lambda: f32,
    /// Shadow-map side in texels.
    pub resolution: u32,
    /// Shadows end here (also caps an infinite far plane).
    pub max_distance: f32,
    /// How far behind each slice (towards the light) casters are still caught.
    pub caster_margin: f32,
}

impl Default for CascadeSettings {
    fn default() -> Self {
        CascadeSettings { count: 4, lambda: 0.7, resolution: 2048, max_distance: 100.0, caster_margin: 50.0 }
    }
}

/// One cascade: a depth slice of the camera and the light's view of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cascade {
    /// Camera-space distance where the slice starts.
    pub split_near: f32,
    /// Camera-space distance where the slice ends.
    pub split_far: f32,
    /// World → light view, in `f64` so the fit holds far from the origin.
    pub view: DMat4,
    /// Light view → clip (reverse-Z orthographic).
    pub projection: Mat4,
    /// Depth of the orthographic box (its far plane; the near plane is 0).
    pub depth: f32,
    /// World size of one shadow-map texel.
    pub texel_world_size: f32,
    /// The box centre in light space after snapping (for tests and debugging).
    pub snapped_center: DVec3,
}

/// Split distances `[near, d1, …, far]` (`count + 1` values).
pub fn cascade_splits(near: f32, far: f32, count: u32, lambda: f32) -> Vec<f32> {
    let count = count.clamp(1, 4);
    let lambda = lambda.clamp(0.0, 1.0);
    (0..=count)
        .map(|i| {
            let t = i as f32 / count as f32;
            let logarithmic = near * (far / near).powf(t);
            let uniform = near + (far - near) * t;
            lambda * logarithmic + (1.0 - lambda) * uniform
        })
        .collect()
}

/// The eight world-space corners of the camera's slice between `d0` and
/// `d1`, in `f64` (a camera far from the origin keeps its precision).
fn slice_corners(camera: &ResolvedView, d0: f32, d1: f32) -> [DVec3; 8] {
    let world_from_view = camera.world_to_view.inverse();
    let p = camera.projection.as_dmat4();
    let perspective = p.w_axis.w == 0.0;
    let (d0, d1) = (d0 as f64, d1 as f64);
    let mut corners = [DVec3::ZERO; 8];
    for (i, corner) in corners.iter_mut().enumerate() {
        let d = if i < 4 { d0 } else { d1 };
        let (sx, sy) = (if i & 1 == 0 { -1.0 } else { 1.0 }, if i & 2 == 0 { -1.0 } else { 1.0 });
        let (half_x, half_y) =
            if perspective { (d / p.x_axis.x, d / p.y_axis.y) } else { (1.0 / p.x_axis.x, 1.0 / p.y_axis.y) };
        *corner = world_from_view.transform_point3(DVec3::new(sx * half_x, sy * half_y, -d));
    }
    corners
}

/// Fits cascade `index` of `settings` to `camera`, for a light shining along
/// `light_direction` (need not be normalized). `None` when the inputs are
/// degenerate (zero direction, empty depth range). Computed in `f64`: the
/// texel snapping must hold a million units from the origin, where `f32`
/// positions are 1/16 of a unit apart, coarser than a shadow texel.
pub fn fit_cascade(
    camera: &ResolvedView,
    light_direction: Vec3,
    settings: &CascadeSettings,
    index: u32,
) -> Option<Cascade> {
    let direction = light_direction.try_normalize()?.as_dvec3();
    let far = camera.far.min(settings.max_distance);
    if !(far > camera.near) || index >= settings.count.clamp(1, 4) {
        return None;
    }
    let splits = cascade_splits(camera.near, far, settings.count, settings.lambda);
    let (d0, d1) = (splits[index as usize], splits[index as usize + 1]);
    let corners = slice_corners(camera, d0, d1);
    let center = corners.iter().copied().sum::<DVec3>() / 8.0;
    // Round the radius up to a multiple of 1/16 so it does not jitter with float noise.
    let radius = (corners.iter().map(|c| c.distance(center)).fold(0.0f64, f64::max) * 16.0).ceil() / 16.0;
    let texel = 2.0 * radius / settings.resolution.max(1) as f64;

    // Light-space rotation (no translation): look along the light.
    let up = if direction.y.abs() > 0.99 { DVec3::Z } else { DVec3::Y };
    let rotation = DMat4::look_to_rh(DVec3::ZERO, direction, up);
    let light_center = rotation.transform_point3(center);
    let snapped =
        DVec3::new((light_center.x / texel).round() * texel, (light_center.y / texel).round() * texel, light_center.z);
    let world_center = rotation.inverse().transform_point3(snapped);

    let margin = settings.caster_margin as f64;
    let eye = world_center - direction * (radius + margin);
    let view = DMat4::look_to_rh(eye, direction, up);
    let depth = (2.0 * radius + margin) as f32;
    let projection = reverse_z_orthographic(radius as f32, radius as f32, 0.0, depth);
    Some(Cascade {
        split_near: d0,
        split_far: d1,
        view,
        projection,
        depth,
        texel_world_size: texel as f32,
        snapped_center: snapped,
    })
}

/// A registered view for one cascade of one directional light: it resolves
/// the main camera itself (cheap) and fits the cascade to it every frame.
#[derive(Clone)]
pub struct CascadeResolver {
    /// The camera whose frustum the cascades cover.
    pub main: Arc<dyn ViewResolver>,
    /// The node carrying the directional light (it shines down its −Z).
    pub light: NodeKey,
    /// Layout of the cascades.
    pub settings: CascadeSettings,
    /// Which cascade this view renders.
    pub index: u32,
}

impl ViewResolver for CascadeResolver {
    fn resolve(&self, ctx: &ViewContext, scene: &Scene) -> Result<ResolvedView, ViewError> {
        let view_id = ctx.view_id;
        let camera = self.main.resolve(ctx, scene)?;
        let light = scene
            .world_transform(self.light)
            .ok_or_else(|| ViewError::Other { view: view_id, message: "the light's node was removed".into() })?;
        let direction = light.as_mat4().transform_vector3(Vec3::NEG_Z);
        let cascade = fit_cascade(&camera, direction, &self.settings, self.index).ok_or_else(|| ViewError::Other {
            view: view_id,
            message: format!(
                "cascade {} cannot be fitted (light direction {direction}, depth {}..{})",
                self.index, camera.near, camera.far
            ),
        })?;
        let side = self.settings.resolution.max(1);
        ResolvedView::new_f64(view_id, cascade.view, cascade.projection, UVec2::splat(side), 0.0, cascade.depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Camera, LookAtResolver, ViewIds};
    use glam::Vec4Swizzles;

    /// `camera` at `eye` looking along `toward`, resolved at 1280 × 720.
    fn view_looking(camera: Camera, eye: Vec3, toward: Vec3) -> ResolvedView {
        let resolver =
            LookAtResolver { camera, eye, target: eye + toward, up: Vec3::Y, viewport: UVec2::new(1280, 720) };
        resolver
            .resolve(
                &ViewContext { view_id: ViewIds::default().allocate(), frame_index: 1, time_seconds: 0.0 },
                &Scene::new(),
            )
            .unwrap()
    }

    fn camera_at(eye: Vec3) -> ResolvedView {
        view_looking(Camera::perspective(60f32.to_radians(), 0.1, Some(200.0)), eye, Vec3::new(0.0, -0.3, -1.0))
    }

    #[test]
    fn splits_cover_the_depth_range_without_gaps() {
        for count in 1..=4 {
            for lambda in [0.0, 0.5, 0.7, 1.0] {
                let s = cascade_splits(0.1, 100.0, count, lambda);
                assert_eq!(s.len(), count as usize + 1);
                assert!((s[0] - 0.1).abs() < 1e-6 && (s[count as usize] - 100.0).abs() < 1e-3, "{s:?}");
                assert!(s.windows(2).all(|w| w[1] > w[0]), "not increasing: {s:?}");
            }
        }
        // The extremes are the pure schemes.
        let uniform = cascade_splits(1.0, 9.0, 2, 0.0);
        assert!((uniform[1] - 5.0).abs() < 1e-5);
        let logarithmic = cascade_splits(1.0, 9.0, 2, 1.0);
        assert!((logarithmic[1] - 3.0).abs() < 1e-5);
    }

    #[test]
    fn every_cascade_box_holds_its_whole_slice_and_consecutive_slices_touch() {
        let camera = camera_at(Vec3::new(3.0, 10.0, 5.0));
        let settings = CascadeSettings { max_distance: 80.0, ..Default::default() };
        let light = Vec3::new(-0.4, -1.0, -0.3);
        let mut previous_far = camera.near;
        for i in 0..settings.count {
            let c = fit_cascade(&camera, light, &settings, i).unwrap();
            assert!((c.split_near - previous_far).abs() < 1e-4, "gap before cascade {i}");
            previous_far = c.split_far;
            let clip_from_world = (c.projection.as_dmat4() * c.view).as_mat4();
            for corner in slice_corners(&camera, c.split_near, c.split_far) {
                let clip = clip_from_world * corner.as_vec3().extend(1.0);
                let ndc = clip.xyz() / clip.w;
                assert!(ndc.x.abs() <= 1.0 + 1e-4 && ndc.y.abs() <= 1.0 + 1e-4, "cascade {i} misses {corner}: {ndc}");
                assert!(ndc.z >= -1e-4 && ndc.z <= 1.0 + 1e-4, "cascade {i} depth misses {corner}: {ndc}");
            }
        }
        assert!((previous_far - 80.0).abs() < 1e-3, "the last cascade ends at max_distance");
    }

    /// The snapped centre moves by whole texels only as the camera
    /// translates: the map's grid origin stays fixed within one texel. Near
    /// the origin and a million units out, where `f32` positions are 1/16
    /// apart, several times the 1/64-unit texel of the first cascade.
    #[test]
    fn texel_snapping_keeps_the_map_grid_fixed_as_the_camera_translates() {
        let settings = CascadeSettings::default();
        let light = Vec3::new(-0.4, -1.0, -0.3);
        for base in [Vec3::new(0.0, 10.0, 0.0), Vec3::new(1.0e6, 10.0, -1.0e6)] {
            for cascade in [0, 1] {
                let first = fit_cascade(&camera_at(base), light, &settings, cascade).unwrap();
                for step in 1..50 {
                    let eye = base + Vec3::new(step as f32 * 0.125, 0.0, step as f32 * -0.1875);
                    let c = fit_cascade(&camera_at(eye), light, &settings, cascade).unwrap();
                    assert_eq!(
                        c.texel_world_size, first.texel_world_size,
                        "texel size must not change with translation"
                    );
                    let offset = (c.snapped_center - first.snapped_center).truncate() / c.texel_world_size as f64;
                    assert!(
                        (offset - offset.round()).abs().max_element() < 1e-2,
                        "camera at {base}, cascade {cascade}, step {step}: off-grid by {offset}"
                    );
                }
            }
        }
    }

    fn view_of(camera: Camera, eye: Vec3) -> ResolvedView {
        view_looking(camera, eye, Vec3::new(0.2, -0.3, -1.0))
    }

    /// Each corner seen through the camera lands on a corner of the screen
    /// (NDC ±1, ±1) at the slice's near or far distance, and together the
    /// eight cover all eight combinations once. Their order is not checked:
    /// `fit_cascade` only sums them and takes the largest distance.
    #[test]
    fn slice_corners_are_the_frustum_corners_at_both_slice_distances() {
        let cameras =
            [Camera::perspective(50f32.to_radians(), 0.1, Some(200.0)), Camera::orthographic(7.5, -2.0, 60.0)];
        for camera in cameras {
            let view = view_of(camera, Vec3::new(4.0, 12.0, -3.0));
            let (d0, d1) = (2.5, 17.0);
            let mut seen = Vec::new();
            for corner in slice_corners(&view, d0, d1) {
                let in_view = view.world_to_view.transform_point3(corner);
                let clip = view.projection.as_dmat4() * in_view.extend(1.0);
                let (ndc_x, ndc_y) = (clip.x / clip.w, clip.y / clip.w);
                // The f64 round trip through the inverse view keeps ~1e-12;
                // 1e-5 leaves room for the f32 projection matrix.
                assert!((ndc_x.abs() - 1.0).abs() < 1e-5 && (ndc_y.abs() - 1.0).abs() < 1e-5, "{camera:?}: {corner}");
                let depth = -in_view.z;
                let far = (depth - f64::from(d1)).abs() < 1e-9;
                assert!(far || (depth - f64::from(d0)).abs() < 1e-9, "{camera:?}: depth {depth}");
                seen.push((ndc_x > 0.0, ndc_y > 0.0, far));
            }
            seen.sort();
            seen.dedup();
            assert_eq!(seen.len(), 8, "{camera:?}: corners repeat: {seen:?}");
        }
    }

    #[test]
    fn no_cascade_is_fitted_to_an_empty_depth_range_or_past_the_cascade_count() {
        let camera = camera_at(Vec3::new(0.0, 5.0, 0.0));
        let light = Vec3::new(-0.4, -1.0, -0.3);
        let settings = CascadeSettings::default();
        assert!(fit_cascade(&camera, light, &settings, settings.count - 1).is_some());
        assert!(fit_cascade(&camera, light, &settings, settings.count).is_none(), "index past the count");
        let six = CascadeSettings { count: 6, ..settings };
        assert!(fit_cascade(&camera, light, &six, 4).is_none(), "the count is capped at 4");
        // Shadows ending exactly at the near plane leave nothing to cover.
        let at_near = CascadeSettings { max_distance: camera.near, ..settings };
        assert!(fit_cascade(&camera, light, &at_near, 0).is_none(), "an empty range");
        let before_near = CascadeSettings { max_distance: camera.near * 0.5, ..settings };
        assert!(fit_cascade(&camera, light, &before_near, 0).is_none(), "a reversed range");
    }

    /// The box's half-side is the slice's bounding radius rounded up to a
    /// sixteenth; the texel size, the projection and the depth all follow it.
    #[test]
    fn a_cascade_box_is_the_bounding_sphere_rounded_up_to_a_sixteenth() {
        let camera = camera_at(Vec3::new(3.0, 10.0, 5.0));
        let settings = CascadeSettings { resolution: 1024, caster_margin: 30.0, ..Default::default() };
        for index in 0..settings.count {
            let c = fit_cascade(&camera, Vec3::new(-0.4, -1.0, -0.3), &settings, index).expect("a valid cascade");
            let corners = slice_corners(&camera, c.split_near, c.split_far);
            let center = corners.iter().copied().sum::<DVec3>() / 8.0;
            let bound = corners.iter().map(|p| p.distance(center)).fold(0.0, f64::max);
            // orthographic_rh's x scale is 2 / (right − left) = 1 / half-side.
            let radius = 1.0 / f64::from(c.projection.x_axis.x);
            // f32 matrix entries: a few ulps of a radius of up to ~50.
            assert!(((radius * 16.0).round() - radius * 16.0).abs() < 1e-4, "cascade {index}: radius {radius}");
            assert!(radius >= bound - 1e-5 && radius < bound + 1.0 / 16.0, "cascade {index}: {radius} for {bound}");
            let texel = 2.0 * radius / 1024.0;
            assert!((f64::from(c.texel_world_size) - texel).abs() < 1e-6 * texel, "cascade {index}");
            let depth = 2.0 * radius + 30.0;
            assert!((f64::from(c.depth) - depth).abs() < 1e-5 * depth, "cascade {index}: depth {}", c.depth);
        }
    }

    /// A light straight down is parallel to the usual up vector (+Y); the
    /// fit must pick another and still enclose the slice.
    #[test]
    fn a_vertical_light_still_gets_a_box_around_its_slice() {
        let camera = camera_at(Vec3::new(3.0, 10.0, 5.0));
        let settings = CascadeSettings { max_distance: 40.0, ..Default::default() };
        for light in [Vec3::NEG_Y, Vec3::Y, Vec3::new(0.05, -1.0, 0.0)] {
            for index in 0..settings.count {
                let c = fit_cascade(&camera, light, &settings, index).expect("a vertical light is not degenerate");
                assert!(c.view.is_finite(), "light {light}, cascade {index}: {:?}", c.view);
                let clip_from_world = c.projection.as_dmat4() * c.view;
                for corner in slice_corners(&camera, c.split_near, c.split_far) {
                    let ndc = clip_from_world.project_point3(corner);
                    assert!(
                        ndc.x.abs() <= 1.0 + 1e-4 && ndc.y.abs() <= 1.0 + 1e-4 && (-1e-4..=1.0 + 1e-4).contains(&ndc.z),
                        "light {light}, cascade {index} misses {corner}: {ndc}"
                    );
                }
            }
        }
    }
}
