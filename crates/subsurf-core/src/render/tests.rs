//! Tests of the renderer as a whole: the "Must show" list on the Rust side.
//! Fixed seeds; tolerances from standard errors (4σ) or the stated bounds.

use super::driver::{with_threads, Method, Renderer};
use super::hierarchical::{Hierarchical, HierarchicalParams};
use super::light::Light;
use super::material::{Material, TestProfile, Translucent};
use super::math::{Rgb, V3};
use super::mesh::Mesh;
use super::scene::{Object, Scene};
use super::shade::ft;
use super::shapes::{cuboid, icosphere};
use super::walk_sim::{simulate, BeamSource, VoxelGrid, WalkConfig};
use super::walk_tests::image_sum_stats;
use super::Camera;
use crate::bssrdf::RadialProfile;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

fn test_material(total: [f64; 3], s: f64, sigma_a: Rgb, sigma_s: Rgb, g: f64, eta: f64, ss: bool) -> Material {
    let profiles: [Arc<dyn RadialProfile>; 3] =
        std::array::from_fn(|k| Arc::new(TestProfile { total: total[k], s }) as _);
    Material::Translucent(Box::new(Translucent::new("m", sigma_a, sigma_s, g, eta, Some(profiles), ss).unwrap()))
}

fn scene(meshes: Vec<Mesh>, m: Material, lights: Vec<Light>, env: Rgb, cam: Option<Camera>) -> Arc<Scene> {
    let objects = meshes
        .into_iter()
        .enumerate()
        .map(|(i, mesh)| Object { name: format!("objects[{i}]"), mesh, material: 0 })
        .collect();
    Arc::new(Scene::new(objects, vec![m], lights, env, cam).unwrap())
}

fn render(s: &Arc<Scene>, method: Method, spp: u32, hp: &HierarchicalParams) -> Vec<f64> {
    let cam = s.camera.as_ref().unwrap();
    let r = Renderer::new(s.clone(), method, 7, hp).unwrap();
    let mut acc = vec![0.0; cam.width * cam.height * 3];
    assert!(r.pass(0, spp, &mut acc, &AtomicBool::new(false)));
    acc.iter().map(|v| v / spp as f64).collect()
}

/// Mean and standard error of a pixel's samples, per channel.
fn pixel_stats(r: &Renderer, x: usize, y: usize, n: u32) -> ([f64; 3], [f64; 3]) {
    let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
    for i in 0..n {
        let l = r.sample(x, y, i);
        for k in 0..3 {
            s[k] += l[k];
            s2[k] += l[k] * l[k];
        }
    }
    let m: [f64; 3] = std::array::from_fn(|k| s[k] / n as f64);
    (m, std::array::from_fn(|k| ((s2[k] / n as f64 - m[k] * m[k]).max(0.0) / (n as f64 - 1.0)).sqrt()))
}

/// A camera looking straight down at the origin from height 50 mm, `n`×`n` pixels, fov 0.5°.
fn down_camera(n: usize) -> Camera {
    Camera::new([0.0, 0.0, 50.0], [0.0; 3], [0.0, 1.0, 0.0], 0.5, n, n).unwrap()
}

/// Flat slab, hierarchical: the exitance in the middle equals total × transmitted irradiance
/// (to 1 %): the radiance seen at normal view is F_t(0) · total · F_t(0) E / (π c(η)). Power: the
/// probe's band (4σ + 0.1 %) is 2.9 % of the value, so a 3 % bias of the probe fails.
#[test]
fn flat_slab_hierarchical_and_probe_match_the_profile_total() {
    let eta = 1.4;
    let total = [0.7, 0.5, 0.3];
    let m = test_material(total, 2.0, [0.01; 3], [1.0; 3], 0.0, eta, false);
    let slab = cuboid([-15.0, -15.0, -10.0], [15.0, 15.0, 0.0]).unwrap();
    let sun = Light::directional("sun", [0.0, 0.0, 1.0], [1.0; 3]).unwrap();
    let s = scene(vec![slab], m, vec![sun], [0.0; 3], Some(down_camera(3)));
    let Material::Translucent(t) = &s.materials[0] else { unreachable!() };
    let f0 = ft(eta, 1.0);
    let want: Vec<f64> = total.iter().map(|&tt| f0 * tt * f0 / (PI * t.c_norm)).collect();
    let img = render(&s, Method::Hierarchical, 1, &HierarchicalParams::default());
    for k in 0..3 {
        let got = img[(4 * 3) + k];
        println!("hierarchical channel {k}: {got:.6} vs {:.6} ({:+.3} %)", want[k], 100.0 * (got / want[k] - 1.0));
        assert!((got / want[k] - 1.0).abs() < 0.01);
    }
    let r = Renderer::new(s.clone(), Method::Probe, 11, &HierarchicalParams::default()).unwrap();
    let (mean, se) = pixel_stats(&r, 1, 1, 20_000);
    for k in 0..3 {
        println!("probe channel {k}: {:.6} ± {:.6} vs {:.6}", mean[k], se[k], want[k]);
        assert!((mean[k] - want[k]).abs() < 4.0 * se[k] + 1e-3 * want[k], "channel {k}");
    }
}

