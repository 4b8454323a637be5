//! Bounding volume hierarchy for the compute-shader path tracer.
//!
//! The same builder serves both levels of the ray scene: per mesh over
//! triangle boxes (bottom level, see [`triangle_boxes`]) and per frame over
//! instance world boxes (top level), so it takes boxes, never triangles.
//!
//! The build is a top-down binned surface-area-heuristic (SAH) split with
//! 16 bins (`BINS`) along the axis of largest centroid extent, partitioning an
//! index array in place, so a build is `O(n log n)` and allocation is linear.
//! The result is flattened into 32-byte [`BvhNode`]s whose siblings sit next
//! to each other, which lets the shader store one index per interior node.
//!
//! ## Primitives without a usable box
//!
//! A box that is empty on some axis (`min > max`, e.g. [`Aabb::EMPTY`]) or
//! has a NaN coordinate is treated as the point at the origin; infinite
//! coordinates are clamped to `±f32::MAX`. Such primitives are kept (they
//! stay reachable from the root and listed in [`Bvh::order`]) so an index
//! never silently disappears, but the tree's boxes are only guaranteed to
//! contain the *sanitised* boxes. Every box in the tree is finite.
//!
//! ## Determinism
//!
//! No hashing, no threads and no floating-point reductions whose order
//! depends on anything but the input: the same boxes give bit-identical
//! nodes and order.

use bytemuck::Zeroable;
use glam::Vec3;
use oxygen_core::Aabb;

/// Bins per SAH evaluation; 16 is the usual sweet spot where more bins stop
/// improving the tree measurably but keep costing build time.
const BINS: usize = 16;

/// SAH cost of visiting a node, relative to intersecting one primitive.
const TRAVERSAL_COST: f64 = 1.0;

/// SAH cost of intersecting one primitive.
const INTERSECTION_COST: f64 = 1.0;

/// Relative widening of a slab interval. The subtraction and product in the
/// slab test each round, so a ray grazing a face can come out an ulp or two
/// outside a box it really touches; widening by a few ulps (PBRT's
/// `1 + 2γ₃`) keeps the test conservative, which only costs an occasional
/// extra visit.
const SLAB_PAD: f32 = 4.0 * f32::EPSILON;

oxygen_gpu::gpu_struct! {
    /// One node as the GPU reads it: 32 bytes.
    ///
    /// Its WGSL twin, generated from this declaration, is `struct { min:
    /// vec3<f32>, first: u32, max: vec3<f32>, count: u32 }`: each `vec3`
    /// takes the 12 bytes before the `u32` that fills its 16-byte slot.
    #[derive(Debug, PartialEq)]
    pub struct BvhNode: 32 bytes {
        /// Smallest corner of the node's box.
        pub min: [f32; 3],
        /// Interior (count == 0): index of the first child; the second is first + 1.
        /// Leaf (count > 0): first index into `Bvh::order`.
        pub first: u32,
        /// Largest corner of the node's box.
        pub max: [f32; 3],
        /// Primitives in a leaf; 0 for an interior node.
        pub count: u32,
    }
}

impl BvhNode {
    fn aabb(&self) -> Aabb {
        Aabb { min: Vec3::from(self.min), max: Vec3::from(self.max) }
    }

    fn set_bounds(&mut self, b: &Aabb) {
        self.min = b.min.to_array();
        self.max = b.max.to_array();
    }
}

/// A flattened bounding volume hierarchy over a list of boxes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    /// `nodes[0]` is the root. Empty when built from no boxes.
    pub nodes: Vec<BvhNode>,
    /// Primitive indices (into the boxes given to `build`) in leaf order.
    pub order: Vec<u32>,
}

/// Work item of the explicit build stack.
struct Task {
    node: usize,
    start: usize,
    end: usize,
    depth: u32,
    /// Union of the range's primitive boxes.
    bounds: Aabb,
    /// Bounds of the range's centroids.
    centroids: Aabb,
}

