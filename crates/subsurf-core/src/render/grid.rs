//! Heterogeneous media for the random walk: σa and σs per colour channel on a voxel grid, in
//! the object's own coordinates, sampled by delta tracking.
//!
//! The grid is an axis-aligned box [lo, hi] of the object's space (the mesh's coordinates
//! before the object's scale, rotation and translation) cut into nx × ny × nz voxels; a point
//! of the world is mapped into the box by the inverse of the object's transform
//! (`to_object`, an affine map), so the medium moves with the mesh. Each voxel holds one
//! value per channel, looked up at the nearest voxel (piecewise-constant media, as MCX's voxel
//! volumes): a tissue segmentation keeps its sharp boundaries (trilinear interpolation would
//! blur a two-valued grid into a ramp one voxel wide), and the optical depth of a straight
//! segment is an exact sum over the voxels it crosses ([`optical_depth`], Amanatides & Woo
//! 1987), so next-event estimation needs no stochastic transmittance. Outside the box the
//! material's own σa, σs apply.
//!
//! Free paths are sampled by delta tracking (Woodcock et al. 1965; the null-collision
//! formulation of Galtier et al. 2013 and Kutz et al. 2017): the walk samples distances with
//! the majorant σ̄_c = max over the voxels and the material's own values of σt,c
//! ([`Translucent::sigma_bar`]); at a tentative collision x the carrier decides whether it is
//! real (σt(x)) or null (σ̄ − σt(x)), see [`super::walk::Carrier::delta`]. For a homogeneous
//! material σ̄ = σt and every collision is real, so the walk is the homogeneous one.

use super::material::Translucent;
use super::math::{Rgb, V3};
use crate::error::{unravel, Error, Result};

/// Most voxels per axis.
pub const MAX_VOXELS_PER_AXIS: usize = 1024;
/// Most voxels in all (2²⁶: 3 GiB of coefficients, σs and σt per channel).
pub const MAX_VOXELS: usize = 1 << 26;

/// σa, σs per channel on a voxel grid in object space, with the world → object map.
#[derive(Clone, Debug)]
pub struct MediumGrid {
    /// Corners of the box, object space (mm).
    pub lo: V3,
    pub hi: V3,
    /// Voxels per axis.
    pub n: [usize; 3],
    /// σs per voxel (mm⁻¹), numpy C order of an (nx, ny, nz) array (z fastest).
    sigma_s: Vec<Rgb>,
    /// σt per voxel.
    sigma_t: Vec<Rgb>,
    /// World → object: x_obj = A x + b, rows (A | b).
    to_object: [[f64; 4]; 3],
    /// Largest σt per channel over the voxels.
    pub max_t: Rgb,
    /// Least σt over the voxels and channels.
    pub min_t: f64,
}

/// The coefficients at a point (mm⁻¹).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Local {
    pub sigma_s: Rgb,
    pub sigma_t: Rgb,
}

