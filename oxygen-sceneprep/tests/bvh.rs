//! Integration tests of the path tracer's BVH: structural invariants on
//! random and degenerate inputs, and closest hits against brute force.

use glam::Vec3;
use oxygen_core::Aabb;
use oxygen_sceneprep::testing::{Bvh, BvhNode, ray_triangle, triangle_boxes};

/// SplitMix64: a seeded generator small enough to live in the test, as the
/// workspace has no `rand`.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }

    fn vec_in(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(self.range(lo.x, hi.x), self.range(lo.y, hi.y), self.range(lo.z, hi.z))
    }

    fn direction(&mut self) -> Vec3 {
        loop {
            let v = self.vec_in(Vec3::splat(-1.0), Vec3::splat(1.0));
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

fn node_box(n: &BvhNode) -> Aabb {
    Aabb { min: Vec3::from(n.min), max: Vec3::from(n.max) }
}

fn contains(outer: &Aabb, inner: &Aabb) -> bool {
    outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
}

fn union(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb { min: a.min.min(b.min), max: a.max.max(b.max) }
}

/// Checks every structural promise of [`Bvh::build`]; returns the depth.
///
/// Boxes that are finite and non-empty must be contained by their leaf (and,
/// when every box is such, leaf boxes must be their exact union); others
/// only need to be present and reachable.
fn validate(bvh: &Bvh, boxes: &[Aabb], max_leaf: u32) -> u32 {
    let n = boxes.len();
    assert_eq!(bvh.order.len(), n, "order length");
    let mut seen = vec![false; n];
    for &p in &bvh.order {
        let p = p as usize;
        assert!(p < n, "primitive {p} out of range");
        assert!(!seen[p], "primitive {p} listed twice");
        seen[p] = true;
    }
    if n == 0 {
        assert!(bvh.nodes.is_empty());
        assert_eq!(bvh.bounds(), Aabb::EMPTY);
        return 0;
    }
    let good = |b: &Aabb| b.is_finite() && !b.is_empty();
    let all_good = boxes.iter().all(good);
    let mut node_seen = vec![false; bvh.nodes.len()];
    let mut covered = vec![false; n];
    let mut deepest = 0;
    let mut stack = vec![(0usize, 0u32)];
    while let Some((index, depth)) = stack.pop() {
        assert!(index < bvh.nodes.len(), "node {index} out of range");
        assert!(!node_seen[index], "node {index} reached twice");
        node_seen[index] = true;
        deepest = deepest.max(depth);
        let node = bvh.nodes[index];
        let b = node_box(&node);
        assert!(b.is_finite() && !b.is_empty(), "node {index} box {b:?}");
        if node.count > 0 {
            let (start, end) = (node.first as usize, node.first as usize + node.count as usize);
            assert!(end <= n, "leaf {index} range {start}..{end} beyond {n}");
            assert!(
                node.count <= max_leaf.max(1) || depth == Bvh::MAX_DEPTH,
                "leaf {index} holds {} at depth {depth}",
                node.count
            );
            let mut exact = Aabb::EMPTY;
            for (k, &p) in bvh.order[start..end].iter().enumerate() {
                assert!(!covered[start + k], "order slot {} in two leaves", start + k);
                covered[start + k] = true;
                let pb = boxes[p as usize];
                if good(&pb) {
                    assert!(contains(&b, &pb), "leaf {index} {b:?} misses primitive {p} {pb:?}");
                    exact = union(&exact, &pb);
                }
            }
            if all_good {
                assert_eq!(b, exact, "leaf {index} box is not the exact union");
            }
        } else {
            let first = node.first as usize;
            assert!(first + 1 < bvh.nodes.len(), "node {index} children {first} out of range");
            let (l, r) = (node_box(&bvh.nodes[first]), node_box(&bvh.nodes[first + 1]));
            assert!(contains(&b, &l) && contains(&b, &r), "node {index} does not contain its children");
            assert_eq!(b, union(&l, &r), "node {index} box is not the exact union of its children");
            stack.push((first, depth + 1));
            stack.push((first + 1, depth + 1));
        }
    }
    assert!(node_seen.iter().all(|&s| s), "unreachable nodes");
    assert!(covered.iter().all(|&c| c), "order slots in no leaf");
    assert_eq!(bvh.depth(), deepest);
    assert!(deepest <= Bvh::MAX_DEPTH, "depth {deepest}");
    deepest
}

fn random_boxes(rng: &mut Rng, n: usize, spread: f32, size: f32) -> Vec<Aabb> {
    (0..n)
        .map(|_| {
            let c = rng.vec_in(Vec3::splat(-spread), Vec3::splat(spread));
            let h = rng.vec_in(Vec3::ZERO, Vec3::splat(size));
            Aabb { min: c - h, max: c + h }
        })
        .collect()
}

#[test]
fn bvh_structure_random_boxes() {
    let mut rng = Rng(1);
    for (n, max_leaf) in [(1, 1), (2, 1), (3, 2), (17, 4), (1000, 1), (5000, 4), (5000, 8), (3000, 0)] {
        let boxes = random_boxes(&mut rng, n, 100.0, 3.0);
        let bvh = Bvh::build(&boxes, max_leaf);
        validate(&bvh, &boxes, max_leaf);
        let all = boxes.iter().fold(Aabb::EMPTY, |a, b| union(&a, b));
        assert_eq!(bvh.bounds(), all);
        assert_eq!(Bvh::build(&boxes, max_leaf), bvh, "not deterministic");
    }
}

#[test]
fn bvh_identical_boxes_depth_bounded() {
    let b = Aabb { min: Vec3::new(1.0, 2.0, 3.0), max: Vec3::new(2.0, 3.0, 4.0) };
    let boxes = vec![b; 100_000];
    for max_leaf in [1, 4] {
        let bvh = Bvh::build(&boxes, max_leaf);
        let depth = validate(&bvh, &boxes, max_leaf);
        assert!(depth <= 18, "identical boxes should split in halves, depth {depth}");
    }
}

#[test]
fn bvh_degenerate_lines_depth_bounded() {
    // Points evenly on a line: every box (and node) has zero area.
    let points: Vec<Aabb> =
        (0..50_000).map(|i| Aabb::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32, 0.0, 0.0))).collect();
    // Exponentially spaced points: binning puts all but a few in bin 0
    // every time, which degrades a pure SAH build into a list.
    let exponential: Vec<Aabb> = (0..1500)
        .map(|i| {
            let x = 1.05f32.powi(i);
            Aabb::new(Vec3::new(x, 1.0, -1.0), Vec3::new(x, 1.0, -1.0))
        })
        .collect();
    // Nested segments sharing one end: heavy overlap on a line.
    let nested: Vec<Aabb> = (1..20_000).map(|i| Aabb::new(Vec3::ZERO, Vec3::new(0.0, 0.0, i as f32))).collect();
    for boxes in [&points, &exponential, &nested] {
        for max_leaf in [1, 2, 8] {
            let bvh = Bvh::build(boxes, max_leaf);
            validate(&bvh, boxes, max_leaf);
        }
    }
}