/// How a node's range is divided.
enum Split {
    Leaf,
    /// Children are `[start, start + mid)` and `[start + mid, end)`; their
    /// bounds are known from the bins, saving a pass over the primitives.
    Binned {
        mid: usize,
        left: (Aabb, Aabb),
        right: (Aabb, Aabb),
    },
    /// Children are the two halves at `mid`; their bounds must be computed.
    Halves {
        mid: usize,
    },
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    centroids: Aabb,
    count: usize,
}

impl Bin {
    const EMPTY: Bin = Bin { bounds: Aabb::EMPTY, centroids: Aabb::EMPTY, count: 0 };
}

impl Bvh {
    /// The deepest a built tree may be (root = depth 0); the GPU's traversal
    /// stack holds MAX_DEPTH + 1 entries, so a deeper tree could not be
    /// traversed without dropping nodes.
    pub const MAX_DEPTH: u32 = 40;

    /// Builds over `boxes`, each a primitive's bounds.
    ///
    /// Leaves hold at most `max_leaf` primitives (`0` is treated as `1`),
    /// except where that would make the tree deeper than [`Bvh::MAX_DEPTH`];
    /// then a leaf at that depth holds the rest. Near the depth limit (and
    /// whenever the remaining depth only just suffices to reach `max_leaf`
    /// by halving) splits switch from SAH to centroid medians, so the limit
    /// is only reached when more than `max_leaf · 2^MAX_DEPTH` boxes are
    /// given.
    ///
    /// Empty or NaN boxes become the point at the origin and infinite
    /// coordinates are clamped to `±f32::MAX` (see the module docs); they
    /// are still placed in a leaf. Node boxes are the exact `f32` union of
    /// the (sanitised) boxes below them. At most `u32::MAX / 2` boxes are
    /// used, as node and order indices are `u32`; beyond that (over 100 GB
    /// of input) the rest are left out.
    pub fn build(boxes: &[Aabb], max_leaf: u32) -> Bvh {
        let max_leaf = max_leaf.max(1) as usize;
        let n = boxes.len().min((u32::MAX / 2) as usize);
        if n == 0 {
            return Bvh::default();
        }
        let prims: Vec<Aabb> = boxes[..n].iter().map(sanitize).collect();
        // Halving before adding keeps the centroid of a ±f32::MAX box finite.
        let centroids: Vec<Vec3> = prims.iter().map(|b| b.min * 0.5 + b.max * 0.5).collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * n.div_ceil(max_leaf));
        nodes.push(BvhNode::zeroed());