/// The octree's cluster approximation against the exact all-pairs sum over the same samples:
/// within 0.5 % at every test point (a lit sphere: area light and environment).
#[test]
fn hierarchical_matches_all_pairs_slow() {
    let m = test_material([0.8, 0.6, 0.4], 3.0, [0.01; 3], [1.0; 3], 0.0, 1.3, false);
    let light = Light::rect("l", [0.0, 0.0, 30.0], [5.0, 0.0, 0.0], [0.0, -5.0, 0.0], [2000.0; 3]).unwrap();
    let s = scene(vec![icosphere([0.0; 3], 10.0, 4).unwrap()], m, vec![light], [0.05; 3], None);
    let h = Hierarchical::new(&s, &HierarchicalParams::default(), 3).unwrap();
    let tree = h.trees[0].as_ref().unwrap();
    let mat = s.materials[0].translucent().unwrap();
    let mut worst: f64 = 0.0;
    println!("{} irradiance samples", tree.samples.len());
    for j in (0..tree.samples.len()).step_by(tree.samples.len() / 97) {
        let x = tree.samples[j].p;
        let fast = tree.exitance(mat, x, h.params.epsilon);
        let exact = tree.exitance(mat, x, 0.0);
        for k in 0..3 {
            worst = worst.max((fast[k] / exact[k] - 1.0).abs());
        }
    }
    println!("worst relative difference {worst:.2e} (epsilon {})", h.params.epsilon);
    assert!(worst < 5e-3);
    assert!(worst > 0.0, "no cluster was used: the comparison would be vacuous");
}

fn lit_sphere(level: u32, method_camera: usize) -> Arc<Scene> {
    let m = test_material([0.8, 0.6, 0.4], 0.7, [0.01; 3], [1.0; 3], 0.0, 1.3, true);
    let light = Light::sphere("l", [20.0, 10.0, 30.0], 4.0, [5000.0; 3]).unwrap();
    let cam = Camera::new([0.0, -60.0, 10.0], [0.0; 3], [0.0, 0.0, 1.0], 22.0, method_camera, method_camera).unwrap();
    scene(vec![icosphere([0.0; 3], 10.0, level).unwrap()], m, vec![light], [0.1, 0.1, 0.12], Some(cam))
}

/// probe converges to the hierarchical image on a lit sphere: at a few pixels, within 4σ of
/// the probe estimate plus the hierarchical method's own discretisation bound (1 %). Power: the
/// band is 4.1 % of the radiance (3.1 % of it 4σ), so a disagreement over ~4 % fails.
#[test]
fn probe_agrees_with_hierarchical_on_a_sphere_slow() {
    let s = lit_sphere(4, 16);
    let hp = HierarchicalParams::default();
    let hier = Renderer::new(s.clone(), Method::Hierarchical, 4, &hp).unwrap();
    let r = Renderer::new(s.clone(), Method::Probe, 5, &hp).unwrap();
    for (x, y) in [(8, 8), (5, 6), (11, 9), (7, 12)] {
        let (mean, se) = pixel_stats(&r, x, y, 8000);
        let (hv, hse) = pixel_stats(&hier, x, y, 8000);
        for k in 0..3 {
            let sig = (se[k] * se[k] + hse[k] * hse[k]).sqrt();
            println!(
                "pixel ({x},{y}) ch {k}: probe {:.5} ± {:.5}, hierarchical {:.5} ± {:.5}",
                mean[k], se[k], hv[k], hse[k]
            );
            assert!((mean[k] - hv[k]).abs() < 4.0 * sig + 0.01 * hv[k], "pixel ({x},{y}) channel {k}");
        }
    }
}

