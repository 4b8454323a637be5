//! The frame phase: everything that is the same for every view.
//!
//! Inputs: the [`Scene`]. Outputs ([`FrameCollection`]): per renderable node a
//! transform index, world AABB and bounding sphere; world and normal matrices
//! indexed by that transform index; directional and positional light records.
//!
//! Gating rules for lights: the node is (effectively) visible, the light
//! affects the world, the light is not baked. A light casts shadows only
//! when both the light and its node say so.
//!
//! Shadows of the frame: shadow-casting spot and point lights get tiles of
//! the local-light shadow atlas in node order, and
//! [`FrameCollection::local_shadow_casters`] says which node got which tiles;
//! [`FrameCollection::shadow_sun`] names the directional light whose
//! cascades the shading pass samples. Both are rebuilt on every collection,
//! so a renderer that reads them each frame registers exactly the shadow
//! views the frame needs.
//!
//! A node whose world matrix is non-finite or singular is skipped with a
//! warning naming it; nothing derived from it reaches the GPU.
//!
//! Camera-relative rendering: what goes to the GPU (world matrices, light
//! positions) is expressed relative to the frame's render origin, subtracted
//! in `f64` before the rounding to `f32`, so that a world a million units
//! across keeps sub-millimetre precision near the camera. Bounds used for
//! culling stay in absolute world space.

use glam::{DMat4, DVec3, Mat3, Mat4, Vec3};
use oxygen_bindless::INVALID_SLOT;
use std::sync::Arc;

use oxygen_core::scene::{geometry_index, material_index, node_index};
use oxygen_core::{
    Aabb, GeometryHandle, LightKind, LodLevel, Mobility, NodeFlags, NodeKey, Scene, Sphere, WorldTransforms,
};
use tracing::{info_span, warn};

use crate::prepared_frame::FrameTransforms;
use crate::{DirectionalLightRecord, MAX_SHADOW_TILES, PassMask, PositionalLightRecord, shadow_tiles_for};

/// A renderable node that survived the frame phase.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderableEntry {
    /// The node.
    pub node: NodeKey,
    /// Stable node id (slot index).
    pub node_id: u32,
    /// Index into the frame's matrices, [`FrameCollection::transforms`].
    pub transform_index: u32,
    /// Its geometry.
    pub geometry: GeometryHandle,
    /// Stable geometry id (slot index), for dense per-geometry tables.
    pub geometry_id: u32,
    /// World-space box.
    pub world_aabb: Aabb,
    /// World-space sphere around `world_aabb`.
    pub world_sphere: Sphere,
    /// Node flags (shadow casting).
    pub flags: NodeFlags,
    /// Its LOD levels: `FrameCollection::lod_levels[start..start + count]`.
    pub lods: (u32, u32),
    /// Its submeshes: `FrameCollection::submeshes[start..start + count]`.
    pub submeshes: (u32, u32),
    /// A skinned renderable's first joint matrix in the frame's matrices
    /// (joint `i` at `joint_base + i`), `INVALID_SLOT` for a rigid one.
    pub joint_base: u32,
    /// A morphed renderable's morph header among the frame's matrices
    /// (laid out by the frame phase's `push_morph_header`), `INVALID_SLOT`
    /// without morph targets.
    pub morph_base: u32,
}

/// Appends the matrices that carry a renderable's morph weights to the
/// vertex shader and returns where they start: 16 floats each,
/// `[vertex count, target count, w0, w1, ...]` padded with zeros (the counts
/// are whole numbers below 2^24; missing weights are 0). Written in place:
/// the frame phase allocates nothing per renderable.
fn push_morph_header(transforms: &mut FrameTransforms, vertex_count: usize, weights: &[f32], targets: usize) -> u32 {
    let base = transforms.world.len() as u32;
    let float = |k: usize| match k {
        0 => vertex_count as f32,
        1 => targets as f32,
        k if k - 2 < targets => weights.get(k - 2).copied().unwrap_or(0.0),
        _ => 0.0,
    };
    for m in 0..(2 + targets).div_ceil(16) {
        let columns: [f32; 16] = std::array::from_fn(|j| float(m * 16 + j));
        transforms.world.push(Mat4::from_cols_array(&columns));
        transforms.normal.push(Mat3::ZERO.into());
    }
    base
}

