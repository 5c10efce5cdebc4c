//! Tests of the shared walk core with nested media: an index-matched inner mesh of the same
//! medium is invisible under every light (renderer), and two nested layers give the layered
//! Monte Carlo engine's answer (simulation). Fixed seeds; 4σ bands whose width is checked
//! against the bias each test must catch.

use super::driver::Renderer;
use super::light::Light;
use super::material::{Material, TestProfile, Translucent};
use super::math::{add, Rgb, V3};
use super::random_walk::{RandomWalk, NEE_SCALE};
use super::scene::{Object, Scene};
use super::shapes::{cuboid, icosphere};
use super::walk_sim::{simulate, BeamSource, WalkConfig};
use super::Camera;
use crate::bssrdf::RadialProfile;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

fn medium(sigma_a: Rgb, sigma_s: Rgb, g: f64, eta: f64) -> Material {
    let profiles: [Arc<dyn RadialProfile>; 3] =
        std::array::from_fn(|_| Arc::new(TestProfile { total: 0.5, s: 1.0 }) as _);
    Material::Translucent(Box::new(Translucent::new("m", sigma_a, sigma_s, g, eta, Some(profiles), false).unwrap()))
}

/// A sphere of radius 2 mm, and optionally a second sphere of radius 1.4 mm of the same
/// material inside it, seen by an 8×8 image that lies wholly on the sphere.
fn spheres(nested: bool, light: Option<Light>, env: Rgb) -> Arc<Scene> {
    let m = medium([0.2, 0.4, 0.8], [2.0, 2.5, 3.0], 0.5, 1.4);
    let mut objects = vec![Object { name: "outer".into(), mesh: icosphere([0.0; 3], 2.0, 3).unwrap(), material: 0 }];
    if nested {
        objects.push(Object { name: "inner".into(), mesh: icosphere([0.0; 3], 1.4, 3).unwrap(), material: 0 });
    }
    let cam = Camera::new([0.0, -12.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 12.0, 8, 8).unwrap();
    Arc::new(Scene::new(objects, vec![m], light.into_iter().collect(), env, Some(cam)).unwrap())
}

/// Mean and standard error, per channel, of the image sum over samples 0..n (per-pixel
/// streams; with `random_walk`'s Sobol coordinates a pixel's samples are stratified rather than
/// independent, so this σ is approximate: `sobol_walks_change_the_noise_not_the_answer` takes
/// its σ from independent renders instead).
pub(super) fn image_sum_stats(r: &Renderer, n: u32) -> (Rgb, Rgb) {
    columns_sum_stats(r, 0..r.scene.camera.as_ref().unwrap().width, n)
}

/// [`image_sum_stats`] of the pixel columns `cols` (all rows).
pub(super) fn columns_sum_stats(r: &Renderer, cols: std::ops::Range<usize>, n: u32) -> (Rgb, Rgb) {
    let cam = r.scene.camera.as_ref().unwrap();
    let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
    for i in 0..n {
        let mut x = [0.0; 3];
        for py in 0..cam.height {
            for px in cols.clone() {
                x = add(x, r.sample(px, py, i));
            }
        }
        for k in 0..3 {
            s[k] += x[k];
            s2[k] += x[k] * x[k];
        }
    }
    let m: Rgb = std::array::from_fn(|k| s[k] / n as f64);
    (m, std::array::from_fn(|k| ((s2[k] / n as f64 - m[k] * m[k]).max(0.0) / (n as f64 - 1.0)).sqrt()))
}

/// An inner sphere of the same medium (index-matched interface) changes nothing: the nested
/// image equals the single-sphere image within 4σ in every channel (`n` samples of each).
/// Power: each band 4σ is asserted to be below 10 % of the mean, so a 10 % loss cannot pass
/// (−72 %, −72 %, −15 %, −19 % were measured for point, directional, sphere and rectangle
/// lights before collisions in inner media connected to lights).
fn nested_matches_single(name: &str, light: Option<Light>, env: Rgb, n: u32, seed: u64) {
    let (sa, sb) = (spheres(false, light.clone(), env), spheres(true, light, env));
    let a = Renderer::from_parts(sa.clone(), Box::new(RandomWalk::new(&sa)), seed);
    let b = Renderer::from_parts(sb.clone(), Box::new(RandomWalk::new(&sb)), seed + 1);
    assert_images_agree(name, ("single", &a), ("nested", &b), n, 0.10);
}

/// The image sums of `a` and `b` (`n` samples each) agree within 4σ in every channel. Power:
/// every band 4σ is asserted below the fraction `power` of the mean, so a bias of that size
/// cannot pass.
pub(super) fn assert_images_agree(name: &str, a: (&str, &Renderer), b: (&str, &Renderer), n: u32, power: f64) {
    let ((ma, sa), (mb, sb)) = (image_sum_stats(a.1, n), image_sum_stats(b.1, n));
    let (mut powerless, mut failed) = (false, false);
    for k in 0..3 {
        let sig = (sa[k] * sa[k] + sb[k] * sb[k]).sqrt();
        println!(
            "{name} ch {k}: {} {:.5} ± {:.5}, {} {:.5} ± {:.5} ({:+.2} %, 4σ = {:.2} %)",
            a.0,
            ma[k],
            sa[k],
            b.0,
            mb[k],
            sb[k],
            100.0 * (mb[k] / ma[k] - 1.0),
            400.0 * sig / ma[k]
        );
        powerless |= 4.0 * sig >= power * ma[k];
        failed |= (ma[k] - mb[k]).abs() >= 4.0 * sig;
    }
    assert!(!powerless, "{name}: a band is too wide to see a {:.0} % bias", 100.0 * power);
    assert!(!failed, "{name}: {} and {} differ", a.0, b.0);
}

#[test]
fn nested_same_medium_is_invisible_point_light_slow() {
    nested_matches_single("point", Some(Light::point("l", [4.0, -6.0, 5.0], [400.0; 3]).unwrap()), [0.0; 3], 250, 0);
}

#[test]
fn nested_same_medium_is_invisible_directional_light_slow() {
    let l = Light::directional("l", [0.5, -0.6, 0.7], [1.0; 3]).unwrap();
    nested_matches_single("directional", Some(l), [0.0; 3], 200, 2);
}

/// Area lights: exits that reach the light (after an internal reflection, or from collisions
/// whose connections were skipped) are heavy-tailed, ∝ the light's radiance; large lights keep
/// the band below 10 %.
#[test]
fn nested_same_medium_is_invisible_sphere_light_slow() {
    let l = Light::sphere("l", [8.0, -10.0, 6.0], 5.0, [2000.0; 3]).unwrap();
    nested_matches_single("sphere", Some(l), [0.0; 3], 1100, 4);
}

#[test]
fn nested_same_medium_is_invisible_rect_light_slow() {
    let l = Light::rect("l", [0.0, -8.0, 8.0], [-6.0, 0.0, 0.0], [0.0, 4.0, 4.0], [2000.0; 3]).unwrap();
    nested_matches_single("rect", Some(l), [0.0; 3], 400, 6);
}

#[test]
fn nested_same_medium_is_invisible_environment() {
    nested_matches_single("environment", None, [0.3; 3], 200, 8);
}

/// The environment's next-flight estimator changes the noise, not the answer: the walk with it
/// (opt-in: `env_nee`) against plain path tracing (no next-event estimation: the environment
/// found only by exits), image sums within 4σ. The scene exercises every part of the exit/
/// estimator partition: a sphere (η 1.4) holding a sphere of another medium and index (η 1.3:
/// a mismatched inner interface, where the chain stops and exits after it count), total
/// internal reflection, and a Lambertian floor that the refracted rays partly meet (those exits
/// count the floor, not the environment). Power: every band is checked below 5 %, so a 5 %
/// bias fails (dropping the exits' exclusion, counting both, gives +60 %; a missing Fresnel
/// weight +10 %).
#[test]
fn environment_next_flight_matches_path_tracing_slow() {
    let mats = vec![
        medium([0.2, 0.4, 0.8], [2.0, 2.5, 3.0], 0.5, 1.4),
        medium([0.6, 0.1, 0.3], [1.0, 4.0, 2.0], 0.0, 1.3),
        Material::lambertian("floor", [0.8, 0.6, 0.4]).unwrap(),
    ];
    let objects = vec![
        Object { name: "outer".into(), mesh: icosphere([0.0; 3], 2.0, 3).unwrap(), material: 0 },
        Object { name: "inner".into(), mesh: icosphere([0.0, 0.0, -0.3], 1.2, 2).unwrap(), material: 1 },
        Object { name: "floor".into(), mesh: cuboid([-8.0, -8.0, -3.0], [8.0, 8.0, -2.2]).unwrap(), material: 2 },
    ];
    let cam = Camera::new([0.0, -12.0, 3.0], [0.0; 3], [0.0, 0.0, 1.0], 12.0, 8, 8).unwrap();
    let s = Arc::new(Scene::new(objects, mats, vec![], [1.0, 0.8, 0.6], Some(cam)).unwrap());
    let mut with = RandomWalk::new(&s);
    with.env_nee = true;
    let a = Renderer::from_parts(s.clone(), Box::new(with), 11);
    let b = Renderer::from_parts(s.clone(), Box::new(RandomWalk::variant(&s, false, NEE_SCALE)), 12);
    assert_images_agree("environment next flight", ("estimator", &a), ("path tracing", &b), 700, 0.05);
}

/// Guided sampling towards the surface changes the noise, not the answer: the guided walk
/// (Dwivedi directions and stretched free paths, MIS against the classic walk) against the
/// classic one, image sums within 4σ, in an environment and under a rectangle light (facet
/// next-event estimation on: its exit partition must hold for guided paths too). An isotropic
/// medium (guided fraction ½; v = 2.9 mfp, a strong stretch) holding a sphere of another,
/// index-mismatched medium (guided by its own v; the flights that cross it continue classic).
/// Power: every band is checked below 5 %, so a 5 % bias fails (the MIS pdf without the
/// guided direction's pdf ratio gave +4 to +8 % in the environment and failed).
#[test]
fn guided_walk_matches_the_classic_walk_slow() {
    let mats = vec![medium([0.05, 0.2, 0.5], [3.0; 3], 0.0, 1.4), medium([0.3, 0.1, 0.2], [4.0, 2.0, 3.0], 0.0, 1.3)];
    if let Material::Translucent(m) = &mats[0] {
        assert!(super::guide::Dwivedi::for_medium(m).is_some());
    }
    let light = Light::rect("l", [0.0, -8.0, 8.0], [-6.0, 0.0, 0.0], [0.0, 4.0, 4.0], [1000.0; 3]).unwrap();
    for (name, light, env, n) in [("environment", None, [1.0; 3], 500), ("rect", Some(light), [0.0; 3], 600)] {
        let objects = vec![
            Object { name: "outer".into(), mesh: icosphere([0.0; 3], 2.0, 3).unwrap(), material: 0 },
            Object { name: "inner".into(), mesh: icosphere([0.0, 0.0, -0.3], 1.2, 2).unwrap(), material: 1 },
        ];
        let cam = Camera::new([0.0, -12.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 12.0, 8, 8).unwrap();
        let s = Arc::new(Scene::new(objects, mats.clone(), light.into_iter().collect(), env, Some(cam)).unwrap());
        let mut guided = RandomWalk::new(&s);
        guided.guided = true;
        let mut classic = RandomWalk::new(&s);
        classic.guided = false;
        let a = Renderer::from_parts(s.clone(), Box::new(guided), 21);
        let b = Renderer::from_parts(s.clone(), Box::new(classic), 22);
        assert_images_agree(&format!("guided, {name}"), ("guided", &a), ("classic", &b), n, 0.05);
    }
}

/// Nested spheres (radius 2 mm, and 1.2 mm off centre inside it) of the two media `mats`, in an
/// environment (1, 0.9, 0.8), seen by an 8×8 image that lies wholly on the outer sphere.
fn two_media_spheres(mats: Vec<Material>) -> Arc<Scene> {
    let objects = vec![
        Object { name: "outer".into(), mesh: icosphere([0.0; 3], 2.0, 3).unwrap(), material: 0 },
        Object { name: "inner".into(), mesh: icosphere([0.0, 0.0, -0.3], 1.2, 2).unwrap(), material: 1 },
    ];
    let cam = Camera::new([0.0, -12.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 12.0, 8, 8).unwrap();
    Arc::new(Scene::new(objects, mats, vec![], [1.0, 0.9, 0.8], Some(cam)).unwrap())
}

/// The environment-only defaults (one walk per colour channel, roulette below β = 0.1) change
/// the noise, not the answer: against one spectral-MIS walk with roulette at θ = 1 (the
/// defaults under lights), image sums within 4σ, on the nested spheres of two media (the
/// walks of a low channel run long: every channel's σt differs). Power: bands checked below 5 %.
#[test]
fn channel_walks_and_roulette_threshold_match_one_walk() {
    let mats =
        vec![medium([0.01, 0.1, 0.4], [2.0, 3.0, 4.0], 0.3, 1.4), medium([0.3, 0.02, 0.2], [4.0, 2.0, 3.0], 0.0, 1.3)];
    let s = two_media_spheres(mats);
    let mut split = RandomWalk::new(&s);
    assert!(split.split_channels && split.rr_threshold < 1.0);
    split.split_albedo = 0.0; // walks split (this medium's blue reduced albedo is 0.875): red, green-blue
    let mut one = RandomWalk::new(&s);
    (one.split_channels, one.rr_threshold, one.flight_mix) = (false, 1.0, 1.0);
    let a = Renderer::from_parts(s.clone(), Box::new(split), 31);
    let b = Renderer::from_parts(s.clone(), Box::new(one), 32);
    assert_images_agree("channel walks", ("per channel, θ 0.1", &a), ("one walk, θ 1", &b), 300, 0.05);
}

/// Walking a group several times per camera path (`walk_repeats`, [`super::walk_alloc`])
/// changes the noise, not the answer: red walked once and the green–blue walk three times
/// against once each, image sums within 4σ on the nested spheres of two media (bands checked
/// below 5 %); the green–blue sum's spread is smaller with three walks (its variance per
/// sample is the mean of three walks'). The pilot gives skin2 in an environment (red alone,
/// green and blue together: red's long walks are nearly lossless) more green–blue walks.
#[test]
fn repeated_walks_change_the_noise_not_the_answer() {
    let mats =
        vec![medium([0.01, 0.1, 0.4], [2.0, 3.0, 4.0], 0.3, 1.4), medium([0.3, 0.02, 0.2], [4.0, 2.0, 3.0], 0.0, 1.3)];
    let s = two_media_spheres(mats);
    let walks = |reps: [u32; 3]| {
        let mut rw = RandomWalk::new(&s);
        rw.split_albedo = 0.0; // red alone, green and blue together (as in the test above)
        rw.walk_repeats = vec![reps; 2];
        rw
    };
    let a = Renderer::from_parts(s.clone(), Box::new(walks([1, 3, 1])), 51);
    let b = Renderer::from_parts(s.clone(), Box::new(walks([1, 1, 1])), 52);
    assert_images_agree("repeated walks", ("green–blue ×3", &a), ("once each", &b), 300, 0.05);
    let ((_, sa), (_, sb)) = (image_sum_stats(&a, 300), image_sum_stats(&b, 300));
    assert!(sa[2] < 0.8 * sb[2], "blue's spread {:.5} with three walks, {:.5} with one", sa[2], sb[2]);
    let skin2 = medium([0.013, 0.07, 0.145], [1.09, 1.59, 1.79], 0.0, 1.3);
    let ball = vec![Object { name: "ear".into(), mesh: icosphere([0.0; 3], 2.0, 3).unwrap(), material: 0 }];
    let s2 = Scene::new(ball, vec![skin2], vec![], [1.0; 3], None).unwrap();
    let reps = RandomWalk::new(&s2).walk_repeats;
    assert!(reps[0][0] == 1 && reps[0][1] > 1, "skin2's walks per camera path: {:?}", reps[0]);
}

/// Free paths mixed towards the channel of least σt (the environment's default for walks that
/// carry every channel, in media where it pays) give the image of spectral MIS alone, within 4σ,
/// on the nested spheres of two media whose least-σt channels differ (red outside, green
/// inside), with the roulette threshold of the environment; and so does the pure least-σt
/// choice (mix 0).
#[test]
fn least_sigma_t_flights_match_spectral_mis() {
    let mats =
        vec![medium([0.05, 0.2, 0.5], [1.0, 1.2, 1.4], 0.0, 1.4), medium([0.3, 0.02, 0.4], [2.0, 1.5, 2.5], 0.0, 1.3)];
    for (m, least) in mats.iter().zip([0, 1]) {
        assert_eq!(super::random_walk::least_sigma_t(m.translucent().unwrap(), [1.0; 3]), Some(least));
    }
    let s = two_media_spheres(mats);
    let plain = |mix: f64| {
        let mut rw = RandomWalk::new(&s);
        assert!(rw.rr_threshold < 1.0 && rw.flight_mix == super::random_walk::FLIGHT_MIX);
        (rw.split_channels, rw.flight_mix) = (false, mix);
        rw
    };
    let b = Renderer::from_parts(s.clone(), Box::new(plain(1.0)), 42);
    for (mix, seed) in [(super::random_walk::FLIGHT_MIX, 41), (0.0, 43)] {
        let a = Renderer::from_parts(s.clone(), Box::new(plain(mix)), seed);
        assert_images_agree(&format!("mix {mix}"), ("least σt", &a), ("spectral MIS", &b), 300, 0.05);
    }
}

/// The walks of a camera path in an environment: one for every channel where a channel's
/// reduced albedo is below the split threshold (skin1); a walk each where every channel's albedo
/// is high (marble); skin2's blue (albedo 0.925) shares its green's walk, whose free paths then
/// mix towards green (the least σt of the two).
#[test]
fn environment_walks_group_the_short_channels() {
    use super::env_walk::walk_starts;
    use super::random_walk::{least_sigma_t, SPLIT_ALBEDO};
    let jensen = |sp: Rgb, sa: Rgb| medium(sa, sp, 0.0, 1.3);
    let cases = [
        (jensen([0.74, 0.88, 1.01], [0.032, 0.17, 0.48]), vec![[1.0; 3]]),
        (jensen([2.19, 2.62, 3.0], [0.0021, 0.0041, 0.0071]), vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
        (jensen([1.09, 1.59, 1.79], [0.013, 0.07, 0.145]), vec![[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]),
    ];
    for (mat, want) in cases {
        let m = mat.translucent().unwrap();
        let (starts, n) = walk_starts(m, SPLIT_ALBEDO);
        assert_eq!(starts[..n].to_vec(), want);
    }
    let skin2 = jensen([1.09, 1.59, 1.79], [0.013, 0.07, 0.145]);
    assert_eq!(least_sigma_t(skin2.translucent().unwrap(), [0.0, 1.0, 1.0]), Some(1));
    assert_eq!(least_sigma_t(skin2.translucent().unwrap(), [1.0, 0.0, 0.0]), None);
}

/// Two nested layers against the layered Monte Carlo engine: a pencil beam on a large box
/// whose top 0.4 mm is one medium (η 1.4) over a second one (η 1.33: a mismatched interface,
/// Fresnel inside) gives the engine's diffuse (and specular) reflectance of the two-layer stack
/// within 4σ; the energy balance closes with the roulette term booked apart (absorbed and the
/// roulette term: the deposits are never negative).
#[test]
fn two_nested_layers_match_the_layered_engine() {
    use crate::mc::tally::totals::{Total, Totals};
    use crate::mc::{run, RunConfig};
    use crate::medium::{Layer, Stack};
    let (top, bottom) = ((0.3, 6.0, 0.8, 1.4), (0.05, 10.0, 0.7, 1.33));
    let d1 = 0.4;
    let mats =
        vec![medium([top.0; 3], [top.1; 3], top.2, top.3), medium([bottom.0; 3], [bottom.1; 3], bottom.2, bottom.3)];
    let objects = vec![
        Object { name: "top".into(), mesh: cuboid([-40.0, -40.0, -30.0], [40.0, 40.0, 0.0]).unwrap(), material: 0 },
        Object { name: "bottom".into(), mesh: cuboid([-39.9, -39.9, -29.9], [39.9, 39.9, -d1]).unwrap(), material: 1 },
    ];
    let s = Scene::new(objects, mats, vec![], [0.0; 3], None).unwrap();
    let cfg = WalkConfig {
        source: BeamSource::Pencil { origin: [0.0, 0.0, 10.0], direction: [0.0, 0.0, -1.0] },
        photons: 20_000,
        seed: 8,
        channel: 0,
        voxels: None,
    };
    let t = simulate(&s, &cfg, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
    let (rd, se) = t.exitance_total();
    let stack = Stack::new(
        vec![
            Layer::new(top.3, top.0, top.1, top.2, d1).unwrap(),
            Layer::new(bottom.3, bottom.0, bottom.1, bottom.2, f64::INFINITY).unwrap(),
        ],
        1.0,
        1.0,
    )
    .unwrap();
    let out = run(&stack, &RunConfig::new(100_000, 9), || Totals::new(2), &AtomicBool::new(false), &AtomicU64::new(0))
        .unwrap();
    let (mc, mc_se) = out.tally.get(Total::Diffuse);
    let (spec, _) = out.tally.get(Total::Specular);
    let n = t.photons as f64;
    println!(
        "two layers: walk Rd {rd:.5} ± {se:.5}; engine {mc:.5} ± {mc_se:.5}; specular {:.5} vs {spec:.5}",
        t.specular / n
    );
    assert!((rd - mc).abs() < 4.0 * (se * se + mc_se * mc_se).sqrt());
    let spec_se = (spec * (1.0 - spec) / n).sqrt(); // all-or-none Fresnel: binomial
    assert!((t.specular / n - spec).abs() < 4.0 * spec_se);
    let bal = (t.specular + t.exit_sum + t.absorbed + t.roulette + t.lost) / n;
    assert!((bal - 1.0).abs() < 1e-12, "energy balance {bal}");
    assert!(t.absorbed > 0.0 && t.lost == 0.0);
}

/// A marble-like sphere (albedo ≈ 0.999, Jensen et al. 2001) of radius 10 mm under a
/// rectangle light and an environment, 12×12 pixels; `grid` false drops the distance bound.
fn marble(grid: bool) -> Arc<Scene> {
    let m = medium([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.0], 0.0, 1.5);
    let objects = vec![Object { name: "marble".into(), mesh: icosphere([0.0; 3], 10.0, 4).unwrap(), material: 0 }];
    let light = Light::rect("l", [0.0, -20.0, 30.0], [8.0, 0.0, 0.0], [0.0, -6.0, 6.0], [3e4; 3]).unwrap();
    let cam = Camera::new([0.0, -50.0, 10.0], [0.0; 3], [0.0, 0.0, 1.0], 24.0, 12, 12).unwrap();
    let mut s = Scene::new(objects, vec![m], vec![light], [0.05; 3], Some(cam)).unwrap();
    if !grid {
        s.accel.distance = None;
        s.accel.cells = None;
    }
    Arc::new(s)
}

/// The distance bound only skips free-path rays that could not change the path: images without
/// next-event estimation (whose connection probability the bound also sets, tested for
/// unbiasedness in `tests::random_walk_nee_through_facets_is_unbiased_slow`) and simulation
/// tallies are bit-identical with and without it.
#[test]
fn distance_bound_changes_no_number() {
    let img = |grid: bool| {
        let s = marble(grid);
        let r = Renderer::from_parts(s.clone(), Box::new(RandomWalk::variant(&s, false, NEE_SCALE)), 5);
        (0..12 * 12).map(|i| r.sample(i % 12, i / 12, 0)).collect::<Vec<Rgb>>()
    };
    assert_eq!(img(true), img(false));
    let cfg = WalkConfig {
        source: BeamSource::Pencil { origin: [0.0, 0.0, 20.0], direction: [0.0, 0.0, -1.0] },
        photons: 200,
        seed: 3,
        channel: 2,
        voxels: None,
    };
    let sim = |grid: bool| {
        let t = simulate(&marble(grid), &cfg, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
        (t.exit, t.absorbed, t.roulette, t.lost)
    };
    assert_eq!(sim(true), sim(false));
}

/// Not a check: the workload of the distance-bound measurement in docs/render.md (run under
/// `valgrind --tool=callgrind`, with and without `SUBSURF_WALK_NO_GRID` set).
#[test]
#[ignore]
fn marble_workload() {
    let grid = std::env::var_os("SUBSURF_WALK_NO_GRID").is_none();
    let s = marble(grid);
    let r = Renderer::from_parts(s.clone(), Box::new(RandomWalk::new(&s)), 9);
    let (m, s) = image_sum_stats(&r, 8);
    println!("grid {grid}: {m:?} ± {s:?}");
}

/// A thin lens (3 × 0.5 × 3 mm) cupped away from the camera (not convex) of a medium of index
/// η under a rect light behind it, seen by an 8 × 8 image from the front.
fn cupped_lens(eta: f64) -> Arc<Scene> {
    let s = icosphere([0.0; 3], 1.0, 3).unwrap();
    let cup = |p: &V3| [3.0 * p[0], 0.5 * p[1] + 0.9 * (p[0] * p[0] + p[2] * p[2]), 3.0 * p[2]];
    let lens = super::Mesh::new("lens", s.positions.iter().map(cup).collect(), s.triangles, None).unwrap();
    let light = Light::rect("l", [0.0, 5.0, 2.0], [4.0, 0.0, 0.0], [0.0, 1.0, 4.0], [3000.0; 3]).unwrap();
    lit(lens, medium([0.05, 0.2, 0.5], [3.0; 3], 0.6, eta), light, [0.0, -12.0, 0.0])
}

/// One object of material `m` under `light`, seen by an 8 × 8 image from `eye`.
fn lit(mesh: super::Mesh, m: Material, light: Light, eye: V3) -> Arc<Scene> {
    let cam = Camera::new(eye, [0.0; 3], [0.0, 0.0, 1.0], 24.0, 8, 8).unwrap();
    let objects = vec![Object { name: "o".into(), mesh, material: 0 }];
    Arc::new(Scene::new(objects, vec![m], vec![light], [0.0; 3], Some(cam)).unwrap())
}

/// The area lights' next-flight estimator (MIS with the facet connections) and the reflected
/// light's expected value change the noise, not the answer: the default walk against plain path
/// tracing (no next-event estimation: the light found only by exits), image sums within 4σ, on
/// a torus lit from the side (not convex: straight exits leave through facets the facet search
/// does not find, and the other side of the ring shades some; a large light close by, so that
/// path tracing converges) and on a cupped lens lit from behind (exits after a reflection off
/// the front face). Power: every band is checked below 5 %; the next flight without its MIS
/// weight (counting what the connections count) gave +25 % on the torus, without its occlusion
/// test +5 %.
#[test]
fn light_next_flight_matches_path_tracing_slow() {
    let light = Light::rect("l", [-5.0, 0.0, 2.0], [0.0, 20.0, 0.0], [2.0, 0.0, 20.0], [45000.0; 3]).unwrap();
    let torus = super::shapes::torus([0.0; 3], 2.5, 1.0, 32, 16).unwrap();
    let m = medium([0.05, 0.2, 0.5], [3.0; 3], 0.6, 1.4);
    for (name, s, n) in [("torus", lit(torus, m, light, [0.0, -12.0, 6.0]), 600), ("lens", cupped_lens(1.4), 600)] {
        let with = RandomWalk::new(&s);
        assert!(with.light_flight && with.reflected);
        let a = Renderer::from_parts(s.clone(), Box::new(with), 41);
        let b = Renderer::from_parts(s.clone(), Box::new(RandomWalk::variant(&s, false, NEE_SCALE)), 42);
        assert_images_agree(&format!("next flight, {name}"), ("estimators", &a), ("path tracing", &b), n, 0.05);
    }
}

/// The reflected light's expected value (`RandomWalk::reflected_light`) equals the light of the
/// exits it replaces (those after exactly one reflection off the boundary): the same walks
/// (the same seed; the estimate draws no random number) with it and without it, the mean
/// per-sample difference of the image sums within 4σ, on the cupped lens at η = 2 (reflections
/// ≈ 3.5 % of the image: counting both, estimate and exits, gave +3.5 %). Power: the band is
/// checked below 0.8 % of the image, so an error of a quarter of the estimate fails.
#[test]
fn reflected_light_matches_the_exits_it_replaces_slow() {
    let s = cupped_lens(2.0);
    let mut off = RandomWalk::new(&s);
    off.reflected = false;
    let a = Renderer::from_parts(s.clone(), Box::new(RandomWalk::new(&s)), 43);
    let b = Renderer::from_parts(s.clone(), Box::new(off), 43);
    let n = 300;
    let (d, sd) = super::tests::image_difference_stats(&a, &b, n);
    let (m, _) = image_sum_stats(&b, n);
    for k in 0..3 {
        println!("reflected light ch {k}: difference {:+.4} ± {:.4} of {:.3}", d[k], sd[k], m[k]);
        assert!(4.0 * sd[k] < 0.008 * m[k], "ch {k}: too noisy");
        assert!(d[k].abs() < 4.0 * sd[k], "ch {k}: the estimate differs from the exits");
    }
}

/// The Fresnel coin's control variate (`super::fresnel_control`, on by default in a scene lit by
/// the environment alone) changes the noise, not the answer: on a torus in an environment (not
/// convex: some refracted rays meet the ring again and keep the plain coin), the same walks (the
/// same seed; the control draws nothing) with and without it, the mean per-sample difference of
/// the image sums within 4σ of 0. Power: the band is checked below 0.3 % of the image; scoring
/// the control at reflections only (its exits' − c F β L left out) gave +0.64 % (35σ) in red. The pilot's
/// coefficients are those of a medium whose reflected walks lose light (0 < c < 1), zero in a
/// furnace (every walk leaves: V = 1), and the image is the same for 1 and 2 threads.
#[test]
fn fresnel_control_changes_the_noise_not_the_answer() {
    let torus = super::shapes::torus([0.0; 3], 2.5, 1.0, 32, 16).unwrap();
    let cam = Camera::new([0.0, -12.0, 6.0], [0.0; 3], [0.0, 0.0, 1.0], 24.0, 8, 8).unwrap();
    let scene = |m: Material| {
        let objects = vec![Object { name: "o".into(), mesh: torus.clone(), material: 0 }];
        Arc::new(Scene::new(objects, vec![m], vec![], [1.0, 0.9, 0.8], Some(cam.clone())).unwrap())
    };
    let s = scene(medium([0.05, 0.2, 0.5], [3.0; 3], 0.6, 1.4));
    let on = RandomWalk::new(&s);
    let c = on.fresnel_control[0];
    println!("control coefficients {c:?}");
    assert!(c.iter().all(|&c| c > 0.05 && c < 0.95), "{c:?}");
    let furnace = scene(medium([0.0; 3], [3.0; 3], 0.6, 1.4));
    assert_eq!(RandomWalk::new(&furnace).fresnel_control, vec![[0.0; 3]]);
    let mut off = RandomWalk::new(&s);
    off.fresnel_control = vec![];
    let a = Renderer::from_parts(s.clone(), Box::new(on), 44);
    let b = Renderer::from_parts(s.clone(), Box::new(off), 44);
    let n = 400;
    let (d, sd) = super::tests::image_difference_stats(&a, &b, n);
    let (m, _) = image_sum_stats(&b, n);
    for k in 0..3 {
        println!("Fresnel control ch {k}: difference {:+.4} ± {:.4} of {:.3}", d[k], sd[k], m[k]);
        assert!(4.0 * sd[k] < 0.003 * m[k], "ch {k}: too noisy");
        assert!(d[k].abs() < 4.0 * sd[k], "ch {k}: the control's mean is not zero");
    }
    let image = |threads| {
        super::driver::with_threads(Some(threads), || {
            let r = Renderer::from_parts(s.clone(), Box::new(RandomWalk::new(&s)), 7);
            let mut acc = vec![0.0; 8 * 8 * 3];
            assert!(r.pass(0, 2, &mut acc, &AtomicBool::new(false)));
            acc
        })
        .unwrap()
    };
    assert_eq!(image(1), image(2));
}

/// The Sobol coordinates of the camera walks' first events (`Qmc`) change the noise, not the
/// answer. A torus of a skin-like medium (non-convex: paths that leave and meet it again walk
/// on from the stream) in an environment, 8×8 pixels; R = 192 renders of 16 spp each (seeds
/// 100 …), with and without them: the image means agree within 4σ (σ from the spread of the
/// renders' means, a band below 0.5 % of the mean), and the per-pixel variance over the renders
/// is lower with them (bound 0.8×; the benchmark's skin torus measured 0.52×).
#[test]
fn sobol_walks_change_the_noise_not_the_answer() {
    let torus = super::shapes::torus([0.0; 3], 2.5, 1.0, 32, 16).unwrap();
    let cam = Camera::new([0.0, -12.0, 6.0], [0.0; 3], [0.0, 0.0, 1.0], 24.0, 8, 8).unwrap();
    let objects = vec![Object { name: "o".into(), mesh: torus, material: 0 }];
    let m = medium([0.03, 0.17, 0.48], [0.74, 0.88, 1.01], 0.0, 1.3);
    let s = Arc::new(Scene::new(objects, vec![m], vec![], [1.0; 3], Some(cam)).unwrap());
    let (r, spp, px) = (192u64, 16u32, 8 * 8 * 3);
    let renders = |qmc: bool| -> Vec<Vec<f64>> {
        (0..r)
            .map(|k| {
                let mut rw = RandomWalk::new(&s);
                rw.qmc = qmc;
                let mut acc = vec![0.0; px];
                assert!(Renderer::from_parts(s.clone(), Box::new(rw), 100 + k).pass(
                    0,
                    spp,
                    &mut acc,
                    &AtomicBool::new(false)
                ));
                acc.iter().map(|v| v / spp as f64).collect()
            })
            .collect()
    };
    let stats = |imgs: &[Vec<f64>]| {
        let n = imgs.len() as f64;
        let means: Vec<Rgb> =
            imgs.iter().map(|im| std::array::from_fn(|c| im.iter().skip(c).step_by(3).sum::<f64>() / 64.0)).collect();
        let mean: Rgb = std::array::from_fn(|c| means.iter().map(|m| m[c]).sum::<f64>() / n);
        let var: Rgb = std::array::from_fn(|c| means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / (n - 1.0));
        let pixel_var = (0..px)
            .map(|i| {
                let mu = imgs.iter().map(|im| im[i]).sum::<f64>() / n;
                imgs.iter().map(|im| (im[i] - mu).powi(2)).sum::<f64>() / (n - 1.0)
            })
            .sum::<f64>()
            / px as f64;
        (mean, var.map(|v| (v / n).sqrt()), pixel_var)
    };
    let ((ma, sa, va), (mb, sb, vb)) = (stats(&renders(true)), stats(&renders(false)));
    for c in 0..3 {
        let sig = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
        println!("ch {c}: Sobol {:.5} ± {:.5}, stream {:.5} ± {:.5}", ma[c], sa[c], mb[c], sb[c]);
        assert!(4.0 * sig < 0.005 * mb[c], "ch {c}: the band is too wide");
        assert!((ma[c] - mb[c]).abs() < 4.0 * sig, "ch {c}: the means differ");
    }
    println!("per-pixel variance: Sobol {va:.3e}, stream {vb:.3e} ({:.2}×)", va / vb);
    assert!(va < 0.8 * vb, "no variance reduction: {va:.3e} against {vb:.3e}");
}

/// The reflected camera ray thinned with the environment as its control (`shade::reflected`) is
/// unbiased where the ray meets the object again: from a facet of a thick torus's hole in a white
/// environment, the reflection of a ray met head-on crosses the hole to the far side (its
/// radiance a walk's, not the environment's). 400 000 estimates at q = 0.25 against 400 000 traced
/// ones (q = 1): means within 4σ per channel (σ from both spreads; the band below 2 % of the
/// mean), and the thinned spread larger (the thinning acts: this ray never escapes). The
/// method's q = min(1, F/F₀) (`shade::REFLECTED_F0`) is fixed by the ray before the draw, so
/// what holds at a fixed q holds for it.
#[test]
fn thinned_reflection_is_unbiased_where_it_meets_the_object() {
    use super::shade::reflected_q;
    let torus = super::shapes::torus([0.0; 3], 2.5, 1.0, 32, 16).unwrap();
    let objects = vec![Object { name: "o".into(), mesh: torus, material: 0 }];
    let m = medium([0.03, 0.17, 0.48], [0.74, 0.88, 1.01], 0.0, 1.3);
    let s = Scene::new(objects, vec![m], vec![], [1.0; 3], None).unwrap();
    // The facet whose normal meets the far side of the hole farthest away, met head-on: the
    // reflection is its normal.
    let (tri, t) = (0..s.accel.tris.len() as u32)
        .filter_map(|i| {
            let c = s.accel.point(i as usize, 1.0 / 3.0, 1.0 / 3.0);
            s.accel.intersect(c, s.accel.tris[i as usize].n, f64::INFINITY, i).map(|f| (i, f.t))
        })
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    let n = s.accel.tris[tri as usize].n;
    let c = s.accel.point(tri as usize, 1.0 / 3.0, 1.0 / 3.0);
    let h = s.accel.intersect(super::math::madd(c, n, 0.1), super::math::neg(n), 1.0, u32::MAX).expect("the facet");
    let r = crate::optics::reflect(super::math::neg(n), h.n);
    assert!(h.tri == tri && t > 2.5 && !s.accel.escapes(r, h.tri), "across the hole: {t}");
    let rw = RandomWalk::new(&s);
    let n = 400_000u64;
    let stats = |q: f64, seed: u64| -> ([f64; 3], [f64; 3]) {
        let (mut sum, mut sq) = ([0.0; 3], [0.0; 3]);
        for i in 0..n {
            let mut rng = crate::rng::PhotonRng::new(seed, i);
            let l = reflected_q(&s, &h, r, 1, &mut rng, &rw, q);
            for c in 0..3 {
                sum[c] += l[c];
                sq[c] += l[c] * l[c];
            }
        }
        let mean = sum.map(|v| v / n as f64);
        (mean, std::array::from_fn(|c| (sq[c] / n as f64 - mean[c] * mean[c]) / n as f64))
    };
    let ((mt, vt), (mq, vq)) = (stats(0.25, 31), stats(1.0, 32));
    for c in 0..3 {
        let sig = (vt[c] + vq[c]).sqrt();
        println!("ch {c}: thinned {:.4} ± {:.4}, traced {:.4} ± {:.4}", mt[c], vt[c].sqrt(), mq[c], vq[c].sqrt());
        assert!(4.0 * sig < 0.02 * mq[c], "ch {c}: band {sig}");
        assert!((mt[c] - mq[c]).abs() < 4.0 * sig, "ch {c}: {} against {}", mt[c], mq[c]);
        assert!(mq[c] < 0.95, "ch {c}: the far side is darker than the environment ({})", mq[c]);
        assert!(vt[c] > 1.5 * vq[c], "ch {c}: thinning adds noise here ({} against {})", vt[c], vq[c]);
    }
}
