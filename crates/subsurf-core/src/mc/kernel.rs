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
//!    Downwards in a semi-infinite clear last layer the packet is transmitted.
//! 3. **Absorption by weight** (implicit capture, MCML §3.6, eq. 3.24): w′ = w σs/σt and the
//!    exact difference Δw = w − w′ (≈ w σa/σt) is deposited (`Tally::absorb`), w ← w′.
//! 4. **Scattering** (MCML §3.7, eqs. 3.28–3.30): cos θ from the layer's phase function
//!    ([`Phase::sample`], HG inversion with [`HgSampler`]), azimuth φ uniform, drawn without
//!    trigonometry from a point (x, y) uniform in the unit disc ([`PhotonRng::disc_point`]):
//!    cos φ = (x² − y²)/ρ², sin φ = 2xy/ρ² (the doubled angle of a uniform point is uniform;
//!    von Neumann 1951), then MCML's direction update ([`spin_disc`], = [`crate::optics::spin`],
//!    with the pole threshold [`SPIN_POLE_COS`]).
//!    (Alternatives not kept, slower on x86-64 — `docs/architecture.md`, "Engine speed
//!    measurements": a branch-free polynomial sincos of 2πu, and fdlibm's division-based `log`
//!    inlined for the step; both add work to the divider/FP ports that the direction update's
//!    division and square root, the critical path of an event, already use.)
//! 5. **Russian roulette** (MCML §3.8, eq. 3.33), relative to the entering weight w₀ = 1 − R_sp:
//!    when w < [`ROULETTE_THRESHOLD`]·w₀ the packet survives with probability 1/m (m =
//!    [`ROULETTE_M`]) with weight m·w, else it dies. (MCML's threshold 10⁻⁴ is absolute; with w₀
//!    in it a survivor never weighs more than 10⁻³ w₀ < w₀, also under grazing incidence where w₀
//!    is tiny.) The estimator is unbiased; so that energy balance is *exact* in every run (not
//!    only in expectation), the roulette's zero-mean control term goes to [`Tally::roulette`]:
//!    a killed packet books +w, a survivor −(m−1)w (E = (1−1/m)w − (1/m)(m−1)w = 0). The totals
//!    count it in `absorbed`, so specular + diffuse reflectance + transmittance + absorbed = 1 to
//!    rounding, and, since no photon leaves with more than w₀, `absorbed` is never negative; the
//!    per-layer absorption and the histograms hold only the physical deposits of step 3.
//!
//! Termination guarantees (so that no input hangs a run):
//! - **Clear layers** (σt = 0): after [`CLEAR_HITS_STEPWISE`] consecutive interface hits, the
//!   remaining bounces between the layer's two faces are sampled at once ([`clear_bounces`]):
//!   the number of round trips k before the packet leaves is geometric, P(k ≥ j) = (R₁R₂)ʲ,
//!   and it leaves through the first face with probability T₁/(T₁ + R₁T₂) — the exact law of
//!   the step-by-step process (memoryless), in O(1) however close R₁R₂ is to 1.
//! - A packet that meets [`MAX_HITS_WITHOUT_INTERACTION`] interfaces in a row without an
//!   interaction (only possible when rounding makes both faces of a stack of clear layers
//!   reflect totally; for every allowed source the probability is below e⁻⁵⁰) is *trapped*:
//!   its weight goes to [`Tally::roulette`] and the history ends.
//! - The caller's stop flag is polled every [`STOP_POLL_STEPS`] steps, so a long history can
//!   be interrupted (the chunk holding it is then discarded by `mc::run`).
//!
//! Random-number order within a photon's stream ([`PhotonRng`]): source draws (diffuse
//! source only), then per step: step ξ (only when the previous optical depth is used up),
//! a Fresnel ξ at each interface hit with 0 < R < 1 (or, in a clear layer after
//! [`CLEAR_HITS_STEPWISE`] hits, two uniforms: round trips, then exit face), and at each
//! interaction: phase ξ, the disc point(s) (x, y, repeated until accepted), then a roulette ξ
//! when w < [`ROULETTE_THRESHOLD`]·w₀.
//!
//! Packet bookkeeping: `order` counts scattering events, `reflections` interface reflections
//! (Fresnel or total), `path` the optical path Σ n ℓ (mm). The last layer may be semi-infinite.
//! Any other kernel (SIMD, GPU) must follow these rules and constants exactly and pass the
//! tests of this module and of `mc::validation_tests`.

