//! How deferred shading finds a pixel's triangle without the primitive
//! index: from the triangle's first corner.
//!
//! The visibility pass writes, per pixel, the draw and one vertex in 32
//! bits: a flat varying carries the value of a triangle's first vertex (its
//! provoking vertex), which the vertex stage writes for free, where the
//! fragment stage's primitive index cost an H200 7–8 % of a 256-view field
//! (docs/performance.md). The compute pass that shades the pixel then needs
//! the triangles whose first corner is that vertex: this module builds,
//! once per geometry at upload,
//!
//! * the geometry's indices with each triangle's corners rotated (winding
//!   and triangle order kept, so rasterisation and blending are unchanged)
//!   so that as few triangles as possible share a first corner: a quad's
//!   two triangles start at two different corners, a closed mesh's about
//!   two triangles a vertex;
//! * the triangle table: for each vertex, the triangles starting at it.
//!
//! Every mesh is uploaded turned; the table only while ScenePrep is asked
//! for tables (`ScenePrep::set_triangle_tables`, which the renderer turns
//! on when a batch shades deferred: it costs about half as much again of
//! index memory). Both then go into the geometry's range of the index
//! domain, table first:
//!
//! ```text
//! [ starts: V + 1 words ][ triangles: T words ][ L ][ indices: 3T words ]
//!                                                    ^ index_slot
//! ```
//!
//! `L` (= V + 1 + T, the table's length) sits just before the indices, so a
//! shader that knows a draw's `index_slot` finds the table at
//! `index_slot - 1 - L`; `starts[v]..starts[v + 1]` (counted from the
//! table's first word) are the positions in the table of the triangles
//! starting at vertex `v`, each stored as its number in the geometry
//! (indices `3t..3t + 3` from `index_slot`).

/// Words before a geometry's first index: the table (V + 1 starts and a
/// word per triangle) and its length. `None` past `u32`.
pub(crate) fn words_before_indices(vertex_count: u32, index_count: u32) -> Option<u32> {
    vertex_count.checked_add(2)?.checked_add(index_count / 3)
}

/// A geometry's index-domain range as uploaded (see the module's
/// documentation): the table, its length, then the turned indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct TriangleLayout {
    /// Every word of the range, in order.
    pub(crate) words: Vec<u32>,
}

/// `indices` with each triangle turned to start at whichever of its
/// corners the fewest earlier triangles start at (its own first corner on a
/// tie), its corners rotated, never swapped; and how many triangles start
/// at each vertex. Meshes are uploaded turned whether or not they get a
/// table, so that a mesh rasterizes the same way (to the last bit of its
/// interpolated values) with triangle tables on or off.
pub(crate) fn turn(indices: &[u32], vertex_count: u32) -> (Vec<u32>, Vec<u32>) {
    let mut turned: Vec<u32> = Vec::with_capacity(indices.len());
    let mut starting = vec![0u32; vertex_count as usize];
    for corners in indices.chunks_exact(3) {
        let count = |k: usize| starting.get(corners[k] as usize).copied().unwrap_or(u32::MAX);
        let first = (0..3).min_by_key(|&k| (count(k), k)).unwrap_or(0);
        let [a, b, c] = [corners[first], corners[(first + 1) % 3], corners[(first + 2) % 3]];
        if let Some(n) = starting.get_mut(a as usize) {
            *n += 1;
        }
        turned.extend_from_slice(&[a, b, c]);
    }
    (turned, starting)
}

impl TriangleLayout {
    /// The layout of `indices` (triangles, each index below
    /// `vertex_count`, as `Geometry` guarantees) over `vertex_count`
    /// vertices. Each triangle starts at whichever of its corners the
    /// fewest earlier triangles start at (its own first corner on a tie),
    /// its corners rotated, never swapped.
    pub(crate) fn new(indices: &[u32], vertex_count: u32) -> Self {
        let triangles = indices.len() / 3;
        let v = vertex_count as usize;
        let (turned, starting) = turn(indices, vertex_count);
        // Counting sort of the triangles by first corner: `starts` are
        // positions in the table, which begins with the V + 1 starts.
        let header = v + 1;
        let mut words = Vec::with_capacity(header + triangles + 1 + turned.len());
        let mut at = header as u32;
        for n in &starting {
            words.push(at);
            at += n;
        }
        words.push(at);
        words.resize(header + triangles, 0);
        let mut next: Vec<u32> = words[..v].to_vec();
        for (t, corners) in turned.chunks_exact(3).enumerate() {
            if let Some(slot) = next.get_mut(corners[0] as usize) {
                words[*slot as usize] = t as u32;
                *slot += 1;
            }
        }
        words.push((header + triangles) as u32);
        words.extend_from_slice(&turned);
        TriangleLayout { words }
    }