/// Where a skinned renderable's joint matrices went and what they give.
#[derive(Clone, Copy)]
struct Joints {
    /// The first joint matrix among the frame's matrices.
    base: u32,
    /// The skinned geometry's bound in this pose.
    bounds: oxygen_core::DAabb,
    /// The first joint mirrors: the skinned triangles' winding flips (a
    /// skin whose joints disagree has no one winding to draw).
    mirrored: bool,
}

/// One submesh of a renderable with its material resolved once per frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubmeshEntry {
    /// Stable material id.
    pub material: u32,
    /// Pass class, variant and shadow bit.
    pub pass_mask: PassMask,
    /// First index in the base geometry.
    pub first_index: u32,
    /// Index count in the base geometry.
    pub index_count: u32,
}

/// How a local light's shadow is stored in the atlas, which decides how many
/// tiles it takes ([`LocalShadowKind::tile_count`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LocalShadowKind {
    /// A spot light: one perspective map, one tile.
    Spot,
    /// A point light: six cube faces, six consecutive tiles in the order
    /// +X, -X, +Y, -Y, +Z, -Z.
    Point,
}

impl LocalShadowKind {
    /// Atlas tiles a light of this kind takes.
    pub fn tile_count(self) -> u32 {
        shadow_tiles_for(self.record_kind())
    }

    /// The `kind` of its [`PositionalLightRecord`].
    fn record_kind(self) -> u32 {
        match self {
            LocalShadowKind::Spot => PositionalLightRecord::SPOT,
            LocalShadowKind::Point => PositionalLightRecord::POINT,
        }
    }
}

/// A spot or point light that casts shadows this frame and got atlas tiles:
/// the renderer registers one shadow view per tile, and the shading pass
/// finds the tiles through the light's `shadow_slot`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LocalShadowCaster {
    /// The light's node.
    pub node: NodeKey,
    /// Spot (one tile) or point (six tiles).
    pub kind: LocalShadowKind,
    /// Index of the light in [`FrameCollection::positional_lights`].
    pub light_index: u32,
    /// Its first atlas tile (the record's `shadow_slot`).
    pub first_tile: u32,
    /// Tiles from `first_tile` on that are its: 1 for a spot, 6 for a point
    /// light.
    pub tile_count: u32,
}

impl LocalShadowCaster {
    /// Its tiles, `first_tile..first_tile + tile_count`.
    pub fn tiles(&self) -> std::ops::Range<u32> {
        self.first_tile..self.first_tile + self.tile_count
    }
}

/// The frame phase's output, shared read-only by every view.
#[derive(Default)]
pub struct FrameCollection {
    /// World matrices of every node (resolved once).
    pub world: WorldTransforms,
    /// Renderables in stable node order.
    pub renderables: Vec<RenderableEntry>,
    /// World and normal matrices indexed by `transform_index`, shared (not
    /// copied) with every view's prepared frame.
    pub transforms: Arc<FrameTransforms>,
    /// Submeshes of all renderables, referenced by [`RenderableEntry::submeshes`].
    pub submeshes: Vec<SubmeshEntry>,
    /// LOD levels of all renderables, referenced by [`RenderableEntry::lods`].
    pub lod_levels: Vec<LodLevel>,
    /// Gated directional lights.
    pub directional_lights: Vec<DirectionalLightRecord>,
    /// Gated point and spot lights.
    pub positional_lights: Vec<PositionalLightRecord>,
    /// Spot and point lights that cast shadows this frame and got atlas
    /// tiles, in node order (the order their tiles were handed out). A
    /// shadow-casting light missing here found [`MAX_SHADOW_TILES`] used up
    /// and is lit unshadowed.
    pub local_shadow_casters: Vec<LocalShadowCaster>,
    /// The directional light whose shadow cascades the shading pass uses:
    /// the first gated directional light, in node order, that casts shadows
    /// (the light and its node both say so). That is the first record of
    /// [`Self::directional_lights`] with its shadow flag set, the one
    /// `mesh/shading.wgsl` gives the cascades to; `None` when no directional
    /// light casts shadows this frame.
    pub shadow_sun: Option<NodeKey>,
    /// Nodes skipped this frame because of a degenerate transform or bounds.
    pub skipped_nodes: u32,
    /// Every node or light left out this frame, and why, for the frame report.
    pub skipped: Vec<SkippedNode>,
    /// (scene id, scene revision, render origin) the collection reflects.
    collected: Option<(u64, u64, DVec3)>,
    /// The last `collect` found the scene unchanged and did nothing.
    reused_last: bool,
}

