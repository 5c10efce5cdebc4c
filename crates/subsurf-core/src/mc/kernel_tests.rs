//! Tests of the kernel's rules (any other kernel — SIMD, GPU — must pass the same): the fused
//! direction update and HG constants, the clear-layer bounce law, roulette bounds, stopping.

use super::*;
use crate::mc::lanes::{Isa, LANES};
use crate::mc::packet::Side;
use crate::mc::source::MAX_PENCIL_THETA;
use crate::mc::tally::{Channel, ChannelState};
use crate::medium::Layer;
use crate::stats::SplitMix64;

/// The fused update equals optics::spin with cos φ, sin φ from the disc point, and the HG
/// constants reproduce optics::sample_hg.
#[test]
fn spin_disc_matches_spin_and_hg_matches() {
    let mut rng = SplitMix64::new(9);
    for i in 0..10_000 {
        let uz: f64 = if i % 100 == 0 { 1.0 } else { 2.0 * rng.next_f64() - 1.0 };
        let ph = std::f64::consts::TAU * rng.next_f64();
        let st = (1.0 - uz * uz).sqrt();
        let d = [st * ph.cos(), st * ph.sin(), uz];
        let ct = 2.0 * rng.next_f64() - 1.0;
        let (x, y) = (2.0 * rng.next_f64() - 1.0, 2.0 * rng.next_f64() - 1.0);
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
    for g in [0.8, -0.5, 1e-7] {
        let s = Stack::new(vec![Layer::new(1.0, 0.1, 1.0, g, 1.0).unwrap()], 1.0, 1.0).unwrap();
        let k = Kernel::new(&s, Source::default());
        for u in [1e-9, 0.1, 0.5, 0.9, 1.0 - 1e-9] {
            assert!((k.layers[0].hg.cos_theta(u) - crate::optics::sample_hg(u, g)).abs() < 1e-12, "g {g}");
        }
    }
}

/// [`clear_bounces`] follows the law of the step-by-step process: exit through the first face
/// with probability T₁/(1 − R₁R₂), round trips geometric with mean ρ/(1 − ρ) (ρ = R₁R₂);
/// checked at 4σ against those closed forms with R₁ ≈ 0.9, R₂ ≈ 0.7.
#[test]
fn clear_bounce_law() {
    // n = 1.5 between 1.0 (top) and 1.2 (bottom), direction just inside the critical angles
    let s = Stack::new(vec![Layer::new(1.5, 0.0, 0.0, 0.0, 2.0).unwrap()], 1.0, 1.2).unwrap();
    let k = Kernel::new(&s, Source::default());
    let lay = &k.layers[0];
    let mu = 0.76; // cos of the critical angle towards n = 1: 0.745
    let (r_bottom, r_top) = (lay.fresnel(false, mu).0, lay.fresnel(true, mu).0);
    let rho = r_bottom * r_top;
    let (n, mut first, mut trips, mut trips2) = (200_000, 0usize, 0.0, 0.0);
    for i in 0..n {
        let mut rng = PhotonRng::new(3, i);
        let mut p = Packet {
            pos: [0.0, 0.0, 0.5],
            dir: [(1.0 - mu * mu).sqrt(), 0.0, mu],
            w: 1.0,
            layer: 0,
            order: 0,
            reflections: 0,
            path: 0.0,
        };
        let up = clear_bounces(&mut p, lay, &mut rng).unwrap();
        assert_eq!(p.pos[2], if up { 0.0 } else { 2.0 });
        let k = (p.reflections / 2) as f64;
        if !up {
            first += 1; // moving down: the first face is the bottom
            assert_eq!(p.reflections % 2, 0);
        }
        trips += k;
        trips2 += k * k;
        // path and lateral travel match the number of traversals
        let dist = (1.5 + 2.0 * p.reflections as f64) / mu;
        assert!((p.path / 1.5 - dist).abs() < 1e-9 * dist, "{} {dist}", p.path / 1.5);
    }
    let nf = n as f64;
    let p_first = (1.0 - r_bottom) / (1.0 - rho);
    let sd = (p_first * (1.0 - p_first) / nf).sqrt();
    assert!((first as f64 / nf - p_first).abs() < 4.0 * sd, "{} vs {p_first}", first as f64 / nf);
    let mean = rho / (1.0 - rho);
    let var = rho / (1.0 - rho).powi(2);
    assert!((trips / nf - mean).abs() < 4.0 * (var / nf).sqrt(), "{} vs {mean}", trips / nf);
    assert!(trips2 / nf > mean * mean);
}

/// A clear slab under the steepest allowed pencil beam: the light that enters (w₀ = 1 − R)
/// leaves through the bottom with probability 1/(1 + R) (incoherent slab, R the same at both
/// faces by reciprocity), although each photon bounces ~10⁵ times. Checked at 4σ; the stepwise
/// tracing alone would take minutes here, and a cap on bounces would give T = 0.
#[test]
fn grazing_clear_slab_transmits() {
    let s = Stack::new(vec![Layer::new(1.5, 0.0, 0.0, 0.0, 1e-9).unwrap()], 1.0, 1.0).unwrap();
    let k = Kernel::new(&s, Source::Pencil { theta: MAX_PENCIL_THETA, phi: 0.0 });
    let mut t = crate::mc::tally::totals::Totals::new(1);
    let stop = AtomicBool::new(false);
    let n = 20_000u64;
    for i in 0..n {
        k.trace::<_, true, false>(1, i, &mut t, &stop).unwrap();
    }
    use crate::mc::tally::totals::Total;
    let r = t.get(Total::Specular).0;
    let w0 = 1.0 - r;
    assert!(w0 > 1e-6 && w0 < 1e-4, "{w0}");
    let (tt, rd) = (t.get(Total::Transmittance), t.get(Total::Diffuse));
    let want = w0 / (1.0 + r);
    assert!((tt.0 - want).abs() < 4.0 * tt.1, "T = {} ± {}, want {want}", tt.0, tt.1);
    assert!((rd.0 - w0 * r / (1.0 + r)).abs() < 4.0 * rd.1);
    assert_eq!(t.get(Total::Absorbed).0, 0.0);
    assert!((t.energy_balance() - 1.0).abs() < 1e-12);
}

/// Per-photon bookkeeping of a tally (one photon per lane at a time): what escaped, what was
/// absorbed and the roulette term.
#[derive(Default)]
struct Ledger {
    w0: [f64; LANES],
    escaped: [f64; LANES],
    absorbed: [f64; LANES],
    roulette: [f64; LANES],
    worst_excess: f64,
    worst_balance: f64,
    negative_deposit: bool,
}

impl Tally for Ledger {
    fn begin_photon(&mut self, lane: usize, _photon: u64) {
        (self.w0[lane], self.escaped[lane], self.absorbed[lane], self.roulette[lane]) = (1.0, 0.0, 0.0, 0.0);
    }
    fn specular(&mut self, lane: usize, w: f64) {
        self.w0[lane] = 1.0 - w;
    }
    fn absorb(&mut self, lane: usize, _p: &Packet, dw: f64) {
        self.negative_deposit |= dw < 0.0;
        self.absorbed[lane] += dw;
    }
    fn roulette(&mut self, lane: usize, _p: &Packet, dw: f64) {
        self.roulette[lane] += dw;
    }
    fn escape(&mut self, lane: usize, _p: &Packet, _side: Side, _dir_out: [f64; 3], w: f64) {
        self.escaped[lane] += w;
    }
    fn end_photon(&mut self, lane: usize) {
        self.worst_excess = self.worst_excess.max(self.escaped[lane] - self.w0[lane]);
        let balance = self.escaped[lane] + self.absorbed[lane] + self.roulette[lane] - self.w0[lane];
        self.worst_balance = self.worst_balance.max(balance.abs());
    }
    fn channels(&self, _out: &mut Vec<Channel>) {}
    fn drain_into(&mut self, _state: &mut [ChannelState]) -> Option<usize> {
        Some(0)
    }
    fn load_from(&mut self, _state: &[ChannelState], _photons: u64) -> usize {
        0
    }
}

/// Every photon conserves its weight exactly (escaped + absorbed + roulette = w₀ to rounding),
/// physical deposits are never negative, and no photon leaves with more than it brought — also
/// under grazing incidence, where w₀ is far below MCML's absolute roulette threshold.
#[test]
fn per_photon_balance_and_roulette_bounds() {
    let stacks = [
        Stack::new(
            vec![Layer::new(1.4, 0.5, 5.0, 0.8, 0.5).unwrap(), Layer::new(1.0, 0.0, 3.0, 0.0, 0.5).unwrap()],
            1.0,
            1.0,
        )
        .unwrap(),
        Stack::new(vec![Layer::new(1.5, 2.0, 1.0, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap(),
    ];
    let stop = AtomicBool::new(false);
    for s in &stacks {
        for theta in [0.0, 1.2, MAX_PENCIL_THETA] {
            let k = Kernel::new(s, Source::Pencil { theta, phi: 0.0 });
            let mut l = Ledger::default();
            for i in 0..3000 {
                k.trace::<_, true, false>(7, i, &mut l, &stop).unwrap();
            }
            // and the lane kernel that runs
            crate::mc::lanes::trace_range(Isa::detect(), &k, 7, 0..3000, &mut l, &stop).unwrap();
            assert!(l.worst_excess <= 1e-15, "θ = {theta}: a photon left with {} more than w0", l.worst_excess);
            assert!(l.worst_balance <= 1e-15, "θ = {theta}: imbalance {}", l.worst_balance);
            assert!(!l.negative_deposit);
        }
    }
}

/// A raised stop flag ends a long history within [`STOP_POLL_STEPS`] steps.
#[test]
fn stop_interrupts_a_history() {
    let s = Stack::new(vec![Layer::new(1.0, 1e-6, 100.0, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let k = Kernel::new(&s, Source::default());
    let stop = AtomicBool::new(true);
    let mut t = ();
    // photons whose history is longer than one poll interval are interrupted
    let interrupted = (0..200).filter(|&i| k.trace::<_, false, false>(1, i, &mut t, &stop).is_none()).count();
    assert!(interrupted > 0);
    // the lane kernel polls every STOP_POLL_STEPS lane steps too
    assert!(crate::mc::lanes::trace_range(Isa::detect(), &k, 1, 0..200, &mut t, &stop).is_none());
}