/// Tessellation: an icosphere at subdivision 3 and at 5 gives the same image within 1 %
/// (mean over the sphere's pixels, per channel; pbrt-v4 issue #504 shows renderers failing it).
#[test]
fn tessellation_3_vs_5_within_one_percent() {
    let hp = HierarchicalParams::default();
    let a = render(&lit_sphere(3, 24), Method::Hierarchical, 2, &hp);
    let b = render(&lit_sphere(5, 24), Method::Hierarchical, 2, &hp);
    let (mut sa, mut sb) = ([0.0; 3], [0.0; 3]);
    for i in 0..24 * 24 {
        for k in 0..3 {
            sa[k] += a[3 * i + k];
            sb[k] += b[3 * i + k];
        }
    }
    for k in 0..3 {
        println!("channel {k}: level 3 {:.5}, level 5 {:.5} ({:+.3} %)", sa[k], sb[k], 100.0 * (sa[k] / sb[k] - 1.0));
        assert!((sa[k] / sb[k] - 1.0).abs() < 0.01);
    }
}

/// Furnace: albedo 1, no absorption, inside a constant environment: random_walk returns
/// exactly the environment radiance at every pixel (equal σt in every channel, or one walk per
/// channel: every sample is exact); with unequal σs and spectral MIS, and with the
/// environment's next-flight estimator, the mean is the environment within 4σ. Power: exact to 10⁻¹² with equal σt; with unequal σs the 4σ band
/// is 3.8 % (2.1 % with the estimator), so a 4 % loss or gain of energy fails.
#[test]
fn furnace_random_walk_slow() {
    use super::random_walk::RandomWalk;
    let unequal = [0.5, 2.0, 6.0];
    for (sigma_s, env_nee, split) in
        [([2.0; 3], false, false), ([2.0; 3], true, false), (unequal, false, false), (unequal, false, true)]
    {
        let exact = (sigma_s == [2.0; 3] || split) && !env_nee;
        let m = test_material([0.5; 3], 1.0, [0.0; 3], sigma_s, 0.7, 1.4, false);
        let cam = Camera::new([0.0, -30.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 25.0, 8, 8).unwrap();
        let s = scene(vec![icosphere([0.0; 3], 5.0, 3).unwrap()], m, vec![], [0.25; 3], Some(cam));
        // Exact per sample: the plain walk (every walk leaves with β = 1), with equal σt or one
        // walk per channel. Spectral MIS over unequal σt and the environment's next-flight
        // estimator (opt-in) give up that property: their means are checked within 4σ.
        let mut rw = RandomWalk::new(&s);
        (rw.env_nee, rw.split_channels, rw.rr_threshold) = (env_nee, split, if split { 0.1 } else { 1.0 });
        let r = Renderer::from_parts(s.clone(), Box::new(rw), 1);
        if exact {
            for y in 0..8 {
                for x in 0..8 {
                    for i in 0..4 {
                        let l = r.sample(x, y, i);
                        assert!(l.iter().all(|&v| (v - 0.25).abs() < 1e-12), "pixel ({x},{y}): {l:?}");
                    }
                }
            }
        } else {
            let (mean, se) = pixel_stats(&r, 4, 4, 20_000);
            println!("furnace, sigma_s {sigma_s:?}: {mean:?} ± {se:?}");
            for k in 0..3 {
                assert!((mean[k] - 0.25).abs() < 4.0 * se[k] + 1e-12, "channel {k}");
            }
        }
    }
}

/// random_walk against the Monte Carlo engine: a pencil beam on a large, thick box; the total
/// exitance equals the engine's total diffuse reflectance of the semi-infinite layer within 4σ
/// (two geometry codes, one physics), and the energy balance closes. Power: the 4σ band is 2.1 %
/// of R_d, so a 2 % bias of the walk fails.
#[test]
fn walk_simulation_matches_the_engine_on_a_slab_slow() {
    use crate::mc::tally::totals::{Total, Totals};
    use crate::mc::{run, RunConfig};
    use crate::medium::{Layer, Stack};
    let (mua, mus, g, n) = (0.1, 10.0, 0.8, 1.4);
    let m = test_material([0.5; 3], 1.0, [mua; 3], [mus; 3], g, n, false);
    let slab = cuboid([-40.0, -40.0, -30.0], [40.0, 40.0, 0.0]).unwrap();
    let s = scene(vec![slab], m, vec![], [0.0; 3], None);
    let grid = VoxelGrid { lo: [-5.0, -5.0, -5.0], hi: [5.0, 5.0, 0.0], n: [10, 10, 10] };
    let cfg = WalkConfig {
        source: BeamSource::Pencil { origin: [0.0, 0.0, 10.0], direction: [0.0, 0.0, -1.0] },
        photons: 40_000,
        seed: 5,
        channel: 1,
        voxels: Some(grid),
    };
    let t = simulate(&s, &cfg, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
    let (rd, se) = t.exitance_total();
    let stack = Stack::new(vec![Layer::new(n, mua, mus, g, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let out = run(&stack, &RunConfig::new(200_000, 9), || Totals::new(1), &AtomicBool::new(false), &AtomicU64::new(0))
        .unwrap();
    let (mc, mc_se) = out.tally.get(Total::Diffuse);
    let (spec, _) = out.tally.get(Total::Specular);
    println!(
        "walk Rd {rd:.5} ± {se:.5}; engine Rd {mc:.5} ± {mc_se:.5}; specular {:.5} vs {spec:.5}",
        t.specular / t.photons as f64
    );
    assert!((rd - mc).abs() < 4.0 * (se * se + mc_se * mc_se).sqrt());
    let bal = (t.specular + t.exit_sum + t.absorbed + t.roulette + t.lost) / t.photons as f64;
    assert!((bal - 1.0).abs() < 1e-9, "energy balance {bal}");
    assert!(t.voxels.iter().sum::<f64>() <= t.absorbed + 1e-9 && t.voxels.iter().sum::<f64>() > 0.5 * t.absorbed);
}

/// The same image for any thread count.
#[test]
fn same_seed_same_image_any_thread_count() {
    let s = lit_sphere(2, 8);
    let hp = HierarchicalParams::default();
    for method in [Method::Hierarchical, Method::Probe, Method::RandomWalk] {
        let a = with_threads(Some(1), || render(&s, method, 2, &hp)).unwrap();
        let b = with_threads(Some(2), || render(&s, method, 2, &hp)).unwrap();
        assert_eq!(a, b, "{method:?}");
    }
}

/// `samples_per_exitance` (one tree walk per block of a pixel's samples, kept per pixel): the
/// same bits for any thread count, and for any split into passes to rounding; and against one walk per sample
/// (the same set-up, seed and points in the pixels) the mean of the per-pixel differences is
/// within 4σ of 0 (σ from their spread): only the pairing of each sample's direction with the
/// exitance of its block's first point differs.
#[test]
fn shared_exitance_blocks_keep_the_image() {
    let s = lit_sphere(3, 24);
    let cam = s.camera.as_ref().unwrap();
    let blocks = HierarchicalParams { samples_per_exitance: 8, ..Default::default() };
    let each = HierarchicalParams { samples_per_exitance: 1, ..Default::default() };
    let passes = |hp: &HierarchicalParams, cuts: &[u32]| {
        let r = Renderer::new(s.clone(), Method::Hierarchical, 7, hp).unwrap();
        let mut acc = vec![0.0; cam.width * cam.height * 3];
        for w in cuts.windows(2) {
            assert!(r.pass(w[0], w[1], &mut acc, &AtomicBool::new(false)));
        }
        acc
    };
    let a = with_threads(Some(1), || passes(&blocks, &[0, 16])).unwrap();
    assert!(a == with_threads(Some(2), || passes(&blocks, &[0, 16])).unwrap(), "the thread count changed the image");
    // passes add their sums in another order: the same to rounding
    let b = with_threads(Some(2), || passes(&blocks, &[0, 1, 3, 11, 16])).unwrap();
    assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= 1e-12 * x.abs()), "the passes changed the image");
    let c = with_threads(Some(2), || passes(&each, &[0, 16])).unwrap();
    let d: Vec<f64> = a.iter().zip(&c).filter(|(x, _)| **x > 0.0).map(|(x, y)| (x - y) / 16.0).collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0)).sqrt();
    let level = c.iter().sum::<f64>() / 16.0 / n;
    println!("{n} values: mean difference {mean:.3e} ± {:.1e} (level {level:.4})", sd / n.sqrt());
    assert!(mean.abs() < 4.0 * sd / n.sqrt(), "{mean} vs σ {}", sd / n.sqrt());
    assert!(sd > 0.0 && sd < 0.2 * level, "the blocks changed the pixels by {sd} at a level of {level}");
}

/// The light that crosses a translucent part unscattered (`shade::unscattered`): a 1 mm slab
/// that hardly scatters (σs = 10⁻⁶ mm⁻¹, a profile of total 10⁻⁹) between the camera and an
/// area light, seen at normal incidence: the BSSRDF methods see the light through it at
/// (1 − F(0))² e^(−σt d) of its radiance (to 10⁻³: the rays within 0.25° of the normal); the
/// random walk does too (its paths include it), within 4σ.
#[test]
fn the_bssrdf_methods_see_a_light_through_a_thin_part() {
    let (eta, sa) = (1.4, [0.5, 1.0, 2.0]);
    let m = test_material([1e-9; 3], 1.0, sa, [1e-6; 3], 0.0, eta, false);
    let slab = cuboid([-15.0, -15.0, -1.0], [15.0, 15.0, 0.0]).unwrap();
    let light = Light::rect("l", [0.0, 0.0, -10.0], [20.0, 0.0, 0.0], [0.0, 20.0, 0.0], [1600.0 * PI; 3]).unwrap();
    let s = scene(vec![slab], m, vec![light], [0.0; 3], Some(down_camera(2)));
    let f = 1.0 - crate::optics::fr_dielectric(1.0, 1.0, eta);
    for method in [Method::Hierarchical, Method::Probe] {
        let img = render(&s, method, 4, &HierarchicalParams::default());
        for k in 0..3 {
            let want = f * f * (-(sa[k] + 1e-6f64)).exp(); // the light's radiance is 1
            let got = img[k];
            println!("{method:?} channel {k}: {got:.6} vs {want:.6}");
            assert!((got / want - 1.0).abs() < 1e-3, "{method:?} channel {k}: {got} vs {want}");
        }
    }
    let walk = Renderer::new(s.clone(), Method::RandomWalk, 3, &HierarchicalParams::default()).unwrap();
    let (mean, se) = pixel_stats(&walk, 0, 0, 4000);
    for k in 0..3 {
        let want = f * f * (-sa[k]).exp();
        println!("walk channel {k}: {:.5} ± {:.5} vs {want:.5}", mean[k], se[k]);
        assert!((mean[k] - want).abs() < 4.0 * se[k] + 1e-3 * want, "walk channel {k}");
    }
}

/// A camera inside an object, random_walk on an open mesh, unknown method: clear errors.
#[test]
fn bad_scenes_are_refused() {
    let m = test_material([0.5; 3], 1.0, [0.1; 3], [1.0; 3], 0.0, 1.3, false);
    let inside = Camera::new([0.0, 0.0, 0.5], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 40.0, 4, 4).unwrap();
    let objects = vec![Object { name: "objects[0]".into(), mesh: icosphere([0.0; 3], 2.0, 2).unwrap(), material: 0 }];
    let e = Scene::new(objects, vec![m.clone()], vec![], [1.0; 3], Some(inside)).err().unwrap().to_string();
    assert!(e.contains("camera.position") && e.contains("inside objects[0]"), "{e}");
    let open =
        Mesh::new("objects[0]", vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2]], None).unwrap();
    let s = scene(vec![open], m, vec![], [1.0; 3], Some(down_camera(2)));
    let e = Renderer::new(s.clone(), Method::RandomWalk, 0, &HierarchicalParams::default()).err().unwrap().to_string();
    assert!(e.contains("not watertight"), "{e}");
    assert!(Method::from_name("method", "photon_map").unwrap_err().to_string().contains("random_walk"));
    let _: V3 = [0.0; 3];
}

