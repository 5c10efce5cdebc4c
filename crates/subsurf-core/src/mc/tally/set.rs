//! [`TallySet`]: every optional histogram of a run (spatial, angular, time-resolved, BRDF/BTDF,
//! per scattering order), with MCML's meaning and normalisation (Wang, Jacques & Zheng 1995,
//! "MCML — Monte Carlo modeling of light transport in multi-layered tissues", Comput. Methods
//! Programs Biomed. 47:131, §4–5 and the MCML manual §4–5), except that every bin is
//! normalised by its *exact* measure (annulus area, ring solid angle, projected solid angle)
//! rather than MCML's midpoint approximations.
//!
//! Conventions (all weights are fractions of the launched power; N = photons traced):
//! - r = √(x² + y²) at the exit or deposition point; bins [i dr, (i+1) dr), the last radial,
//!   depth and time bin also collecting everything beyond the grid (MCML's overflow convention)
//!   yet normalised by its nominal width, so Σ value × measure = total exactly.
//! - θ = exit angle in the ambient medium after refraction, acos|dir_out_z| ∈ [0, π/2], `na`
//!   bins of width π/(2 na) (MCML's `da`).
//! - R(r) = Σw / (N · π(r_{i+1}² − r_i²)) [mm⁻²]; R(θ) = Σw / (N · 2π(cos θ_i − cos θ_{i+1}))
//!   [sr⁻¹] (MCML: 2π sin θ_c Δθ); R(r,θ) = Σw / (N · area · ∫cos θ dω) [mm⁻² sr⁻¹], i.e. per
//!   unit area *perpendicular to the exit direction* as MCML's `Rd_ra` (which uses
//!   cos θ_c × ring solid angle for ∫cos θ dω = π(sin²θ_{i+1} − sin²θ_i)); the same for T.
//! - A(z) = Σdw / (N dz) [mm⁻¹]; A(r,z) = Σdw / (N · area · dz) [mm⁻³]. Fluence (MCML's
//!   F = A/μa, manual §5.3): A/μa in bins inside one layer; in a bin straddling an interface
//!   each deposit is divided by μa of the layer it happens in, so that bin is right too; Φ(z) [1] (planar integral per unit incident power),
//!   Φ(r,z) [mm⁻²]; NaN for bins touching a layer with μa = 0 (fluence is not observable there
//!   through absorption).
//! - Time t = (optical path Σ nᵢ ℓᵢ)/c, c = 0.299792458 mm/ps; R(t) = Σw/(N dt) [ps⁻¹],
//!   R(r,t) [mm⁻² ps⁻¹].
//! - BRDF/BTDF on bins uniform in μ = cos θ_out ∈ [0, 1] × φ_out ∈ [0, 2π) (equal solid angle),
//!   φ = atan2(dir_out_y, dir_out_x) in the ambient medium:
//!   f̄ = Σw / (N ∫_bin cos θ dω) [sr⁻¹] with ∫_bin cos θ dω = Δφ (μ₁² − μ₀²)/2.
//!   Why this is the BRDF for any incidence: f = dL_o/dE_i with E_i the incident power per unit
//!   *surface* area. A pencil beam of power 1 (each photon carries power 1 onto the surface,
//!   whatever θ_i) gives exit power p(ω) dω into dω; by translation invariance the same stack
//!   under a plane wave of irradiance E emits, per unit surface area, E p(ω) dω = L_o cos θ_o dω.
//!   Hence f = p(ω)/cos θ_o and Σw/N = ∫_bin f cos θ dω: the value is the cosine-weighted bin
//!   average of f. Specular reflection is a delta and is excluded (scored by the totals). Under
//!   diffuse (Lambertian) illumination the same number is the response per unit irradiance,
//!   (1/π)∫f cos θ_i dω_i.
//! - Per scattering order: `order` bins 0, 1, …, K and a last bin "> K". `*_single_direct`:
//!   order = 1 and no interface reflection anywhere on the path (the Hanrahan–Krueger 1993
//!   single-scattering paths).

use std::f64::consts::PI;

use super::accum::Accum;
use super::config::TallyConfig;
use super::histogram::{
    annulus_area, bin_clamped, cos_bin_projected_solid_angle, histogram, ring_projected_solid_angle, ring_solid_angle,
    Axis, HistogramOut,
};
use super::{Deposits, Tally};
use crate::error::Result;
use crate::mc::lanes::LANES;
use crate::mc::packet::{Packet, Side};
use crate::medium::Stack;