#[test]
fn bvh_empty_input() {
    let bvh = Bvh::build(&[], 4);
    validate(&bvh, &[], 4);
    assert_eq!(bvh.depth(), 0);
    assert_eq!(bvh.closest_hit(Vec3::ZERO, Vec3::Z, 0.0, f32::INFINITY, |_| Some(1.0)), None);
    assert!(triangle_boxes(&[], &[]).is_empty());
}

#[test]
fn bvh_bad_boxes_are_never_lost() {
    let mut rng = Rng(7);
    let mut boxes = random_boxes(&mut rng, 300, 50.0, 2.0);
    let bad = [
        Aabb::EMPTY,
        Aabb { min: Vec3::splat(f32::NAN), max: Vec3::ONE },
        Aabb { min: Vec3::new(0.0, f32::NAN, 0.0), max: Vec3::new(1.0, f32::NAN, 1.0) },
        Aabb { min: Vec3::splat(f32::NEG_INFINITY), max: Vec3::splat(f32::INFINITY) },
        Aabb { min: Vec3::new(5.0, 5.0, 5.0), max: Vec3::new(4.0, 6.0, 6.0) },
        Aabb { min: Vec3::new(1e30, 0.0, 0.0), max: Vec3::new(f32::INFINITY, 1.0, 1.0) },
    ];
    for (k, b) in bad.iter().enumerate() {
        boxes.insert(k * 50, *b);
    }
    for max_leaf in [0, 1, 3] {
        let bvh = Bvh::build(&boxes, max_leaf);
        validate(&bvh, &boxes, max_leaf);
        assert!(bvh.nodes.iter().all(|n| node_box(n).is_finite()));
        // Every primitive is reachable: a leaf lists it.
        let mut listed = vec![false; boxes.len()];
        for n in bvh.nodes.iter().filter(|n| n.count > 0) {
            for &p in &bvh.order[n.first as usize..(n.first + n.count) as usize] {
                listed[p as usize] = true;
            }
        }
        assert!(listed.iter().all(|&l| l));
        // The empty box (index 0) is filed at the origin, where a ray finds it.
        let hit =
            bvh.closest_hit(Vec3::new(0.0, 0.0, -200.0), Vec3::Z, 0.0, f32::INFINITY, |p| (p == 0).then_some(200.0));
        assert_eq!(hit, Some((0, 200.0)));
    }
}