/// A node (or its light) the frame phase left out, so that one bad object
/// costs only itself, and the application hears about it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SkippedNode {
    /// The node.
    pub node: NodeKey,
    /// Its name.
    pub name: String,
    /// Why it was left out.
    pub reason: &'static str,
}

/// The normal matrix `transpose(inverse(upper3x3(world)))`, or `None` when
/// the matrix is non-finite or singular.
pub fn normal_matrix(world: &Mat4) -> Option<Mat3> {
    if !world.is_finite() {
        return None;
    }
    let m = Mat3::from_mat4(*world);
    let det = m.determinant();
    // Relative test: a scale of 1e-4 per axis (det 1e-12) is legitimate,
    // an exactly flat or NaN-producing matrix is not.
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let n = m.inverse().transpose();
    n.is_finite().then_some(n)
}

/// `world` moved so that `origin` becomes (0, 0, 0), rounded to `f32`
/// last: `T(-origin) · world`, exact for projective matrices too.
pub fn relative_to_origin(world: &DMat4, origin: DVec3) -> Mat4 {
    let shift = |c: glam::DVec4| c - (origin * c.w).extend(0.0);
    DMat4::from_cols(shift(world.x_axis), shift(world.y_axis), shift(world.z_axis), shift(world.w_axis)).as_mat4()
}

