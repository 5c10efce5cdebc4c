//! A conservative distance-to-surface bound on a uniform grid, built at load time, so that a
//! random-walk collision that cannot reach any surface skips the ray cast (issue 19's "no ray
//! cast per collision" lever).
//!
//! Every cell that a triangle's (padded) bounding box overlaps is marked; the exact Euclidean
//! distance transform of the marked cells (Felzenszwalb & Huttenlocher 2012, "Distance
//! transforms of sampled functions", Theory of Computing 8: three separable passes of the lower
//! envelope of parabolas) gives each cell the distance D (in cells, between cell indices) to the
//! nearest marked cell. A point p in a cell at distance D is at least (D − √3) h from every
//! surface point q (h: the cell size): q lies in a marked cell c′, and the boxes of the two
//! cells are apart by at least max(|cₐ − c′ₐ| − 1, 0) h along each axis a, whose norm is at
//! least ‖c − c′‖ − ‖(1, 1, 1)‖. A margin of 10⁻⁶ h covers the rounding of p's cell index.

use super::accel::Tri;
use super::math::{madd, V3};
use rayon::prelude::*;

// Every squared distance in cells (at most 3 (n − 1)²) fits a u16 cell.
const _: () = assert!(3 * (DistanceGrid::MAX_CELLS - 1) * (DistanceGrid::MAX_CELLS - 1) <= u16::MAX as usize);

/// The grid of distance bounds (mm) to the nearest triangle.
///
/// Each cell stores its squared distance D² in cells (an integer, below 3·128² < 2¹⁶) as a u16,
/// and the bound (D − √3) h of every possible D² comes from a table: 2 bytes per cell instead of 4
/// (4 MB at 128³: the walk's lookups are scattered over the grid), the same f32 values as a grid
/// of f32 bounds (the table holds them); the table entries that a walk inside an object reads
/// (D up to the object's inradius in cells: 16 kB on the benchmark's sphere) stay cached.
pub struct DistanceGrid {
    lo: V3,
    h: f64,
    n: [usize; 3],
    d2: Vec<u16>,
    /// The bound (mm, as f32) of each squared distance D² = 0, 1, 2, … in cells.
    table: Vec<f32>,
    /// 1/h, and the cells per axis as f64 (the lookup multiplies instead of dividing).
    inv_h: f64,
    nf: V3,
    /// The box's far corner, lo + n h.
    hi: V3,
}

impl DistanceGrid {
    /// Cells per axis of the longest side of the bounding box: at least [`Self::MIN_CELLS`], and
    /// up to [`Self::MAX_CELLS`] so that a cell is at most a third of the least mean free path
    /// (the bound is (D − √3) h: its loss near the surface is what makes collisions cast rays and
    /// make connections; measured on the 81,920-triangle marble sphere, 64 → 128 cells: −20 %
    /// render instructions at the same noise, 4 MB per grid of u16, about 0.1 s to build).
    pub const MIN_CELLS: usize = 64;
    pub const MAX_CELLS: usize = 128;

