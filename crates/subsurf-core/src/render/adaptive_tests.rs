//! The adaptive BSSRDF on flat slabs: a thick slab gives the semi-infinite Monte Carlo exitance
//! (total × E_t) at normal incidence and the engine's pencil and diffuse totals under oblique and
//! diffuse light, a thin slab lit from below transmits T(d) × E_t to its top face.

use super::super::driver::{Method, Renderer};
use super::super::hierarchical::HierarchicalParams;
use super::super::light::Light;
use super::super::material::{Material, TranslucentSpec};
use super::super::scene::{Object, Scene};
use super::super::shade::ft;
use super::super::shapes::cuboid;
use super::super::Camera;
use crate::bssrdf::adaptive::AdaptiveTable;
use crate::bssrdf::monte_carlo::McSettings;
use crate::medium::{Layer, Stack};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

pub(in crate::render) const SA: f64 = 0.05;
pub(in crate::render) const SS: f64 = 2.0;
pub(in crate::render) const ETA: f64 = 1.4;

/// An `adaptive` material of one semi-infinite layer (the same in every channel), its table
/// traced at `photons` per run unless given.
fn one_layer(
    field: &str,
    (sa, ss, g, eta): (f64, f64, f64, f64),
    photons: u64,
    adaptive: Option<Arc<AdaptiveTable>>,
) -> TranslucentSpec {
    let stack = Stack::new(vec![Layer::new(eta, sa, ss, g, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    TranslucentSpec {
        field: field.into(),
        sigma_a: [sa; 3],
        sigma_s: [ss; 3],
        g,
        eta,
        model: "adaptive".into(),
        stacks: [stack.clone(), stack.clone(), stack],
        mc: McSettings { photons, seed: 1, threads: Some(2), ..McSettings::default() },
        reflectance: None,
        single_scattering: None,
        grid: None,
        texture: None,
        adaptive,
    }
}

/// The test material (the same stack in every channel), its table traced once for all the
/// tests of this file and `flow_tests` (each channel's nodes, curvature and oblique runs at 20 000
/// photons).
pub(in crate::render) fn material() -> Material {
    static TABLE: std::sync::OnceLock<Arc<AdaptiveTable>> = std::sync::OnceLock::new();
    let spec = |adaptive| one_layer("materials.m", (SA, SS, 0.0, ETA), 20_000, adaptive);
    let build = |s: TranslucentSpec| s.build(true, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap().unwrap();
    let table = TABLE.get_or_init(|| build(spec(None)).adaptive.clone().unwrap());
    Material::Translucent(Box::new(build(spec(Some(table.clone())))))
}

/// A 3×3 camera looking down at a 30 × 30 mm slab from 50 mm (fov 0.5°): the middle pixel sees
/// the centre of the top face at normal view. Lit by unit suns from `to_light` (with the
/// irradiance of each per channel).
fn slab_scene_lit(thickness: f64, suns: &[([f64; 3], [f64; 3])]) -> Arc<Scene> {
    let slab = cuboid([-15.0, -15.0, -thickness], [15.0, 15.0, 0.0]).unwrap();
    let suns = suns.iter().map(|&(d, e)| Light::directional("sun", d, e).unwrap()).collect();
    let cam = Camera::new([0.0, 0.0, 50.0], [0.0; 3], [0.0, 1.0, 0.0], 0.5, 3, 3).unwrap();
    let obj = Object { name: "slab".into(), mesh: slab, material: 0 };
    Arc::new(Scene::new(vec![obj], vec![material()], suns, [0.0; 3], Some(cam)).unwrap())
}

/// [`slab_scene_lit`] with one white sun.
fn slab_scene(thickness: f64, to_light: [f64; 3]) -> Arc<Scene> {
    slab_scene_lit(thickness, &[(to_light, [1.0; 3])])
}

/// Radiance of the middle pixel (1 spp: hierarchical is deterministic there).
fn middle(s: &Arc<Scene>) -> [f64; 3] {
    let r = Renderer::new(s.clone(), Method::Hierarchical, 7, &HierarchicalParams::default()).unwrap();
    r.sample(1, 1, 0)
}

fn table(s: &Scene) -> (Arc<AdaptiveTable>, f64) {
    let Material::Translucent(t) = &s.materials[0] else { unreachable!() };
    (t.adaptive.clone().unwrap(), t.c_norm)
}

/// A slab 30 mm thick (25 diffusion lengths) lit from above: at normal incidence (red) exitance
/// = R(d) × E_t to 1 % (the hierarchical method's quadrature, as for every model), and R(30 mm)
/// is the semi-infinite total within the Monte Carlo noise of the two nodes (4σ).
/// Oblique light (green and blue: a sun at 60°) gives the engine's own pencil total at 60°
/// (an independent run, not a table node) times F_t(60°)·cos 60°, within 1 % (the quadrature)
/// plus 4σ of the Monte Carlo numbers involved (the check run, the two nodes at 30 mm, the
/// table's ∞ node and its 50° and 65° runs between which the gain is interpolated); and under
/// diffuse light the gain integrated over the hemisphere gives the engine's diffuse reflectance
/// (the table's flat diffuse run, independent of the pencils) within 4σ.
#[test]
fn thick_slab_reduces_to_the_semi_infinite_profile() {
    use crate::mc::tally::totals::{Total, Totals};
    use crate::mc::{run, RunConfig, Source};
    let th = 60f64.to_radians();
    let (sun0, sun60) = ([0.0, 0.0, 1.0], [th.sin(), 0.0, th.cos()]);
    let s = slab_scene_lit(30.0, &[(sun0, [1.0, 0.0, 0.0]), (sun60, [0.0, 1.0, 1.0])]);
    let (t, c) = table(&s);
    let f0 = ft(ETA, 1.0);
    let got = middle(&s);
    let Material::Translucent(m) = &s.materials[0] else { unreachable!() };
    let stack = &m.stacks[0];
    let cfg = RunConfig {
        photons: 20_000,
        seed: 7777,
        threads: Some(2),
        source: Source::Pencil { theta: th, phi: 0.0 },
        isa: None,
    };
    let check = run(stack, &cfg, || Totals::new(1), &AtomicBool::new(false), &AtomicU64::new(0)).unwrap().tally;
    let (r60, se60) = check.get(Total::Diffuse);
    let mu = th.cos();
    for k in 0..3 {
        let (r, tr) = t.totals(k, 30.0);
        let n = t.data()[k].len();
        let node = |j: usize| &t.data()[k][j].top;
        let cd = &t.curvature()[k];
        let s1 = t.exit(k).factor(1.0); // seen along the normal: the exit term's shape there
        if k == 0 {
            let want = f0 * r * f0 / (PI * c) * s1;
            println!("channel {k}: {:.6} vs {want:.6} ({:+.3} %), T = {tr:.2e}", got[k], 100.0 * (got[k] / want - 1.0));
            assert!((got[k] / want - 1.0).abs() < 0.01, "channel {k}");
            let semi = m.profiles()[k].total();
            let se = (node(n - 1).total_stderr.powi(2) + node(n - 2).total_stderr.powi(2)).sqrt();
            assert!((r - semi).abs() < 4.0 * se * 1.1, "R(30) = {r}, semi-infinite {semi} ± {se}");
        } else {
            // per unit incident power at 60°: R(60°) F_t(60°) cos 60° (the engine scores R per incident)
            let want = r60 * mu * f0 / (PI * c) * s1;
            let rel = [
                (r60, se60),
                (node(n - 1).total, node(n - 1).total_stderr),
                (node(n - 2).total, node(n - 2).total_stderr),
            ]
            .into_iter()
            .chain(cd.oblique[1..3].iter().map(|e| (e.mean, e.stderr)))
            .map(|(v, e)| (e / v).powi(2))
            .sum::<f64>()
            .sqrt();
            println!(
                "channel {k} at 60°: {:.6} vs {want:.6} ({:+.3} % ± {:.3} %)",
                got[k],
                100.0 * (got[k] / want - 1.0),
                100.0 * rel
            );
            assert!((got[k] / want - 1.0).abs() < 0.01 + 4.0 * rel, "channel {k} at 60°");
            assert_eq!(t.oblique_gain(k, 1.0), 1.0);
        }
        // diffuse light: 2∫ R(0) g(μ) F_t(μ) μ dμ (per incident power) = the flat diffuse run
        let r0 = node(n - 1).total / f0;
        let steps = 4000;
        let pred: f64 = (0..steps)
            .map(|i| (i as f64 + 0.5) / steps as f64)
            .map(|x| 2.0 * r0 * t.oblique_gain(k, x) * ft(ETA, x) * x / steps as f64)
            .sum();
        let worst =
            cd.oblique.iter().map(|e| e.stderr / e.mean).fold(node(n - 1).total_stderr / node(n - 1).total, f64::max);
        let se = (cd.flat.stderr.powi(2) + (worst * pred).powi(2)).sqrt();
        println!("channel {k} diffuse: {pred:.5} vs the engine's {:.5} ± {se:.5}", cd.flat.mean);
        assert!((pred - cd.flat.mean).abs() < 4.0 * se, "channel {k} diffuse: {pred} vs {}", cd.flat.mean);
    }
}

/// A 1 mm slab lit from below only: its top face shows the transmitted light T(1 mm) × E_t
/// (to 2 %: the quadrature of a profile about one thickness wide on samples 0.35 median radii
/// apart, with the near-field correction), far above what the flat model would give.
#[test]
fn thin_slab_lit_from_below_transmits() {
    let s = slab_scene(1.0, [0.0, 0.0, -1.0]);
    let (t, c) = table(&s);
    let f0 = ft(ETA, 1.0);
    let got = middle(&s);
    for k in 0..3 {
        let (_, tr) = t.totals(k, 1.0);
        let want = f0 * tr * f0 / (PI * c); // light across the part: the flat exit term
        println!("channel {k}: {:.6} vs {want:.6} ({:+.3} %)", got[k], 100.0 * (got[k] / want - 1.0));
        assert!(tr > 0.2 && (got[k] / want - 1.0).abs() < 0.02, "channel {k}: T = {tr}");
    }
}

/// The curvature probe: 1/ρ on a sphere (icosphere level 5, radius 10 mm: facets 0.7 mm, so
/// within 10 %), 0 in the middle of a flat face; the kernel's profiles there are the table's at
/// the probed thickness scaled by the table's curvature scale (1 when flat).
#[test]
fn curvature_probe_and_kernel_scale() {
    use super::super::tree::PairProfiles;
    use super::{mean_curvature, thickness, Kernel};
    use crate::bssrdf::RadialProfile;
    use crate::render::accel::Hit;
    let sphere = super::super::shapes::icosphere([0.0; 3], 10.0, 5).unwrap();
    let obj = Object { name: "s".into(), mesh: sphere, material: 0 };
    let s = Scene::new(vec![obj], vec![material()], vec![], [0.0; 3], None).unwrap();
    let top: Hit = s.accel.intersect([0.3, 0.2, 50.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
    let h = mean_curvature(&s, &top, 2.0);
    assert!((h * 10.0 - 1.0).abs() < 0.1, "H = {h}");
    assert!((thickness(&s, &top) - 20.0).abs() < 0.1);
    let flat = slab_scene(30.0, [0.0, 0.0, 1.0]);
    let mid: Hit = flat.accel.intersect([0.3, 0.2, 50.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
    assert_eq!(mean_curvature(&flat, &mid, 2.0), 0.0);
    let (t, _) = table(&s);
    let k = Kernel::at(&s, &t, &top);
    assert!((k.h * 10.0 - 1.0).abs() < 0.1 && (k.d - 20.0).abs() < 0.1);
    for c in 0..3 {
        let sc = t.curvature_scale_principal(c, k.k.0, k.k.1);
        let (r, tr) = t.scaled(c, t.local(c, k.d), (1.0, sc.far));
        assert_eq!(k.profile(1, c).total(), tr.total());
        let want = crate::bssrdf::curvature::Binned::new(r, &sc);
        assert_eq!(k.profile(0, c).total(), want.total());
    }
    assert!((t.curvature_scale(0, k.h).near[0] - 1.0).abs() > 1e-3, "a curved point is corrected");
    assert!((k.k.0 * 10.0 - 1.0).abs() < 0.1 && (k.k.1 * 10.0 - 1.0).abs() < 0.1, "umbilic: {:?}", k.k);
    assert_eq!(t.curvature_scale(0, 0.0), crate::bssrdf::curvature::LocalScale::ONE);
    // flat: the bins' edges are all at ∞ and the kernel is the slab profile itself
    let (r, _) = t.scaled(0, t.local(0, 20.0), (1.0, 1.0));
    let flat = crate::bssrdf::curvature::Binned::new(r.clone(), &crate::bssrdf::curvature::LocalScale::ONE);
    assert_eq!(flat.total(), r.total());
    for x in [0.01, 0.3, 3.0] {
        assert_eq!(flat.rd(x), r.rd(x));
        assert!((flat.cdf(x) - r.cdf(x)).abs() < 1e-12);
    }
}

/// The principal curvatures of a torus (major 7, tube 2.5 mm, 0.12–0.2 mm facets) from the three
/// probe rays: on the outer equator 1/2.5 and 1/9.5 mm⁻¹, on the top of the tube 1/2.5 and 0,
/// on the inner equator 1/2.5 and −1/4.5 (a saddle); within 10 % of the tube's 1/2.5, 0.02 mm⁻¹
/// for the ring's direction.
#[test]
fn principal_curvatures_of_a_torus() {
    use super::principal_curvatures;
    let mesh = super::super::shapes::torus([0.0; 3], 7.0, 2.5, 384, 96).unwrap();
    let obj = Object { name: "t".into(), mesh, material: 0 };
    let grey = Material::lambertian("m", [0.5; 3]).unwrap();
    let s = Scene::new(vec![obj], vec![grey], vec![], [0.0; 3], None).unwrap();
    let probe = |o: [f64; 3], d: [f64; 3]| s.accel.intersect(o, d, f64::INFINITY, u32::MAX).unwrap();
    let cases = [
        (probe([50.0, 0.01, 0.02], [-1.0, 0.0, 0.0]), 1.0 / 9.5),
        (probe([7.01, 0.02, 50.0], [0.0, 0.0, -1.0]), 0.0),
        (probe([0.01, 0.02, 0.03], [1.0, 0.0, 0.0]), -1.0 / 4.5),
    ];
    for (hit, k2) in cases {
        let (a, b) = principal_curvatures(&s, &hit, 0.6);
        assert!(a >= b && (a * 2.5 - 1.0).abs() < 0.1 && (b - k2).abs() < 0.02, "κ = ({a}, {b}), want {k2}");
    }
}

/// A cube's flat face: no curvature in its middle (every probe finds the face), a convex one
/// within a probe step of an edge (the probes that fall off count [`super::EDGE_SAG`]).
#[test]
fn edges_count_as_convex() {
    use super::principal_curvatures;
    let grey = Material::lambertian("m", [0.5; 3]).unwrap();
    let obj = Object { name: "c".into(), mesh: cuboid([-5.0; 3], [5.0; 3]).unwrap(), material: 0 };
    let s = Scene::new(vec![obj], vec![grey], vec![], [0.0; 3], None).unwrap();
    let at = |x: f64, y: f64| s.accel.intersect([x, y, 50.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
    assert_eq!(principal_curvatures(&s, &at(0.3, 0.2), 1.0), (0.0, 0.0));
    let (k1, k2) = principal_curvatures(&s, &at(4.6, 0.2), 1.0);
    assert!(k1 > 0.1 && k1 >= k2, "κ = ({k1}, {k2})");
}

/// The far class' near field survives clustering: on a sphere (a dipole profile for both classes,
/// the far one at the lateral offset r⊥ behind x, as the adaptive kernel's T), the exitance with
/// clusters (ε = 0.05 sr) equals the all-pairs sum (ε = 0) within 1 %. Clustering by the
/// straight distance lost the far class' peak behind x (its samples are far from x in space):
/// −38 % here (ρ₀ = 2 median radii, `spacing` 1).
#[test]
fn far_class_near_field_is_not_clustered_away() {
    use super::super::hierarchical::Hierarchical;
    use super::super::math::{dot, length, sub, V3};
    use super::super::tree::PairProfiles;
    use crate::bssrdf::RadialProfile;
    use crate::render::accel::Hit;
    /// Both classes the material's profile; across (h > d/2) at r⊥, as `Kernel::class`.
    struct Across<'a>(&'a super::super::material::Translucent, V3, f64);
    impl PairProfiles for Across<'_> {
        fn class(&self, x: V3, q: V3) -> (usize, f64) {
            let v = sub(x, q);
            let (h, r) = (dot(v, self.1), length(v));
            if h > 0.5 * self.2 {
                (1, (r * r - h * h).max(0.0).sqrt())
            } else {
                (0, r)
            }
        }
        fn profile(&self, _c: usize, k: usize) -> &dyn RadialProfile {
            &*self.0.profiles()[k]
        }
    }
    let stack = Stack::new(vec![Layer::new(ETA, 0.5, 1.0, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let m = TranslucentSpec {
        field: "materials.m".into(),
        sigma_a: [0.5; 3],
        sigma_s: [1.0; 3],
        g: 0.0,
        eta: ETA,
        model: "dipole".into(),
        stacks: [stack.clone(), stack.clone(), stack],
        mc: McSettings::default(),
        reflectance: None,
        single_scattering: None,
        grid: None,
        texture: None,
        adaptive: None,
    };
    let t = m.build(true, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap().unwrap();
    let sphere = super::super::shapes::icosphere([0.0; 3], 10.0, 4).unwrap();
    let obj = Object { name: "s".into(), mesh: sphere, material: 0 };
    let s = Scene::new(vec![obj], vec![Material::Translucent(Box::new(t))], vec![], [1.0; 3], None).unwrap();
    let params = HierarchicalParams { spacing: 1.0, env_samples: 2, light_samples: 1, ..HierarchicalParams::default() };
    let tree = Hierarchical::new(&s, &params, 1).unwrap().trees.swap_remove(0).unwrap();
    let Material::Translucent(m) = &s.materials[0] else { unreachable!() };
    let top: Hit = s.accel.intersect([0.3, 0.2, 50.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
    let pp = Across(m, top.n, 20.0);
    let (all, clustered) = (tree.exitance_with(&pp, top.p, 0.0), tree.exitance_with(&pp, top.p, 0.05));
    println!("{} samples; all pairs {all:?}, clustered {clustered:?}", tree.samples.len());
    assert!((clustered[0] / all[0] - 1.0).abs() < 0.01);
}

/// A sun on a sphere of radius 2 mm (ℓ/ρ = 0.25; 1.1 diffusion lengths): the exitance of its lit
/// cap (cos α ≥ 0.9 about the sub-solar point, 64 points uniform in area, each read from the
/// `hierarchical` radiance along its normal as M = L π c / F_t(1)) against the exact curved
/// transport's (`sun_exitance`, the same cap; 8 independent batches give its standard error).
/// A collimated beam's light leaves forward of its entry, away from the sub-solar point; without
/// the azimuthal harmonic the radially symmetric kernel keeps it there (+16 % here, measured).
/// Bound: 6 % (the model's stated accuracy on a sphere's lit side, `docs/render.md`) + 4σ.
#[test]
fn sun_lit_sphere_cap_matches_the_curved_transport() {
    use super::super::hierarchical::Hierarchical;
    use super::super::shade::Translucency;
    use crate::bssrdf::curved::sun_exitance;
    use crate::rng::PhotonRng;
    let rho = 2.0;
    let obj =
        Object { name: "s".into(), mesh: super::super::shapes::icosphere([0.0; 3], rho, 5).unwrap(), material: 0 };
    let sun = Light::directional("sun", [0.0, 0.0, 1.0], [1.0; 3]).unwrap();
    let s = Scene::new(vec![obj], vec![material()], vec![sun], [0.0; 3], None).unwrap();
    let (t, c) = table(&s);
    let h = Hierarchical::new(&s, &HierarchicalParams::default(), 7).unwrap();
    let s1 = t.exit(0).factor(1.0);
    let (n_mu, n_phi) = (8, 8);
    let mut got = 0.0;
    for i in 0..n_mu {
        let mu = 1.0 - 0.1 * (i as f64 + 0.5) / n_mu as f64;
        for j in 0..n_phi {
            let phi = 2.0 * PI * (j as f64 + 0.5) / n_phi as f64;
            let r = (1.0 - mu * mu).sqrt();
            let dir = [r * phi.cos(), r * phi.sin(), mu];
            let o = [3.0 * rho * dir[0], 3.0 * rho * dir[1], 3.0 * rho * dir[2]];
            let hit = s.accel.intersect(o, [-dir[0], -dir[1], -dir[2]], f64::INFINITY, u32::MAX).unwrap();
            let l = h.radiance(&s, &hit, hit.n, 0, &mut PhotonRng::new(3, (i * n_phi + j) as u64));
            got += l[0] * PI * c / (ft(ETA, 1.0) * s1) / (n_mu * n_phi) as f64;
        }
    }
    let Material::Translucent(m) = &s.materials[0] else { unreachable!() };
    let (bins, batches) = (20, 8);
    let cap: Vec<f64> = (0..batches)
        .map(|b| {
            let e = sun_exitance(
                &m.stacks[0],
                rho,
                bins,
                5_000,
                100 + b,
                Some(2),
                &AtomicBool::new(false),
                &AtomicU64::new(0),
            );
            e.unwrap().unwrap()[bins - 1]
        })
        .collect();
    let want = cap.iter().sum::<f64>() / batches as f64;
    let var = cap.iter().map(|x| (x - want).powi(2)).sum::<f64>() / (batches - 1) as f64;
    let se = (var / batches as f64).sqrt();
    println!("lit cap: model {got:.5}, exact {want:.5} ± {se:.5} ({:+.1} %)", 100.0 * (got / want - 1.0));
    assert!((got - want).abs() < 0.06 * want + 4.0 * se, "{got} vs {want} ± {se}");
}

/// The exit term on a flat ketchup slab (8 × 8 × 4 mm; red albedo 0.75, green and blue 0.07 and
/// 0.02: low-order media) under a normal sun: the share of the exitance that the
/// `hierarchical` radiance at the centre sends into the exit-cosine bins [0.9, 1], [0.7, 0.8] and
/// [0.2, 0.3] (about 18°, 41° and 75° from the normal; the radiance μ-weighted over 100 exit
/// cosines) against the engine's own exit-angle tally of an independent run (normal pencil,
/// 10⁶ photons per channel): within 2 % (the stated model tolerance: the shape is fitted on the
/// table's flat run under diffuse light, and β moves by up to 0.02 with the incidence on ketchup,
/// `bssrdf::exit`) + 4σ of the tally. The flat surface's F_t(μ_o)/(π c) misses by more than that
/// bound in the first and last bins (asserted: the test can fail). The shape is applied to any
/// exitance alike, so the slab need not be thick for this (the thick-slab test above checks the
/// totals with it).
#[test]
fn ketchup_slab_exit_shape_matches_the_engine() {
    use super::super::hierarchical::Hierarchical;
    use super::super::shade::Translucency;
    use crate::bssrdf::exit::{ExitTally, EXIT_BINS};
    use crate::mc::{run, RunConfig, Source};
    use crate::rng::PhotonRng;
    let (sa, ss, eta) = ([0.061, 0.97, 1.45], [0.18, 0.07, 0.03], 1.3);
    let stacks = [0, 1, 2]
        .map(|k| Stack::new(vec![Layer::new(eta, sa[k], ss[k], 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap());
    let spec = TranslucentSpec {
        field: "materials.ketchup".into(),
        sigma_a: sa,
        sigma_s: ss,
        g: 0.0,
        eta,
        model: "adaptive".into(),
        stacks: stacks.clone(),
        mc: McSettings { photons: 20_000, seed: 1, threads: Some(2), ..McSettings::default() },
        reflectance: None,
        single_scattering: None,
        grid: None,
        texture: None,
        adaptive: None,
    };
    let m = spec.build(true, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap().unwrap();
    let slab = cuboid([-4.0, -4.0, -4.0], [4.0, 4.0, 0.0]).unwrap();
    let sun = Light::directional("sun", [0.0, 0.0, 1.0], [1.0; 3]).unwrap();
    let obj = Object { name: "slab".into(), mesh: slab, material: 0 };
    let s = Scene::new(vec![obj], vec![Material::Translucent(Box::new(m))], vec![sun], [0.0; 3], None).unwrap();
    let params = HierarchicalParams { spacing: 2.0, ..HierarchicalParams::default() };
    let h = Hierarchical::new(&s, &params, 7).unwrap();
    let hit = s.accel.intersect([0.3, 0.2, 50.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
    // the renderer's μ-weighted radiance on 100 exit cosines, summed per bin
    let steps = 100;
    let (mut model, mut flat) = ([[0.0; EXIT_BINS]; 3], [0.0; EXIT_BINS]);
    for i in 0..steps {
        let mu = (i as f64 + 0.5) / steps as f64;
        let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
        let l = h.radiance(&s, &hit, wo, 0, &mut PhotonRng::new(3, i as u64));
        for k in 0..3 {
            model[k][i * EXIT_BINS / steps] += l[k] * mu;
        }
        flat[i * EXIT_BINS / steps] += ft(eta, mu) * mu;
    }
    for k in 0..3 {
        let cfg = RunConfig { photons: 1_000_000, seed: 4242, threads: Some(2), source: Source::default(), isa: None };
        let o = run(&stacks[k], &cfg, ExitTally::default, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
        let (w, se) = o.tally.data();
        let total: f64 = w.iter().sum();
        let (mt, ft_t) = (model[k].iter().sum::<f64>(), flat.iter().sum::<f64>());
        for b in [9, 7, 2] {
            let (want, sig) = (w[b] / total, se[b] / total);
            let (got, flat_share) = (model[k][b] / mt, flat[b] / ft_t);
            println!(
                "channel {k} bin {b}: model {got:.5} ({:+.2} %), flat term {flat_share:.5} ({:+.2} %), engine {want:.5} ± {sig:.5}",
                100.0 * (got / want - 1.0),
                100.0 * (flat_share / want - 1.0)
            );
            let bound = 0.02 * want + 4.0 * sig;
            assert!((got - want).abs() < bound, "channel {k} bin {b}: {got} vs {want} ± {sig}");
            if b != 7 {
                assert!((flat_share - want).abs() > bound, "channel {k} bin {b}: the flat term passes too");
            }
        }
    }
}

/// A saddle (the inside of a torus' ring: κ₂ < 0 < H) takes a tube's scales, but the ring rises
/// above the tangent plane there, so the kernel's integral over the torus exceeds its integral
/// over the tangent cylinder (the shape its scales make exact); [`super::Kernel::target`] makes
/// the hierarchical sum the cylinder's, and `probe` scales by [`super::Kernel::normalisation`].
/// On the hierarchical samples of a fine torus (tube 2.5, ring 7 mm) with E_t = 1
/// ([`area_tree`]): at the inner equator the gathered exitance is the tangent cylinder's mass
/// (10⁻⁹), the mesh's own integral is above it (> 2 %), and the probe's factor times it is the
/// same; at the outer equator (no saddle: factor 1) the mesh's integral is the tangent
/// cylinder's within 2 %.
#[test]
fn saddle_kernel_gathers_the_tube_total() {
    use super::super::hierarchical::area_tree;
    use super::super::math::Rgb;
    use super::super::tree::PairProfiles;
    use super::{Kernel, Unnormalised};
    use crate::bssrdf::curvature::cylinder_mass;
    let mesh = super::super::shapes::torus([0.0; 3], 7.0, 2.5, 384, 96).unwrap();
    let obj = Object { name: "t".into(), mesh, material: 0 };
    let s = Scene::new(vec![obj], vec![material()], vec![], [0.0; 3], None).unwrap();
    let (t, _) = table(&s);
    let tree = area_tree(&s, 0).unwrap();
    let probe = |o: [f64; 3], d: [f64; 3]| s.accel.intersect(o, d, f64::INFINITY, u32::MAX).unwrap();
    for (hit, saddle) in
        [(probe([50.0, 0.01, 0.02], [-1.0, 0.0, 0.0]), false), (probe([0.01, 0.02, 0.03], [1.0, 0.0, 0.0]), true)]
    {
        let k = Kernel::at(&s, &t, &hit);
        assert_eq!(k.target.is_some(), saddle, "κ = {:?}", k.k);
        let cyl: Rgb = std::array::from_fn(|c| cylinder_mass(k.profile(0, c), k.profile(1, c), 1.0 / k.k.0));
        let plain = tree.exitance_with(&Unnormalised(&k), hit.p, 0.05);
        let got = tree.exitance_with(&k, hit.p, 0.05);
        let f = k.normalisation(&tree, 0.05);
        for c in 0..3 {
            assert!((f[c] * plain[c] / got[c] - 1.0).abs() < 1e-12, "{c}: {f:?} {plain:?} {got:?}");
            if saddle {
                assert!(
                    (got[c] / cyl[c] - 1.0).abs() < 1e-9 && plain[c] > 1.02 * cyl[c],
                    "{c}: {got:?} {plain:?} {cyl:?}"
                );
            } else {
                assert!(got == plain && (plain[c] / cyl[c] - 1.0).abs() < 0.02, "{c}: {plain:?} vs {cyl:?}");
            }
        }
    }
}

/// The exit direction's coupling to the light (`bssrdf::coupling`) on a flat slab (8 × 8 × 4 mm)
/// of a forward-scattering medium (n 1.4, σa 0.5, σs 10 mm⁻¹, g 0.8: A ≈ −0.18, the two-layer
/// skin's order) under a sun at 65°: the `hierarchical` radiance at the centre sent back to the
/// sun's side (exit azimuth 0) and to the mirror side (π), as the first harmonic
/// Σ (L₀ − L_π) μ / Σ (L₀ + L_π) μ over 80 exit cosines in [0.2, 1], against the same harmonic
/// 2 Σ w cos Δφ / Σ w of an independent engine run ([`CouplingTally`], pencil at 65°, 4·10⁵
/// photons): within 0.015 (the stated model tolerance: the sin θo form, χ² 2–6 for 4 degrees of
/// freedom, and A pooled over the angles) + 4σ (the engine run's and the table's fitted A). An exit term symmetric about the
/// normal has no harmonic (0), outside that bound (asserted: the test fails without the coupling).
#[test]
fn forward_slab_exit_coupling_matches_the_engine_slow() {
    use super::super::hierarchical::Hierarchical;
    use super::super::shade::Translucency;
    use crate::bssrdf::coupling::{CouplingTally, COUPLING_BINS};
    use crate::mc::{run, RunConfig, Source};
    use crate::rng::PhotonRng;
    let (sa, ss, g, eta, theta) = (0.5, 10.0, 0.8, 1.4, 65f64.to_radians());
    let stack = Stack::new(vec![Layer::new(eta, sa, ss, g, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let spec = one_layer("materials.forward", (sa, ss, g, eta), 10_000, None);
    let m = spec.build(true, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap().unwrap();
    let table = m.adaptive.clone().unwrap();
    let slab = cuboid([-4.0, -4.0, -4.0], [4.0, 4.0, 0.0]).unwrap();
    let sun = Light::directional("sun", [theta.sin(), 0.0, theta.cos()], [1.0; 3]).unwrap();
    let obj = Object { name: "slab".into(), mesh: slab, material: 0 };
    let s = Scene::new(vec![obj], vec![Material::Translucent(Box::new(m))], vec![sun], [0.0; 3], None).unwrap();
    let params = HierarchicalParams { spacing: 2.0, ..HierarchicalParams::default() };
    let h = Hierarchical::new(&s, &params, 7).unwrap();
    let hit = s.accel.intersect([0.3, 0.2, 50.0], [0.0, 0.0, -1.0], f64::INFINITY, u32::MAX).unwrap();
    let (steps, lo) = (80, 0.2);
    let (mut diff, mut sum) = ([0.0; 3], [0.0; 3]);
    for i in 0..steps {
        let mu = lo + (1.0 - lo) * (i as f64 + 0.5) / steps as f64;
        let st = (1.0 - mu * mu).sqrt();
        let l0 = h.radiance(&s, &hit, [st, 0.0, mu], 0, &mut PhotonRng::new(3, i as u64));
        let lpi = h.radiance(&s, &hit, [-st, 0.0, mu], 0, &mut PhotonRng::new(3, i as u64));
        for k in 0..3 {
            diff[k] += (l0[k] - lpi[k]) * mu;
            sum[k] += (l0[k] + lpi[k]) * mu;
        }
    }
    let source = Source::Pencil { theta, phi: 0.0 };
    let cfg = RunConfig { photons: 400_000, seed: 4343, threads: Some(2), source, isa: None };
    let o = run(&stack, &cfg, CouplingTally::default, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
    let (w, se) = o.tally.data();
    let first = (lo * COUPLING_BINS as f64).round() as usize;
    let total: f64 = w[first..COUPLING_BINS].iter().sum();
    let want = 2.0 * w[COUPLING_BINS + first..].iter().sum::<f64>() / total;
    let sig_engine = 2.0 * se[COUPLING_BINS + first..].iter().map(|x| x * x).sum::<f64>().sqrt() / total;
    for k in 0..3 {
        let got = diff[k] / sum[k];
        let sig_table = table.coupling(k).stderr * theta.sin();
        let bound = 0.015 + 4.0 * sig_engine.hypot(sig_table);
        println!("channel {k}: model harmonic {got:+.4}, engine {want:+.4} ± {sig_engine:.4} (table ± {sig_table:.4}), bound {bound:.4}");
        assert!((got - want).abs() < bound, "channel {k}: {got} vs {want}, bound {bound}");
        assert!(want.abs() > bound, "an exit term symmetric about the normal (no harmonic) passes too");
    }
}