/// Speed of light in vacuum, mm/ps.
pub const C_MM_PER_PS: f64 = 0.299_792_458;

/// The tallies of one side (reflection through the top, transmission through the bottom).
/// An empty [`Accum`] means "not scored".
#[derive(Clone, Debug, PartialEq)]
struct SideTallies {
    r: Accum,
    a: Accum,
    ra: Accum,
    t: Accum,
    rt: Accum,
    brdf: Accum,
    order: Accum,
    brdf_order: Accum,
    single: Accum,
    brdf_single: Accum,
}

impl SideTallies {
    fn new(c: &TallyConfig, time: bool) -> Self {
        let e = c.errors;
        let on = |b: bool, n: usize| Accum::new(if b { n } else { 0 }, e);
        let nb = c.brdf.map_or(0, |(a, b)| a * b);
        let no = c.max_order.map_or(0, |k| k as usize + 2);
        SideTallies {
            r: on(c.spatial, c.nr),
            a: on(c.angular, c.na),
            ra: on(c.spatial && c.angular, c.nr * c.na),
            t: on(time && c.nt > 0, c.nt),
            rt: on(time && c.nt > 0 && c.spatial, c.nr * c.nt),
            brdf: Accum::new(nb, e),
            order: Accum::new(no, e),
            brdf_order: Accum::new(no * nb, e),
            single: on(no > 0, 1),
            brdf_single: on(no > 0, nb),
        }
    }

    fn each_mut(&mut self) -> [&mut Accum; 10] {
        [
            &mut self.r,
            &mut self.a,
            &mut self.ra,
            &mut self.t,
            &mut self.rt,
            &mut self.brdf,
            &mut self.order,
            &mut self.brdf_order,
            &mut self.single,
            &mut self.brdf_single,
        ]
    }

    fn each(&self) -> [&Accum; 10] {
        [
            &self.r,
            &self.a,
            &self.ra,
            &self.t,
            &self.rt,
            &self.brdf,
            &self.order,
            &self.brdf_order,
            &self.single,
            &self.brdf_single,
        ]
    }
}

/// Every optional tally of a run; implements [`Tally`] and is combined with the engine's
/// `Totals` as `(Totals, TallySet)`. Plain data: no allocation per event.
#[derive(Clone, Debug, PartialEq)]
pub struct TallySet {
    cfg: TallyConfig,
    /// Photons and batches closed so far (see [`Accum`]).
    photons: u64,
    batches: u64,
    inv_dr: f64,
    inv_dz: f64,
    inv_da: f64,
    inv_dt: f64,
    n_cos: usize,
    n_phi: usize,
    max_order: u32,
    /// 1/μa per layer (0 where μa = 0: no fluence deposit).
    inv_mua: Vec<f64>,
    /// Interface depths [0, d₀, d₀ + d₁, …], mm.
    bounds: Vec<f64>,
    rd: SideTallies,
    tt: SideTallies,
    a_z: Accum,
    a_rz: Accum,
    /// Per depth bin: μa (mm⁻¹) of the one layer the bin lies in, or −1 if it straddles an
    /// interface. Fluence is A/μa in the former; only straddling bins need their own Σ dw/μa.
    bin_mua: Vec<f64>,
    phi_z: Accum,
    phi_rz: Accum,
    /// Per lane, the (r, z) bin of its latest absorption deposits and their sum, not yet
    /// added to `a_z`/`a_rz`: consecutive deposits of a lane often fall in one bin (deep or
    /// far photons in the overflow bins), and adding them up per lane avoids a chain of
    /// dependent read-modify-writes on that bin. Flushed when the lane moves to another bin,
    /// at each batch end, and folded in by `merge` and `finalize`.
    pend_bin: [usize; LANES],
    pend: [f64; LANES],
}

/// No pending deposit.
const NO_BIN: usize = usize::MAX;