    /// Build over the box `lo`..`hi` (the translucent objects', where walks run), with cells
    /// sized for the least extinction coefficient `sigma_t` (mm⁻¹) of the media walked. A
    /// triangle outside the box marks the cells of its bounding box clamped into the box:
    /// clamping onto a convex box brings no point closer to a point inside it, so the bound
    /// stays conservative.
    pub fn new(tris: &[Tri], lo: V3, hi: V3, sigma_t: f64) -> DistanceGrid {
        let side = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
        let want = 3.0 * side * sigma_t;
        let cells = if want.is_finite() {
            (want.ceil() as usize).clamp(Self::MIN_CELLS, Self::MAX_CELLS)
        } else {
            Self::MIN_CELLS
        };
        let h = side / cells as f64;
        if !(h > 0.0 && h.is_finite()) || tris.is_empty() {
            return DistanceGrid { lo, h: 0.0, n: [0; 3], d2: vec![], table: vec![], inv_h: 0.0, nf: [0.0; 3], hi: lo };
        }
        let pad = 1e-6 * side;
        let n: [usize; 3] = std::array::from_fn(|a| (((hi[a] - lo[a]) / h).ceil() as usize).clamp(1, cells));
        let lo = std::array::from_fn(|a| lo[a] - pad);
        let h = (0..3).map(|a| (hi[a] + pad - lo[a]) / n[a] as f64).fold(0.0f64, f64::max);
        let (nf, hi) = (n.map(|c| c as f64), std::array::from_fn(|a| lo[a] + n[a] as f64 * h));
        let mut g = DistanceGrid { lo, h, n, d2: vec![], table: vec![], inv_h: 1.0 / h, nf, hi };
        let mut d2 = vec![f64::INFINITY; n[0] * n[1] * n[2]];
        for t in tris {
            let vs = [t.v0, madd(t.v0, t.e1, 1.0), madd(t.v0, t.e2, 1.0)];
            let cell = |p: V3, a: usize, s: f64| g.axis_index(p[a] + s, a);
            let lo_c: [usize; 3] = std::array::from_fn(|a| vs.iter().map(|&p| cell(p, a, -pad)).min().unwrap_or(0));
            let hi_c: [usize; 3] = std::array::from_fn(|a| vs.iter().map(|&p| cell(p, a, pad)).max().unwrap_or(0));
            for x in lo_c[0]..=hi_c[0] {
                for y in lo_c[1]..=hi_c[1] {
                    for z in lo_c[2]..=hi_c[2] {
                        d2[g.flat([x, y, z])] = 0.0;
                    }
                }
            }
        }
        // Squared distances by three separable 1-D passes (x, then y, then z): the lines of a
        // pass in parallel (rayon; each worker reuses its buffers), gathered into a line-major
        // buffer, then scattered back.
        let cap = n.iter().copied().max().unwrap_or(1);
        let stride = [n[1] * n[2], n[2], 1];
        let mut lines = vec![0.0; d2.len()];
        for axis in 0..3 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let (len, st) = (n[axis], stride[axis]);
            let base = |l: usize| (l / n[b]) * stride[a] + (l % n[b]) * stride[b];
            let src = &d2;
            lines.par_chunks_mut(len).enumerate().for_each_init(
                || Envelope::new(cap),
                |env, (l, out)| {
                    let b0 = base(l);
                    for t in 0..len {
                        env.f[t] = src[b0 + t * st];
                    }
                    if axis == 0 {
                        env.scan(len); // binary marks: the 1-D distance by two sweeps
                    } else {
                        env.run(len);
                    }
                    out.copy_from_slice(&env.out[..len]);
                },
            );
            for (l, line) in lines.chunks(len).enumerate() {
                let b0 = base(l);
                for (t, &v) in line.iter().enumerate() {
                    d2[b0 + t * st] = v;
                }
            }
        }
        // Squared distances between cell indices are integers up to Σ (n − 1)² (< 2¹⁶ for
        // n ≤ 128); a cell left at ∞ (none: every triangle marks a cell) gets the bound 0.
        let top = n.iter().map(|&c| (c - 1) * (c - 1)).sum::<usize>();
        let margin = 3f64.sqrt() + 1e-6;
        g.table = (0..=top).map(|v| (((v as f64).sqrt() - margin) * h).max(0.0) as f32).collect();
        g.d2 = d2.par_iter().map(|&v| if v.is_finite() && v <= top as f64 { v as u16 } else { 0 }).collect();
        g
    }

    /// Per-cell triangle lists of `tris` on this grid's cells ([`super::cells`]; None for an
    /// empty grid).
    pub fn cell_lists(&self, tris: &[Tri]) -> Option<super::cells::CellLists> {
        super::cells::CellLists::new(tris, self.lo, self.h, self.n)
    }

    #[inline]
    fn axis_index(&self, x: f64, a: usize) -> usize {
        (((x - self.lo[a]) / self.h).max(0.0) as usize).min(self.n[a] - 1)
    }

    #[inline]
    fn flat(&self, c: [usize; 3]) -> usize {
        (c[0] * self.n[1] + c[1]) * self.n[2] + c[2]
    }

    /// Whether `p` lies in the grid's box (always, for an empty grid).
    #[inline]
    pub fn contains(&self, p: V3) -> bool {
        self.d2.is_empty() || (0..3).all(|a| p[a] >= self.lo[a] && p[a] <= self.hi[a])
    }

    /// A distance (mm) not above the distance from `p` to the nearest triangle (0 outside the
    /// grid).
    #[inline]
    pub fn bound(&self, p: V3) -> f64 {
        // The cell by a product with 1/h (a point within an ulp of a cell face may land in the
        // neighbouring cell: the 10⁻⁶ margin of the bound covers it); the f64 → i32 cast of a
        // value checked to lie in [0, n) is exact truncation.
        let mut c = [0usize; 3];
        for a in 0..3 {
            let f = (p[a] - self.lo[a]) * self.inv_h;
            if !(f >= 0.0 && f < self.nf[a]) {
                return 0.0;
            }
            // Safety: f is finite and in [0, n) with n ≤ `MAX_CELLS` (checked above), so the
            // truncation is representable (a plain `as` adds the
            // saturation's compares and moves: 6 instructions per axis).
            c[a] = unsafe { f.to_int_unchecked::<i32>() } as usize;
        }
        // f32 storage rounds down by at most one ulp: taken off with the factor.
        self.table[self.d2[self.flat(c)] as usize] as f64 * (1.0 - 1e-6)
    }
}

