//! The photon-packet kernel: one photon history from launch to escape or death.
//!
//! The algorithm is MCML's (L. Wang, S. L. Jacques, L. Zheng, "MCML — Monte Carlo modeling of
//! light transport in multi-layered tissues", Comput. Methods Programs Biomed. 47 (1995) 131,
//! §3; after Prahl et al. 1989):
//!
//! 1. **Step** (MCML §3.3, eq. 3.4/3.5): an optical depth s = −ln ξ is drawn and consumed by
//!    σt of the layers the packet moves through: if the geometric step s/σt reaches the layer's
//!    interface, the packet moves to the interface and keeps the unused optical depth
//!    s − σt·d_b for the next layer (MCML's `StepSizeInTissue`/`HitBoundary`). In a layer with
//!    σt = 0 the packet goes straight to the next interface and keeps its s.
//! 2. **Interface** (MCML §3.5, eqs. 3.16–3.22): all-or-none Fresnel reflection with the two
//!    layers' (or ambient) indices: reflect if ξ ≤ R(θi), else refract by Snell's law (the
//!    tangential direction is scaled by η = nᵢ/nₜ); R = 1 past the critical angle (total
//!    internal reflection); an index-matched interface is crossed without a draw. Refraction
//!    out of the top (bottom) of the stack is an escape: `Tally::escape(Side::Top/Bottom)`.
//! 3. **Absorption by weight** (implicit capture, MCML §3.6, eq. 3.24): Δw = w σa/σt is
//!    deposited (`Tally::absorb`), w ← w − Δw.
//! 4. **Scattering** (MCML §3.7, eqs. 3.28–3.30): cos θ from the layer's phase function
//!    ([`Phase::sample`], HG inversion), azimuth φ uniform, drawn without trigonometry from a
//!    point (x, y) uniform in the unit disc (rejection from [−1, 1]², x then y):
//!    cos φ = (x² − y²)/ρ², sin φ = 2xy/ρ² (the doubled angle of a uniform point is uniform;
//!    von Neumann 1951), then MCML's direction update (`spin_disc`, = [`crate::optics::spin`]).
//!    (Measured alternatives, slower on x86-64 and not kept: one uniform with a branch-free
//!    degree-13/12 polynomial sincos of 2πu, 3.45·10⁷ vs 3.6·10⁷ events per CPU-second; and
//!    fdlibm's division-based `log` inlined for the step, 3.4·10⁷ vs 3.67·10⁷ — both add work
//!    to the divider/FP ports that the direction update's division and square root, the
//!    critical path of an event, already use.)
//! 5. **Russian roulette** (MCML §3.8, eq. 3.33): when w < 10⁻⁴ the packet survives with
//!    probability 1/m (m = 10) with weight m·w, else it dies. The estimator is unbiased; so
//!    that energy balance is *exact* in every run (not only in expectation), the roulette's
//!    zero-mean control term is deposited as absorption at the packet's position: a killed
//!    packet deposits +w, a survivor deposits −(m−1)w (E = (1−1/m)w − (1/m)(m−1)w = 0).
//!    Hence specular + diffuse reflectance + transmittance + absorbed = 1 to rounding.
//!
//! Random-number order within a photon's stream ([`PhotonRng`]): source draws (diffuse
//! source only), then per step: step ξ (only when the previous optical depth is used up),
//! a Fresnel ξ at each interface hit with 0 < R < 1, and at each interaction: phase ξ, the
//! disc point(s) (x, y, repeated until accepted), then a roulette ξ when w < 10⁻⁴.
//!
//! Packet bookkeeping: `order` counts scattering events, `reflections` interface reflections
//! (Fresnel or total), `path` the optical path Σ n ℓ (mm). The last layer may be semi-infinite.

use super::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use super::packet::{Packet, Side};
use super::source::{Launcher, Source};
use super::tally::Tally;
use crate::medium::Stack;
use crate::optics::{fr_dielectric_cos_t, Phase};
use crate::rng::PhotonRng;

/// Safety net for a packet bouncing between interfaces of clear (σt = 0) layers without ever
/// interacting: after this many consecutive interface hits its weight is deposited where it is
/// (physically impossible for plane-parallel layers, where total internal reflection cannot
/// trap a packet that entered from outside; guards against rounding pathologies only).
#[cfg_attr(not(test), allow(dead_code))] // the scalar kernel is the tests' reference (see mc::lanes)
const MAX_CLEAR_HITS: u32 = 1_000_000;

