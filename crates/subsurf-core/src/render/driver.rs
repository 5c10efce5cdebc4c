//! The progressive renderer: passes of samples per pixel over the image, reproducible for any
//! thread count.
//!
//! Sample `s` of pixel `i` (row-major index) draws from the stream `PhotonRng::new(seed,
//! (s << 32) | i)` ([`crate::rng`]): a counter-based stream per (pixel, sample), so the image
//! does not depend on how rows are scheduled; its point in the pixel is the pixel's own
//! scrambled Sobol point `s` ([`super::pixel`]), stratified over the pixel's samples. Each pass adds its per-pixel sums (formed in
//! sample order) to the accumulator, so an image of N spp is the same number whether it was
//! rendered in one pass or many, and a cancelled render keeps every completed pass.

use super::camera::Camera;
use super::hierarchical::{Hierarchical, HierarchicalParams};
use super::material::Material;
use super::math::{Rgb, V3};
use super::primary::PixelLists;
use super::probe::Probe;
use super::random_walk::RandomWalk;
use super::scene::Scene;
use super::shade::{shade_seen, Seen, Translucency};
use crate::error::{Error, Result};
use crate::mc::config::{MAX_THREADS, THREADS_ALLOWED};
use crate::rng::PhotonRng;
use rayon::prelude::*;
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

crate::named_enum! {
    /// The way the translucent term is computed.
    pub enum Method ("a render method") {
        /// Jensen & Buhler (2002): irradiance samples and an octree.
        Hierarchical = "hierarchical",
        /// pbrt-v4's probe-ray importance sampling of the profile.
        Probe = "probe",
        /// Brute-force volumetric random walk inside the closed mesh.
        RandomWalk = "random_walk",
    }
}

impl Method {
    /// Whether the method evaluates the materials' radial profiles (the BSSRDF methods); the
    /// random walk follows the medium itself.
    pub fn uses_profiles(self) -> bool {
        match self {
            Method::Hierarchical | Method::Probe => true,
            Method::RandomWalk => false,
        }
    }
}

/// A cancel flag and progress counters shared between long work and a thread waiting for it
/// (the binding's Ctrl-C handling): the work polls `cancel` and counts finished items in `done`
/// out of `total` (which may grow once the work knows its size).
#[derive(Debug, Default)]
pub struct Control {
    pub cancel: AtomicBool,
    pub done: AtomicU64,
    pub total: AtomicU64,
}

/// One camera sample: sample `s` of pixel `pixel` (row-major index) of an image of seed `seed`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CameraSample {
    pub seed: u64,
    pub pixel: u64,
    pub s: u32,
}

/// The unit direction of camera sample `cs`'s ray (from `cam.position`): through its point of
/// the pixel ([`super::pixel::pixel_offset`]).
pub fn camera_ray(cam: &Camera, cs: CameraSample) -> V3 {
    camera_ray_at(cam, cs, super::pixel::pixel_offset(cs.seed, cs.pixel, cs.s))
}

/// The unit direction through offset (u, v) of camera sample `cs`'s pixel.
fn camera_ray_at(cam: &Camera, cs: CameraSample, (u, v): (f64, f64)) -> V3 {
    let w = cam.width as u64;
    cam.ray((cs.pixel % w) as f64 + u, (cs.pixel / w) as f64 + v)
}

thread_local! {
    static TRACING: Cell<Option<CameraSample>> = const { Cell::new(None) };
}

/// The camera sample this thread is tracing ([`Renderer::sample`]; `None` elsewhere, e.g. in a
/// method's set-up): through it a method can share work between the samples of one pixel
/// (`hierarchical`'s [`HierarchicalParams::samples_per_exitance`]).
pub fn camera_sample() -> Option<CameraSample> {
    TRACING.with(|t| t.get())
}

/// Names the sample being traced until dropped (also when the trace unwinds).
struct Tracing(Option<CameraSample>);

impl Tracing {
    fn start(cs: CameraSample) -> Tracing {
        Tracing(TRACING.with(|t| t.replace(Some(cs))))
    }
}