/// Hostile input refused by the core, never a panic, an abort or a dropped light: huge images
/// (memory checked first), far cameras, overflowing light power, spp and thread counts, a walk
/// starting inside an object; a light inside a closed object is reported.
#[test]
fn extreme_inputs_are_refused_or_reported() {
    let cam = Camera::new([0.0, -30.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 30.0, 32768, 32768).unwrap();
    let e = cam.check_memory(Some(1 << 30)).unwrap_err().to_string();
    assert!(e.contains("32768 × 32768") && e.contains("244.813 GB"), "{e}");
    assert!(cam.check_memory(Some(u64::MAX)).is_ok());
    let e = Camera::new([0.0, -1e200, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 30.0, 4, 4).unwrap_err().to_string();
    assert!(e.starts_with("camera.position = -1e+200 is out of range"), "{e}");
    let e = Light::point("lights[0]", [0.0; 3], [1e308; 3]).unwrap_err().to_string();
    assert!(e.starts_with("lights[0].power[0] = 1e+308 is out of range"), "{e}");
    let Light::Directional { to_light, .. } = Light::directional("l", [1e300; 3], [1.0; 3]).unwrap() else {
        unreachable!()
    };
    assert!(to_light.iter().all(|&c| (c - 1.0 / 3f64.sqrt()).abs() < 1e-15), "{to_light:?}");
    assert!(Light::directional("l", [f64::NAN, 0.0, 1.0], [1.0; 3]).is_err());
    assert!(super::driver::check_spp(0).is_err() && super::driver::check_spp(1 << 32).is_err());
    assert_eq!(super::driver::check_spp(7).unwrap(), 7);
    let e = with_threads(Some(20_000), || ()).unwrap_err().to_string();
    assert!(e.starts_with("threads = 20000 is out of range: must be an integer in [1, 1024]"), "{e}");
    let m = test_material([0.5; 3], 1.0, [0.1; 3], [1.0; 3], 0.0, 1.3, false);
    let inside = Light::point("lights[0]", [0.0; 3], [1.0; 3]).unwrap();
    let s = scene(vec![icosphere([0.0; 3], 2.0, 2).unwrap()], m, vec![inside], [0.0; 3], None);
    assert_eq!(s.warnings(), ["lights[0] is inside the closed object objects[0]: it lights nothing outside it"]);
    let cfg = WalkConfig {
        source: BeamSource::Pencil { origin: [0.0; 3], direction: [0.0, 0.0, -1.0] },
        photons: 10,
        seed: 0,
        channel: 0,
        voxels: None,
    };
    let e = simulate(&s, &cfg, &AtomicBool::new(false), &AtomicU64::new(0)).err().unwrap().to_string();
    assert!(e.contains("source.origin: the pencil beam starts inside objects[0]"), "{e}");
}

/// Next-event estimation through facets changes the noise, not the answer: random_walk with
/// and without it (the area light then reached only by exits) agree within 4σ on a tessellated
/// sphere (R 5 mm) seen from above, under an 8 × 8 mm light 2 mm above its top (large and
/// close, so that exits find it often and both estimators converge): with the default
/// connection probability of area lights (c = 0.25: q ≤ 0.25 everywhere, connections weighted
/// by 1/q ≥ 4 at every collision, and the exits' partition decided for collisions that made
/// none, so that a wrong weight or partition of skipped connections shows), and with c = 1
/// (q = 1 at the surface). (Any q > 0
/// gives the same mean; the law of q, distance bounds included, changes only the noise.)
/// Power: each 4σ band is below 3 % of the radiance in every channel (checked), so a 3 % bias of
/// the facet connections (geometry factor, Fresnel, phase, attenuation) fails the test; a
/// factor 1.05 on `facet_nee::point` did.
#[test]
fn random_walk_nee_through_facets_is_unbiased_slow() {
    use super::random_walk::{NEE_SCALE, NEE_SCALE_AREA};
    let top = Light::rect("l", [0.0, 0.0, 7.0], [4.0, 0.0, 0.0], [0.0, -4.0, 0.0], [1000.0; 3]).unwrap();
    nee_matches_path_tracing("top", top, &[(NEE_SCALE_AREA, 3, 1400), (NEE_SCALE, 5, 1000)], 2500);
}

/// random_walk with next-event estimation (one renderer per (scale c, seed, samples) in
/// `cases`) against random_walk without it (`n` samples) under `light` (see
/// `random_walk_nee_through_facets_is_unbiased_slow`).
fn nee_matches_path_tracing(name: &str, light: Light, cases: &[(f64, u64, u32)], n: u32) {
    use super::random_walk::{RandomWalk, NEE_SCALE};
    let m = test_material([0.5; 3], 1.0, [0.2, 0.3, 0.5], [2.0; 3], 0.5, 1.4, false);
    let cam = Camera::new([0.0, 0.0, 6.0], [0.0; 3], [0.0, 1.0, 0.0], 30.0, 10, 10).unwrap();
    let s = scene(vec![icosphere([0.0; 3], 5.0, 3).unwrap()], m, vec![light], [0.0; 3], Some(cam));
    let without = Renderer::from_parts(s.clone(), Box::new(RandomWalk::variant(&s, false, NEE_SCALE)), 4);
    let (b, sb) = image_sum_stats(&without, n);
    for &(scale, seed, n) in cases {
        let with = Renderer::from_parts(s.clone(), Box::new(RandomWalk::variant(&s, true, scale)), seed);
        let (a, sa) = image_sum_stats(&with, n);
        for k in 0..3 {
            let band = 4.0 * (sa[k] * sa[k] + sb[k] * sb[k]).sqrt();
            println!(
                "{name}, c = {scale}, channel {k}: NEE {:.4} ± {:.4}, no NEE {:.4} ± {:.4}, 4σ band {:.2} %",
                a[k],
                sa[k],
                b[k],
                sb[k],
                100.0 * band / b[k]
            );
            assert!(band < 0.03 * b[k], "{name}, c = {scale}, channel {k}: too noisy to catch a 3 % bias");
            assert!((a[k] - b[k]).abs() < band, "{name}, c = {scale}, channel {k}");
        }
    }
}

/// A point light far above a slab gives the radiance of a directional light of the same
/// irradiance (the point connection's geometry factor against the collimated one). Both images
/// use the same seed, so their camera paths are the same and the per-sample differences have a
/// small spread (common random numbers): the band is 4σ of the mean difference plus 0.1 % for
/// the finite distance (depth/h ≈ 10⁻³). Power: the band is below 1 % of the radiance (checked),
/// so a 1 % bias of the point connection fails the test; a factor 1.05 on `facet_nee::point` did.
#[test]
fn random_walk_point_light_far_away_is_a_directional_light() {
    let m = test_material([0.5; 3], 1.0, [0.1; 3], [10.0; 3], 0.8, 1.4, false);
    let h = 2000.0;
    let cam = || Some(Camera::new([0.0, 0.0, 50.0], [0.0; 3], [0.0, 1.0, 0.0], 0.5, 4, 4).unwrap());
    let slab = || cuboid([-40.0, -40.0, -30.0], [40.0, 40.0, 0.0]).unwrap();
    let pt = Light::point("p", [0.0, 0.0, h], [4.0 * PI * h * h; 3]).unwrap();
    let dir = Light::directional("d", [0.0, 0.0, 1.0], [1.0; 3]).unwrap();
    let sp = scene(vec![slab()], m.clone(), vec![pt], [0.0; 3], cam());
    let sd = scene(vec![slab()], m, vec![dir], [0.0; 3], cam());
    let hp = HierarchicalParams::default();
    let rp = Renderer::new(sp, Method::RandomWalk, 1, &hp).unwrap();
    let rd = Renderer::new(sd, Method::RandomWalk, 1, &hp).unwrap();
    let (b, _) = image_sum_stats(&rd, 200);
    let (d, sd) = image_difference_stats(&rp, &rd, 200);
    let band = 4.0 * sd[0] + 1e-3 * b[0];
    println!(
        "point − directional {:+.5} ± {:.5} (directional {:.4}), band {:.3} %",
        d[0],
        sd[0],
        b[0],
        100.0 * band / b[0]
    );
    assert!(band < 0.01 * b[0], "too noisy to catch a 1 % bias");
    assert!(d[0].abs() < band);
}

/// Per-sample differences of the image sums of two renderers (same pixels, same sample indices):
/// (mean, standard error) per channel.
pub(super) fn image_difference_stats(r1: &Renderer, r2: &Renderer, n: u32) -> ([f64; 3], [f64; 3]) {
    let cam = r1.scene.camera.as_ref().unwrap();
    let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
    for i in 0..n {
        let mut x = [0.0; 3];
        for py in 0..cam.height {
            for px in 0..cam.width {
                x = super::math::add(x, super::math::sub(r1.sample(px, py, i), r2.sample(px, py, i)));
            }
        }
        for k in 0..3 {
            s[k] += x[k];
            s2[k] += x[k] * x[k];
        }
    }
    let m: [f64; 3] = std::array::from_fn(|k| s[k] / n as f64);
    (m, std::array::from_fn(|k| ((s2[k] / n as f64 - m[k] * m[k]).max(0.0) / (n as f64 - 1.0)).sqrt()))
}

/// A monte_carlo material of `photons` per channel, as the binding gives it.
fn mc_spec(photons: u64) -> super::TranslucentSpec {
    let stack = crate::medium::Stack::new(
        vec![crate::medium::Layer::new(1.3, 0.01, 1.0, 0.0, f64::INFINITY).unwrap()],
        1.0,
        1.0,
    )
    .unwrap();
    super::TranslucentSpec {
        field: "materials.m".into(),
        sigma_a: [0.01; 3],
        sigma_s: [1.0; 3],
        g: 0.0,
        eta: 1.3,
        model: "monte_carlo".into(),
        stacks: [stack.clone(), stack.clone(), stack],
        mc: crate::bssrdf::monte_carlo::McSettings { photons, ..Default::default() },
        reflectance: None,
        single_scattering: None,
        grid: None,
        texture: None,
        adaptive: None,
    }
}

/// A material for `random_walk` computes no profile (u64::MAX photons would
/// never end), and a Monte Carlo profile stops when its cancel flag is set.
#[test]
fn material_set_up_skips_unused_profiles_and_stops_when_cancelled() {
    let (never, done) = (AtomicBool::new(false), AtomicU64::new(0));
    let t = mc_spec(u64::MAX).build(false, &never, &done).unwrap().unwrap();
    assert!(t.bssrdf.is_none() && done.into_inner() == 0);
    let (cancel, done) = (AtomicBool::new(true), AtomicU64::new(0));
    assert!(mc_spec(u64::MAX).build(true, &cancel, &done).unwrap().is_none());
    let t = mc_spec(2000).build(true, &never, &done).unwrap().unwrap();
    assert!(t.bssrdf.is_some() && done.into_inner() == 6000);
    // the BSSRDF methods refuse a material prepared without profiles
    let m = Material::Translucent(Box::new(mc_spec(1).build(false, &never, &AtomicU64::new(0)).unwrap().unwrap()));
    let s = scene(vec![icosphere([0.0; 3], 5.0, 2).unwrap()], m, vec![], [1.0; 3], Some(down_camera(2)));
    for method in [Method::Hierarchical, Method::Probe] {
        let e = Renderer::new(s.clone(), method, 0, &HierarchicalParams::default()).err().unwrap();
        assert!(e.to_string().contains("has no profiles"), "{e}");
    }
    assert!(Renderer::new(s, Method::RandomWalk, 0, &HierarchicalParams::default()).is_ok());
}

/// The hierarchical set-up of a dense medium (millions of irradiance samples)
/// counts its samples, at most `max_samples`, and stops at once when cancelled.
#[test]
fn hierarchical_set_up_counts_and_stops_when_cancelled() {
    let m = test_material([0.5; 3], 1e5, [1e4; 3], [1e6; 3], 0.0, 1.3, false);
    let sun = Light::directional("sun", [0.0, 0.0, 1.0], [1.0; 3]).unwrap();
    let s = scene(vec![icosphere([0.0; 3], 5.0, 3).unwrap()], m, vec![sun], [0.0; 3], Some(down_camera(2)));
    let ctl = super::Control::default();
    ctl.cancel.store(true, std::sync::atomic::Ordering::Relaxed);
    let hp = HierarchicalParams { max_samples: 50_000, ..Default::default() };
    let r = Renderer::prepare(s.clone(), Method::Hierarchical, 0, &hp, &ctl).unwrap();
    assert!(r.is_none());
    let (done, total) = (ctl.done.into_inner(), ctl.total.into_inner());
    // at most `max_samples` (the facets' cut into k² gave 62 720 here before)
    assert!(done == 0 && (40_000..=50_000).contains(&total), "{done} of {total}");
    let hp = HierarchicalParams { max_samples: 500, ..Default::default() };
    let ctl = super::Control::default();
    assert!(Renderer::prepare(s, Method::Hierarchical, 0, &hp, &ctl).unwrap().is_some());
    let (done, total) = (ctl.done.into_inner(), ctl.total.into_inner());
    assert!(done == total && (400..=500).contains(&total), "{done} of {total}");
}

/// The pixels whose lists show that they see no surface (`Renderer::sky`) render the samples
/// that tracing them gives, bit for bit: a sphere seen in part of the image, in an environment,
/// each pixel's pass sum against its samples traced one by one; with a light in the scene no
/// pixel is taken for the environment.
#[test]
fn pixels_that_see_only_the_environment_are_their_samples() {
    let m = test_material([0.5; 3], 1.0, [0.02, 0.05, 0.1], [1.0; 3], 0.0, 1.3, false);
    let cam = Camera::new([0.0, -30.0, 4.0], [0.0; 3], [0.0, 0.0, 1.0], 30.0, 12, 10).unwrap();
    let env = [0.3, 0.7, 1.1];
    let s = scene(vec![icosphere([0.0; 3], 4.0, 2).unwrap()], m.clone(), vec![], env, Some(cam.clone()));
    let r = Renderer::new(s, Method::RandomWalk, 5, &HierarchicalParams::default()).unwrap();
    let spp = 3;
    let mut acc = vec![0.0; cam.width * cam.height * 3];
    assert!(r.pass(0, spp, &mut acc, &AtomicBool::new(false)));
    let mut sky = 0;
    for i in 0..cam.width * cam.height {
        sky += usize::from(r.sky(i) == Some(env));
        let mut want = [0.0; 3];
        for s in 0..spp {
            let l = r.sample(i % cam.width, i / cam.width, s);
            (0..3).for_each(|k| want[k] += l[k]);
        }
        assert_eq!(&acc[3 * i..3 * i + 3], &want, "pixel {i}");
    }
    assert!(sky > 20 && sky < 100, "{sky} of 120 pixels see the environment alone");
    let sun = Light::directional("sun", [0.0, 0.0, 1.0], [1.0; 3]).unwrap();
    let lit = scene(vec![icosphere([0.0; 3], 4.0, 2).unwrap()], m, vec![sun], env, Some(cam.clone()));
    let r = Renderer::new(lit, Method::RandomWalk, 5, &HierarchicalParams::default()).unwrap();
    assert!((0..cam.width * cam.height).all(|i| r.sky(i).is_none()));
}