/// One layer as the kernel sees it (plain data, precomputed once per run).
#[derive(Clone, Copy, Debug)]
pub(crate) struct KLayer {
    pub(crate) z0: f64,
    pub(crate) z1: f64,
    pub(crate) n: f64,
    pub(crate) sigma_t: f64,
    pub(crate) inv_sigma_t: f64,
    /// σa/σt, the fraction of weight deposited per interaction.
    pub(crate) absorb_frac: f64,
    /// HG sampling constants (see [`hg_cos`]): 1 + g², 1/(2g), 1 − g², 1 − g, 2g; `iso` when
    /// |g| < 10⁻⁶ (isotropic formula, as [`crate::optics::sample_hg`]).
    pub(crate) hg: [f64; 5],
    pub(crate) iso: bool,
    pub(crate) phase: Phase,
    /// Index above / below the layer (the neighbour's or the ambient's).
    pub(crate) n_up: f64,
    pub(crate) n_down: f64,
    /// n / n_up and n / n_down (Snell's η).
    pub(crate) eta_up: f64,
    pub(crate) eta_down: f64,
    /// cos of the critical angle towards up / down (0 when n ≤ neighbour: no TIR).
    pub(crate) cos_crit_up: f64,
    pub(crate) cos_crit_down: f64,
}

/// The stack and source prepared for tracing.
#[derive(Clone, Debug)]
pub(crate) struct Kernel {
    pub(crate) layers: Vec<KLayer>,
    pub(crate) launcher: Launcher,
    /// Some layer has σt = 0 (a clear layer): selects the kernel variant that handles it.
    #[allow(dead_code)]
    pub(crate) any_clear: bool,
    /// Some layer has a phase-function mixture: selects the general phase sampler.
    pub(crate) any_mixture: bool,
}

fn cos_crit(n_i: f64, n_t: f64) -> f64 {
    if n_i > n_t {
        let s = n_t / n_i;
        (1.0 - s * s).sqrt()
    } else {
        0.0
    }
}

impl Kernel {
    pub(crate) fn new(stack: &Stack, source: Source) -> Self {
        let nl = stack.layers.len();
        let bounds = stack.boundaries();
        let mut layers = Vec::with_capacity(nl);
        for (i, l) in stack.layers.iter().enumerate() {
            let n_up = if i == 0 { stack.n_above } else { stack.layers[i - 1].n };
            let n_down = if i + 1 == nl { stack.n_below } else { stack.layers[i + 1].n };
            let st = l.sigma_t();
            layers.push(KLayer {
                z0: bounds[i],
                z1: bounds[i + 1],
                n: l.n,
                sigma_t: st,
                inv_sigma_t: if st > 0.0 { 1.0 / st } else { f64::INFINITY },
                absorb_frac: if st > 0.0 { l.mua / st } else { 0.0 },
                hg: {
                    let g = l.phase.lobes()[0].g;
                    [1.0 + g * g, 0.5 / g, (1.0 - g) * (1.0 + g), 1.0 - g, 2.0 * g]
                },
                iso: l.phase.lobes()[0].g.abs() < 1e-6,
                phase: l.phase,
                n_up,
                n_down,
                eta_up: l.n / n_up,
                eta_down: l.n / n_down,
                cos_crit_up: cos_crit(l.n, n_up),
                cos_crit_down: cos_crit(l.n, n_down),
            });
        }
        let any_clear = stack.layers.iter().any(|l| l.sigma_t() == 0.0);
        let any_mixture = stack.layers.iter().any(|l| l.phase.lobes().len() > 1);
        Kernel { layers, launcher: Launcher::new(source, stack.n_above, stack.layers[0].n), any_clear, any_mixture }
    }