impl Drop for Tracing {
    fn drop(&mut self) {
        TRACING.with(|t| t.set(self.0));
    }
}

/// A scene prepared for one method.
pub struct Renderer {
    pub scene: Arc<Scene>,
    tr: Box<dyn Translucency>,
    seed: u64,
    /// Samples whose radiance was not finite (dropped; should stay 0).
    pub dropped: AtomicU64,
    /// The camera rays' per-pixel triangle lists (None: the BVH).
    primary: Option<PixelLists>,
}

impl Renderer {
    /// Prepare `scene` for `method` (the hierarchical method computes its irradiance samples
    /// and octree here). Errors: random_walk on an open translucent mesh, bad parameters.
    pub fn new(scene: Arc<Scene>, method: Method, seed: u64, hp: &HierarchicalParams) -> Result<Renderer> {
        Ok(Self::prepare(scene, method, seed, hp, &Control::default())?.expect("never cancelled"))
    }

    /// [`new`](Self::new), cancellable: the hierarchical set-up (seconds to minutes for a dense
    /// medium) polls `ctl.cancel` and counts its irradiance samples in `ctl` ([`Hierarchical::new_with`]);
    /// `None` when cancelled. Errors also when a BSSRDF method meets a material built without
    /// profiles (for `random_walk`).
    pub fn prepare(
        scene: Arc<Scene>,
        method: Method,
        seed: u64,
        hp: &HierarchicalParams,
        ctl: &Control,
    ) -> Result<Option<Renderer>> {
        let Some(camera) = &scene.camera else {
            return Err(Error::Invalid("camera: the scene has no camera; add one to render an image".into()));
        };
        camera.check_memory(None)?;
        let no_profiles =
            |m: &Material| m.translucent().is_some_and(|t| t.variants().iter().any(|v| v.bssrdf.is_none()));
        if method.uses_profiles() && scene.materials.iter().any(no_profiles) {
            return Err(Error::Invalid(format!("method {}: a translucent material has no profiles", method.name())));
        }
        let tr: Box<dyn Translucency> = match method {
            Method::Hierarchical => match Hierarchical::new_with(&scene, hp, seed, ctl)? {
                Some(h) => Box::new(h),
                None => return Ok(None),
            },
            Method::Probe => Box::new(Probe::new(&scene)),
            Method::RandomWalk => {
                scene.require_closed_translucent("method random_walk")?;
                Box::new(RandomWalk::new(&scene))
            }
        };
        Ok(Some(Self::from_parts(scene, tr, seed)))
    }

    fn camera(&self) -> &super::camera::Camera {
        self.scene.camera.as_ref().expect("checked in new")
    }

    /// A renderer with a given translucent term (tests compare variants of a method with it).
    pub fn from_parts(scene: Arc<Scene>, tr: Box<dyn Translucency>, seed: u64) -> Renderer {
        let primary = scene.camera.as_ref().and_then(|c| PixelLists::new(c, &scene.accel));
        Renderer { scene, tr, seed, dropped: AtomicU64::new(0), primary }
    }

    /// One sample of pixel (x, y): the radiance through a point of the pixel, stratified over
    /// the pixel's samples ([`super::pixel`]). While it is traced, [`camera_sample`] names it.
    pub fn sample(&self, x: usize, y: usize, s: u32) -> Rgb {
        let cam = self.camera();
        let idx = (y * cam.width + x) as u64;
        let (offset, (qi, qk)) = super::pixel::pixel_sample(self.seed, idx, s);
        let mut rng = PhotonRng::new(self.seed, ((s as u64) << 32) | idx).with_qmc(qi, qk);
        let cs = CameraSample { seed: self.seed, pixel: idx, s };
        let _now = Tracing::start(cs);
        let d = camera_ray_at(cam, cs, offset);
        let (sc, o) = (&self.scene, cam.position);
        let hit = match &self.primary {
            Some(p) => p.intersect(&sc.accel, idx as usize, o, d),
            None => sc.accel.intersect(o, d, f64::INFINITY, u32::MAX),
        };
        let l = shade_seen(sc, (o, d), hit, 0, &mut rng, self.tr.as_ref(), Seen::All);
        if l.iter().all(|v| v.is_finite()) {
            l
        } else {
            self.dropped.fetch_add(1, Ordering::Relaxed);
            [0.0; 3]
        }
    }