impl TallySet {
    /// Build the tallies asked for by `cfg` for a run on `stack` (validates `cfg`).
    pub fn new(cfg: &TallyConfig, stack: &Stack) -> Result<Self> {
        cfg.validate()?;
        let (n_cos, n_phi) = cfg.brdf.unwrap_or((0, 0));
        let sp = |n: usize| Accum::new(if cfg.spatial { n } else { 0 }, cfg.errors);
        let mut t = TallySet {
            cfg: *cfg,
            photons: 0,
            batches: 0,
            inv_dr: 1.0 / cfg.dr,
            inv_dz: 1.0 / cfg.dz,
            inv_da: 1.0 / cfg.da(),
            inv_dt: 1.0 / cfg.dt,
            n_cos,
            n_phi,
            max_order: cfg.max_order.unwrap_or(0),
            inv_mua: stack.layers.iter().map(|l| if l.mua > 0.0 { 1.0 / l.mua } else { 0.0 }).collect(),
            bounds: stack.boundaries(),
            rd: SideTallies::new(cfg, true),
            tt: SideTallies::new(cfg, false),
            a_z: sp(cfg.nz),
            a_rz: sp(cfg.nr * cfg.nz),
            bin_mua: Vec::new(),
            phi_z: sp(cfg.nz),
            phi_rz: sp(cfg.nr * cfg.nz),
            pend_bin: [NO_BIN; LANES],
            pend: [0.0; LANES],
        };
        if cfg.spatial {
            t.bin_mua = (0..cfg.nz)
                .map(|iz| {
                    let mut touched = t.layers_touching(iz);
                    match (touched.next(), touched.next()) {
                        (Some(j), None) => stack.layers[j].mua,
                        _ => -1.0,
                    }
                })
                .collect();
        }
        Ok(t)
    }

