//! The triangles of a tree's leaves laid out as the AVX2 leaf test reads
//! them (`Bvh::leaf_triangles_lanes`): each leaf's ten rows (the x of its
//! triangles' first, second and third vertices, their y, their z, then a
//! tag) one after another, a float per triangle each, so that a row of the
//! leaf is one unaligned load of eight floats instead of a transposition
//! of its triangles' records, which cost as much as the test itself. On
//! the 102k-triangle blob: closest-hit walks -8% instructions and -8% L1
//! misses (cachegrind), the render -3.2% instructions a sample, images
//! identical. It costs 40 bytes a triangle beside the primitives' own
//! records, in the trees that have it (too big for packets, on CPUs with
//! AVX2).
//!
//! A leaf of `count` primitives from `first` starts at float `ROWS *
//! first`, so the layout needs no index of its own; a load reads `8 -
//! count` floats past its row (the next row, or the next leaf), lanes the
//! test leaves out.

use super::bvh::LEAF_LANES;

/// Rows per leaf: three coordinates of three vertices, and the tag.
pub const ROWS: usize = 10;

/// The row of the tag: 0 for a triangle, all bits set (a NaN, never a
/// slow denormal in the lanes left out) for any other primitive.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub const TAG_ROW: usize = 9;

/// The tag of a primitive the lanes cannot test.
const NOT_A_TRIANGLE: u32 = u32::MAX;

/// Every leaf's rows (see the module's documentation).
pub struct LeafRows {
    rows: Vec<f32>,
}

impl LeafRows {
    /// The rows of `leaves` (`(first, count)` each) over `n` primitives,
    /// `triangle(i)` giving primitive `i`'s coordinates by axis (the x of
    /// its three vertices, their y, their z: the rows' order), `None` if
    /// it is not a triangle.
    pub fn new(
        n: usize,
        leaves: impl Iterator<Item = (u32, u32)>,
        triangle: impl Fn(usize) -> Option<[[f32; 3]; 3]>,
    ) -> LeafRows {
        let mut rows = vec![0.0f32; ROWS * n + LEAF_LANES];
        for (first, count) in leaves {
            let (first, count) = (first as usize, count as usize);
            let block = &mut rows[ROWS * first..ROWS * (first + count)];
            for k in 0..count {
                let Some(axes) = triangle(first + k) else {
                    block[TAG_ROW * count + k] = f32::from_bits(NOT_A_TRIANGLE);
                    continue;
                };
                for (row, &c) in axes.iter().flatten().enumerate() {
                    block[row * count + k] = c;
                }
            }
        }
        LeafRows { rows }
    }

    /// No rows: for trees whose leaves are not tested in lanes.
    pub fn empty() -> LeafRows {
        LeafRows { rows: Vec::new() }
    }

    /// The rows of the leaf of `count` (1 to [`LEAF_LANES`]) primitives
    /// from `first`, as one slice that every row's eight-float load stays
    /// in: row `r` starts at `r * count`.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    #[inline(always)]
    pub fn leaf(&self, first: u32, count: u32) -> &[f32] {
        let (first, count) = (first as usize, count as usize);
        let start = ROWS * first;
        &self.rows[start..start + (ROWS - 1) * count + LEAF_LANES]
    }

    /// Row `row` of a leaf of `count` from [`LeafRows::leaf`], in eight
    /// AVX2 lanes (those from `count` on hold other values).
    ///
    /// # Safety
    /// Call only from functions compiled for AVX2 (the walks' AVX2 copies,
    /// into which it is inlined), with `row < ROWS` and the `count` the
    /// leaf was taken with.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn load(leaf: &[f32], count: usize, row: usize) -> std::arch::x86_64::__m256 {
        debug_assert!(row < ROWS && row * count + LEAF_LANES <= leaf.len());
        // SAFETY: `leaf` holds `(ROWS - 1) * count + LEAF_LANES` floats,
        // so the eight from `row * count` are in it.
        unsafe { std::arch::x86_64::_mm256_loadu_ps(leaf.as_ptr().add(row * count)) }
    }

    /// The rows of axis `axis` (0 to 2) of a leaf of `count` from
    /// [`LeafRows::leaf`]: the coordinate of vertex 0, 1 and 2 on that
    /// axis, in eight AVX2 lanes each. (A row a step of `count` floats from
    /// the last: one multiply for the three.)
    ///
    /// # Safety
    /// As [`LeafRows::load`], with `axis < 3`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn load_axis(
        leaf: &[f32],
        count: usize,
        axis: usize,
    ) -> [std::arch::x86_64::__m256; 3] {
        use std::arch::x86_64::_mm256_loadu_ps;
        debug_assert!(axis < 3 && (3 * axis + 2) * count + LEAF_LANES <= leaf.len());
        // SAFETY: rows 3 axis to 3 axis + 2 are rows of the leaf (< ROWS).
        unsafe {
            let row = leaf.as_ptr().add(3 * axis * count);
            [
                _mm256_loadu_ps(row),
                _mm256_loadu_ps(row.add(count)),
                _mm256_loadu_ps(row.add(2 * count)),
            ]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_hold_each_leafs_triangles_and_tags() {
        // Two leaves, of two and three primitives; primitive 3 is a sphere.
        // Primitive i's vertices: (i, 10 + i, 20 + i), (30, 30, 30) and
        // (40, 40, 40), given by axis.
        let tri = |i: usize| {
            let i = i as f32;
            (i != 3.0).then_some([
                [i, 30.0, 40.0],
                [10.0 + i, 30.0, 40.0],
                [20.0 + i, 30.0, 40.0],
            ])
        };
        let rows = LeafRows::new(5, [(0, 2), (2, 3)].into_iter(), tri);
        let leaf = rows.leaf(2, 3);
        assert_eq!(leaf.len(), 9 * 3 + LEAF_LANES);
        // x of the first vertex, lanes 2, 3, 4.
        assert_eq!(&leaf[0..3], &[2.0, 0.0, 4.0]);
        // x of the second vertex, y and z of the first.
        assert_eq!(&leaf[3..6], &[30.0, 0.0, 30.0]);
        assert_eq!(&leaf[9..12], &[12.0, 0.0, 14.0]);
        assert_eq!(&leaf[18..21], &[22.0, 0.0, 24.0]);
        // z of the third vertex.
        assert_eq!(&leaf[8 * 3..9 * 3], &[40.0, 0.0, 40.0]);
        let tags: Vec<u32> = leaf[9 * 3..10 * 3].iter().map(|t| t.to_bits()).collect();
        assert_eq!(tags, [0, NOT_A_TRIANGLE, 0]);
        // The first leaf: x of the second vertex, then the tags.
        let first = rows.leaf(0, 2);
        assert_eq!(&first[2..4], &[30.0, 30.0]);
        assert_eq!(&first[18..20], &[0.0, 0.0]);
    }
}