        let (bounds, cbounds) = range_bounds(&order, &prims, &centroids);
        let mut stack = vec![Task { node: 0, start: 0, end: n, depth: 0, bounds, centroids: cbounds }];
        while let Some(task) = stack.pop() {
            nodes[task.node].set_bounds(&task.bounds);
            let range = &mut order[task.start..task.end];
            let split = choose_split(range, &prims, &centroids, &task, max_leaf);
            let (mid, left, right) = match split {
                Split::Leaf => {
                    nodes[task.node].first = task.start as u32;
                    nodes[task.node].count = range.len() as u32;
                    continue;
                }
                Split::Binned { mid, left, right } => (mid, left, right),
                Split::Halves { mid } => {
                    let (l, r) = range.split_at(mid);
                    (mid, range_bounds(l, &prims, &centroids), range_bounds(r, &prims, &centroids))
                }
            };
            let first = nodes.len();
            nodes.push(BvhNode::zeroed());
            nodes.push(BvhNode::zeroed());
            nodes[task.node].first = first as u32;
            nodes[task.node].count = 0;
            let depth = task.depth + 1;
            let split_at = task.start + mid;
            // Right pushed first so the left subtree is built (and laid out) first.
            stack.push(Task {
                node: first + 1,
                start: split_at,
                end: task.end,
                depth,
                bounds: right.0,
                centroids: right.1,
            });
            stack.push(Task {
                node: first,
                start: task.start,
                end: split_at,
                depth,
                bounds: left.0,
                centroids: left.1,
            });
        }
        Bvh { nodes, order }
    }

    /// Bounding box of the whole tree (Aabb::EMPTY when empty).
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, BvhNode::aabb)
    }

    /// Depth of the deepest leaf (0 for a lone root leaf and for an empty
    /// tree).
    ///
    /// Child indices outside `nodes` are ignored and at most `nodes.len()`
    /// nodes are visited, so a hand-made malformed tree cannot make this
    /// loop forever or panic.
    pub fn depth(&self) -> u32 {
        if self.nodes.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut stack = vec![(0usize, 0u32)];
        let mut visits = 0;
        while let Some((index, depth)) = stack.pop() {
            visits += 1;
            if visits > self.nodes.len() {
                break;
            }
            let Some(node) = self.nodes.get(index) else { continue };
            deepest = deepest.max(depth);
            if node.count == 0 {
                let first = node.first as usize;
                stack.push((first, depth + 1));
                stack.push((first.saturating_add(1), depth + 1));
            }
        }
        deepest
    }

    /// CPU closest-hit traversal, the reference for tests and the twin of
    /// the WGSL one.
    ///
    /// Visits the leaves whose box the ray `origin + t · dir`, `t` in
    /// `(t_min, t_max)`, touches, nearer child first, calls
    /// `hit(primitive)` for each primitive there and returns the closest
    /// `(primitive, t)` with `t_min < t < best so far`. On an exact tie the
    /// first primitive found is kept.
    ///
    /// The slab test uses `1 / dir`. A direction component of exactly zero
    /// (either sign) makes the ray parallel to that slab pair: the box is
    /// then hit on that axis iff the origin lies within `[min, max]`
    /// (inclusive), which is how an axis-aligned ray starting inside a box
    /// is never rejected by a `0 · ∞ = NaN`. For a nonzero component so
    /// small that `1 / d` overflows, a NaN can only come from a plane
    /// through the origin, whose true `t` is 0, and is replaced by 0. The
    /// interval is widened by a few ulps so grazing rays stay conservative.
    pub fn closest_hit(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
        mut hit: impl FnMut(u32) -> Option<f32>,
    ) -> Option<(u32, f32)> {
        // Also rejects NaN bounds.
        if !(t_min < t_max) {
            return None;
        }
        let root = self.nodes.first()?;
        let ray = Ray { origin, dir, inv: dir.recip(), t_min };
        let mut best: Option<(u32, f32)> = None;
        let mut best_t = t_max;
        let mut current = 0usize;
        ray.enter(root, best_t)?;
        // Far children waiting, with their entry distance so those beyond a
        // hit found meanwhile are dropped without another slab test.
        let mut stack: Vec<(usize, f32)> = Vec::with_capacity(Self::MAX_DEPTH as usize + 1);
        // A valid tree visits each node at most once; the cap only matters
        // for hand-made trees with cycles.
        let mut visits = 0usize;
        loop {
            visits += 1;
            if visits > self.nodes.len() {
                return best;
            }
            let mut next = None;
            if let Some(node) = self.nodes.get(current) {
                if node.count > 0 {
                    let start = node.first as usize;
                    let end = start.saturating_add(node.count as usize).min(self.order.len());
                    for &prim in self.order.get(start..end).unwrap_or(&[]) {
                        if let Some(t) = hit(prim)
                            && t > t_min
                            && t < best_t
                        {
                            best_t = t;
                            best = Some((prim, t));
                        }
                    }
                } else {
                    let left = node.first as usize;
                    let right = left.saturating_add(1);
                    let tl = self.nodes.get(left).and_then(|n| ray.enter(n, best_t));
                    let tr = self.nodes.get(right).and_then(|n| ray.enter(n, best_t));
                    next = match (tl, tr) {
                        (Some(a), Some(b)) => {
                            let (near, far) = if a <= b { (left, (right, b)) } else { (right, (left, a)) };
                            stack.push(far);
                            Some(near)
                        }
                        (Some(_), None) => Some(left),
                        (None, Some(_)) => Some(right),
                        (None, None) => None,
                    };
                }
            }
            current = match next {
                Some(n) => n,
                None => loop {
                    match stack.pop() {
                        None => return best,
                        // `<=` because entry distances were padded downwards
                        // and a primitive exactly at the entry is still closer.
                        Some((n, t)) if t <= best_t => break n,
                        Some(_) => {}
                    }
                },
            };
        }
    }
}