    /// The table's length `L` (the word before the indices).
    #[cfg(test)]
    fn table_len(&self, index_count: usize) -> usize {
        self.words.len() - index_count - 1
    }

    /// The turned indices (the last `index_count` words).
    #[cfg(test)]
    pub(crate) fn indices(&self, index_count: usize) -> &[u32] {
        &self.words[self.words.len() - index_count..]
    }

    /// The triangles (numbers in the geometry) whose first corner is
    /// `vertex`, read as the shader reads them.
    #[cfg(test)]
    pub(crate) fn starting_at(&self, vertex: u32, index_count: usize) -> &[u32] {
        let table = &self.words[..self.table_len(index_count)];
        let v = vertex as usize;
        match (table.get(v), table.get(v + 1)) {
            (Some(&begin), Some(&end)) => &table[begin as usize..end as usize],
            _ => &[],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift), so that failures repeat.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 32) as u32
        }
    }

    /// `turned` is `original` rotated: the same cyclic order of corners.
    fn same_triangle(original: &[u32], turned: &[u32]) -> bool {
        (0..3).any(|r| (0..3).all(|k| original[(k + r) % 3] == turned[k]))
    }

    /// Every triangle keeps its corners in their cyclic order (winding) and
    /// its place, the table lists exactly the triangles starting at each
    /// vertex, the lengths are what the allocation is told, and the word
    /// before the indices gives the table's length: on random meshes,
    /// degenerate triangles and unused vertices included.
    #[test]
    fn the_table_finds_every_triangle_from_its_first_corner() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for case in 0..300 {
            let vertex_count = 1 + rng.next() % 40;
            let triangles = (rng.next() % 80) as usize;
            let indices: Vec<u32> = (0..triangles * 3).map(|_| rng.next() % vertex_count).collect();
            let layout = TriangleLayout::new(&indices, vertex_count);
            let n = indices.len();
            let before = words_before_indices(vertex_count, n as u32).unwrap_or(0) as usize;
            assert_eq!(layout.words.len(), before + n, "{case}");
            assert_eq!(layout.words[before - 1] as usize, before - 1, "{case}: the length word");
            let turned = layout.indices(n);
            for (t, (a, b)) in indices.chunks_exact(3).zip(turned.chunks_exact(3)).enumerate() {
                assert!(same_triangle(a, b), "case {case}, triangle {t}: {a:?} became {b:?}");
            }
            let mut listed = 0;
            for v in 0..vertex_count {
                let found = layout.starting_at(v, n);
                let expected: Vec<u32> = (0..triangles as u32).filter(|&t| turned[3 * t as usize] == v).collect();
                assert_eq!(found, expected.as_slice(), "case {case}, vertex {v}");
                listed += found.len();
            }
            assert_eq!(listed, triangles, "case {case}: every triangle listed once");
        }
    }

    /// A quad's two triangles start at two corners, so a box (six quads)
    /// has one triangle per first corner: the shader's search is one read.
    /// Both triangles of the quad keep their corners' cycle.
    #[test]
    fn a_box_has_one_triangle_per_first_corner() {
        let cube = oxygen_core::Geometry::cube(1.0);
        let layout = TriangleLayout::new(cube.indices(), cube.vertices().len() as u32);
        let n = cube.indices().len();
        let most = (0..cube.vertices().len() as u32).map(|v| layout.starting_at(v, n).len()).max();
        assert_eq!(most, Some(1));
        let quad = TriangleLayout::new(&[0, 1, 2, 0, 2, 3], 4);
        assert_eq!(quad.indices(6), [0, 1, 2, 2, 3, 0]);
    }

    /// On a closed mesh (twice as many triangles as vertices) no vertex
    /// starts more than a few triangles: the greedy turn spreads them.
    #[test]
    fn a_sphere_spreads_its_triangles_over_its_vertices() {
        let sphere = oxygen_core::Geometry::uv_sphere(1.0, 32, 16);
        let n = sphere.indices().len();
        let layout = TriangleLayout::new(sphere.indices(), sphere.vertices().len() as u32);
        let most = (0..sphere.vertices().len() as u32).map(|v| layout.starting_at(v, n).len()).max();
        assert!(most.is_some_and(|m| m <= 2), "{most:?}");
    }
}