    /// Trace photon `photon` of the run with `seed` into `tally` (as lane 0); returns its
    /// number of scattering events. `CLEAR`: handle σt = 0 layers; `MIXTURE`: general phase
    /// sampler. The reference the lane kernel (`mc::lanes`) is tested against.
    #[inline]
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn trace<T: Tally, const CLEAR: bool, const MIXTURE: bool>(
        &self,
        seed: u64,
        photon: u64,
        tally: &mut T,
    ) -> u64 {
        let mut rng = PhotonRng::new(seed, photon);
        tally.begin_photon(0, photon);
        let (dir, rsp) = self.launcher.launch(&mut rng);
        tally.specular(0, rsp);
        let mut p = Packet { pos: [0.0; 3], dir, w: 1.0 - rsp, layer: 0, order: 0, reflections: 0, path: 0.0 };
        let last = self.layers.len() - 1;
        let mut s_left = 0.0f64; // unused optical depth
        let mut clear_hits = 0u32;
        loop {
            let lay = &self.layers[p.layer];
            let dz = p.dir[2];
            // Distance to the interface ahead (only computed when needed: it costs a division).
            let dist_b = |z: f64| {
                if dz > 0.0 {
                    (lay.z1 - z) / dz
                } else if dz < 0.0 {
                    (lay.z0 - z) / dz
                } else {
                    f64::INFINITY
                }
            };
            let hit;
            if CLEAR && lay.sigma_t == 0.0 {
                let db = dist_b(p.pos[2]);
                if !db.is_finite() {
                    // Down a semi-infinite clear layer (transmitted, no interface to refract
                    // at) or exactly parallel to the interfaces (deposit: cannot leave).
                    if dz > 0.0 {
                        tally.escape(0, &p, Side::Bottom, p.dir, p.w);
                    } else {
                        tally.absorb(0, &p, p.w);
                    }
                    break;
                }
                clear_hits += 1;
                if clear_hits > MAX_CLEAR_HITS {
                    tally.absorb(0, &p, p.w);
                    break;
                }
                hop(&mut p, db, lay.n);
                hit = true;
            } else {
                if s_left <= 0.0 {
                    s_left = -rng.uniform().ln();
                }
                let s = s_left * lay.inv_sigma_t;
                let z_new = p.pos[2] + s * dz;
                if z_new > lay.z1 || z_new < lay.z0 {
                    let db = dist_b(p.pos[2]);
                    hop(&mut p, db, lay.n);
                    s_left -= db * lay.sigma_t;
                    hit = true;
                } else {
                    hop(&mut p, s, lay.n);
                    s_left = 0.0;
                    hit = false;
                }
                if CLEAR {
                    clear_hits = 0;
                }
            }

            if hit {
                // At an interface: place the packet exactly on it, then Fresnel.
                let up = dz < 0.0;
                let (n_t, eta, cc) = if up {
                    (lay.n_up, lay.eta_up, lay.cos_crit_up)
                } else {
                    (lay.n_down, lay.eta_down, lay.cos_crit_down)
                };
                p.pos[2] = if up { lay.z0 } else { lay.z1 };
                let cos_i = dz.abs();
                let (r, cos_t) = if cos_i <= cc {
                    (1.0, 0.0)
                } else if lay.n == n_t {
                    (0.0, cos_i)
                } else {
                    fr_dielectric_cos_t(cos_i, lay.n, n_t)
                };
                let transmit = if r <= 0.0 {
                    true
                } else if r >= 1.0 {
                    false
                } else {
                    rng.uniform() > r
                };
                if transmit {
                    let nd = [p.dir[0] * eta, p.dir[1] * eta, if up { -cos_t } else { cos_t }];
                    if up && p.layer == 0 {
                        tally.escape(0, &p, Side::Top, nd, p.w);
                        break;
                    }
                    if !up && p.layer == last {
                        tally.escape(0, &p, Side::Bottom, nd, p.w);
                        break;
                    }
                    p.dir = nd;
                    if up {
                        p.layer -= 1;
                    } else {
                        p.layer += 1;
                    }
                } else {
                    p.dir[2] = -dz;
                    p.reflections += 1;
                }
                continue;
            }

            // Interaction: absorption by weight, then scattering.
            let dw = p.w * lay.absorb_frac;
            if dw != 0.0 {
                p.w -= dw;
                tally.absorb(0, &p, dw);
                if p.w <= 0.0 {
                    break;
                }
            }
            let cos_theta = if MIXTURE { lay.phase.sample(rng.uniform()) } else { hg_cos(lay, rng.uniform()) };
            let (x, y) = loop {
                let x = rng.symmetric(); // 2ξ − 1
                let y = rng.symmetric();
                // x² + y² > 0 always: x, y are odd multiples of 2⁻³², never both 0.
                if x * x + y * y < 1.0 {
                    break (x, y);
                }
            };
            p.dir = spin_disc(p.dir, cos_theta, x, y);
            p.order += 1;

            if p.w < ROULETTE_THRESHOLD {
                if rng.uniform() * ROULETTE_M <= 1.0 {
                    tally.absorb(0, &p, -(ROULETTE_M - 1.0) * p.w);
                    p.w *= ROULETTE_M;
                } else {
                    tally.absorb(0, &p, p.w);
                    break;
                }
            }
        }
        tally.end_photon(0);
        p.order as u64
    }
}