/// Ray with its precomputed reciprocal direction.
struct Ray {
    origin: Vec3,
    dir: Vec3,
    inv: Vec3,
    t_min: f32,
}

impl Ray {
    /// Distance at which the ray enters `node`'s box within `(t_min,
    /// t_max)` (padded slightly downwards), or `None` when it misses.
    fn enter(&self, node: &BvhNode, t_max: f32) -> Option<f32> {
        let mut enter = self.t_min;
        let mut exit = t_max;
        for axis in 0..3 {
            let (lo, hi, o) = (node.min[axis], node.max[axis], self.origin[axis]);
            if self.dir[axis] == 0.0 {
                if !(o >= lo && o <= hi) {
                    return None;
                }
                continue;
            }
            let inv = self.inv[axis];
            let a = nan_to_zero((lo - o) * inv);
            let b = nan_to_zero((hi - o) * inv);
            let (near, far) = if a <= b { (a, b) } else { (b, a) };
            enter = enter.max(near);
            exit = exit.min(far);
        }
        let enter = enter - enter.abs() * SLAB_PAD;
        let exit = exit + exit.abs() * SLAB_PAD;
        (enter <= exit).then_some(enter)
    }
}

fn nan_to_zero(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x }
}

/// The finite box a primitive is filed under (see the module docs).
fn sanitize(b: &Aabb) -> Aabb {
    // `<=` is false for NaN, so this also catches NaN on any axis.
    if !b.min.cmple(b.max).all() {
        return Aabb { min: Vec3::ZERO, max: Vec3::ZERO };
    }
    let lo = Vec3::splat(-f32::MAX);
    let hi = Vec3::splat(f32::MAX);
    Aabb { min: b.min.max(lo).min(hi), max: b.max.max(lo).min(hi) }
}

fn union(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb { min: a.min.min(b.min), max: a.max.max(b.max) }
}

/// Box and centroid bounds of the primitives listed in `range`.
fn range_bounds(range: &[u32], prims: &[Aabb], centroids: &[Vec3]) -> (Aabb, Aabb) {
    let mut bounds = Aabb::EMPTY;
    let mut cbounds = Aabb::EMPTY;
    for &i in range {
        bounds = union(&bounds, &prims[i as usize]);
        cbounds = cbounds.including(centroids[i as usize]);
    }
    (bounds, cbounds)
}