impl FrameCollection {
    /// Runs the frame phase over `scene`, reusing this collection's buffers.
    /// The GPU's matrices and light positions are relative to `origin`.
    pub fn collect(&mut self, scene: &Scene, origin: DVec3) {
        let _span = info_span!("frame_phase", nodes = scene.node_count()).entered();
        // An unchanged scene seen from the same origin has unchanged
        // transforms, bounds and lights.
        let key = (scene.id(), scene.revision(), origin);
        self.reused_last = self.collected == Some(key);
        if self.reused_last {
            return;
        }
        self.collected = Some(key);
        {
            let _span = info_span!("world_transforms").entered();
            scene.resolve_world_transforms(&mut self.world);
        }
        self.renderables.clear();
        // In place when no prepared frame still holds the previous frame's
        // matrices (ScenePrep releases them first); a copy otherwise.
        let transforms = Arc::make_mut(&mut self.transforms);
        transforms.world.clear();
        transforms.normal.clear();
        self.directional_lights.clear();
        self.positional_lights.clear();
        self.local_shadow_casters.clear();
        self.shadow_sun = None;
        self.lod_levels.clear();
        self.submeshes.clear();
        self.skipped_nodes = 0;
        self.skipped.clear();

        let _span = info_span!("collect_renderables_and_lights").entered();
        for (key, node) in scene.nodes() {
            if node.renderable.is_none() && node.light.is_none() {
                continue;
            }
            if !self.world.is_effectively_visible(key) {
                continue;
            }
            let Some(world64) = self.world.get_f64(key) else { continue };
            let world = world64.as_mat4();
            // A skinned mesh does not use its node's transform (its joints
            // place it), so a singular one there does not hide it.
            let skinned_node = node.skin.is_some()
                && node
                    .renderable
                    .as_ref()
                    .and_then(|r| scene.geometry(r.geometry))
                    .is_some_and(|g| g.skin_weights().is_some());
            let Some(normal) = normal_matrix(&world).or_else(|| skinned_node.then_some(Mat3::IDENTITY)) else {
                warn!(node = %node.name, "skipping node with a non-finite or singular world transform");
                self.skip(key, &node.name, "non-finite or singular world transform");
                continue;
            };
            if let Some(light) = &node.light {
                let position = (world64.w_axis.truncate() - origin).as_vec3();
                if let Err(reason) = self.collect_light(key, &node.name, light, node.flags, &world, position) {
                    self.skipped.push(SkippedNode { node: key, name: node.name.clone(), reason });
                }
            }
            let Some(renderable) = &node.renderable else { continue };
            let Some(geometry) = scene.geometry(renderable.geometry) else {
                warn!(node = %node.name, "skipping renderable whose geometry was removed");
                continue;
            };
            // A skinned renderable: its joint matrices join the frame's
            // matrices, and its bound is the union of each joint's move of
            // the vertices it weighs (every pose stays inside).
            let skinned = match (&node.skin, geometry.skin_weights()) {
                (Some(skin), Some(_)) => match self.collect_joints(skin, geometry, &node.morph_weights, origin) {
                    Ok(joints) => Some(joints),
                    Err(reason) => {
                        warn!(node = %node.name, "skipping skinned renderable: {reason}");
                        self.skip(key, &node.name, reason);
                        continue;
                    }
                },
                _ => None,
            };
            // In f64 and rounded outward: far from the origin the f32
            // matrix and corners would round the box inward by up to a
            // unit, and culling must never lose what it bounds.
            let world_aabb = match skinned {
                Some(joints) => joints.bounds.to_f32_outward(),
                None => {
                    let local = geometry.morphed_bound(geometry.local_aabb(), &node.morph_weights);
                    oxygen_core::DAabb::transformed(&local, &world64).to_f32_outward()
                }
            };
            // Morph weights travel with the frame's matrices (a header the
            // vertex shader reads), so they change without any upload but
            // the matrices'.
            let morph_base = if geometry.morph_targets().is_empty() {
                oxygen_bindless::INVALID_SLOT
            } else {
                push_morph_header(
                    Arc::make_mut(&mut self.transforms),
                    geometry.vertices().len(),
                    &node.morph_weights,
                    geometry.morph_targets().len(),
                )
            };
            let joint_base = skinned.map_or(oxygen_bindless::INVALID_SLOT, |joints| joints.base);
            if !world_aabb.is_finite() {
                warn!(node = %node.name, "skipping renderable with non-finite world bounds");
                self.skip(key, &node.name, "non-finite world bounds");
                continue;
            }
            let submesh_start = self.submeshes.len() as u32;
            let mut per_node =
                if node.flags.contains(NodeFlags::CASTS_SHADOWS) { PassMask::CASTS_SHADOWS } else { PassMask::empty() };
            // A mirroring world transform flips the triangles' winding; a
            // skinned mesh's is its joints'.
            let mirrored = skinned.map_or(Mat3::from_mat4(world).determinant() < 0.0, |joints| joints.mirrored);
            if mirrored {
                per_node |= PassMask::MIRRORED;
            }
            for (range, handle) in geometry.submeshes().iter().zip(&renderable.materials) {
                let Some(material) = scene.material(*handle) else { continue };
                self.submeshes.push(SubmeshEntry {
                    material: material_index(*handle),
                    pass_mask: PassMask::for_material(material.alpha_mode, material.double_sided) | per_node,
                    first_index: range.first_index,
                    index_count: range.index_count,
                });
            }
            let submeshes = (submesh_start, self.submeshes.len() as u32 - submesh_start);
            // A skinned or morphed renderable is drawn with its base mesh:
            // its LODs' vertices have no skin or morph records matching it.
            let deformed = skinned.is_some() || !geometry.morph_targets().is_empty();
            let node_lods: &[oxygen_core::LodLevel] = if deformed { &[] } else { &node.lods };
            let lods = (self.lod_levels.len() as u32, node_lods.len() as u32);
            self.lod_levels.extend_from_slice(node_lods);
            let transforms = Arc::make_mut(&mut self.transforms);
            let transform_index = transforms.world.len() as u32;
            transforms.world.push(relative_to_origin(&world64, origin));
            transforms.normal.push(crate::NormalMatrix::with_class(normal, node.semantic_class));
            self.renderables.push(RenderableEntry {
                node: key,
                node_id: node_index(key),
                transform_index,
                geometry: renderable.geometry,
                geometry_id: geometry_index(renderable.geometry),
                world_aabb,
                world_sphere: Sphere::from_aabb(&world_aabb),
                flags: node.flags,
                lods,
                submeshes,
                joint_base,
                morph_base,
            });
        }
    }