impl MediumGrid {
    /// Validate and build. `field` names the grid in errors (`materials.cloud.grid`);
    /// `sigma_a`, `sigma_s`: one RGB value per voxel, C order of (nx, ny, nz); `to_object`:
    /// the world → object affine map (rows of (A | b)); identity when the object is not
    /// transformed. Errors: counts outside [1, 1024] or above 2²⁶ voxels in all, arrays of the
    /// wrong length, a value not finite or negative, an empty or non-finite box, a singular or
    /// non-finite map.
    pub fn new(
        field: &str,
        bounds: (V3, V3),
        n: [usize; 3],
        sigma_a: Vec<Rgb>,
        sigma_s: Vec<Rgb>,
        to_object: [[f64; 4]; 3],
    ) -> Result<MediumGrid> {
        let (lo, hi) = bounds;
        for k in 0..3 {
            if !(lo[k].is_finite() && hi[k].is_finite() && hi[k] > lo[k]) {
                return Err(Error::Invalid(format!(
                    "{field}.bounds: the box is empty or not finite on axis {k} (lo {}, hi {}); give \
                     [[x0, y0, z0], [x1, y1, z1]] with x0 < x1, y0 < y1, z0 < z1 (mm, object space)",
                    lo[k], hi[k]
                )));
            }
            if n[k] == 0 || n[k] > MAX_VOXELS_PER_AXIS {
                return Err(Error::param_int(format!("{field}.shape[{k}]"), n[k] as i128, "an integer in [1, 1024]"));
            }
        }
        let len = n[0] * n[1] * n[2];
        if len > MAX_VOXELS {
            return Err(Error::param_int(format!("{field}: voxels"), len as i128, "at most 2^26 = 67108864 in all"));
        }
        for (name, v) in [("sigma_a", &sigma_a), ("sigma_s", &sigma_s)] {
            if v.len() != len {
                return Err(Error::Invalid(format!(
                    "{field}.{name}: {} voxels given, the shape {n:?} needs {len}",
                    v.len()
                )));
            }
            if let Some(i) = v.iter().position(|c| c.iter().any(|x| !(x.is_finite() && *x >= 0.0))) {
                let k = v[i].iter().position(|x| !(x.is_finite() && *x >= 0.0)).expect("found");
                let [x, y, z] = unravel(i, &n)[..] else { unreachable!("three axes") };
                let f = format!("{field}.{name}[{x}, {y}, {z}, {k}]");
                return Err(Error::param(f, v[i][k], "a finite number >= 0 (mm^-1)"));
            }
        }
        if to_object.iter().flatten().any(|x| !x.is_finite()) || det3(&to_object) == 0.0 {
            return Err(Error::Invalid(format!("{field}: the object's transform is singular or not finite")));
        }
        let sigma_t: Vec<Rgb> =
            sigma_a.iter().zip(&sigma_s).map(|(a, s)| std::array::from_fn(|k| a[k] + s[k])).collect();
        let max_t = sigma_t.iter().fold([0.0; 3], |m, t| std::array::from_fn(|k| f64::max(m[k], t[k])));
        let min_t = sigma_t.iter().flatten().fold(f64::INFINITY, |m, &t| m.min(t));
        Ok(MediumGrid { lo, hi, n, sigma_s, sigma_t, to_object, max_t, min_t })
    }

    /// Object-space coordinates of the world point `p`.
    #[inline]
    fn object(&self, p: V3) -> V3 {
        std::array::from_fn(|r| {
            let a = &self.to_object[r];
            a[0] * p[0] + a[1] * p[1] + a[2] * p[2] + a[3]
        })
    }

    /// The linear part of the world → object map applied to the direction `d`.
    #[inline]
    fn object_dir(&self, d: V3) -> V3 {
        std::array::from_fn(|r| {
            let a = &self.to_object[r];
            a[0] * d[0] + a[1] * d[1] + a[2] * d[2]
        })
    }

    /// The voxel (flat index) holding the object-space point `q`, if it is in the box.
    #[inline]
    fn voxel(&self, q: V3) -> Option<usize> {
        let mut idx = 0;
        for k in 0..3 {
            let f = (q[k] - self.lo[k]) / (self.hi[k] - self.lo[k]);
            if !(0.0..=1.0).contains(&f) {
                return None;
            }
            idx = idx * self.n[k] + ((f * self.n[k] as f64) as usize).min(self.n[k] - 1);
        }
        Some(idx)
    }

    /// σs, σt at the world point `p` (nearest voxel), `None` outside the box.
    #[inline]
    pub fn at(&self, p: V3) -> Option<Local> {
        self.voxel(self.object(p)).map(|i| Local { sigma_s: self.sigma_s[i], sigma_t: self.sigma_t[i] })
    }