/// Half the surface area, in `f64` because the extents of clamped boxes
/// (up to 2 · f32::MAX) would overflow an `f32` product.
fn half_area(b: &Aabb) -> f64 {
    let d = b.max.as_dvec3() - b.min.as_dvec3();
    if !(d.x >= 0.0 && d.y >= 0.0 && d.z >= 0.0) {
        return 0.0;
    }
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// Sum of the extents: the SAH measure used when a node is flat or a
/// segment, where every area is zero and the SAH could not tell splits
/// apart.
fn half_perimeter(b: &Aabb) -> f64 {
    let d = b.max.as_dvec3() - b.min.as_dvec3();
    if !(d.x >= 0.0 && d.y >= 0.0 && d.z >= 0.0) {
        return 0.0;
    }
    d.x + d.y + d.z
}

/// Number of halvings needed to get `count` primitives down to leaves of
/// `max_leaf`.
fn halvings_needed(count: usize, max_leaf: usize) -> u32 {
    let leaves = count.div_ceil(max_leaf);
    leaves.next_power_of_two().trailing_zeros()
}

/// Decides how to divide `range` (reordering it in place) or makes it a leaf.
fn choose_split(range: &mut [u32], prims: &[Aabb], centroids: &[Vec3], task: &Task, max_leaf: usize) -> Split {
    let count = range.len();
    if count <= 1 || task.depth >= Bvh::MAX_DEPTH {
        return Split::Leaf;
    }
    let cb = &task.centroids;
    let extent = cb.max.as_dvec3() - cb.min.as_dvec3();
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let axis_extent = extent[axis];
    if !(axis_extent > 0.0) {
        // Every centroid coincides: no plane separates them, and splitting
        // by position in the range at least keeps leaves small.
        return if count > max_leaf { Split::Halves { mid: count / 2 } } else { Split::Leaf };
    }

    // SAH splits can peel off one primitive per level on skewed inputs
    // (e.g. exponentially spaced centroids); medians halve the count, so
    // switching early enough bounds the depth while still reaching
    // `max_leaf`.
    if task.depth >= Bvh::MAX_DEPTH - 8 || task.depth + halvings_needed(count, max_leaf) >= Bvh::MAX_DEPTH {
        if count <= max_leaf {
            return Split::Leaf;
        }
        let mid = count / 2;
        // Ties broken by index so the result does not depend on the
        // selection algorithm's internal order.
        range.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]).then(a.cmp(&b))
        });
        return Split::Halves { mid };
    }

    let cmin = cb.min[axis] as f64;
    let scale = BINS as f64 / axis_extent;
    // The same function decides binning and partitioning, so the two agree
    // exactly; the extremes land in bins 0 and BINS - 1, so every candidate
    // split has primitives on both sides.
    let bin_of = |i: u32| -> usize {
        let c = centroids[i as usize][axis] as f64;
        (((c - cmin) * scale) as usize).min(BINS - 1)
    };
    let mut bins = [Bin::EMPTY; BINS];
    for &i in range.iter() {
        let bin = &mut bins[bin_of(i)];
        bin.bounds = union(&bin.bounds, &prims[i as usize]);
        bin.centroids = bin.centroids.including(centroids[i as usize]);
        bin.count += 1;
    }

    let measure: fn(&Aabb) -> f64 = if half_area(&task.bounds) > 0.0 { half_area } else { half_perimeter };
    // right[k] accumulates bins k.. from the right; the sweep from the left
    // then evaluates "bins 0..=k | bins k+1.." for each k.
    let mut right = [Bin::EMPTY; BINS];
    let mut acc = Bin::EMPTY;
    for k in (0..BINS).rev() {
        acc = merge(&acc, &bins[k]);
        right[k] = acc;
    }
    let mut best: Option<(usize, f64, Bin)> = None;
    let mut left = Bin::EMPTY;
    for k in 0..BINS - 1 {
        left = merge(&left, &bins[k]);
        let r = &right[k + 1];
        if left.count == 0 || r.count == 0 {
            continue;
        }
        let cost = measure(&left.bounds) * left.count as f64 + measure(&r.bounds) * r.count as f64;
        if best.as_ref().is_none_or(|(_, c, _)| cost < *c) {
            best = Some((k, cost, left));
        }
    }
    let Some((k, cost, left)) = best else {
        // Unreachable with a positive extent; kept so odd float behaviour
        // still yields a valid tree.
        return if count > max_leaf { Split::Halves { mid: count / 2 } } else { Split::Leaf };
    };
    if count <= max_leaf {
        // Both sides scaled by the parent's measure, so no division (which
        // would be 0/0 for a degenerate parent).
        let parent = measure(&task.bounds);
        let split_cost = TRAVERSAL_COST * parent + INTERSECTION_COST * cost;
        let leaf_cost = INTERSECTION_COST * parent * count as f64;
        if !(split_cost < leaf_cost) {
            return Split::Leaf;
        }
    }
    let mid = partition(range, |i| bin_of(i) <= k);
    if mid != left.count || mid == 0 || mid == count {
        return if count > max_leaf { Split::Halves { mid: count / 2 } } else { Split::Leaf };
    }
    let r = &right[k + 1];
    Split::Binned { mid, left: (left.bounds, left.centroids), right: (r.bounds, r.centroids) }
}

