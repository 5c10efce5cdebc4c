//! The exit flow of `adaptive` (`bssrdf::flow`) at the edge of a lit half-plane, against the
//! engine.

use super::adaptive::tests::{material, ETA, SA, SS};
use super::adaptive::Kernel;
use super::material::Material;
use super::scene::{Object, Scene};
use super::shapes::cuboid;
use super::tree::{Cut, FlowAt, Sample, Tree, COARSE_FACTOR};
use crate::bssrdf::coupling::{fit, COUPLING_BINS};
use crate::bssrdf::exit::{mu_bin, ExitBins};
use crate::bssrdf::harmonic::Lobe;
use crate::mc::tally::accum::Accum;
use crate::mc::tally::{Channel, ChannelState};
use crate::mc::{run, Packet, RunConfig, Side, Source, Tally};
use crate::medium::{Layer, Stack};
use std::sync::atomic::{AtomicBool, AtomicU64};

/// Offsets a (mm) of the shading points from the edge of the lit half-plane x < 0.
const OFFSETS: [f64; 5] = [-0.5, -0.2, 0.2, 0.5, 1.5];

/// Weight leaving through the top at x > a for each a of [`OFFSETS`], per exit-cosine bin, then
/// the same × cos Δφ about +x (the source at the origin: by translation, the exits at (a, 0) of
/// light entering uniformly over x < 0).
struct HalfPlane {
    all: Accum,
    photons: u64,
}

const LEN: usize = 2 * COUPLING_BINS * OFFSETS.len();

impl Tally for HalfPlane {
    const POSITIONS: bool = false;
    const TRACKS: bool = true;
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    fn specular(&mut self, _lane: usize, _w: f64) {}
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    fn escape(&mut self, _lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        if side != Side::Top {
            return;
        }
        let j = mu_bin(dir_out, COUPLING_BINS);
        let t = dir_out[0].hypot(dir_out[1]);
        for (i, &a) in OFFSETS.iter().enumerate() {
            if p.pos[0] > a {
                let b = 2 * COUPLING_BINS * i + j;
                self.all.add(b, w);
                if t > 0.0 {
                    self.all.add(b + COUPLING_BINS, w * dir_out[0] / t);
                }
            }
        }
    }
    fn end_photon(&mut self, _lane: usize) {
        self.photons += 1;
    }
    fn channels(&self, out: &mut Vec<Channel>) {
        out.push(Channel { name: "half_plane".into(), len: LEN, extremes: false });
    }
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize> {
        let ok = self.all.drain_into(&mut state[0]);
        self.photons = 0;
        ok.then_some(1)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        self.all.load_from(&state[0]);
        self.photons = photons;
        1
    }
}

/// A thick slab (n 1.4, σa 0.05, σs 2 mm⁻¹, g 0: ℓ 0.49 mm, diffusion length 1.8 mm) lit over the
/// half-plane x < 0 (E_t = 1 there, 0 beyond; the tree's samples on a grid of spacing Δ, no light
/// sources: the tree alone). At x_o 0.5 and 0.2 mm inside the lit half and 0.2, 0.5 and 1.5 mm
/// beyond its edge, the model's first harmonic of the near class' radiance about +x,
/// B = F·x̂ / near ([`Tree::exitance_flow`]; its radiance is near (1 + B sin θo cos Δφ)), against
/// the same harmonic of an independent engine run under the table's diffuse light (4·10⁵
/// photons, exits at x > a, fitted as the table's, [`fit`] at θi = 90°): within 0.04 (the
/// table's B is linear in ln r between its bins' centres) + 4σ (the engine run's), at Δ = 0.1 mm
/// (ρ₀ = 0.2 mm: the pairs' own directions) and at Δ = 0.4 mm (ρ₀ = 0.8 mm: the points within ρ₀
/// of the edge take their flow from the near field's irradiance gradient; without it 0.25 and
/// 0.28 at +0.2 and +0.5 mm against the engine's 0.376 and 0.343, measured). An exit term
/// symmetric about the normal has B = 0, outside that bound (asserted: the test fails without
/// the flow).
#[test]
fn half_plane_flow_matches_the_engine() {
    // the adaptive tests' material and its table, traced once for both files
    let stack = Stack::new(vec![Layer::new(ETA, SA, SS, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let Material::Translucent(m) = material() else { unreachable!() };
    let table = m.adaptive.clone().unwrap();
    assert!(!table.flow(0).is_zero());
    let slab = cuboid([-30.0, -30.0, -30.0], [30.0, 30.0, 0.0]).unwrap();
    let obj = Object { name: "slab".into(), mesh: slab, material: 0 };
    let s = Scene::new(vec![obj], vec![Material::Translucent(m)], vec![], [0.0; 3], None).unwrap();
    let half = 20.0;
    let tree = |delta: f64| {
        let n = (2.0 * half / delta) as usize;
        let samples: Vec<Sample> = (0..n * n)
            .map(|i| {
                let p = [-half + delta * ((i % n) as f64 + 0.5), -half + delta * ((i / n) as f64 + 0.5), 0.0];
                let e = if p[0] < 0.0 { [1.0; 3] } else { [0.0; 3] };
                Sample { p, area: delta * delta, e, n: [0.0, 0.0, 1.0], m: [[Lobe::default(); 3]; 2], d: [[0.0; 3]; 3] }
            })
            .collect();
        Tree::build(samples, delta)
    };
    let trees = [(0.1, tree(0.1)), (0.4, tree(0.4))];
    let cut = Cut { epsilon: 0.05, sigma: false, coarse: COARSE_FACTOR * 0.05 };
    let cfg = RunConfig { photons: 400_000, seed: 9191, threads: Some(2), source: Source::Diffuse, isa: None };
    let make = || HalfPlane { all: Accum::per_photon(LEN, true), photons: 0 };
    let o = run(&stack, &cfg, make, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
    let data: Vec<(f64, f64)> = (0..LEN).map(|i| o.tally.all.mean_stderr(i, o.tally.photons)).collect();
    for (i, &a) in OFFSETS.iter().enumerate() {
        let part = &data[2 * COUPLING_BINS * i..2 * COUPLING_BINS * (i + 1)];
        let bins = ExitBins { weight: part.iter().map(|x| x.0).collect(), stderr: part.iter().map(|x| x.1).collect() };
        let want = fit(ETA, std::f64::consts::FRAC_PI_2, &bins);
        let hit = s.accel.intersect([a, 0.03, 10.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
        let k = Kernel::at(&s, &table, &hit);
        let b = std::array::from_fn(|c| table.flow(c));
        let bound = 0.04 + 4.0 * want.stderr;
        for (delta, tree) in &trees {
            let ([near, _], _, f) = tree.exitance_flow(&k, hit.p, cut, &FlowAt { normal: hit.n, b });
            let got = f[0][0] / near[0];
            println!(
                "Δ {delta} mm, a {a:+.1} mm: model B {got:+.4} (y {:+.4}), engine {:+.4} ± {:.4} (χ² {:.1}), bound {bound:.4}",
                f[0][1] / near[0],
                want.a,
                want.stderr,
                want.chi2
            );
            assert!((got - want.a).abs() < bound, "Δ {delta}, a {a}: {got} vs {}", want.a);
        }
        assert!(want.a.abs() > bound, "an exit term symmetric about the normal (B = 0) passes too");
    }
}
