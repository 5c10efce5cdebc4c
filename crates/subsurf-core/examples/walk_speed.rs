//! Measurement harness for the `random_walk` method's speed (docs/render.md, "Random walk
//! speed"): renders one of the measurement scenes at a fixed size and spp, prints the wall time
//! per spp and, against a stored long reference, the RMSE over the object's pixels and the
//! efficiency 1/(RMSE² × seconds). Run it under `valgrind --tool=callgrind` for instruction counts.
//!
//! Usage: `cargo run --release --example walk_speed -- SCENE SIZE SPP THREADS SEED [REF]`,
//! SCENE one of marble, marble-env, skin, leaf (see `scene`), or `marble512` (the benchmark's
//! 81,920-triangle sphere); with `REF` an existing file the image is compared with it, a missing
//! one is written (raw little-endian f64 RGB, row-major: the mean radiance per pixel).

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;
use subsurf_core::render::shapes::{icosphere, torus};
use subsurf_core::render::{with_threads, Camera, HierarchicalParams, Light, Material, Method, Object, Renderer};
use subsurf_core::render::{Mesh, Scene, Translucent};

fn medium(name: &str, sigma_s_prime: [f64; 3], sigma_a: [f64; 3], g: f64, eta: f64) -> Material {
    let sigma_s = sigma_s_prime.map(|s| s / (1.0 - g));
    Material::Translucent(Box::new(Translucent::new(name, sigma_a, sigma_s, g, eta, None, false).expect("valid")))
}

/// The measurement scenes (Jensen et al. 2001 media; σs = σs'/(1 − g)):
/// - marble: sphere R = 10 mm (5120 triangles), albedo ≈ 0.999, η 1.5, under the benchmark's
///   rectangle light and a dim environment (benches/render_bench.py's scene);
/// - marble-env: the same sphere in a constant environment only;
/// - skin: a torus (non-convex) of skin1 (albedo 0.68–0.96, g 0.8, η 1.4), rectangle light and
///   environment;
/// - leaf: a thin lens (icosphere scaled to 18 × 2.4 × 18 mm) of skin2 lit from behind by a
///   rectangle light;
/// - marble512: the benchmark's sphere of 81,920 triangles.
fn scene(name: &str, size: usize) -> Scene {
    let rect = Light::rect("l", [-20.0, -30.0, 40.0], [8.0, 0.0, 0.0], [0.0, -5.0, 5.0], [4e4; 3]).expect("valid");
    let cam = |pos: [f64; 3], fov| Camera::new(pos, [0.0; 3], [0.0, 0.0, 1.0], fov, size, size).expect("valid");
    let marble = || medium("marble", [2.19, 2.62, 3.0], [0.0021, 0.0041, 0.0071], 0.0, 1.5);
    let obj = |mesh: Mesh| vec![Object { name: "o".into(), mesh, material: 0 }];
    let (objects, mat, lights, env, camera) = match name {
        "marble" | "marble512" => {
            let level = if name == "marble" { 4 } else { 6 };
            let m = icosphere([0.0; 3], 10.0, level).expect("valid");
            (obj(m), marble(), vec![rect], [0.05, 0.05, 0.06], cam([0.0, -60.0, 10.0], 24.0))
        }
        "marble-env" => {
            let m = icosphere([0.0; 3], 10.0, 4).expect("valid");
            (obj(m), marble(), vec![], [1.0; 3], cam([0.0, -60.0, 10.0], 24.0))
        }
        "skin" => {
            let m = torus([0.0; 3], 7.0, 3.0, 64, 32).expect("valid");
            let skin = medium("skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48], 0.8, 1.4);
            (obj(m), skin, vec![rect], [0.05, 0.05, 0.06], cam([0.0, -40.0, 25.0], 30.0))
        }
        "leaf" => {
            let s = icosphere([0.0; 3], 1.0, 4).expect("valid");
            let pos = s.positions.iter().map(|p| [9.0 * p[0], 1.2 * p[1], 9.0 * p[2]]).collect();
            let m = Mesh::new("leaf", pos, s.triangles.clone(), None).expect("valid");
            let back =
                Light::rect("l", [0.0, 30.0, 10.0], [10.0, 0.0, 0.0], [0.0, 0.0, 10.0], [4e4; 3]).expect("valid");
            let skin = medium("skin2", [1.09, 1.59, 1.79], [0.013, 0.07, 0.145], 0.0, 1.3);
            (obj(m), skin, vec![back], [0.02; 3], cam([0.0, -45.0, 5.0], 30.0))
        }
        _ => panic!("scene: one of marble, marble-env, skin, leaf, marble512"),
    };
    Scene::new(objects, vec![mat], lights, env, Some(camera)).expect("valid scene")
}

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, what: &str| a.get(i).unwrap_or_else(|| panic!("missing {what}")).clone();
    let name = arg(0, "SCENE");
    let size: usize = arg(1, "SIZE").parse().expect("SIZE");
    let spp: u32 = arg(2, "SPP").parse().expect("SPP");
    let threads: usize = arg(3, "THREADS").parse().expect("THREADS");
    let seed: u64 = arg(4, "SEED").parse().expect("SEED");
    let sc = Arc::new(scene(&name, size));
    let r = Renderer::new(sc, Method::RandomWalk, seed, &HierarchicalParams::default()).expect("renderer");
    let mut acc = vec![0.0; size * size * 3];
    let t0 = Instant::now();
    with_threads(Some(threads), || r.pass(0, spp, &mut acc, &AtomicBool::new(false))).expect("pool");
    let secs = t0.elapsed().as_secs_f64();
    let img: Vec<f64> = acc.iter().map(|v| v / spp as f64).collect();
    let mean = img.iter().sum::<f64>() / img.len() as f64;
    println!(
        "{name} {size}x{size} {spp} spp, {threads} threads: {secs:.3} s ({:.4} s/spp), mean {mean:.6}",
        secs / spp as f64
    );
    let Some(path) = a.get(5) else { return };
    match std::fs::read(path) {
        Ok(bytes) => {
            let rf: Vec<f64> = bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().expect("8"))).collect();
            assert_eq!(rf.len(), img.len(), "reference size");
            // Object pixels: reference luminance above 20 % of its 99th percentile.
            let mut lum: Vec<f64> = rf.chunks(3).map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
            let px = lum.clone();
            lum.sort_by(f64::total_cmp);
            let cut = 0.2 * lum[(0.99 * (lum.len() - 1) as f64) as usize];
            let (mut se, mut n, mut sref, mut simg) = (0.0, 0usize, 0.0, 0.0);
            for (i, &l) in px.iter().enumerate() {
                if l > cut {
                    for k in 0..3 {
                        let d = img[3 * i + k] - rf[3 * i + k];
                        se += d * d;
                        sref += rf[3 * i + k];
                        simg += img[3 * i + k];
                    }
                    n += 3;
                }
            }
            let rmse = (se / n as f64).sqrt();
            println!(
                "RMSE {rmse:.4e} over {} object pixels; object mean {:+.3} %; efficiency 1/(RMSE² s) {:.4e}",
                n / 3,
                100.0 * (simg / sref - 1.0),
                1.0 / (rmse * rmse * secs)
            );
        }
        Err(_) => {
            let bytes: Vec<u8> = img.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(path, bytes).expect("write reference");
            println!("reference written to {path}");
        }
    }
}