fn merge(a: &Bin, b: &Bin) -> Bin {
    Bin { bounds: union(&a.bounds, &b.bounds), centroids: union(&a.centroids, &b.centroids), count: a.count + b.count }
}

/// In-place two-pointer partition; returns how many satisfy `pred` (they
/// end up first). Not stable, but deterministic.
fn partition(v: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let (mut i, mut j) = (0, v.len());
    while i < j {
        if pred(v[i]) {
            i += 1;
        } else {
            j -= 1;
            v.swap(i, j);
        }
    }
    i
}

/// Per-triangle boxes of an indexed mesh (`indices.len() / 3` triangles):
/// what a bottom-level BVH is built from.
///
/// Trailing indices that do not make a whole triangle are ignored. A vertex
/// index outside `positions` is skipped, so such a triangle's box covers
/// only its valid corners ([`Aabb::EMPTY`] if none; [`Bvh::build`] files
/// that at the origin).
pub fn triangle_boxes(positions: &[[f32; 3]], indices: &[u32]) -> Vec<Aabb> {
    indices
        .chunks_exact(3)
        .map(|tri| Aabb::from_points(tri.iter().filter_map(|&i| positions.get(i as usize)).map(|&p| Vec3::from(p))))
        .collect()
}

/// Möller–Trumbore ray/triangle test, returning t (and barycentrics u, v)
/// when t in (t_min, t_max); no back-face culling. Used by tests and as the
/// CPU twin of the shader's.
///
/// `u` weights `b` and `v` weights `c`: the hit point is
/// `a + u (b − a) + v (c − a)`. The origin is first moved along the ray
/// to the point nearest `a` (see the body) so far-away origins stay
/// accurate; the shader's twin should do the same. Edges count as inside (`u, v >= 0`,
/// `u + v <= 1`), so a ray through a shared edge hits at least one of the
/// two triangles. Degenerate triangles (zero determinant) and NaNs miss.
pub fn ray_triangle(
    origin: Vec3,
    dir: Vec3,
    a: Vec3,
    b: Vec3,
    c: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let e1 = b - a;
    let e2 = c - a;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    // No epsilon: an absolute one would reject small but valid triangles,
    // and a parallel ray gives exactly 0 or lands outside via u/v anyway.
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    // Textbook Möller–Trumbore takes dot products of `origin - a` with
    // unit-sized vectors; with the origin far away (a camera 1e6 from the
    // mesh) those cancel catastrophically and edge-on triangles report hits
    // thousands of triangle-widths off. Sliding the origin along the ray to
    // the point nearest `a` first keeps the vector short, so the error
    // stays near the ray's own precision (which is what the conservative
    // slab test allows for), and costs nothing in accuracy when the origin
    // is already close. The shift is done on `origin - a` rather than on
    // `origin`, so no large coordinate is rounded.
    let s = origin - a;
    let t0 = -s.dot(dir) / dir.length_squared();
    let t0 = if t0.is_finite() { t0 } else { 0.0 };
    let s = s + dir * t0;
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = t0 + e2.dot(q) * inv_det;
    (t > t_min && t < t_max).then_some((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(x: f32) -> Aabb {
        Aabb { min: Vec3::new(x, 0.0, 0.0), max: Vec3::new(x + 1.0, 1.0, 1.0) }
    }

    #[test]
    fn bvh_node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 32);
        assert_eq!(std::mem::align_of::<BvhNode>(), 4);
    }

    #[test]
    fn bvh_empty_input() {
        let bvh = Bvh::build(&[], 4);
        assert!(bvh.nodes.is_empty() && bvh.order.is_empty());
        assert_eq!(bvh.bounds(), Aabb::EMPTY);
        assert_eq!(bvh.depth(), 0);
        assert_eq!(bvh.closest_hit(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY, |_| Some(1.0)), None);
    }

    #[test]
    fn bvh_single_box_is_root_leaf() {
        let bvh = Bvh::build(&[unit_box(2.0)], 0);
        assert_eq!(bvh.nodes.len(), 1);
        assert_eq!(bvh.nodes[0], BvhNode { min: [2.0, 0.0, 0.0], first: 0, max: [3.0, 1.0, 1.0], count: 1 });
        assert_eq!(bvh.order, vec![0]);
        assert_eq!(bvh.bounds(), unit_box(2.0));
    }

    #[test]
    fn bvh_max_leaf_zero_is_one() {
        let boxes: Vec<Aabb> = (0..9).map(|i| unit_box(i as f32 * 3.0)).collect();
        let bvh = Bvh::build(&boxes, 0);
        assert!(bvh.nodes.iter().all(|n| n.count <= 1));
        assert_eq!(bvh.nodes.iter().filter(|n| n.count == 1).count(), 9);
    }

    #[test]
    fn bvh_sanitize_policy() {
        assert_eq!(sanitize(&Aabb::EMPTY), Aabb { min: Vec3::ZERO, max: Vec3::ZERO });
        let nan = Aabb { min: Vec3::new(f32::NAN, 0.0, 0.0), max: Vec3::ONE };
        assert_eq!(sanitize(&nan), Aabb { min: Vec3::ZERO, max: Vec3::ZERO });
        let inf = Aabb { min: Vec3::splat(f32::NEG_INFINITY), max: Vec3::new(1.0, 2.0, f32::INFINITY) };
        let s = sanitize(&inf);
        assert_eq!(s.min, Vec3::splat(-f32::MAX));
        assert_eq!(s.max, Vec3::new(1.0, 2.0, f32::MAX));
    }

    #[test]
    fn bvh_bad_boxes_are_kept_finite() {
        let boxes = [
            Aabb::EMPTY,
            Aabb { min: Vec3::splat(f32::NAN), max: Vec3::splat(f32::NAN) },
            Aabb { min: Vec3::splat(f32::NEG_INFINITY), max: Vec3::splat(f32::INFINITY) },
            unit_box(5.0),
        ];
        let bvh = Bvh::build(&boxes, 1);
        let mut order = bvh.order.clone();
        order.sort_unstable();
        assert_eq!(order, vec![0, 1, 2, 3]);
        assert!(bvh.nodes.iter().all(|n| n.aabb().is_finite()));
        // The empty box, filed at the origin, is found by a ray through it.
        let found = bvh.closest_hit(Vec3::new(-1.0, 0.0, 0.0), Vec3::X, 0.0, 10.0, |p| (p == 0).then_some(1.0));
        assert_eq!(found, Some((0, 1.0)));
    }

    #[test]
    fn bvh_slab_parallel_ray_on_face() {
        let node = BvhNode { min: [0.0; 3], first: 0, max: [1.0; 3], count: 1 };
        // Starts on the min face and runs along it: 0 · ∞ must not reject it.
        let ray = Ray { origin: Vec3::ZERO, dir: Vec3::X, inv: Vec3::X.recip(), t_min: 0.0 };
        assert!(ray.enter(&node, f32::INFINITY).is_some());
        let ray = Ray { origin: Vec3::new(0.5, 2.0, 0.5), dir: Vec3::X, inv: Vec3::X.recip(), t_min: 0.0 };
        assert!(ray.enter(&node, f32::INFINITY).is_none());
        let d = Vec3::new(-0.0, -1.0, 0.0);
        let ray = Ray { origin: Vec3::new(1.0, 5.0, 1.0), dir: d, inv: d.recip(), t_min: 0.0 };
        assert!(ray.enter(&node, f32::INFINITY).is_some());
        assert!(ray.enter(&node, 3.9).is_none());
    }

    #[test]
    fn bvh_ray_triangle_basics() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let o = Vec3::new(0.25, 0.25, 1.0);
        let (t, u, v) = ray_triangle(o, -Vec3::Z, a, b, c, 0.0, 10.0).unwrap();
        assert_eq!((t, u, v), (1.0, 0.25, 0.25));
        // No back-face culling.
        assert!(ray_triangle(-o, Vec3::Z, a, b, c, 0.0, 10.0).is_none());
        assert!(ray_triangle(Vec3::new(0.25, 0.25, -1.0), Vec3::Z, a, b, c, 0.0, 10.0).is_some());
        // Interval is open.
        assert!(ray_triangle(o, -Vec3::Z, a, b, c, 1.0, 10.0).is_none());
        assert!(ray_triangle(o, -Vec3::Z, a, b, c, 0.0, 1.0).is_none());
        // Parallel and degenerate.
        assert!(ray_triangle(o, Vec3::X, a, b, c, 0.0, 10.0).is_none());
        assert!(ray_triangle(o, -Vec3::Z, a, a, c, 0.0, 10.0).is_none());
        assert!(ray_triangle(o, Vec3::new(f32::NAN, 0.0, -1.0), a, b, c, 0.0, 10.0).is_none());
    }

    #[test]
    fn bvh_triangle_boxes_tolerates_bad_indices() {
        let positions = [[0.0, 0.0, 0.0], [1.0, 2.0, 0.0], [0.0, 1.0, 3.0]];
        let boxes = triangle_boxes(&positions, &[0, 1, 2, 0, 1, 99, 7]);
        assert_eq!(boxes.len(), 2);
        assert_eq!(boxes[0], Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 2.0, 3.0) });
        assert_eq!(boxes[1], Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 2.0, 0.0) });
        assert!(triangle_boxes(&[], &[0, 1, 2])[0].is_empty());
    }

    /// The SAH's measures: half the surface area and the sum of the
    /// extents (of a 2 × 3 × 5 box off the origin here), both zero for a box
    /// empty along any one axis; a flat box has no area but a perimeter.
    #[test]
    fn bvh_half_area_and_half_perimeter() {
        let b = Aabb { min: Vec3::new(1.0, 1.0, 1.0), max: Vec3::new(3.0, 4.0, 6.0) };
        assert_eq!((half_area(&b), half_perimeter(&b)), (31.0, 10.0));
        for axis in 0..3 {
            let mut empty = b;
            empty.max[axis] = 0.0;
            assert_eq!((half_area(&empty), half_perimeter(&empty)), (0.0, 0.0), "empty along {axis}");
        }
        let flat = Aabb { min: b.min, max: Vec3::new(3.0, 4.0, 1.0) };
        assert_eq!((half_area(&flat), half_perimeter(&flat)), (6.0, 5.0));
    }

    #[test]
    fn bvh_halvings_needed() {
        assert_eq!(halvings_needed(1, 1), 0);
        assert_eq!(halvings_needed(2, 1), 1);
        assert_eq!(halvings_needed(5, 1), 3);
        assert_eq!(halvings_needed(8, 4), 1);
        assert_eq!(halvings_needed(9, 4), 2);
    }

    #[test]
    fn bvh_is_deterministic() {
        let boxes: Vec<Aabb> = (0..500u32)
            .map(|i| {
                let x = (i.wrapping_mul(2_654_435_761) % 1000) as f32;
                let y = (i.wrapping_mul(40_503) % 777) as f32;
                Aabb { min: Vec3::new(x, y, 0.0), max: Vec3::new(x + 2.0, y + 1.0, 1.0) }
            })
            .collect();
        assert_eq!(Bvh::build(&boxes, 2), Bvh::build(&boxes, 2));
    }
}