/// cos θ sampled from the layer's single HG lobe by inverting its CDF (MCML eq. 3.28; the same
/// formula as [`crate::optics::sample_hg`], with the constants precomputed so that one
/// division remains): s = (1 − g²)/(1 − g + 2gξ), cos θ = (1 + g² − s²)/(2g).
#[inline(always)]
#[cfg_attr(not(test), allow(dead_code))] // the scalar kernel is the tests' reference (see mc::lanes)
fn hg_cos(lay: &KLayer, u: f64) -> f64 {
    if lay.iso {
        return 2.0 * u - 1.0;
    }
    let [a, b, c, d, e] = lay.hg;
    let s = c / (d + e * u);
    ((a - s * s) * b).clamp(-1.0, 1.0)
}

/// MCML's direction update (Wang et al. 1995, eq. 3.30; [`crate::optics::spin`]) with the
/// azimuth given by a point (x, y) of the unit disc, cos φ = (x² − y²)/ρ², sin φ = 2xy/ρ²
/// (ρ² = x² + y²), fused so that one division and one square root remain:
/// q = √((1 − cos²θ)/((1 − uz²) ρ⁴)) = sin θ /(√(1 − uz²) ρ²), then
/// u′x = q (ux uz X − uy Y) + ux cos θ, u′y = q (uy uz X + ux Y) + uy cos θ,
/// u′z = −q X (1 − uz²) + uz cos θ, with X = x² − y², Y = 2xy (for |uz| ≈ 1:
/// u′ = (sin θ cos φ, sin θ sin φ, cos θ sign uz)).
#[inline(always)]
#[cfg_attr(not(test), allow(dead_code))] // the scalar kernel is the tests' reference (see mc::lanes)
fn spin_disc(d: [f64; 3], cos_theta: f64, x: f64, y: f64) -> [f64; 3] {
    let [ux, uy, uz] = d;
    let rho2 = x * x + y * y;
    let (cx, cy) = (x * x - y * y, 2.0 * x * y);
    let sin2 = (1.0 - cos_theta * cos_theta).max(0.0);
    if uz.abs() > 1.0 - 1e-12 {
        let q = (sin2 / (rho2 * rho2)).sqrt();
        [q * cx, q * cy, if uz > 0.0 { cos_theta } else { -cos_theta }]
    } else {
        let t2 = 1.0 - uz * uz;
        let q = (sin2 / (t2 * rho2 * rho2)).sqrt();
        [
            q * (ux * uz * cx - uy * cy) + ux * cos_theta,
            q * (uy * uz * cx + ux * cy) + uy * cos_theta,
            -q * cx * t2 + uz * cos_theta,
        ]
    }
}

/// Move the packet a geometric distance `s` (mm) along its direction in a layer of index `n`.
#[inline(always)]
#[cfg_attr(not(test), allow(dead_code))] // the scalar kernel is the tests' reference (see mc::lanes)
fn hop(p: &mut Packet, s: f64, n: f64) {
    p.pos[0] += s * p.dir[0];
    p.pos[1] += s * p.dir[1];
    p.pos[2] += s * p.dir[2];
    p.path += n * s;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fused update equals optics::spin with cos φ, sin φ from the disc point, and the HG
    /// constants reproduce optics::sample_hg.
    #[test]
    fn spin_disc_matches_spin_and_hg_matches() {
        let mut rng = PhotonRng::new(9, 9);
        for i in 0..10_000 {
            let uz: f64 = if i % 100 == 0 { 1.0 } else { 2.0 * rng.uniform() - 1.0 };
            let ph = std::f64::consts::TAU * rng.uniform();
            let st = (1.0 - uz * uz).sqrt();
            let d = [st * ph.cos(), st * ph.sin(), uz];
            let ct = 2.0 * rng.uniform() - 1.0;
            let (x, y) = (2.0 * rng.uniform() - 1.0, 2.0 * rng.uniform() - 1.0);
            let r2 = x * x + y * y;
            if r2 >= 1.0 {
                continue;
            }
            let a = spin_disc(d, ct, x, y);
            let b = crate::optics::spin(d, ct, (x * x - y * y) / r2, 2.0 * x * y / r2);
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-12, "{a:?} {b:?}");
            }
        }
        let s = Stack::new(vec![crate::medium::Layer::new(1.0, 0.1, 1.0, 0.8, 1.0).unwrap()], 1.0, 1.0).unwrap();
        let k = Kernel::new(&s, Source::default());
        for u in [1e-9, 0.1, 0.5, 0.9, 1.0 - 1e-9] {
            assert!((hg_cos(&k.layers[0], u) - crate::optics::sample_hg(u, 0.8)).abs() < 1e-12);
        }
    }
}