/// The lower envelope of the parabolas (q − t)² + f(q) at every t (Felzenszwalb & Huttenlocher
/// 2012, Algorithm 1); infinite f(q) contribute nothing. Buffers for lines of up to `cap` cells.
struct Envelope {
    f: Vec<f64>,
    out: Vec<f64>,
    v: Vec<usize>,
    z: Vec<f64>,
}

impl Envelope {
    fn new(cap: usize) -> Envelope {
        Envelope { f: vec![0.0; cap], out: vec![0.0; cap], v: Vec::with_capacity(cap), z: Vec::with_capacity(cap + 1) }
    }

    /// `out[..n]` ← the squared distance to the nearest finite `f[..n]` when every finite value
    /// is 0 (the marked cells): two sweeps, the same values as [`Self::run`].
    fn scan(&mut self, n: usize) {
        let (f, out) = (&self.f[..n], &mut self.out[..n]);
        let mut last = f64::NEG_INFINITY;
        for t in 0..n {
            if f[t] == 0.0 {
                last = t as f64;
            }
            out[t] = t as f64 - last;
        }
        let mut next = f64::INFINITY;
        for t in (0..n).rev() {
            if f[t] == 0.0 {
                next = t as f64;
            }
            let d = out[t].min(next - t as f64);
            out[t] = d * d;
        }
    }

    /// `out[..n]` ← the envelope of `f[..n]`.
    fn run(&mut self, n: usize) {
        let (f, v, z) = (&self.f[..n], &mut self.v, &mut self.z);
        v.clear();
        z.clear();
        for q in (0..n).filter(|&q| f[q].is_finite()) {
            let fq = f[q] + (q * q) as f64;
            loop {
                let Some(&p) = v.last() else {
                    v.push(q);
                    z.push(f64::NEG_INFINITY);
                    break;
                };
                let p: usize = p;
                let s = (fq - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
                if s <= *z.last().expect("one per vertex") {
                    v.pop();
                    z.pop();
                } else {
                    v.push(q);
                    z.push(s);
                    break;
                }
            }
        }
        let out = &mut self.out[..n];
        if v.is_empty() {
            out.fill(f64::INFINITY);
            return;
        }
        let mut k = 0;
        for (t, o) in out.iter_mut().enumerate() {
            while k + 1 < v.len() && z[k + 1] < t as f64 {
                k += 1;
            }
            let d = t as f64 - v[k] as f64;
            *o = d * d + f[v[k]];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shapes::icosphere;
    use crate::render::Mesh;

    /// The bound never exceeds the distance to the mesh (for an icosphere of circumradius R
    /// and inradius R − δ that distance is at most |‖p‖ − R| + δ), and it is not vacuous (at
    /// the centre at least 70 % of R: 78 % measured).
    #[test]
    fn bound_is_below_the_distance_to_a_sphere() {
        let r = 5.0;
        let m: Mesh = icosphere([0.0; 3], r, 3).unwrap();
        let acc = crate::render::accel::Accel::new(&[&m]);
        let g = DistanceGrid::new(&acc.tris, acc.lo, acc.hi, 0.0);
        let delta = r * (1.0 - 0.16f64.cos()); // faces span < 0.16 rad from their centre
        let mut rng = crate::rng::PhotonRng::new(1, 0);
        for _ in 0..20_000 {
            let p: V3 = std::array::from_fn(|_| 12.0 * rng.uniform() - 6.0);
            let norm = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            let upper = (norm - r).abs() + delta;
            assert!(g.bound(p) <= upper, "{p:?}: bound {} above {upper}", g.bound(p));
        }
        assert!(g.bound([0.0; 3]) > 0.7 * r, "{}", g.bound([0.0; 3]));
    }
}
