//! Synthetic-event tests of [`TallySet`]: escape/absorb calls fed by hand, normalisation
//! identities checked exactly, bin placement, standard errors against brute force, merging.

use super::*;
use crate::mc::config::BATCH_PHOTONS;
use crate::medium::Layer;
use crate::stats::SplitMix64;

fn stack() -> Stack {
    Stack::new(
        vec![
            Layer::new(1.4, 1.0, 10.0, 0.9, 0.0625).unwrap(),
            Layer::new(1.5, 0.0, 0.0, 0.0, 0.03125).unwrap(), // glass: fluence undefined
            Layer::new(1.4, 2.0, 5.0, 0.0, f64::INFINITY).unwrap(),
        ],
        1.0,
        1.0,
    )
    .unwrap()
}

fn config() -> TallyConfig {
    TallyConfig {
        nr: 10,
        dr: 0.02,
        nz: 12,
        dz: 0.015625,
        na: 6,
        nt: 8,
        dt: 0.5,
        brdf: Some((5, 4)),
        max_order: Some(3),
        spatial: true,
        angular: true,
        errors: true,
    }
}

fn packet(pos: [f64; 3], layer: usize, order: u32, reflections: u32, path: f64) -> Packet {
    Packet { pos, dir: [0.0, 0.0, 1.0], w: 1.0, layer, order, reflections, path }
}

/// What a synthetic run put in, for the identities.
#[derive(Default)]
struct Truth {
    top: f64,
    bottom: f64,
    absorbed: f64,
    fluence_plane: f64, // Σ dw/μa over deposits in layers with μa > 0 and z below the grid's glass bins
    top_order: [f64; 5],
    top_single: f64,
    bottom_single: f64,
}

/// Random photons: a few absorptions (some off-grid, some negative like roulette) and one
/// escape each through a random side in a random direction.
fn run(t: &mut TallySet, photons: std::ops::Range<u64>, seed: u64, truth: &mut Truth) {
    let s = stack();
    let mut st = SplitMix64::new(seed);
    let end = photons.end;
    for ph in photons {
        t.begin_photon(0, ph);
        for _ in 0..(st.next_f64() * 5.0) as usize {
            let z = st.next_f64() * 0.2; // beyond the 0.12 mm grid sometimes
            let layer = if z < 0.0625 {
                0
            } else if z < 0.09375 {
                1
            } else {
                2
            };
            let r = st.next_f64() * 0.25;
            let dw = st.next_f64() * 0.3 - 0.05;
            t.absorb(0, &packet([r * 0.6, r * 0.8, z], layer, 1, 0, 0.0), dw);
            truth.absorbed += dw;
            if s.layers[layer].mua > 0.0 {
                truth.fluence_plane += dw / s.layers[layer].mua;
            }
        }
        let w = st.next_f64();
        let mu = st.next_f64().max(1e-9);
        let phi = 2.0 * PI * st.next_f64();
        let sin = (1.0 - mu * mu).sqrt();
        let top = st.next_f64() < 0.6;
        let order = (st.next_f64() * 6.0) as u32;
        let refl = (st.next_f64() * 2.0) as u32;
        let r = st.next_f64() * 0.25;
        let path = st.next_f64() * 1.5; // up to 5 ps, beyond the 4 ps grid
        let dz = if top { -mu } else { mu };
        let p = packet([r, 0.0, if top { 0.0 } else { 1.0 }], 0, order, refl, path);
        t.escape(0, &p, if top { Side::Top } else { Side::Bottom }, [sin * phi.cos(), sin * phi.sin(), dz], w);
        t.end_photon(0);
        close_batch(t, ph, end);
        if top {
            truth.top += w;
            truth.top_order[order.min(4) as usize] += w;
            if order == 1 && refl == 0 {
                truth.top_single += w;
            }
        } else {
            truth.bottom += w;
            if order == 1 && refl == 0 {
                truth.bottom_single += w;
            }
        }
    }
}