struct Soup {
    positions: Vec<[f32; 3]>,
    indices: Vec<u32>,
}

impl Soup {
    fn random(rng: &mut Rng, n: usize, lo: Vec3, hi: Vec3, size: f32) -> Soup {
        let mut positions = Vec::with_capacity(3 * n);
        for _ in 0..n {
            let c = rng.vec_in(lo, hi);
            for _ in 0..3 {
                positions.push((c + rng.vec_in(Vec3::splat(-size), Vec3::splat(size))).to_array());
            }
        }
        let indices = (0..3 * n as u32).collect();
        Soup { positions, indices }
    }

    fn len(&self) -> usize {
        self.indices.len() / 3
    }

    fn tri(&self, i: u32) -> (Vec3, Vec3, Vec3) {
        let i = 3 * i as usize;
        let p = |k: usize| Vec3::from(self.positions[self.indices[i + k] as usize]);
        (p(0), p(1), p(2))
    }

    fn centroid(&self, i: u32) -> Vec3 {
        let (a, b, c) = self.tri(i);
        (a + b + c) / 3.0
    }

    fn hit(&self, i: u32, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let (a, b, c) = self.tri(i);
        ray_triangle(o, d, a, b, c, t_min, t_max).map(|h| h.0)
    }

    fn brute(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(u32, f32)> {
        let mut best = None;
        let mut best_t = t_max;
        for i in 0..self.len() as u32 {
            if let Some(t) = self.hit(i, o, d, t_min, best_t) {
                best_t = t;
                best = Some((i, t));
            }
        }
        best
    }
}

/// Outcome of comparing a BVH against brute force over a batch of rays.
#[derive(Default)]
struct Stats {
    rays: usize,
    hits: usize,
    tested: usize,
}

fn compare(soup: &Soup, bvh: &Bvh, o: Vec3, d: Vec3, t_min: f32, t_max: f32, stats: &mut Stats) {
    let mut tested = 0;
    let got = bvh.closest_hit(o, d, t_min, t_max, |p| {
        tested += 1;
        soup.hit(p, o, d, t_min, t_max)
    });
    let want = soup.brute(o, d, t_min, t_max);
    stats.rays += 1;
    stats.tested += tested;
    match (got, want) {
        (None, None) => {}
        (Some((gp, gt)), Some((wp, wt))) => {
            stats.hits += 1;
            assert!((gt - wt).abs() <= 1e-5 * wt.abs().max(1e-30), "ray {o} {d}: t {gt} vs brute {wt}");
            // A different primitive is only acceptable as an exact tie.
            if gp != wp {
                assert_eq!(soup.hit(gp, o, d, t_min, t_max), Some(wt), "ray {o} {d}: prim {gp} vs brute {wp}");
            }
        }
        _ => panic!("ray {o} {d} (t in {t_min}..{t_max}): bvh {got:?} vs brute {want:?}"),
    }
}

fn axis_dir(rng: &mut Rng) -> Vec3 {
    let axis = rng.below(3);
    let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
    let mut d = Vec3::ZERO;
    d[axis] = sign;
    d
}

/// 2 000 rays of several kinds against brute force.
fn check_soup_rays(rng: &mut Rng, soup: &Soup, bvh: &Bvh, lo: Vec3, hi: Vec3) -> Stats {
    let mut stats = Stats::default();
    let pad = (hi - lo) * 0.25;
    for r in 0..2000 {
        let (o, d, t_min, t_max) = match r % 5 {
            // Random origin around the soup, random direction.
            0 => (rng.vec_in(lo - pad, hi + pad), rng.direction(), 0.0, f32::INFINITY),
            // Aimed at a triangle's centroid, so most of these hit.
            1 => {
                let o = rng.vec_in(lo - pad, hi + pad);
                let target = soup.centroid(rng.below(soup.len()) as u32);
                let d = (target - o).normalize_or(Vec3::X);
                (o, d, 0.0, f32::INFINITY)
            }
            // Exactly axis-parallel from inside the bounds (two zero components).
            2 => (rng.vec_in(lo, hi), axis_dir(rng), 0.0, f32::INFINITY),
            // One zero component, from inside, bounded interval.
            3 => {
                let mut d = rng.direction();
                d[rng.below(3)] = 0.0;
                let d = d.normalize_or(Vec3::Y);
                (rng.vec_in(lo, hi), d, rng.range(0.0, 1.0), rng.range(2.0, 40.0))
            }
            // Axis-parallel ray starting on a triangle's vertex plane, aimed
            // through a centroid, with a negative t_min.
            _ => {
                let target = soup.centroid(rng.below(soup.len()) as u32);
                let d = axis_dir(rng);
                let o = target - d * rng.range(0.0, (hi - lo).max_element());
                (o, d, -1.0, f32::INFINITY)
            }
        };
        compare(soup, bvh, o, d, t_min, t_max, &mut stats);
    }
    stats
}

#[test]
fn bvh_closest_hit_matches_brute_force() {
    let mut rng = Rng(0xB1A5);
    let (lo, hi) = (Vec3::splat(-10.0), Vec3::splat(10.0));
    for (n, size, max_leaf) in [(1, 2.0, 4), (50, 2.0, 1), (2000, 0.8, 4), (3000, 0.3, 2)] {
        let soup = Soup::random(&mut rng, n, lo, hi, size);
        let boxes = triangle_boxes(&soup.positions, &soup.indices);
        assert_eq!(boxes.len(), n);
        let bvh = Bvh::build(&boxes, max_leaf);
        validate(&bvh, &boxes, max_leaf);
        let stats = check_soup_rays(&mut rng, &soup, &bvh, lo, hi);
        assert_eq!(stats.rays, 2000);
        // Guard against a vacuous comparison.
        assert!(stats.hits > 400, "only {} of {} rays hit", stats.hits, stats.rays);
    }
}

#[test]
fn bvh_far_from_origin_still_hits() {
    let mut rng = Rng(1_000_000);
    let lo = Vec3::new(1.0e6, -1.0e6, 1.0e6);
    let hi = lo + Vec3::splat(40.0);
    let soup = Soup::random(&mut rng, 2000, lo, hi, 0.5);
    let boxes = triangle_boxes(&soup.positions, &soup.indices);
    let bvh = Bvh::build(&boxes, 4);
    validate(&bvh, &boxes, 4);
    let stats = check_soup_rays(&mut rng, &soup, &bvh, lo, hi);
    assert!(stats.hits > 400, "only {} of {} rays hit", stats.hits, stats.rays);
    // From the origin, 1.7e6 away, aimed at triangles.
    let mut from_origin = Stats::default();
    for _ in 0..300 {
        let target = soup.centroid(rng.below(soup.len()) as u32);
        compare(&soup, &bvh, Vec3::ZERO, target.normalize(), 0.0, f32::INFINITY, &mut from_origin);
    }
    assert!(from_origin.hits > 200, "only {} of 300 rays from the origin hit", from_origin.hits);
}

#[test]
fn bvh_sah_quality() {
    let mut rng = Rng(42);
    let (lo, hi) = (Vec3::splat(0.0), Vec3::splat(30.0));
    let soup = Soup::random(&mut rng, 10_000, lo, hi, 0.5);
    let boxes = triangle_boxes(&soup.positions, &soup.indices);
    let bvh = Bvh::build(&boxes, 4);
    validate(&bvh, &boxes, 4);
    let mut stats = Stats::default();
    for _ in 0..500 {
        let o = rng.vec_in(lo, hi);
        compare(&soup, &bvh, o, rng.direction(), 0.0, f32::INFINITY, &mut stats);
    }
    let per_ray = stats.tested as f64 / stats.rays as f64;
    let brute = soup.len() as f64;
    assert!(per_ray < 0.05 * brute, "{per_ray:.1} primitives tested per ray, brute force tests {brute}");
    println!(
        "SAH quality: {per_ray:.1} primitives per ray ({:.2}% of brute force), {} hits",
        100.0 * per_ray / brute,
        stats.hits
    );
}

#[test]
fn bvh_large_build() {
    // Unoptimised test builds are slow; this keeps the size modest while
    // still exercising deep trees. `bvh_two_million_boxes` covers the
    // release-size case on demand.
    let mut rng = Rng(99);
    let boxes = random_boxes(&mut rng, 200_000, 1000.0, 1.0);
    let start = std::time::Instant::now();
    let bvh = Bvh::build(&boxes, 4);
    println!("200k boxes built in {:?}, {} nodes, depth {}", start.elapsed(), bvh.nodes.len(), bvh.depth());
    validate(&bvh, &boxes, 4);
}

#[test]
#[ignore = "slow without optimisation; run with --release -- --ignored"]
fn bvh_two_million_boxes() {
    let mut rng = Rng(2);
    let boxes = random_boxes(&mut rng, 2_000_000, 1000.0, 0.5);
    let start = std::time::Instant::now();
    let bvh = Bvh::build(&boxes, 4);
    println!("2M boxes built in {:?}, {} nodes, depth {}", start.elapsed(), bvh.nodes.len(), bvh.depth());
    validate(&bvh, &boxes, 4);
}

/// The build's and the walks' finer promises, one test per promise (each
/// kills survivors of the sceneprep mutant shards; see
/// docs/records/mutants/SURVIVORS.md).
mod contracts {
    use super::*;

