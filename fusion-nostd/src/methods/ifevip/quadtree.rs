//! `qtdecomp(I, 0.2, 32)` on the `D×D` grid without recursion or allocation.
//!
//! One pass over the grid records the minimum and maximum of every smallest block
//! (`min_dim` side, at most 16 × 16 of them); a block's range is then the combination of its
//! smallest blocks. The tree is walked depth first with an explicit `heapless` stack (depth
//! ≤ 4 levels, so at most 3·4 + 1 entries) and the leaves are collected in a `heapless::Vec`
//! of at most 256, then put in the published write order: largest side first, column-major
//! by top-left corner within a side (MATLAB `find` order).

use crate::{Error, FrameRef};
use heapless::Vec;

/// Most smallest blocks per side (`quad_norm_dim / quad_min_dim ≤ 16`).
pub const MAX_GRID: usize = 16;
/// Most leaves.
pub const MAX_LEAVES: usize = MAX_GRID * MAX_GRID;

/// One quadtree leaf: top-left corner (0-based) and side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Leaf {
    /// Top row.
    pub row: u16,
    /// Left column.
    pub col: u16,
    /// Side in pixels.
    pub side: u16,
}

/// `(min, max)` of every smallest block (`min_dim` side) of a `D×D` grid, gathered row by
/// row: the whole-frame [`decompose`] adds every row at once, the strip form adds the rows as
/// they are produced. The tree needs nothing else of the grid.
#[derive(Debug, Clone)]
pub struct BlockRanges {
    range: [[(i32, i32); MAX_GRID]; MAX_GRID],
    d: usize,
    min_dim: usize,
}

impl BlockRanges {
    /// Empty ranges of a `d×d` grid in blocks of `min_dim` (`d / min_dim` in `1..=16`, exact).
    pub fn new(d: usize, min_dim: usize) -> Result<Self, Error> {
        let cells = d / min_dim.max(1);
        if min_dim == 0 || cells == 0 || cells > MAX_GRID || cells * min_dim != d {
            return Err(Error::InvalidParameter { name: "quad_min_dim" });
        }
        Ok(Self { range: [[(i32::MAX, i32::MIN); MAX_GRID]; MAX_GRID], d, min_dim })
    }

    /// Adds grid row `y` (`d` values; rows past the grid are refused).
    pub fn add_row(&mut self, y: usize, row: &[i32]) -> Result<(), Error> {
        let cells_row = self
            .range
            .get_mut(y / self.min_dim.max(1))
            .ok_or(Error::InvalidParameter { name: "quad_min_dim" })?;
        for (cell, seg) in cells_row.iter_mut().zip(row.chunks_exact(self.min_dim.max(1))) {
            let (lo, hi) = seg.iter().fold(*cell, |(lo, hi), &v| (lo.min(v), hi.max(v)));
            *cell = (lo, hi);
        }
        Ok(())
    }

    /// The leaves, split while `max − min > threshold` and the side is at least `2·min_dim`,
    /// in write order.
    pub fn leaves(&self, threshold: i32) -> Result<Vec<Leaf, MAX_LEAVES>, Error> {
        let (range, d, min_dim) = (&self.range, self.d, self.min_dim.max(1));
        let block_range = |r: usize, c: usize, n: usize| {
            let (r0, c0, k) = (r / min_dim, c / min_dim, n / min_dim);
            range
                .iter()
                .skip(r0)
                .take(k)
                .flat_map(|row| row.iter().skip(c0).take(k))
                .fold((i32::MAX, i32::MIN), |(lo, hi), &(a, b)| (lo.min(a), hi.max(b)))
        };
        let mut leaves: Vec<Leaf, MAX_LEAVES> = Vec::new();
        let mut stack: Vec<(usize, usize, usize), 16> = Vec::new();
        let overflow = Error::InvalidParameter { name: "quad_min_dim" };
        stack.push((0, 0, d)).map_err(|_| overflow)?;
        while let Some((r, c, n)) = stack.pop() {
            let (lo, hi) = block_range(r, c, n);
            if hi - lo > threshold && n / 2 >= min_dim {
                let h = n / 2;
                for (dr, dc) in [(h, h), (0, h), (h, 0), (0, 0)] {
                    stack.push((r + dr, c + dc, h)).map_err(|_| overflow)?;
                }
            } else {
                let leaf = Leaf { row: r as u16, col: c as u16, side: n as u16 };
                leaves.push(leaf).map_err(|_| overflow)?;
            }
        }
        heapsort_by_key(&mut leaves, |l| {
            (u64::from(u16::MAX - l.side) << 32) | (u64::from(l.col) << 16) | u64::from(l.row)
        });
        Ok(leaves)
    }
}