use super::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use super::packet::{Packet, Side};
use super::source::{Launcher, Source};
use super::tally::Tally;
use crate::medium::Stack;
use crate::optics::{fr_dielectric_cos_t, Phase, G_ISOTROPIC, SPIN_POLE_COS};
use crate::rng::PhotonRng;
use std::sync::atomic::{AtomicBool, Ordering};

/// Interface hits in a row inside clear layers that are traced one by one before the rest of
/// the bounces in the current clear layer are sampled at once (`clear_bounces`).
pub const CLEAR_HITS_STEPWISE: u32 = 8;

/// Interface hits in a row without an interaction after which a packet counts as trapped by
/// rounding (see the module docs).
pub const MAX_HITS_WITHOUT_INTERACTION: u32 = 10_000_000;

/// The stop flag is polled every this many steps (interactions and interface hits).
pub const STOP_POLL_STEPS: u32 = 4096;

/// HG sampling constants of a layer's single lobe (see [`HgSampler::cos_theta`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct HgSampler {
    pub(crate) one_plus_g2: f64,
    pub(crate) inv_two_g: f64,
    pub(crate) one_minus_g2: f64,
    pub(crate) one_minus_g: f64,
    pub(crate) two_g: f64,
    /// |g| < [`G_ISOTROPIC`]: the isotropic formula.
    pub(crate) isotropic: bool,
}

impl HgSampler {
    fn new(g: f64) -> Self {
        HgSampler {
            one_plus_g2: 1.0 + g * g,
            inv_two_g: 0.5 / g,
            one_minus_g2: (1.0 - g) * (1.0 + g),
            one_minus_g: 1.0 - g,
            two_g: 2.0 * g,
            isotropic: g.abs() < G_ISOTROPIC,
        }
    }

    /// cos θ by inverting the HG CDF (MCML eq. 3.28; the same formula as
    /// [`crate::optics::sample_hg`], with the constants precomputed so that one division
    /// remains): s = (1 − g²)/(1 − g + 2gξ), cos θ = (1 + g² − s²)/(2g).
    #[inline(always)]
    #[cfg_attr(not(test), allow(dead_code))] // the scalar kernel: the lanes' reference in tests
    fn cos_theta(&self, u: f64) -> f64 {
        if self.isotropic {
            return 2.0 * u - 1.0;
        }
        let s = self.one_minus_g2 / (self.one_minus_g + self.two_g * u);
        ((self.one_plus_g2 - s * s) * self.inv_two_g).clamp(-1.0, 1.0)
    }
}

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
    /// σs/σt = 1 − σa/σt, the fraction kept.
    pub(crate) keep_frac: f64,
    pub(crate) hg: HgSampler,
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

impl KLayer {
    /// Fresnel reflectance and transmitted cosine at the face up (`up`) or down for the
    /// incidence cosine `cos_i`: total reflection past the critical angle, none when matched.
    #[inline(always)]
    fn fresnel(&self, up: bool, cos_i: f64) -> (f64, f64) {
        let (n_t, cc) = if up { (self.n_up, self.cos_crit_up) } else { (self.n_down, self.cos_crit_down) };
        if cos_i <= cc {
            (1.0, 0.0)
        } else if self.n == n_t {
            (0.0, cos_i)
        } else {
            fr_dielectric_cos_t(cos_i, self.n, n_t)
        }
    }
}

/// The stack and source prepared for tracing.
#[derive(Clone, Debug)]
pub(crate) struct Kernel {
    pub(crate) layers: Vec<KLayer>,
    pub(crate) launcher: Launcher,
    /// Some layer has σt = 0 (a clear layer): selects the kernel variant that handles it.
    #[allow(dead_code)] // (selects the scalar kernel's variant; the lane kernel needs no variant)
    pub(crate) any_clear: bool,
    /// Some layer has a phase-function mixture: selects the general phase sampler.
    #[cfg_attr(not(test), allow(dead_code))] // the scalar kernel: the lanes' reference in tests
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

/// What became of a packet at an interface.
pub(crate) enum Crossing {
    /// Still inside the stack (reflected, or refracted into the neighbouring layer).
    Inside,
    /// Left the stack (already scored).
    Escaped,
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
                keep_frac: if st > 0.0 { l.mus / st } else { 1.0 },
                hg: HgSampler::new(l.phase.lobes()[0].g),
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