    fn cube_at(x: f32) -> Aabb {
        Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0))
    }

    fn along_x(lo: f32, hi: f32) -> Aabb {
        Aabb::new(Vec3::new(lo, 0.0, 0.0), Vec3::new(hi, 1.0, 1.0))
    }

    fn interior(first: u32) -> BvhNode {
        BvhNode { min: [0.0; 3], first, max: [1.0; 3], count: 0 }
    }

    fn leaf() -> BvhNode {
        BvhNode { min: [0.0; 3], first: 0, max: [1.0; 3], count: 1 }
    }

    /// Appends `levels` pairs of interior nodes, both of each pair pointing
    /// at the next pair (so the paths through them double per level), and a
    /// last pair of leaves.
    fn push_shared_levels(nodes: &mut Vec<BvhNode>, levels: u32) {
        for _ in 0..levels {
            let next = nodes.len() as u32 + 2;
            nodes.extend([interior(next), interior(next)]);
        }
        nodes.extend([leaf(), leaf()]);
    }

    /// The child with the lower box centre comes first, the centre being
    /// the midpoint (not a corner, nor weighted towards either).
    #[test]
    fn lower_box_centre_comes_first() {
        let long = along_x(0.0, 10.0);
        // Centres 5 (long) and 4.5: the short box first; 5 and 5.75: the long one.
        for (short, long_first) in [(along_x(4.0, 5.0), false), (along_x(5.5, 6.0), true)] {
            for (boxes, long_index) in [([long, short], 0), ([short, long], 1)] {
                let bvh = Bvh::build(&boxes, 1);
                validate(&bvh, &boxes, 1);
                assert_eq!(bvh.nodes.len(), 3);
                assert_eq!(bvh.order[0] == long_index, long_first, "{boxes:?}: order {:?}", bvh.order);
            }
        }
    }

    /// Points 2^5 apart: every one but the farthest falls in the first bin,
    /// so SAH peels one point off per level and would make a list 48 deep.
    /// At depth 32 (`MAX_DEPTH - 8`) splits switch to medians, and the 17
    /// points left there take five more levels: 37, each leaf one point.
    #[test]
    fn depth_bounded_when_sah_peels_one_box_per_level() {
        let boxes: Vec<Aabb> = (-24..=24)
            .map(|i| {
                let p = Vec3::new(2f32.powi(5 * i), 0.0, 0.0);
                Aabb::new(p, p)
            })
            .collect();
        let bvh = Bvh::build(&boxes, 1);
        assert_eq!(validate(&bvh, &boxes, 1), 37);
        assert!(bvh.nodes.iter().all(|n| n.count <= 1));
    }

    /// The SAH weighs children by surface area: two unit cubes a unit apart
    /// are split even with room for both in one leaf (half areas: parent 7,
    /// children 3 each, 7 + 3 + 3 < 2 · 7), where half-perimeters would keep
    /// the leaf (5 + 3 + 3 > 2 · 5).
    #[test]
    fn sah_weighs_children_by_area() {
        let boxes = [cube_at(0.0), cube_at(2.0)];
        let bvh = Bvh::build(&boxes, 2);
        validate(&bvh, &boxes, 2);
        assert_eq!(bvh.nodes.len(), 3, "{:?}", bvh.nodes);
    }

    /// Four unit cubes in two clusters ten apart along `axis`, given
    /// interleaved; `jitter` moves two of them a unit along the next axis.
    fn two_clusters(axis: usize, base: f32, offset: f32, jitter: bool) -> Vec<Aabb> {
        [(0.0, 0.0), (10.0, 1.0), (1.0, 1.0), (11.0, 0.0)]
            .into_iter()
            .map(|(along, across)| {
                let mut p = Vec3::splat(offset);
                p[axis] = base + along;
                if jitter {
                    p[(axis + 1) % 3] += across;
                }
                Aabb::new(p, p + Vec3::ONE)
            })
            .collect()
    }

    /// The split axis is the one along which the centres spread most (by
    /// their extent, not their values): the root separates two clusters
    /// along any axis, off the origin, and when another axis spreads less
    /// but in a larger ratio.
    #[test]
    fn the_root_splits_along_the_widest_spread_of_centres() {
        for axis in 0..3 {
            for (base, offset, jitter) in [(0.0, 100.0, false), (100.0, 1.0, true), (0.0, 0.0, false)] {
                let boxes = two_clusters(axis, base, offset, jitter);
                let bvh = Bvh::build(&boxes, 1);
                validate(&bvh, &boxes, 1);
                let first = bvh.nodes[0].first as usize;
                let (a, b) = (node_box(&bvh.nodes[first]), node_box(&bvh.nodes[first + 1]));
                assert!(
                    a.max[axis] < b.min[axis] || b.max[axis] < a.min[axis],
                    "axis {axis}, base {base}, offset {offset}, jitter {jitter}: children {a:?} and {b:?} overlap"
                );
            }
        }
    }

    /// Sixteen evenly spaced boxes (cubes, then points, whose every area is
    /// zero so the SAH measures lengths) split eight and eight at the root:
    /// binning spreads them one to a bin, and the cheapest cut is the middle.
    #[test]
    fn evenly_spaced_boxes_split_in_the_middle() {
        let cubes: Vec<Aabb> = (0..16).map(|i| cube_at(10.0 * i as f32)).collect();
        let points: Vec<Aabb> = (0..16)
            .map(|i| {
                let p = Vec3::new(10.0 * i as f32, 0.0, 0.0);
                Aabb::new(p, p)
            })
            .collect();
        for boxes in [cubes, points] {
            let bvh = Bvh::build(&boxes, 1);
            validate(&bvh, &boxes, 1);
            let first = bvh.nodes[0].first as usize;
            let under = |node: usize| {
                let mut stack = vec![node];
                let mut count = 0;
                while let Some(n) = stack.pop() {
                    let node = bvh.nodes[n];
                    if node.count > 0 {
                        count += node.count;
                    } else {
                        stack.extend([node.first as usize, node.first as usize + 1]);
                    }
                }
                count
            };
            assert_eq!((under(first), under(first + 1)), (8, 8), "{:?}", boxes[1]);
        }
    }

    /// With one box to a bin (centres evenly spaced, sizes random), the
    /// root's cut is the cheapest of all fifteen by the SAH, against a
    /// brute-force evaluation of every cut.
    #[test]
    fn the_root_cut_is_the_cheapest_by_the_sah() {
        let half_area = |b: &Aabb| {
            let d = b.max.as_dvec3() - b.min.as_dvec3();
            d.x * d.y + d.y * d.z + d.z * d.x
        };
        let union_of = |boxes: &[Aabb]| boxes.iter().fold(Aabb::EMPTY, |u, b| union(&u, b));
        let mut rng = Rng(7);
        for _ in 0..20 {
            let boxes: Vec<Aabb> = (0..16)
                .map(|i| {
                    let half = rng.vec_in(Vec3::new(0.5, 0.5, 0.5), Vec3::new(4.5, 8.0, 8.0));
                    let centre = Vec3::new(10.0 * i as f32, 0.0, 0.0);
                    Aabb::new(centre - half, centre + half)
                })
                .collect();
            let cost = |cut: usize| {
                half_area(&union_of(&boxes[..cut])) * cut as f64
                    + half_area(&union_of(&boxes[cut..])) * (16 - cut) as f64
            };
            let bvh = Bvh::build(&boxes, 1);
            let left = bvh.nodes[bvh.nodes[0].first as usize];
            let cut = (0..16).filter(|&i| contains(&node_box(&left), &boxes[i])).count();
            let cheapest = (1..16).map(cost).fold(f64::INFINITY, f64::min);
            assert_eq!(cost(cut), cheapest, "cut {cut} of {boxes:?}");
        }
    }

    /// With room for both in one leaf, two heavily overlapping cubes stay
    /// one leaf (a split would cost more than the leaf), and so do two cubes
    /// whose split costs exactly as much (half areas 6 for the pair, 3 each:
    /// 6 + 3 + 3 = 2 · 6), while collinear points, whose SAH is by length,
    /// are split; at any scale (powers of two keep the tie exact), as the
    /// SAH has no unit.
    #[test]
    fn a_leaf_is_kept_when_splitting_costs_more() {
        let points = |x: f32| {
            let p = Vec3::new(x, 0.0, 0.0);
            Aabb::new(p, p)
        };
        for scale in [1.0 / 1024.0, 1.0, 1024.0] {
            let scaled =
                |boxes: &[Aabb]| boxes.iter().map(|b| Aabb::new(b.min * scale, b.max * scale)).collect::<Vec<_>>();
            for (boxes, nodes) in [
                (scaled(&[cube_at(0.0), cube_at(0.1)]), 1),
                (scaled(&[cube_at(0.0), cube_at(1.5)]), 1),
                (scaled(&[points(0.0), points(10.0)]), 3),
            ] {
                let bvh = Bvh::build(&boxes, 2);
                validate(&bvh, &boxes, 2);
                assert_eq!(bvh.nodes.len(), nodes, "scale {scale}: {boxes:?}");
            }
        }
    }

    /// A triangle whose determinant overflows `f32` is a miss, as a
    /// degenerate one is, even for a ray exactly through its corner; the
    /// same triangle at a billionth of the size is hit there.
    #[test]
    fn ray_triangle_misses_when_the_determinant_overflows() {
        let a = Vec3::new(1.0, 2.0, 3.0);
        for (size, hit) in [(1.0e20, None), (1.0e11, Some((5.0, 0.0, 0.0)))] {
            let (b, c) = (a + Vec3::X * size, a + Vec3::Y * size);
            assert_eq!(ray_triangle(a - Vec3::Z * 5.0, Vec3::Z, a, b, c, 0.0, f32::INFINITY), hit, "size {size}");
        }
    }

    /// A ray from far away whose direction is not of unit length (here the
    /// whole way to its target, so the target is at t = 1, or a power of
    /// two of that) is as accurate as a unit one: it hits a unit triangle
    /// near the point aimed at, a quarter along both edges. (Every
    /// coordinate is exact in `f32`, so the ray passes through that point.)
    #[test]
    fn ray_triangle_is_accurate_from_far_away_along_a_long_direction() {
        let a = Vec3::new(3.0, -2.0, 1.0);
        let (b, c) = (a + Vec3::X, a + Vec3::Y);
        let target = a + Vec3::new(0.25, 0.25, 0.0);
        for away in [Vec3::new(1.0e6, 2.0e6, -1.5e6), Vec3::new(-3.0e5, 1.0e5, 4.0e5), Vec3::new(0.0, 0.0, 50.0)] {
            let origin = target + away;
            for length in [1.0, 2f32.powi(-10), 2f32.powi(8)] {
                let dir = -away * length;
                let hit = ray_triangle(origin, dir, a, b, c, 0.0, f32::INFINITY);
                let (t, u, v) = hit.unwrap_or_else(|| panic!("from {origin} along {dir}: missed"));
                assert!((t * length - 1.0).abs() < 1e-5, "from {origin} along {dir}: t = {t}");
                assert!((u - 0.25).abs() < 0.2 && (v - 0.25).abs() < 0.2, "from {origin} along {dir}: ({u}, {v})");
            }
        }
    }

    /// `depth` ignores a child index outside `nodes` and still counts its
    /// sibling, even when that sibling is the last node it visits.
    #[test]
    fn depth_counts_a_child_whose_sibling_is_out_of_range() {
        let bvh = Bvh { nodes: vec![interior(2), leaf(), leaf()], order: vec![0] };
        assert_eq!(bvh.depth(), 1);
    }

    /// On a malformed tree whose nodes share children (paths doubling per
    /// level), `depth` stops after `nodes.len()` visits: inside the shared
    /// subtree (whose leaves are at depth 10), which it walks first as the
    /// second child, before the chain under the first child (18 deep).
    #[test]
    fn depth_stops_after_as_many_visits_as_nodes() {
        let mut nodes = vec![interior(1), interior(0), interior(3)];
        push_shared_levels(&mut nodes, 8);
        nodes[1] = interior(nodes.len() as u32);
        for _ in 0..16 {
            let next = nodes.len() as u32 + 2;
            nodes.extend([interior(next), leaf()]);
        }
        nodes.extend([leaf(), leaf()]);
        assert_eq!(Bvh { nodes, order: vec![0] }.depth(), 10);
    }

    /// The same bound for `closest_hit`: at most `nodes.len()` visits, so at
    /// most that many `hit` calls, where the shared children hold 2048 leaf
    /// visits.
    #[test]
    fn closest_hit_stops_after_as_many_visits_as_nodes() {
        let mut nodes = vec![interior(1)];
        push_shared_levels(&mut nodes, 10);
        let bvh = Bvh { nodes, order: vec![0] };
        let mut calls = 0;
        let hit = bvh.closest_hit(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, 10.0, |_| {
            calls += 1;
            None
        });
        assert_eq!(hit, None);
        assert!(calls <= bvh.nodes.len(), "{calls} hit calls for {} nodes", bvh.nodes.len());
    }

    /// The interval `(t_min, t_max)` is open: a hit exactly at either end
    /// is no hit, and an empty interval calls `hit` for nothing. On a tie
    /// the first primitive found is kept.
    #[test]
    fn closest_hit_interval_is_open_and_ties_keep_the_first() {
        let bvh = Bvh::build(&[cube_at(0.0), cube_at(0.0)], 2);
        assert_eq!(bvh.nodes.len(), 1);
        let (o, d) = (Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        assert_eq!(bvh.closest_hit(o, d, 0.0, 10.0, |_| Some(1.5)), Some((bvh.order[0], 1.5)));
        assert_eq!(bvh.closest_hit(o, d, 1.5, 10.0, |_| Some(1.5)), None);
        assert_eq!(bvh.closest_hit(o, d, 0.0, 1.5, |_| Some(1.5)), None);
        let mut calls = 0;
        let empty = bvh.closest_hit(o, d, 1.5, 1.5, |_| {
            calls += 1;
            Some(1.5)
        });
        assert_eq!((empty, calls), (None, 0));
    }

    /// The nearer child is visited first, and a hit there drops the farther
    /// child without calling `hit` for it, from either side.
    #[test]
    fn closest_hit_visits_the_nearer_child_and_drops_the_farther() {
        let boxes = [cube_at(0.0), cube_at(5.0)];
        let bvh = Bvh::build(&boxes, 1);
        assert_eq!(bvh.nodes.len(), 3);
        for (origin, dir, near) in [(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0), (Vec3::new(7.0, 0.5, 0.5), -Vec3::X, 1)] {
            let mut calls = Vec::new();
            let hit = bvh.closest_hit(origin, dir, 0.0, 100.0, |p| {
                calls.push(p);
                Some(if p == near { 1.0 } else { 6.0 })
            });
            assert_eq!(hit, Some((near, 1.0)));
            assert_eq!(calls, [near], "from {origin}");
        }
    }

    /// The slab interval is widened by a few ulps, so a ray whose slab
    /// intervals miss each other by one ulp (a graze) still enters the box.
    #[test]
    fn a_graze_one_ulp_wide_still_enters() {
        let node = BvhNode { min: [1.0 + f32::EPSILON, -1.0, -1.0], first: 0, max: [2.0, 1.0, 1.0], count: 1 };
        let bvh = Bvh { nodes: vec![node], order: vec![0] };
        // The ray leaves the y slab at t = 1 and enters the x slab one ulp later.
        assert_eq!(bvh.closest_hit(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), 0.0, 10.0, |_| Some(1.0)), Some((0, 1.0)));
    }
}