    /// Indices of the layers that overlap depth bin `iz` (the last bin reaches to infinity).
    fn layers_touching(&self, iz: usize) -> impl Iterator<Item = usize> + '_ {
        let z0 = iz as f64 * self.cfg.dz;
        let z1 = if iz + 1 == self.cfg.nz { f64::INFINITY } else { (iz + 1) as f64 * self.cfg.dz };
        (0..self.inv_mua.len()).filter(move |&j| z0 < self.bounds[j + 1] && self.bounds[j] < z1)
    }

    /// Add `dw` to the absorption bin `irz` (= ir · nz + iz) of `a_rz` and to `a_z`.
    #[inline]
    fn add_rz(&mut self, irz: usize, dw: f64) {
        self.a_z.add(irz % self.cfg.nz, dw);
        self.a_rz.add(irz, dw);
    }

    /// Add lane `i`'s pending deposits to the grids.
    #[inline]
    fn flush_lane(&mut self, i: usize) {
        if self.pend_bin[i] != NO_BIN {
            self.add_rz(self.pend_bin[i], self.pend[i]);
            self.pend_bin[i] = NO_BIN;
            self.pend[i] = 0.0;
        }
    }

    /// The configuration.
    pub fn config(&self) -> &TallyConfig {
        &self.cfg
    }

    /// Whether any layer touching depth bin `iz` has μa = 0.
    fn fluence_undefined(&self, iz: usize) -> bool {
        self.layers_touching(iz).any(|j| self.inv_mua[j] == 0.0)
    }

    /// Normalise everything into histograms for a run of `photons` photons (see the module docs
    /// for each normalisation). Only the enabled tallies are returned.
    pub fn finalize(&self, photons: u64) -> Vec<HistogramOut> {
        if self.pend_bin.iter().any(|&b| b != NO_BIN) {
            let mut t = self.clone();
            for i in 0..LANES {
                t.flush_lane(i);
            }
            return t.finalize(photons);
        }
        let c = &self.cfg;
        let n = (photons, self.batches);
        let (r_ax, z_ax) = (Axis::uniform("r", "mm", c.nr, c.dr), Axis::uniform("z", "mm", c.nz, c.dz));
        let a_ax = Axis::span("theta", "rad", c.na, 0.0, PI / 2.0);
        let t_ax = Axis::uniform("t", "ps", c.nt, c.dt);
        let area = |i: usize| annulus_area(i, c.dr);
        let th = &a_ax.edges;
        let mut out = Vec::new();
        for (side, s) in [("rd", &self.rd), ("tt", &self.tt)] {
            let what = if side == "rd" { "diffuse reflectance" } else { "transmittance" };
            let mcml = if side == "rd" { "Rd" } else { "Tt" };
            if !s.r.is_empty() {
                let d = format!(
                    "{what} per unit area vs radius ({mcml}_r); last bin also holds r > {} mm",
                    c.nr as f64 * c.dr
                );
                out.push(histogram(&format!("{side}_r"), &s.r, n, std::slice::from_ref(&r_ax), "mm^-2", &d, |i| {
                    1.0 / area(i)
                }));
            }
            if !s.a.is_empty() {
                let d = format!("{what} per unit solid angle vs exit angle in the ambient medium ({mcml}_a)");
                out.push(histogram(&format!("{side}_a"), &s.a, n, std::slice::from_ref(&a_ax), "sr^-1", &d, |i| {
                    1.0 / ring_solid_angle(th[i], th[i + 1])
                }));
            }
            if !s.ra.is_empty() {
                let d =
                    format!("{what} per unit area perpendicular to the exit direction and per solid angle ({mcml}_ra)");
                out.push(histogram(
                    &format!("{side}_ra"),
                    &s.ra,
                    n,
                    &[r_ax.clone(), a_ax.clone()],
                    "mm^-2 sr^-1",
                    &d,
                    |i| {
                        let (ir, ia) = (i / c.na, i % c.na);
                        1.0 / (area(ir) * ring_projected_solid_angle(th[ia], th[ia + 1]))
                    },
                ));
            }
            if !s.t.is_empty() {
                let d = format!(
                    "time-resolved {what} (time = optical path / c); last bin also holds t > {} ps",
                    c.nt as f64 * c.dt
                );
                out.push(histogram(&format!("{side}_t"), &s.t, n, std::slice::from_ref(&t_ax), "ps^-1", &d, |_| {
                    1.0 / c.dt
                }));
            }
            if !s.rt.is_empty() {
                let d = format!("time-resolved {what} per unit area vs radius and time");
                out.push(histogram(
                    &format!("{side}_rt"),
                    &s.rt,
                    n,
                    &[r_ax.clone(), t_ax.clone()],
                    "mm^-2 ps^-1",
                    &d,
                    |i| 1.0 / (area(i / c.nt) * c.dt),
                ));
            }
            let bsdf = if side == "rd" { "brdf" } else { "btdf" };
            let (mu_ax, phi_ax) = (
                Axis::span("cos_theta", "1", self.n_cos, 0.0, 1.0),
                Axis::span("phi", "rad", self.n_phi, 0.0, 2.0 * PI),
            );
            let nb = self.n_cos * self.n_phi;
            let proj = |b: usize| {
                let ic = (b % nb.max(1)) / self.n_phi.max(1);
                cos_bin_projected_solid_angle(mu_ax.edges[ic], mu_ax.edges[ic + 1], 2.0 * PI / self.n_phi as f64)
            };
            let bsdf_d = format!(
                "{} (cosine-weighted bin average of f, sr^-1) on equal-solid-angle bins of the exit direction",
                bsdf.to_uppercase()
            );
            if !s.brdf.is_empty() {
                out.push(histogram(bsdf, &s.brdf, n, &[mu_ax.clone(), phi_ax.clone()], "sr^-1", &bsdf_d, |b| {
                    1.0 / proj(b)
                }));
            }
            if !s.order.is_empty() {
                let o_ax = Axis::order(self.max_order);
                let d = format!("{what} by scattering order 0 … {k} and > {k} (last bin)", k = self.max_order);
                out.push(histogram(
                    &format!("{side}_order"),
                    &s.order,
                    n,
                    std::slice::from_ref(&o_ax),
                    "1",
                    &d,
                    |_| 1.0,
                ));
                let d =
                    format!("{what} of singly scattered light with no interface reflection (Hanrahan–Krueger paths)");
                out.push(histogram(
                    &format!("{side}_single_direct"),
                    &s.single,
                    n,
                    &[Axis::order_one()],
                    "1",
                    &d,
                    |_| 1.0,
                ));
                if nb > 0 {
                    let d = format!("{bsdf_d}, by scattering order (last order bin: > {})", self.max_order);
                    let axes = [o_ax, mu_ax.clone(), phi_ax.clone()];
                    out.push(histogram(&format!("{bsdf}_order"), &s.brdf_order, n, &axes, "sr^-1", &d, |b| {
                        1.0 / proj(b)
                    }));
                    let d = format!("{bsdf_d}, single scattering with no interface reflection (Hanrahan–Krueger)");
                    let axes = [Axis::order_one(), mu_ax.clone(), phi_ax.clone()];
                    out.push(histogram(&format!("{bsdf}_single_direct"), &s.brdf_single, n, &axes, "sr^-1", &d, |b| {
                        1.0 / proj(b)
                    }));
                }
            }
        }
        if !self.a_z.is_empty() {
            let over = format!("last bin also holds z > {} mm", c.nz as f64 * c.dz);
            out.push(histogram(
                "a_z",
                &self.a_z,
                n,
                std::slice::from_ref(&z_ax),
                "mm^-1",
                &format!("absorbed fraction per unit depth (A_z); {over}"),
                |_| 1.0 / c.dz,
            ));
            let rz = [r_ax.clone(), z_ax.clone()];
            let d =
                format!("absorbed fraction per unit volume (A_rz); {over}, last r bin r > {} mm", c.nr as f64 * c.dr);
            out.push(histogram("a_rz", &self.a_rz, n, &rz, "mm^-3", &d, |i| 1.0 / (area(i / c.nz) * c.dz)));
            let mut fz = histogram("fluence_z", &self.phi_z, n, &[z_ax], "1", &format!("fluence A/mu_a integrated over the plane, per unit incident power (F_z); {over}; NaN where mu_a = 0"), |_| 1.0 / c.dz);
            let mut frz = histogram(
                "fluence_rz",
                &self.phi_rz,
                n,
                &rz,
                "mm^-2",
                &format!("fluence A/mu_a per unit incident power (F_rz); {over}; NaN where mu_a = 0"),
                |i| 1.0 / (area(i / c.nz) * c.dz),
            );
            let (az, arz) = (&out[out.len() - 2], &out[out.len() - 1]);
            for iz in 0..c.nz {
                let mua = self.bin_mua[iz];
                if mua > 0.0 {
                    // the bin lies in one absorbing layer: Φ = A/μa, bin by bin
                    fz.values[iz] = az.values[iz] / mua;
                    fz.stderr[iz] = az.stderr[iz] / mua;
                    for k in (iz..c.nr * c.nz).step_by(c.nz) {
                        frz.values[k] = arz.values[k] / mua;
                        frz.stderr[k] = arz.stderr[k] / mua;
                    }
                } else if mua == 0.0 || self.fluence_undefined(iz) {
                    fz.values[iz] = f64::NAN;
                    fz.stderr[iz] = f64::NAN;
                    for ir in 0..c.nr {
                        frz.values[ir * c.nz + iz] = f64::NAN;
                        frz.stderr[ir * c.nz + iz] = f64::NAN;
                    }
                }
            }
            out.push(fz);
            out.push(frz);
        }
        out
    }
}