    /// Trace photon `photon` of the run with `seed` into `tally`; returns its number of
    /// scattering events, or `None` when `stop` was raised during the history (the tally then
    /// holds part of it). `CLEAR`: handle σt = 0 layers; `MIXTURE`: general phase sampler.
    #[inline]
    #[cfg_attr(not(test), allow(dead_code))] // the scalar kernel: the lanes' reference in tests
    pub(crate) fn trace<T: Tally, const CLEAR: bool, const MIXTURE: bool>(
        &self,
        seed: u64,
        photon: u64,
        tally: &mut T,
        stop: &AtomicBool,
    ) -> Option<u64> {
        let mut rng = PhotonRng::new(seed, photon);
        tally.begin_photon(0, photon);
        let (dir, rsp) = self.launcher.launch(&mut rng);
        tally.specular(0, rsp);
        let w0 = 1.0 - rsp;
        let mut p = Packet { pos: [0.0; 3], dir, w: w0, layer: 0, order: 0, reflections: 0, path: 0.0 };
        if w0 > 0.0 {
            self.history::<T, CLEAR, MIXTURE>(&mut p, &mut rng, tally, stop)?;
        }
        tally.end_photon(0);
        Some(p.order as u64)
    }

    /// The loop of steps of one history (see the module docs); `None` when stopped.
    #[inline(always)]
    #[cfg_attr(not(test), allow(dead_code))] // the scalar kernel: the lanes' reference in tests
    fn history<T: Tally, const CLEAR: bool, const MIXTURE: bool>(
        &self,
        p: &mut Packet,
        rng: &mut PhotonRng,
        tally: &mut T,
        stop: &AtomicBool,
    ) -> Option<()> {
        let w_min = ROULETTE_THRESHOLD * p.w;
        let mut s_left = 0.0f64; // unused optical depth
        let mut hits = 0u32; // interface hits since the last interaction
        let mut steps = 0u32;
        loop {
            steps = steps.wrapping_add(1);
            if steps.is_multiple_of(STOP_POLL_STEPS) && stop.load(Ordering::Relaxed) {
                return None;
            }
            let lay = &self.layers[p.layer];
            let dz = p.dir[2];
            if CLEAR && lay.sigma_t == 0.0 {
                if dz > 0.0 && lay.z1.is_infinite() {
                    // down a semi-infinite clear layer: transmitted, no interface to refract at
                    tally.escape(0, p, Side::Bottom, p.dir, p.w);
                    return Some(());
                }
                hits += 1;
                if dz == 0.0 || hits > MAX_HITS_WITHOUT_INTERACTION {
                    tally.roulette(0, p, p.w); // trapped (see the module docs)
                    return Some(());
                }
                if hits > CLEAR_HITS_STEPWISE && lay.z1.is_finite() {
                    let Some(up) = clear_bounces(p, lay, rng) else {
                        tally.roulette(0, p, p.w); // both faces reflect totally: trapped
                        return Some(());
                    };
                    match self.transmit(0, p, lay, up, tally) {
                        Crossing::Escaped => return Some(()),
                        Crossing::Inside => continue,
                    }
                }
                let (up, _) = move_to_face(p, lay);
                match self.at_face(p, lay, up, rng, tally) {
                    Crossing::Escaped => return Some(()),
                    Crossing::Inside => continue,
                }
            }

            if s_left <= 0.0 {
                s_left = -rng.uniform().ln();
            }
            let s = s_left * lay.inv_sigma_t;
            let z_new = p.pos[2] + s * dz;
            if z_new > lay.z1 || z_new < lay.z0 {
                // reaches the interface ahead: move onto it, keep the unused optical depth
                let (up, db) = move_to_face(p, lay);
                s_left -= db * lay.sigma_t;
                hits += 1;
                if hits > MAX_HITS_WITHOUT_INTERACTION {
                    tally.roulette(0, p, p.w); // trapped (see the module docs)
                    return Some(());
                }
                match self.at_face(p, lay, up, rng, tally) {
                    Crossing::Escaped => return Some(()),
                    Crossing::Inside => continue,
                }
            }
            hop(p, s, lay.n);
            s_left = 0.0;
            hits = 0;

            // Interaction: absorption by weight, then scattering. The deposit is the exact
            // weight change (w − w′ is exact for w′ ≥ w/2), so that histories of 10⁷ events
            // still conserve energy to rounding of the tallies' sums.
            if lay.absorb_frac != 0.0 {
                let w_new = p.w * lay.keep_frac;
                let dw = p.w - w_new;
                p.w = w_new;
                tally.absorb(0, p, dw);
                if p.w <= 0.0 {
                    return Some(());
                }
            }
            let cos_theta = if MIXTURE { lay.phase.sample(rng.uniform()) } else { lay.hg.cos_theta(rng.uniform()) };
            let (x, y) = rng.disc_point();
            p.dir = spin_disc(p.dir, cos_theta, x, y);
            p.order += 1;

            if p.w < w_min {
                if rng.uniform() * ROULETTE_M <= 1.0 {
                    tally.roulette(0, p, -(ROULETTE_M - 1.0) * p.w);
                    p.w *= ROULETTE_M;
                } else {
                    tally.roulette(0, p, p.w);
                    return Some(());
                }
            }
        }
    }