    /// ∫ σt ds along the world segment o + s d, s ∈ [0, t] (d a unit vector), per channel,
    /// with `outside` (the material's σt) where the segment is outside the box: a slab
    /// clip to the box, then a 3D-DDA over the voxels it crosses (Amanatides & Woo 1987).
    pub fn optical_depth(&self, o: V3, d: V3, t: f64, outside: Rgb) -> Rgb {
        let (q, e) = (self.object(o), self.object_dir(d));
        // The parameter interval [t0, t1] ⊂ [0, t] inside the box (object-space slabs; the
        // parameter is the world distance along d).
        let (mut t0, mut t1) = (0.0f64, t);
        for k in 0..3 {
            if e[k] == 0.0 {
                if q[k] < self.lo[k] || q[k] > self.hi[k] {
                    return std::array::from_fn(|c| outside[c] * t);
                }
                continue;
            }
            let (a, b) = ((self.lo[k] - q[k]) / e[k], (self.hi[k] - q[k]) / e[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        if !(t1 > t0) {
            return std::array::from_fn(|c| outside[c] * t);
        }
        let mut tau: Rgb = std::array::from_fn(|c| outside[c] * (t - (t1 - t0)));
        // The voxel at the middle of the first step, then step voxel by voxel.
        let h: V3 = std::array::from_fn(|k| (self.hi[k] - self.lo[k]) / self.n[k] as f64);
        let start: V3 = std::array::from_fn(|k| q[k] + e[k] * t0);
        let mut cell = [0usize; 3];
        let (mut next, mut delta, mut step) = ([f64::INFINITY; 3], [f64::INFINITY; 3], [0i64; 3]);
        for k in 0..3 {
            let f = ((start[k] - self.lo[k]) / h[k]).floor();
            let mut i = f.clamp(0.0, (self.n[k] - 1) as f64) as usize;
            // On a voxel face, moving backwards: the voxel behind the face.
            if e[k] < 0.0 && i > 0 && f == i as f64 && start[k] - self.lo[k] == i as f64 * h[k] {
                i -= 1;
            }
            cell[k] = i;
            if e[k] != 0.0 {
                step[k] = if e[k] > 0.0 { 1 } else { -1 };
                let face = self.lo[k] + (i as f64 + if e[k] > 0.0 { 1.0 } else { 0.0 }) * h[k];
                next[k] = (face - q[k]) / e[k];
                delta[k] = h[k] / e[k].abs();
            }
        }
        let mut tc = t0;
        for _ in 0..(self.n[0] + self.n[1] + self.n[2] + 3) {
            let k = if next[0] <= next[1] && next[0] <= next[2] {
                0
            } else if next[1] <= next[2] {
                1
            } else {
                2
            };
            let tn = next[k].min(t1);
            let st = &self.sigma_t[(cell[0] * self.n[1] + cell[1]) * self.n[2] + cell[2]];
            let len = (tn - tc).max(0.0);
            tau = std::array::from_fn(|c| tau[c] + st[c] * len);
            tc = tn;
            if tn >= t1 {
                break;
            }
            let i = cell[k] as i64 + step[k];
            if i < 0 || i >= self.n[k] as i64 {
                break;
            }
            cell[k] = i as usize;
            next[k] += delta[k];
        }
        tau
    }
}

fn det3(m: &[[f64; 4]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The identity world → object map.
pub const IDENTITY: [[f64; 4]; 3] = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];

/// The delta-tracking hook of the walk: the coefficients at a tentative collision `p` in `m`,
/// or `None` for a homogeneous material (whose collisions are all real; a textured object's
/// walk is in its entry texel's homogeneous material, [`super::walk::Media::medium`]).
#[inline]
pub fn local(m: &Translucent, p: V3) -> Option<Local> {
    let g = m.grid.as_deref()?;
    Some(g.at(p).unwrap_or(Local { sigma_s: m.sigma_s, sigma_t: m.sigma_t }))
}

/// ∫ σt ds per channel along o + s d, s ∈ [0, t], in `m` (σt t for a homogeneous material).
#[inline]
pub fn optical_depth(m: &Translucent, o: V3, d: V3, t: f64) -> Rgb {
    match m.grid.as_deref() {
        None => std::array::from_fn(|k| m.sigma_t[k] * t),
        Some(g) => g.optical_depth(o, d, t, m.sigma_t),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::math::{madd, normalize};

    fn two_valued() -> MediumGrid {
        // 4 × 3 × 2 voxels on [0, 4] × [0, 3] × [0, 2]: σt = 1 + x-index in channel 0.
        let n = [4, 3, 2];
        let mut sa = vec![];
        for i in 0..4 {
            for _ in 0..6 {
                sa.push([i as f64, 0.5, 0.0]);
            }
        }
        let ss = vec![[1.0, 0.0, 2.0]; 24];
        MediumGrid::new("g", ([0.0; 3], [4.0, 3.0, 2.0]), n, sa, ss, IDENTITY).unwrap()
    }

    /// The DDA's optical depth equals a fine midpoint sum of the nearest-voxel σt along
    /// random segments, in and across the box (piecewise constant: the sum converges to it).
    #[test]
    fn optical_depth_matches_fine_sums() {
        let g = two_valued();
        let outside = [0.25, 0.5, 0.75];
        let mut rng = crate::rng::PhotonRng::new(3, 0);
        for _ in 0..200 {
            let o = [rng.uniform() * 6.0 - 1.0, rng.uniform() * 5.0 - 1.0, rng.uniform() * 4.0 - 1.0];
            let d = normalize([rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5]);
            let t = rng.uniform() * 6.0;
            let tau = g.optical_depth(o, d, t, outside);
            let m = 200_000;
            let mut s = [0.0; 3];
            for j in 0..m {
                let x = madd(o, d, (j as f64 + 0.5) * t / m as f64);
                let st = g.at(x).map_or(outside, |l| l.sigma_t);
                s = std::array::from_fn(|k| s[k] + st[k] * t / m as f64);
            }
            for k in 0..3 {
                // Each voxel face crossed moves at most one midpoint: error ≤ faces × σ range × t/m.
                assert!((tau[k] - s[k]).abs() < 20.0 * 4.0 * t / m as f64 + 1e-12, "{tau:?} vs {s:?}");
            }
        }
    }

    /// Bad grids are refused with the field and the allowed range.
    #[test]
    fn bad_grids_are_refused() {
        let e = |sa: Vec<Rgb>, b: (V3, V3)| {
            MediumGrid::new("materials.m.grid", b, [2, 1, 1], sa, vec![[1.0; 3]; 2], IDENTITY).unwrap_err().to_string()
        };
        let unit = ([0.0; 3], [1.0; 3]);
        let msg = e(vec![[0.1; 3], [0.1, -1.0, 0.1]], unit);
        assert!(msg.contains("materials.m.grid.sigma_a[1, 0, 0, 1]") && msg.contains(">= 0"), "{msg}");
        let msg = e(vec![[0.1; 3], [f64::NAN, 0.1, 0.1]], unit);
        assert!(msg.contains("sigma_a[1, 0, 0, 0] = nan"), "{msg}");
        let msg = e(vec![[0.1; 3]], unit);
        assert!(msg.contains("1 voxels given"), "{msg}");
        let msg = e(vec![[0.1; 3]; 2], ([0.0; 3], [1.0, 0.0, 1.0]));
        assert!(msg.contains("grid.bounds") && msg.contains("empty"), "{msg}");
        let msg = MediumGrid::new("g", unit, [0, 1, 1], vec![], vec![], IDENTITY).unwrap_err().to_string();
        assert!(msg.contains("g.shape[0]") && msg.contains("[1, 1024]"), "{msg}");
    }

    /// A transformed object carries its grid: the world point maps to the object's voxel.
    #[test]
    fn the_grid_moves_with_the_object() {
        let mut g = two_valued();
        // Object scaled by 2 and moved by (10, 0, 0): x_obj = (x − 10)/2.
        g.to_object = [[0.5, 0.0, 0.0, -5.0], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 0.5, 0.0]];
        let l = g.at([10.0 + 2.0 * 2.5, 1.0, 1.0]).unwrap();
        assert_eq!(l.sigma_t[0], 3.0);
        assert!(g.at([9.0, 1.0, 1.0]).is_none());
        // Along x through all four voxels, 2 mm each in the world: 2 (1 + 2 + 3 + 4) = 20.
        let tau = g.optical_depth([9.0, 1.0, 1.0], [1.0, 0.0, 0.0], 10.0, [0.0; 3]);
        assert!((tau[0] - 20.0).abs() < 1e-12, "{tau:?}");
    }
}