/// Close the batch photon `ph` ends, as the run does: at each multiple of [`BATCH_PHOTONS`]
/// and at the end of the range.
fn close_batch(t: &mut TallySet, ph: u64, end: u64) {
    if (ph + 1).is_multiple_of(BATCH_PHOTONS) || ph + 1 == end {
        t.end_batch(ph + 1 - (ph / BATCH_PHOTONS) * BATCH_PHOTONS);
    }
}

fn get<'a>(h: &'a [HistogramOut], name: &str) -> &'a HistogramOut {
    h.iter().find(|x| x.name == name).unwrap_or_else(|| panic!("no histogram {name}"))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

#[test]
fn normalisations_integrate_to_totals() {
    let cfg = config();
    let mut t = TallySet::new(&cfg, &stack()).unwrap();
    let mut truth = Truth::default();
    let n = 2000;
    run(&mut t, 0..n, 1, &mut truth);
    let h = t.finalize(n);
    let nf = n as f64;
    let area = |i: usize| PI * cfg.dr * cfg.dr * ((i + 1).pow(2) - i * i) as f64;
    let th = |i: usize| i as f64 * PI / 2.0 / cfg.na as f64;
    for (side, total) in [("rd", truth.top / nf), ("tt", truth.bottom / nf)] {
        let r = get(&h, &format!("{side}_r"));
        assert_eq!(r.shape, vec![cfg.nr]);
        assert!(close((0..cfg.nr).map(|i| r.values[i] * area(i)).sum(), total));
        let a = get(&h, &format!("{side}_a"));
        let sa: f64 = (0..cfg.na).map(|i| a.values[i] * 2.0 * PI * (th(i).cos() - th(i + 1).cos())).sum();
        assert!(close(sa, total), "{sa} {total}");
        let ra = get(&h, &format!("{side}_ra"));
        let mut s = 0.0;
        for ir in 0..cfg.nr {
            for ia in 0..cfg.na {
                s += ra.values[ir * cfg.na + ia] * area(ir) * PI * (th(ia + 1).sin().powi(2) - th(ia).sin().powi(2));
            }
        }
        assert!(close(s, total), "{s} {total}");
        let bsdf = get(&h, if side == "rd" { "brdf" } else { "btdf" });
        assert_eq!(bsdf.shape, vec![5, 4]);
        assert_eq!(bsdf.axes, vec!["cos_theta", "phi"]);
        let proj = |ic: usize| {
            let (m0, m1) = (ic as f64 / 5.0, (ic + 1) as f64 / 5.0);
            (m1 * m1 - m0 * m0) / 2.0 * (2.0 * PI / 4.0)
        };
        let sb: f64 = (0..20).map(|b| bsdf.values[b] * proj(b / 4)).sum();
        assert!(close(sb, total), "{sb} {total}");
        let ord = get(&h, &format!("{side}_order"));
        assert_eq!(ord.edges[0], vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        assert!(close(ord.values.iter().sum(), total));
        let bo = get(&h, if side == "rd" { "brdf_order" } else { "btdf_order" });
        assert_eq!(bo.shape, vec![5, 5, 4]);
        for b in 0..20 {
            let s: f64 = (0..5).map(|k| bo.values[k * 20 + b]).sum();
            assert!(close(s, bsdf.values[b]), "order split of bin {b}");
        }
        let single = get(&h, &format!("{side}_single_direct")).values[0];
        let want = if side == "rd" { truth.top_single } else { truth.bottom_single } / nf;
        assert!(close(single, want));
        let bs = get(&h, if side == "rd" { "brdf_single_direct" } else { "btdf_single_direct" });
        let s: f64 = (0..20).map(|b| bs.values[b] * proj(b / 4)).sum();
        assert!(close(s, want));
        for b in 0..20 {
            assert!(bs.values[b] <= bo.values[20 + b] + 1e-15, "single-direct ⊂ order 1");
        }
    }
    let ord = get(&h, "rd_order");
    for k in 0..5 {
        assert!(close(ord.values[k], truth.top_order[k] / nf), "order {k}");
    }
    let rt = get(&h, "rd_t");
    assert!(close(rt.values.iter().map(|v| v * cfg.dt).sum(), truth.top / nf));
    let rrt = get(&h, "rd_rt");
    let s: f64 = (0..cfg.nr * cfg.nt).map(|i| rrt.values[i] * area(i / cfg.nt) * cfg.dt).sum();
    assert!(close(s, truth.top / nf));
    assert!(h.iter().all(|x| x.name != "tt_t"), "no time-resolved transmittance");
    let az = get(&h, "a_z");
    assert!(close(az.values.iter().map(|v| v * cfg.dz).sum(), truth.absorbed / nf));
    let arz = get(&h, "a_rz");
    assert_eq!(arz.axes, vec!["r", "z"]);
    let s: f64 = (0..cfg.nr * cfg.nz).map(|i| arz.values[i] * area(i / cfg.nz) * cfg.dz).sum();
    assert!(close(s, truth.absorbed / nf));
    // fluence: NaN in the bins of the glass layer z ∈ [0.0625, 0.09375] (bins 4, 5); the last
    // bin [0.171875, ∞) lies in layer 2 only.
    let fz = get(&h, "fluence_z");
    for iz in 0..cfg.nz {
        assert_eq!(fz.values[iz].is_nan(), (4..=5).contains(&iz), "bin {iz}");
    }
    let fz_sum: f64 = fz.values.iter().filter(|v| !v.is_nan()).map(|v| v * cfg.dz).sum();
    // every other bin lies in one layer: Φ = A/μa there
    let mut want = 0.0;
    for iz in 0..cfg.nz {
        let zc = (iz as f64 + 0.5) * cfg.dz;
        if (4..=5).contains(&iz) {
            continue;
        }
        let mua = if zc < 0.0625 { 1.0 } else { 2.0 };
        want += az.values[iz] * cfg.dz / mua;
    }
    assert!(close(fz_sum, want), "{fz_sum} {want}");
    assert!(truth.fluence_plane != 0.0);
}

#[test]
fn bin_placement_by_hand() {
    let cfg = config();
    let mut t = TallySet::new(&cfg, &stack()).unwrap();
    t.begin_photon(0, 0);
    // r = 0.05 mm → bin 2 (edges 0.04, 0.06); exit θ = 40° → bin 2 of 15° bins; t = 0.6/c ≈ 2.0 ps → bin 4
    let th = 40f64.to_radians();
    let dir = [th.sin() * (-0.5f64).cos(), th.sin() * (-0.5f64).sin(), -th.cos()]; // φ = 2π − 0.5
    t.escape(0, &packet([0.03, 0.04, 0.0], 0, 1, 0, 0.6), Side::Top, dir, 0.5);
    t.absorb(0, &packet([0.0, 0.5, 0.3], 2, 1, 0, 0.0), 0.25); // r, z overflow → last bins
    t.end_photon(0);
    t.end_batch(1);
    let h = t.finalize(4);
    let area2 = PI * 0.02 * 0.02 * 5.0;
    let rd_r = get(&h, "rd_r");
    assert!(close(rd_r.values[2], 0.5 / 4.0 / area2));
    assert_eq!(rd_r.values.iter().filter(|&&v| v != 0.0).count(), 1);
    let rd_a = get(&h, "rd_a");
    let (t0, t1) = (30f64.to_radians(), 45f64.to_radians());
    assert!(close(rd_a.values[2], 0.5 / 4.0 / (2.0 * PI * (t0.cos() - t1.cos()))));
    assert!(close(get(&h, "rd_t").values[4], 0.5 / 4.0 / 0.5));
    // μ = cos 40° = 0.766 → cos bin 3 of 5; φ = 2π − 0.5 → φ bin 3 of 4
    let brdf = get(&h, "brdf");
    let proj = (0.8f64.powi(2) - 0.6f64.powi(2)) / 2.0 * (PI / 2.0);
    assert!(close(brdf.values[3 * 4 + 3], 0.5 / 4.0 / proj));
    assert!(close(get(&h, "brdf_order").values[20 + 15], brdf.values[15]));
    assert!(close(get(&h, "rd_single_direct").values[0], 0.125));
    let arz = get(&h, "a_rz");
    let area9 = PI * 0.02 * 0.02 * 19.0;
    assert!(close(arz.values[9 * 12 + 11], 0.25 / 4.0 / (area9 * cfg.dz)));
    assert!(close(get(&h, "fluence_z").values[11], 0.25 / 2.0 / 4.0 / cfg.dz));
    // the transmittance side saw nothing
    assert!(get(&h, "tt_r").values.iter().all(|&v| v == 0.0));
    // edges and units
    assert_eq!(rd_r.edges[0].len(), 11);
    assert!(close(rd_r.edges[0][10], 0.2));
    assert_eq!(get(&h, "rd_ra").units, "mm^-2 sr^-1");
    assert_eq!(*get(&h, "rd_a").edges[0].last().unwrap(), PI / 2.0);
}

#[test]
fn stderr_matches_brute_force() {
    // Several deposits per photon, some in the same bin; the stderr is the batch-means one
    // (batches of BATCH_PHOTONS photons, the last one short), computed here by brute force.
    let cfg = config();
    let s = stack();
    let mut t = TallySet::new(&cfg, &s).unwrap();
    let n = 3 * BATCH_PHOTONS + 44;
    let mut st = SplitMix64::new(5);
    let nb = n.div_ceil(BATCH_PHOTONS) as usize;
    let mut totals = vec![[0.0f64; 12]; nb];
    for ph in 0..n {
        t.begin_photon(0, ph);
        for _ in 0..3 {
            let z = st.next_f64() * 0.045; // depth bins 0..2, layer 0
            let dw = st.next_f64();
            t.absorb(0, &packet([0.0, 0.0, z], 0, 0, 0, 0.0), dw);
            totals[(ph / BATCH_PHOTONS) as usize][(z / cfg.dz) as usize] += dw;
        }
        t.end_photon(0);
        close_batch(&mut t, ph, n);
    }
    let h = t.finalize(n);
    let az = get(&h, "a_z");
    let nf = n as f64;
    for iz in 0..3 {
        let s1: f64 = totals.iter().map(|x| x[iz]).sum();
        let q: f64 =
            (0..nb).map(|k| totals[k][iz].powi(2) / (n - k as u64 * BATCH_PHOTONS).min(BATCH_PHOTONS) as f64).sum();
        let m = s1 / nf;
        let se = ((q - nf * m * m) / (nb as f64 - 1.0) / nf).sqrt() / cfg.dz;
        assert!(close(az.values[iz], m / cfg.dz));
        assert!((az.stderr[iz] - se).abs() < 1e-10 * se, "{} {se}", az.stderr[iz]);
    }
    assert_eq!(az.stderr[5], 0.0);
}

/// The exact state of chunk tallies (drained in any grouping and order) finalises to the same
/// bits, and to the histograms of one tally that saw every photon (up to rounding).
#[test]
fn exact_merge_is_partition_independent_and_matches_a_single_tally() {
    let cfg = config();
    let s = stack();
    let mut whole = TallySet::new(&cfg, &s).unwrap();
    let mut truth = Truth::default();
    // same seeds per chunk so the photons are identical
    // (chunks of a run hold whole batches)
    let b = BATCH_PHOTONS;
    let chunks: Vec<(std::ops::Range<u64>, u64)> = vec![(0..b, 1), (b..3 * b, 2), (3 * b..3 * b + 144, 3)];
    let n = 3 * b + 144;
    for (r, seed) in &chunks {
        run(&mut whole, r.clone(), *seed, &mut truth);
    }
    let mut layout = Vec::new();
    whole.channels(&mut layout);
    assert_eq!(layout, TallySet::layout(&cfg).unwrap());
    let fresh = || layout.iter().map(ChannelState::new).collect::<Vec<_>>();
    let parts: Vec<Vec<ChannelState>> = chunks
        .iter()
        .map(|(r, seed)| {
            let mut t = TallySet::new(&cfg, &s).unwrap();
            run(&mut t, r.clone(), *seed, &mut Truth::default());
            let mut st = fresh();
            assert_eq!(t.drain_into(&mut st), Some(layout.len()));
            st
        })
        .collect();
    let fold = |order: &[usize]| {
        let mut acc = fresh();
        for &k in order {
            for (a, b) in acc.iter_mut().zip(&parts[k]) {
                a.merge(b);
            }
        }
        let mut t = TallySet::new(&cfg, &s).unwrap();
        t.load_from(&acc, n);
        t.finalize(n)
    };
    let (ha, hb) = (fold(&[0, 1, 2]), fold(&[2, 0, 1]));
    assert!(ha.iter().zip(&hb).all(|(a, b)| a.same_bits(b)), "exact merge must not depend on the order");
    let hw = whole.finalize(n);
    assert_eq!(ha.len(), hw.len());
    for (x, y) in ha.iter().zip(&hw) {
        assert_eq!(x.name, y.name);
        for i in 0..x.values.len() {
            for (u, v) in [(x.values[i], y.values[i]), (x.stderr[i], y.stderr[i])] {
                assert!(
                    u.is_nan() && v.is_nan() || (u - v).abs() <= 1e-9 * (1.0 + v.abs()),
                    "{} bin {i}: {u} {v}",
                    x.name
                );
            }
        }
    }
}

#[test]
fn switches_select_histograms() {
    let mut cfg = TallyConfig::default();
    let names = |c: &TallyConfig| -> Vec<String> {
        TallySet::new(c, &stack()).unwrap().finalize(10).into_iter().map(|h| h.name).collect()
    };
    assert_eq!(
        names(&cfg),
        ["rd_r", "rd_a", "rd_ra", "tt_r", "tt_a", "tt_ra", "a_z", "a_rz", "fluence_z", "fluence_rz"]
    );
    cfg.spatial = false;
    cfg.angular = false;
    assert!(names(&cfg).is_empty());
    cfg.nt = 3;
    cfg.max_order = Some(0);
    assert_eq!(names(&cfg), ["rd_t", "rd_order", "rd_single_direct", "tt_order", "tt_single_direct"]);
    cfg.brdf = Some((2, 1));
    assert_eq!(names(&cfg).len(), 11);
    // a disabled TallySet ignores events without touching memory
    cfg = TallyConfig { spatial: false, angular: false, ..TallyConfig::default() };
    let mut t = TallySet::new(&cfg, &stack()).unwrap();
    t.begin_photon(0, 0);
    t.absorb(0, &packet([0.0, 0.0, 0.1], 0, 0, 0, 0.0), 1.0);
    t.escape(0, &packet([0.0, 0.0, 0.0], 0, 0, 0, 0.0), Side::Top, [0.0, 0.0, -1.0], 1.0);
    assert!(t.finalize(1).is_empty());
    let bad = TallyConfig { nr: 0, ..TallyConfig::default() };
    assert!(TallySet::new(&bad, &stack()).unwrap_err().to_string().starts_with("tallies.nr"));
}

/// Two absorbing layers with an interface at 0.015 mm, inside depth bin 1 of a 0.01 mm grid.
fn straddling_stack() -> Stack {
    Stack::new(
        vec![Layer::new(1.4, 1.0, 5.0, 0.0, 0.015).unwrap(), Layer::new(1.4, 4.0, 5.0, 0.0, f64::INFINITY).unwrap()],
        1.0,
        1.0,
    )
    .unwrap()
}

#[test]
fn fluence_in_a_bin_straddling_two_absorbing_layers() {
    let s = straddling_stack();
    let cfg = TallyConfig { nr: 2, dr: 0.1, nz: 3, dz: 0.01, ..TallyConfig::default() };
    let mut t = TallySet::new(&cfg, &s).unwrap();
    t.begin_photon(0, 0);
    t.absorb(0, &packet([0.0, 0.0, 0.005], 0, 1, 0, 0.0), 0.2); // bin 0, layer 0
    t.absorb(0, &packet([0.0, 0.0, 0.012], 0, 1, 0, 0.0), 0.3); // bin 1, layer 0
    t.absorb(0, &packet([0.0, 0.0, 0.018], 1, 1, 0, 0.0), 0.4); // bin 1, layer 1
    t.absorb(0, &packet([0.0, 0.0, 0.5], 1, 1, 0, 0.0), 0.8); // bin 2 (overflow), layer 1
    t.end_photon(0);
    t.begin_photon(0, 1);
    t.absorb(0, &packet([0.0, 0.0, 0.019], 1, 1, 0, 0.0), 0.4); // bin 1, layer 1
    t.end_photon(0);
    t.end_batch(2);
    let h = t.finalize(2);
    let (fz, frz) = (get(&h, "fluence_z"), get(&h, "fluence_rz"));
    let want = [0.2 / 1.0, 0.3 / 1.0 + 0.4 / 4.0 + 0.4 / 4.0, 0.8 / 4.0].map(|x| x / 2.0 / 0.01);
    for iz in 0..3 {
        assert!(close(fz.values[iz], want[iz]), "bin {iz}: {} {}", fz.values[iz], want[iz]);
        assert!(close(frz.values[iz], want[iz] / (PI * 0.01)), "rz bin {iz}");
        assert_eq!(frz.values[3 + iz], 0.0);
    }
    // two photons are one batch: no standard error (see `accum`)
    assert!(fz.stderr[1].is_nan());
}

/// The lane kernel's path: deposits of [`LANES`] lanes at once (random masks, lanes often
/// staying in their bin — the vector update of the pending sums — or moving, across an
/// interface inside a straddling bin too), against per-bin sums made by hand.
#[test]
fn absorb_lanes_pending_sums_match_per_bin_sums() {
    let s = straddling_stack();
    let cfg = TallyConfig { nr: 2, dr: 0.1, nz: 3, dz: 0.01, errors: false, ..TallyConfig::default() };
    let mut t = TallySet::new(&cfg, &s).unwrap();
    // (r, z, layer) spots: bins 0, 1 (both layers: straddling), 2 (overflow), two radii
    let spots =
        [(0.05, 0.005, 0), (0.05, 0.012, 0), (0.05, 0.018, 1), (0.15, 0.018, 1), (0.15, 0.5, 1), (0.3, 0.002, 0)];
    let mut rng = SplitMix64::new(9);
    let (mut a, mut phi) = ([[0.0; 3]; 2], [[0.0; 3]; 2]);
    let mut spot = [0usize; LANES];
    for _ in 0..3000 {
        let (mut x, mut y, mut z, mut dep) = ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let mut layer = [0u32; LANES];
        // (all lanes in one step out of 8, as in the overflow bins of a thick medium)
        let full = ((1u64 << LANES) - 1) as u32;
        let all = if rng.next_u64().is_multiple_of(8) { full } else { 0 };
        let mask = rng.next_u64() as u32 & full | all;
        for i in 0..LANES {
            if rng.next_u64().is_multiple_of(5) {
                spot[i] = (rng.next_u64() % spots.len() as u64) as usize;
            }
            let (r, zz, l) = spots[spot[i]];
            (x[i], y[i], z[i], layer[i], dep[i]) = (r * 0.6, r * 0.8, zz, l as u32, rng.next_f64());
            if mask & (1 << i) != 0 {
                let (ir, iz) = (usize::from(r > 0.1), ((zz / 0.01) as usize).min(2));
                a[ir][iz] += dep[i];
                phi[ir][iz] += dep[i] / s.layers[l].mua;
            }
        }
        t.absorb_lanes(&Deposits { x: &x, y: &y, z: &z, layer: &layer, dep: &dep, mask });
    }
    let h = t.finalize(1);
    let (az, arz, fz, frz) = (get(&h, "a_z"), get(&h, "a_rz"), get(&h, "fluence_z"), get(&h, "fluence_rz"));
    let area = [PI * 0.01, PI * 0.03];
    for iz in 0..3 {
        assert!(close(az.values[iz], (a[0][iz] + a[1][iz]) / 0.01), "a_z {iz}");
        assert!(close(fz.values[iz], (phi[0][iz] + phi[1][iz]) / 0.01), "fluence_z {iz}");
        for ir in 0..2 {
            assert!(close(arz.values[ir * 3 + iz], a[ir][iz] / 0.01 / area[ir]), "a_rz {ir} {iz}");
            assert!(close(frz.values[ir * 3 + iz], phi[ir][iz] / 0.01 / area[ir]), "fluence_rz {ir} {iz}");
        }
    }
}