    /// Pushes a skin's joint matrices (world of the joint × inverse bind,
    /// relative to the render origin) and says where they start, the
    /// skinned geometry's bound in this pose and whether it is mirrored.
    /// Leaves the matrices as they were on failure.
    fn collect_joints(
        &mut self,
        skin: &oxygen_core::Skin,
        geometry: &oxygen_core::Geometry,
        morph_weights: &[f32],
        origin: DVec3,
    ) -> Result<Joints, &'static str> {
        if geometry.joint_bounds().len() > skin.joints.len() {
            return Err("a vertex names a joint past the skin's joints");
        }
        let transforms = Arc::make_mut(&mut self.transforms);
        let base = transforms.world.len();
        let mut bounds: Option<oxygen_core::DAabb> = None;
        for (i, (joint, inverse_bind)) in skin.joints.iter().zip(&skin.inverse_bind_matrices).enumerate() {
            let Some(joint_world) = self.world.get_f64(*joint) else {
                transforms.world.truncate(base);
                transforms.normal.truncate(base);
                return Err("a joint node is missing");
            };
            let m = joint_world * inverse_bind.as_dmat4();
            let relative = relative_to_origin(&m, origin);
            // A joint scaled to nothing moves its vertices to a point: no
            // normal to keep there, so the unit matrix stands in.
            let normal = normal_matrix(&relative).unwrap_or(Mat3::IDENTITY);
            transforms.world.push(relative);
            transforms.normal.push(normal.into());
            if let Some(Some(local)) = geometry.joint_bounds().get(i) {
                // Morphing comes before skinning: the joint moves the
                // morphed vertices.
                let local = geometry.morphed_bound(*local, morph_weights);
                let moved = oxygen_core::DAabb::transformed(&local, &m);
                bounds = Some(bounds.map_or(moved, |b| b.union(moved)));
            }
        }
        let bounds = bounds.ok_or("no vertex is weighted to any joint")?;
        let mirrored = transforms.world.get(base).is_some_and(|m| Mat3::from_mat4(*m).determinant() < 0.0);
        Ok(Joints { base: base as u32, bounds, mirrored })
    }

    fn skip(&mut self, node: NodeKey, name: &str, reason: &'static str) {
        self.skipped_nodes += 1;
        self.skipped.push(SkippedNode { node, name: name.to_owned(), reason });
    }

    /// Forgets what was collected, so the next `collect` redoes everything,
    /// world transforms included.
    pub fn invalidate(&mut self) {
        self.collected = None;
        self.world.invalidate();
    }

    /// True when the last `collect` reused the previous frame's results
    /// because the scene had not changed.
    pub fn reused_last(&self) -> bool {
        self.reused_last
    }

    /// A stable text listing of the gated lights, for snapshot tests.
    pub fn dump_lights(&self) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let v = |a: [f32; 3]| format!("({:.3}, {:.3}, {:.3})", a[0], a[1], a[2]);
        let _ = writeln!(out, "directional lights ({}):", self.directional_lights.len());
        for l in &self.directional_lights {
            let _ = writeln!(
                out,
                "  direction={} intensity={} color={} casts_shadows={}",
                v(l.direction),
                l.intensity,
                v(l.color),
                l.flags & DirectionalLightRecord::CASTS_SHADOWS != 0
            );
        }
        let _ = writeln!(out, "positional lights ({}):", self.positional_lights.len());
        for l in &self.positional_lights {
            let kind = if l.kind == PositionalLightRecord::SPOT { "spot " } else { "point" };
            let _ = writeln!(
                out,
                "  {kind} position={} direction={} range={} intensity={} cos_inner={:.3} cos_outer={:.3} casts_shadows={}",
                v(l.position),
                v(l.direction),
                l.range,
                l.intensity,
                l.cos_inner,
                l.cos_outer,
                l.flags & PositionalLightRecord::CASTS_SHADOWS != 0
            );
        }
        out
    }

    /// `position` is the light's position relative to the render origin.
    /// An unusable light is an `Err` with the reason; a light gated out
    /// (baked, not affecting the world) is simply not collected.
    fn collect_light(
        &mut self,
        key: NodeKey,
        name: &str,
        light: &oxygen_core::Light,
        flags: NodeFlags,
        world: &Mat4,
        position: Vec3,
    ) -> Result<(), &'static str> {
        if !light.affects_world || light.mobility == Mobility::Baked {
            return Ok(());
        }
        let Some(direction) = world.transform_vector3(Vec3::NEG_Z).try_normalize() else {
            warn!(node = %name, "skipping light whose node transform has no direction");
            return Err("light whose node transform has no direction");
        };
        let cones_finite = match light.kind {
            LightKind::Spot { inner_cone, outer_cone, .. } => inner_cone.is_finite() && outer_cone.is_finite(),
            _ => true,
        };
        if !light.color.is_finite() || !cones_finite || !position.is_finite() {
            warn!(node = %name, "skipping light with a non-finite colour, cone angle or position");
            return Err("light with a non-finite colour, cone angle or position");
        }
        let casts = light.casts_shadows && flags.contains(NodeFlags::CASTS_SHADOWS);
        let shadow_flags = u32::from(casts);
        let color = light.color.max(Vec3::ZERO).to_array();
        let intensity = if light.intensity.is_finite() { light.intensity.max(0.0) } else { 0.0 };
        match light.kind {
            LightKind::Directional => {
                // The shader gives the cascades to the first record with the
                // shadow flag; naming that same light keeps the cascade views
                // the renderer registers and the light they shade in step.
                if casts && self.shadow_sun.is_none() {
                    self.shadow_sun = Some(key);
                }
                self.directional_lights.push(DirectionalLightRecord {
                    direction: direction.to_array(),
                    intensity,
                    color,
                    flags: shadow_flags,
                    shadow_slot: INVALID_SLOT,
                    angular_radius: light.angular_radius(),
                    reserved: [0; 2],
                });
            }
            LightKind::Point { range } | LightKind::Spot { range, .. } => {
                let (shadow_kind, cos_inner, cos_outer) = match light.kind {
                    LightKind::Spot { inner_cone, outer_cone, .. } => {
                        let outer = outer_cone.clamp(1e-4, std::f32::consts::FRAC_PI_2);
                        let inner = inner_cone.clamp(0.0, outer - 1e-4);
                        (LocalShadowKind::Spot, inner.cos(), outer.cos())
                    }
                    _ => (LocalShadowKind::Point, 1.0, -1.0),
                };
                // Shadow-casting spot and point lights get atlas tiles in
                // node order (one per spot, six per point light) while
                // MAX_SHADOW_TILES lasts; a light that does not fit leaves
                // the tiles to a later, smaller one.
                let tiles_used = self.local_shadow_casters.last().map_or(0, |c| c.first_tile + c.tile_count);
                let tile_count = shadow_kind.tile_count();
                let shadow_slot = if casts && tiles_used + tile_count <= MAX_SHADOW_TILES {
                    self.local_shadow_casters.push(LocalShadowCaster {
                        node: key,
                        kind: shadow_kind,
                        light_index: self.positional_lights.len() as u32,
                        first_tile: tiles_used,
                        tile_count,
                    });
                    tiles_used
                } else {
                    INVALID_SLOT
                };
                let kind = shadow_kind.record_kind();
                self.positional_lights.push(PositionalLightRecord {
                    position: position.to_array(),
                    range: range.filter(|r| r.is_finite() && *r > 0.0).unwrap_or(0.0),
                    direction: direction.to_array(),
                    intensity,
                    color,
                    kind,
                    cos_inner,
                    cos_outer,
                    flags: shadow_flags,
                    shadow_slot,
                    radius: light.radius(),
                    pad0: 0,
                    pad1: 0,
                    pad2: 0,
                });
            }
        }
        Ok(())
    }
}