    /// The packet sits on its layer's face up (`up`) or down: all-or-none Fresnel reflection
    /// ([`fresnel_transmits`]) back into the layer, else refraction out of it ([`Kernel::transmit`]).
    #[inline(always)]
    #[cfg_attr(not(test), allow(dead_code))] // the scalar kernel: the lanes' reference in tests
    fn at_face<T: Tally>(
        &self,
        p: &mut Packet,
        lay: &KLayer,
        up: bool,
        rng: &mut PhotonRng,
        tally: &mut T,
    ) -> Crossing {
        if fresnel_transmits(lay, up, p.dir[2].abs(), rng) {
            self.transmit(0, p, lay, up, tally)
        } else {
            p.dir[2] = -p.dir[2];
            p.reflections += 1;
            Crossing::Inside
        }
    }

    /// Refract the packet, which sits on its layer's face up (`up`) or down, out of the layer:
    /// an escape from the stack at its top or bottom, else into the neighbouring layer.
    #[inline(always)]
    pub(crate) fn transmit<T: Tally>(
        &self,
        lane: usize,
        p: &mut Packet,
        lay: &KLayer,
        up: bool,
        tally: &mut T,
    ) -> Crossing {
        let (_, cos_t) = lay.fresnel(up, p.dir[2].abs());
        let eta = if up { lay.eta_up } else { lay.eta_down };
        let nd = [p.dir[0] * eta, p.dir[1] * eta, if up { -cos_t } else { cos_t }];
        if up && p.layer == 0 {
            tally.escape(lane, p, Side::Top, nd, p.w);
            return Crossing::Escaped;
        }
        if !up && p.layer + 1 == self.layers.len() {
            tally.escape(lane, p, Side::Bottom, nd, p.w);
            return Crossing::Escaped;
        }
        p.dir = nd;
        if up {
            p.layer -= 1;
        } else {
            p.layer += 1;
        }
        Crossing::Inside
    }
}

/// Move the packet along its direction onto the face of `lay` it heads to (placed exactly on
/// it); returns whether that is the upper face and the distance travelled, mm.
#[inline(always)]
fn move_to_face(p: &mut Packet, lay: &KLayer) -> (bool, f64) {
    let dz = p.dir[2];
    let up = dz < 0.0;
    let db = if up { (lay.z0 - p.pos[2]) / dz } else { (lay.z1 - p.pos[2]) / dz };
    hop(p, db, lay.n);
    p.pos[2] = if up { lay.z0 } else { lay.z1 };
    (up, db)
}

/// All-or-none Fresnel test at the face up/down for the incidence cosine `cos_i`: transmit
/// with probability 1 − R, drawing one uniform only when 0 < R < 1.
#[inline(always)]
fn fresnel_transmits(lay: &KLayer, up: bool, cos_i: f64, rng: &mut PhotonRng) -> bool {
    let (r, _) = lay.fresnel(up, cos_i);
    if r <= 0.0 {
        true
    } else if r >= 1.0 {
        false
    } else {
        rng.uniform() > r
    }
}

/// The rest of a packet's bounces between the two faces of a finite clear layer, sampled at
/// once (exact; see the module docs). The packet is inside or on a face, moving along `p.dir`;
/// with R₁, R₂ the reflectances of the face it moves towards and of the other one, the number
/// of complete round trips is k = ⌊ln ξ₁ / ln(R₁R₂)⌋ and it leaves through the first face if
/// ξ₂ (T₁ + R₁T₂) < T₁, else through the other after one more reflection. The packet is moved
/// onto the exit face (lateral position, optical path and reflection count updated), heading
/// out; returns whether that is the upper face, or `None` if R₁R₂ = 1 (it can never leave).
pub(crate) fn clear_bounces(p: &mut Packet, lay: &KLayer, rng: &mut PhotonRng) -> Option<bool> {
    let mu = p.dir[2].abs();
    let down = p.dir[2] > 0.0;
    let (r1, _) = lay.fresnel(!down, mu);
    let (r2, _) = lay.fresnel(down, mu);
    let (t1, t2) = (1.0 - r1, 1.0 - r2);
    let leave = t1 + r1 * t2; // probability to leave within one round trip, 1 − R₁R₂
    let ln_stay = (-leave).ln_1p();
    if !(ln_stay < 0.0) {
        return None;
    }
    let k = (rng.uniform().ln() / ln_stay).floor();
    let first = rng.uniform() * leave < t1;
    let to_first = if down { lay.z1 - p.pos[2] } else { p.pos[2] - lay.z0 } / mu;
    let traverse = (lay.z1 - lay.z0) / mu;
    let reflections = if first { 2.0 * k } else { 2.0 * k + 1.0 };
    let dist = to_first + reflections * traverse;
    p.pos[0] += dist * p.dir[0];
    p.pos[1] += dist * p.dir[1];
    p.path += lay.n * dist;
    p.reflections = p.reflections.saturating_add(reflections.min(u32::MAX as f64) as u32);
    let exit_down = down == first;
    p.dir[2] = if exit_down { mu } else { -mu };
    p.pos[2] = if exit_down { lay.z1 } else { lay.z0 };
    Some(!exit_down)
}

/// MCML's direction update (Wang et al. 1995, eq. 3.30; [`crate::optics::spin`]) with the
/// azimuth given by a point (x, y) of the unit disc, cos φ = (x² − y²)/ρ², sin φ = 2xy/ρ²
/// (ρ² = x² + y²), fused so that one division and one square root remain:
/// q = √((1 − cos²θ)/((1 − uz²) ρ⁴)) = sin θ /(√(1 − uz²) ρ²), then
/// u′x = q (ux uz X − uy Y) + ux cos θ, u′y = q (uy uz X + ux Y) + uy cos θ,
/// u′z = −q X (1 − uz²) + uz cos θ, with X = x² − y², Y = 2xy (for |uz| > [`SPIN_POLE_COS`]:
/// u′ = (sin θ cos φ, sin θ sin φ, cos θ sign uz)).
#[inline(always)]
pub(crate) fn spin_disc(d: [f64; 3], cos_theta: f64, x: f64, y: f64) -> [f64; 3] {
    let [ux, uy, uz] = d;
    let rho2 = x * x + y * y;
    let (cx, cy) = (x * x - y * y, 2.0 * x * y);
    let sin2 = (1.0 - cos_theta * cos_theta).max(0.0);
    if uz.abs() > SPIN_POLE_COS {
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
fn hop(p: &mut Packet, s: f64, n: f64) {
    p.pos[0] += s * p.dir[0];
    p.pos[1] += s * p.dir[1];
    p.pos[2] += s * p.dir[2];
    p.path += n * s;
}

#[cfg(test)]
#[path = "kernel_tests.rs"]
mod tests;
