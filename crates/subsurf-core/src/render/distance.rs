//! A conservative distance-to-surface bound on a uniform grid, built at load time, so that a
//! random-walk collision that cannot reach any surface skips the ray cast (issue 19's "no ray
//! cast per collision" lever).
//!
//! Every cell that a triangle's (padded) bounding box overlaps is marked; a multi-source
//! breadth-first search over the 26-neighbourhood gives each cell its Chebyshev distance k (in
//! cells) to the nearest marked cell. A point p in a cell with distance k is at least (k − 1) h
//! from every surface point q (h: the cell size): q lies in a marked cell, and along the axis
//! where the two cells' indices differ by k the coordinates of p and q differ by at least
//! (k − 1) h. A margin of 10⁻⁶ h covers the rounding of p's cell index.

use super::accel::Tri;
use super::math::{madd, V3};
use std::collections::VecDeque;

/// The grid of Chebyshev distances (in cells) to the nearest cell touched by a triangle.
pub struct DistanceGrid {
    lo: V3,
    h: f64,
    n: [usize; 3],
    k: Vec<u16>,
}

impl DistanceGrid {
    /// Cells per axis of the longest side of the bounding box `lo`..`hi`.
    pub const CELLS: usize = 64;

    /// Build over `tris` (bounding box `lo`..`hi`).
    pub fn new(tris: &[Tri], lo: V3, hi: V3) -> DistanceGrid {
        let side = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
        let h = side / Self::CELLS as f64;
        if !(h > 0.0 && h.is_finite()) || tris.is_empty() {
            return DistanceGrid { lo, h: 0.0, n: [0; 3], k: vec![] };
        }
        let pad = 1e-6 * side;
        let n: [usize; 3] = std::array::from_fn(|a| (((hi[a] - lo[a]) / h).ceil() as usize).clamp(1, Self::CELLS));
        let lo = std::array::from_fn(|a| lo[a] - pad);
        let h = (0..3).map(|a| (hi[a] + pad - lo[a]) / n[a] as f64).fold(0.0f64, f64::max);
        let mut g = DistanceGrid { lo, h, n, k: vec![u16::MAX; n[0] * n[1] * n[2]] };
        let mut queue = VecDeque::new();
        for t in tris {
            let vs = [t.v0, madd(t.v0, t.e1, 1.0), madd(t.v0, t.e2, 1.0)];
            let cell = |p: V3, a: usize, s: f64| g.axis_index(p[a] + s, a);
            let lo_c: [usize; 3] = std::array::from_fn(|a| vs.iter().map(|&p| cell(p, a, -pad)).min().unwrap_or(0));
            let hi_c: [usize; 3] = std::array::from_fn(|a| vs.iter().map(|&p| cell(p, a, pad)).max().unwrap_or(0));
            for x in lo_c[0]..=hi_c[0] {
                for y in lo_c[1]..=hi_c[1] {
                    for z in lo_c[2]..=hi_c[2] {
                        let i = g.flat([x, y, z]);
                        if g.k[i] != 0 {
                            g.k[i] = 0;
                            queue.push_back([x, y, z]);
                        }
                    }
                }
            }
        }
        while let Some(c) = queue.pop_front() {
            let next = g.k[g.flat(c)].saturating_add(1);
            for dx in -1i64..=1 {
                for dy in -1i64..=1 {
                    for dz in -1i64..=1 {
                        let nb = [c[0] as i64 + dx, c[1] as i64 + dy, c[2] as i64 + dz];
                        if (0..3).any(|a| nb[a] < 0 || nb[a] >= n[a] as i64) {
                            continue;
                        }
                        let nb = nb.map(|v| v as usize);
                        let i = g.flat(nb);
                        if g.k[i] > next {
                            g.k[i] = next;
                            queue.push_back(nb);
                        }
                    }
                }
            }
        }
        g
    }

    #[inline]
    fn axis_index(&self, x: f64, a: usize) -> usize {
        (((x - self.lo[a]) / self.h).max(0.0) as usize).min(self.n[a] - 1)
    }

    #[inline]
    fn flat(&self, c: [usize; 3]) -> usize {
        (c[0] * self.n[1] + c[1]) * self.n[2] + c[2]
    }

    /// A distance (mm) not above the distance from `p` to the nearest triangle (0 outside the
    /// grid).
    #[inline]
    pub fn bound(&self, p: V3) -> f64 {
        let mut c = [0usize; 3];
        for a in 0..3 {
            let f = (p[a] - self.lo[a]) / self.h;
            if !(f >= 0.0 && f < self.n[a] as f64) {
                return 0.0;
            }
            c[a] = f as usize;
        }
        let k = self.k[self.flat(c)];
        if k < 2 || k == u16::MAX {
            return 0.0;
        }
        self.h * (k as f64 - 1.0 - 1e-6)
    }
}