    /// The radiance of every camera sample of pixel `pixel` (row-major) where it is known
    /// without tracing: the constant environment, where the pixel lists show that no camera ray
    /// through the pixel meets a surface ([`PixelLists::misses`]) and the scene has no light
    /// (which a camera ray could meet). What [`Renderer::sample`] would return for each sample,
    /// bit for bit (`shade` of no hit is the environment), without its random numbers, camera
    /// ray or list search; the other pixels' streams are their own, so their numbers are
    /// unchanged. Measured (docs/render.md, "Pixels that see only the environment"): the
    /// benchmark's skin torus in its environment covers 28 % of the image, and the other 72 %
    /// of the pixels' samples were 7.6 % of the render pass's instructions (the ear: 60 %, 3.0 %).
    pub(super) fn sky(&self, pixel: usize) -> Option<Rgb> {
        let lists = self.primary.as_ref()?;
        (self.scene.lights.is_empty() && lists.misses(pixel)).then_some(self.scene.environment)
    }

    /// Add samples `s0 .. s1` of every pixel to `accum` (row-major, 3 floats per pixel: sums
    /// of radiance). Returns false (leaving `accum` untouched) if `cancel` was set meanwhile.
    /// The work items are runs of [`PIXEL_RUN`] pixels, each a task of its own (`with_max_len(1)`:
    /// rayon otherwise runs a quarter of the rows as one unsplittable leaf on 2 threads, and a
    /// pixel's cost varies with what it sees, so one thread was left with a long tail on small
    /// images); each pixel sums its samples in order: the same bits for any thread count.
    pub fn pass(&self, s0: u32, s1: u32, accum: &mut [f64], cancel: &AtomicBool) -> bool {
        let (w, h) = (self.camera().width, self.camera().height);
        assert_eq!(accum.len(), w * h * 3, "accumulator size");
        let mut sums = vec![0.0; w * h * 3];
        let stopped = AtomicBool::new(false);
        sums.par_chunks_mut(3 * PIXEL_RUN).enumerate().with_max_len(1).for_each(|(run, out)| {
            if cancel.load(Ordering::Relaxed) {
                stopped.store(true, Ordering::Relaxed);
                return;
            }
            for (j, px) in out.chunks_exact_mut(3).enumerate() {
                let i = run * PIXEL_RUN + j;
                let sky = self.sky(i);
                for s in s0..s1 {
                    let l = sky.unwrap_or_else(|| self.sample(i % w, i / w, s));
                    for k in 0..3 {
                        px[k] += l[k];
                    }
                }
            }
        });
        if stopped.load(Ordering::Relaxed) {
            return false;
        }
        for (a, v) in accum.iter_mut().zip(sums) {
            *a += v;
        }
        true
    }
}

/// Pixels per work item of a pass.
pub const PIXEL_RUN: usize = 8;

/// The allowed samples per pixel of a render, as errors state it.
pub const SPP_ALLOWED: &str = "an integer in [1, 4294967295]";

/// Samples per pixel of a render: 1 … 2³² − 1 (sample indices are 32 bits of each stream's
/// counter).
pub fn check_spp(spp: u64) -> Result<u32> {
    match u32::try_from(spp) {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(Error::param_int("spp", spp as i128, SPP_ALLOWED)),
    }
}

/// Run `f` on a pool of `threads` worker threads (all cores for `None`).
pub fn with_threads<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    match threads {
        None => Ok(f()),
        Some(t) if !(1..=MAX_THREADS).contains(&t) => Err(Error::param_int("threads", t as i128, THREADS_ALLOWED)),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map(|p| p.install(f))
            .map_err(|e| Error::Invalid(format!("threads = {t}: cannot start the thread pool: {e}"))),
    }
}