/// r = √(x² + y²) of the packet (no `hypot`: coordinates are far from overflow, and `hypot`
/// is several times slower).
#[inline(always)]
fn radius(p: &Packet) -> f64 {
    (p.pos[0] * p.pos[0] + p.pos[1] * p.pos[1]).sqrt()
}

impl Tally for TallySet {
    fn batched(&self) -> bool {
        self.cfg.errors
    }

    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}

    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}

    #[inline]
    fn absorb(&mut self, _lane: usize, p: &Packet, dw: f64) {
        if self.a_z.is_empty() {
            return;
        }
        let c = &self.cfg;
        let iz = bin_clamped(p.pos[2], self.inv_dz, c.nz);
        let ir = bin_clamped(radius(p), self.inv_dr, c.nr);
        let irz = ir * c.nz + iz;
        self.a_z.add(iz, dw);
        self.a_rz.add(irz, dw);
        let im = self.inv_mua.get(p.layer).copied().unwrap_or(0.0);
        if im > 0.0 && self.bin_mua[iz] < 0.0 {
            self.phi_z.add(iz, dw * im);
            self.phi_rz.add(irz, dw * im);
        }
    }

    /// Bins of all lanes first (a loop LLVM vectorises), then the scattered adds.
    #[inline(always)]
    fn absorb_lanes(&mut self, d: &Deposits) {
        if self.a_z.is_empty() || d.mask == 0 {
            return;
        }
        let (nz, nr) = (self.cfg.nz, self.cfg.nr);
        let (mut iz, mut irz) = ([0usize; LANES], [0usize; LANES]);
        for i in 0..LANES {
            let r = (d.x[i] * d.x[i] + d.y[i] * d.y[i]).sqrt();
            let z = bin_clamped(d.z[i], self.inv_dz, nz);
            iz[i] = z;
            irz[i] = bin_clamped(r, self.inv_dr, nr) * nz + z;
        }
        for i in d.lanes() {
            let dw = d.dep[i];
            if self.pend_bin[i] == irz[i] {
                self.pend[i] += dw;
            } else {
                self.flush_lane(i);
                self.pend_bin[i] = irz[i];
                self.pend[i] = dw;
            }
            if self.bin_mua[iz[i]] < 0.0 {
                let im = self.inv_mua.get(d.layer[i] as usize).copied().unwrap_or(0.0);
                if im > 0.0 {
                    self.phi_z.add(iz[i], dw * im);
                    self.phi_rz.add(irz[i], dw * im);
                }
            }
        }
    }

    #[inline]
    fn escape(&mut self, _lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        let c = &self.cfg;
        let s = match side {
            Side::Top => &mut self.rd,
            Side::Bottom => &mut self.tt,
        };
        let ir = bin_clamped(radius(p), self.inv_dr, c.nr);
        let mu = dir_out[2].abs().min(1.0);
        if !s.r.is_empty() {
            s.r.add(ir, w);
        }
        if !s.a.is_empty() {
            let ia = bin_clamped(mu.acos(), self.inv_da, c.na);
            s.a.add(ia, w);
            if !s.ra.is_empty() {
                s.ra.add(ir * c.na + ia, w);
            }
        }
        if !s.t.is_empty() {
            let it = bin_clamped(p.path / C_MM_PER_PS, self.inv_dt, c.nt);
            s.t.add(it, w);
            if !s.rt.is_empty() {
                s.rt.add(ir * c.nt + it, w);
            }
        }
        let ko = p.order.min(self.max_order + 1) as usize;
        let direct1 = p.order == 1 && p.reflections == 0;
        if !s.order.is_empty() {
            s.order.add(ko, w);
            if direct1 {
                s.single.add(0, w);
            }
        }
        if !s.brdf.is_empty() {
            let ic = bin_clamped(mu, self.n_cos as f64, self.n_cos);
            let mut phi = dir_out[1].atan2(dir_out[0]);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            let ip = bin_clamped(phi, self.n_phi as f64 / (2.0 * PI), self.n_phi);
            let b = ic * self.n_phi + ip;
            s.brdf.add(b, w);
            if !s.order.is_empty() {
                s.brdf_order.add(ko * s.brdf.len() + b, w);
                if direct1 {
                    s.brdf_single.add(b, w);
                }
            }
        }
    }

    #[inline]
    fn end_photon(&mut self, _lane: usize) {}

    fn end_batch(&mut self, photons: u64) {
        for i in 0..LANES {
            self.flush_lane(i);
        }
        self.photons += photons;
        self.batches += 1;
        for a in self.rd.each_mut().into_iter().chain(self.tt.each_mut()) {
            a.end_batch(photons);
        }
        for a in [&mut self.a_z, &mut self.a_rz, &mut self.phi_z, &mut self.phi_rz] {
            a.end_batch(photons);
        }
    }

    fn merge(&mut self, other: &Self) {
        self.photons += other.photons;
        self.batches += other.batches;
        for (a, b) in self.rd.each_mut().into_iter().zip(other.rd.each()) {
            a.merge(b);
        }
        for (a, b) in self.tt.each_mut().into_iter().zip(other.tt.each()) {
            a.merge(b);
        }
        self.a_z.merge(&other.a_z);
        self.a_rz.merge(&other.a_rz);
        self.phi_z.merge(&other.phi_z);
        self.phi_rz.merge(&other.phi_rz);
        // Pending deposits exist only without errors (a batch end flushes them): plain sums.
        for i in 0..LANES {
            if other.pend_bin[i] != NO_BIN {
                self.add_rz(other.pend_bin[i], other.pend[i]);
            }
        }
    }
}

#[cfg(test)]
#[path = "set_tests.rs"]
mod tests;