/// Leaves of the quadtree of the square `grid` (values 0..=255), split while
/// `max − min > threshold` and the side is at least `2·min_dim`, in write order.
pub fn decompose(
    grid: FrameRef<'_, i32>,
    min_dim: usize,
    threshold: i32,
) -> Result<Vec<Leaf, MAX_LEAVES>, Error> {
    let d = grid.width();
    if grid.height() != d {
        return Err(Error::InvalidParameter { name: "quad_min_dim" });
    }
    let mut ranges = BlockRanges::new(d, min_dim)?;
    for (y, row) in grid.rows().enumerate() {
        ranges.add_row(y, row)?;
    }
    ranges.leaves(threshold)
}

/// Sorts `v` by ascending `key` (here: side descending, then column, then row) in place.
///
/// A heapsort written with checked accesses instead of `sort_unstable_by_key`: core's sort keeps
/// a panic path for comparators that are not total orders, which no caller here can reach but
/// the optimiser cannot remove, and the firmware's no-panic link check refuses it. O(n log n),
/// no extra memory.
fn heapsort_by_key(v: &mut [Leaf], key: impl Fn(&Leaf) -> u64) {
    let k = |v: &[Leaf], i: usize| v.get(i).map(&key);
    // Moves the element at `root` down the max-heap `v[..end]`.
    let sift_down = |v: &mut [Leaf], mut root: usize, end: usize| loop {
        let mut child = 2 * root + 1;
        if child >= end {
            return;
        }
        if child + 1 < end && k(v, child + 1) > k(v, child) {
            child += 1;
        }
        if k(v, root) >= k(v, child) {
            return;
        }
        if let (Some(&a), Some(&b)) = (v.get(root), v.get(child)) {
            if let Some(x) = v.get_mut(root) {
                *x = b;
            }
            if let Some(x) = v.get_mut(child) {
                *x = a;
            }
        }
        root = child;
    };
    let n = v.len();
    for root in (0..n / 2).rev() {
        sift_down(v, root, n);
    }
    for end in (1..n).rev() {
        if let (Some(&first), Some(&last)) = (v.first(), v.get(end)) {
            if let Some(x) = v.first_mut() {
                *x = last;
            }
            if let Some(x) = v.get_mut(end) {
                *x = first;
            }
        }
        sift_down(v, 0, end);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    #[test]
    fn heapsort_orders_like_the_core_sort() {
        let mut s = 12345u32;
        for n in [0usize, 1, 2, 3, 7, 64, 500] {
            let mut v: std::vec::Vec<Leaf> = (0..n)
                .map(|_| {
                    s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    Leaf {
                        side: 1 << ((s >> 8) % 6),
                        col: ((s >> 12) % 7) as u16,
                        row: ((s >> 20) % 9) as u16,
                    }
                })
                .collect();
            let mut expected = v.clone();
            expected.sort_by_key(|l| (core::cmp::Reverse(l.side), l.col, l.row));
            heapsort_by_key(&mut v, |l| {
                (u64::from(u16::MAX - l.side) << 32) | (u64::from(l.col) << 16) | u64::from(l.row)
            });
            assert_eq!(v, expected, "n = {n}");
        }
    }

    #[test]
    fn flat_grid_is_one_leaf_and_a_spike_splits_to_the_minimum() -> Result<(), Error> {
        let mut g = [10i32; 64 * 64];
        let leaves = decompose(FrameRef::new(&g, 64, 64)?, 8, 51)?;
        assert_eq!(leaves.as_slice(), &[Leaf { row: 0, col: 0, side: 64 }]);
        g[64 * 10 + 10] = 62; // range 52 > 51
        let leaves = decompose(FrameRef::new(&g, 64, 64)?, 8, 51)?;
        // 3 of side 32, 3 of side 16, 4 of side 8, column-major within a side.
        assert_eq!(leaves.len(), 10);
        assert_eq!(leaves[0], Leaf { row: 32, col: 0, side: 32 });
        assert_eq!(leaves[1], Leaf { row: 0, col: 32, side: 32 });
        assert_eq!(leaves[2], Leaf { row: 32, col: 32, side: 32 });
        assert_eq!(leaves[3], Leaf { row: 16, col: 0, side: 16 });
        assert_eq!(leaves[4], Leaf { row: 0, col: 16, side: 16 });
        assert!(leaves[6..].iter().all(|l| l.side == 8));
        assert!(leaves[6..].iter().any(|l| l.row == 8 && l.col == 8));
        g[64 * 10 + 10] = 61; // range 51: no split
        assert_eq!(decompose(FrameRef::new(&g, 64, 64)?, 8, 51)?.len(), 1);
        Ok(())
    }
}
