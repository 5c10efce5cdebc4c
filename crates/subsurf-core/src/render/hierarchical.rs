//! `hierarchical`: H. W. Jensen and J. Buhler, "A rapid hierarchical rendering technique for
//! translucent materials", ACM TOG 21(3) (SIGGRAPH 2002).
//!
//! 1. Irradiance samples spread evenly over each translucent object: every triangle is cut
//!    into k² congruent sub-triangles (k = ⌈√A / Δ⌉) and a sample sits at each centroid,
//!    carrying the sub-triangle's area. The spacing Δ is `spacing` × the smallest median
//!    radius of the object's profiles (the radius holding half of R_d's energy), so the
//!    density follows the mean free path as in the paper (§3.1).
//! 2. The transmitted irradiance E_t = ∫ F_t L_i cos dω at each sample
//!    ([`super::irradiance`]; for `adaptive` each direction also weighted by the oblique gain):
//!    every light by shadow rays (`light_samples` each, jittered over the light's area) and the
//!    rest (the visible environment, light reflected by other surfaces) by `env_samples` cosine
//!    gathering rays. Translucent surfaces those rays reach are black in a first gathering; if
//!    any ray reached one, the samples are gathered again with the last trees as their
//!    radiance, each gathering one more bounce of light between translucent surfaces, until one
//!    changes the trees' total power by ≤ 1 % (`BOUNCE_TOLERANCE`; a concave marble bowl takes
//!    five; the tree walks of that radiance use coarser clusters evaluated at their sigma
//!    points, [`Cut`], and are shared by the rays that reach the same cell of 2 Δ, `Cached`).
//! 3. An octree over the samples; each node keeps its area, its power Σ E_t A per channel and
//!    the power-weighted centroid (§3.2).
//! 4. At a shading point x_o the tree is walked: a node is used as a whole when its solid
//!    angle ΔΩ = A_node/‖x_o − centroid‖² is below `epsilon` and x_o is outside its box
//!    (the paper's error criterion, §3.3); otherwise its children (or samples) are visited.
//!    Nodes wholly beyond the kernel's reach (10⁻⁶ of its energy) are skipped.
//!    M_o = Σ R_d(‖x_o − x_j‖) P_j, and L_o = F_t(η, ω_o) M_o /(π c(η)) (see `material`),
//!    plus the single-scattering term S⁽¹⁾ ([`super::shade::single_scattering`]). For
//!    `adaptive` under lights every pair (sample or cluster) is also weighted by the entry's
//!    azimuthal factor ([`crate::bssrdf::harmonic`]: the samples carry their lights' harmonic,
//!    the nodes its power-weighted mean), and the near class' radiance carries the exit
//!    direction's coupling to the light's ([`crate::bssrdf::coupling`]: the samples carry their
//!    lights' vector D, the nodes its power-weighted mean, [`Tree::exitance_coupled`]), and
//!    its flow along the light from each entry point ([`crate::bssrdf::flow`], under any light:
//!    [`Tree::exitance_flow`]).

use super::accel::Hit;
use super::driver::{camera_ray, camera_sample, CameraSample, Control};
use super::irradiance::{irradiance_and_harmonic, transmitted_irradiance, Coupled, Entry, Unlit};
use super::material::Translucent;
use super::math::{add, dot, mul, scale, sub, Rgb, V3};
use super::scene::Scene;
use super::shade::{ft, single_scattering, tint, Translucency};
use super::texture::shading_medium;
use super::tree::{add_classes, Cut, Flat, FlowAt, Sample, Tree, COARSE_FACTOR};
use crate::bssrdf::harmonic::{AtRho, Lobe};
use crate::error::{Error, Result};
use crate::rng::PhotonRng;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

/// Settings of the hierarchical method.
#[derive(Clone, Copy, Debug)]
pub struct HierarchicalParams {
    /// Sample spacing as a fraction of the smallest median profile radius.
    pub spacing: f64,
    /// Largest solid angle (sr) of a node used as a cluster.
    pub epsilon: f64,
    /// Cosine-weighted gathering rays per irradiance sample (environment and light reflected
    /// by other surfaces; see [`super::irradiance`]). The default, 16: each pixel's kernel
    /// averages the irradiance of tens of samples, so their gathering noise is not the image's
    /// (64 rays gave the same means and per-pixel variance at up to 3× the set-up time on the
    /// validation matrix and the shipped example with its floor: `docs/render.md`).
    pub env_samples: u32,
    /// Samples of each light per irradiance sample.
    pub light_samples: u32,
    /// Most irradiance samples per object (Δ grows until the facets' cut respects it, `placed`).
    /// The default, 250 000, binds only where the profile is short against the object (a 10 mm sphere of ≥ 5 marble
    /// diffusion lengths): the near field then integrates the profile's peak exactly over a
    /// mean irradiance, and the set-up costs an eighth of 2 000 000 samples' (the validation
    /// matrix's 100 L sphere: object means within their seed-to-seed noise, `docs/render.md`).
    pub max_samples: usize,
    /// Consecutive camera samples of a pixel that share one tree walk: samples k·b … k·b + b − 1
    /// take the exitance M_o (and its direction vectors) at the surface point of sample k·b
    /// where that sample's ray meets the same object first, each then applying its own normal,
    /// direction, F_t and tint (`Hierarchical::block_exitance`); 1 walks the tree for every
    /// sample. The anchor's point is uniform over the pixel as every sample's is, so a pixel's
    /// mean is unchanged but for the covariance of the direction factors and M_o across the
    /// pixel; the samples still resolve what changes within a pixel fast (a highlight's edge,
    /// the silhouette), which is where the error of a few samples per pixel is (`docs/render.md`).
    /// Above 1, rays after a bounce (depth ≥ 1) also share the exitance per cell of 2 Δ
    /// (`Hierarchical::deep`); 1 walks at every point.
    pub samples_per_exitance: u32,
}

impl Default for HierarchicalParams {
    fn default() -> Self {
        HierarchicalParams {
            spacing: 0.35,
            epsilon: 0.05,
            env_samples: 16,
            light_samples: 16,
            max_samples: 250_000,
            samples_per_exitance: 16,
        }
    }
}

impl HierarchicalParams {
    pub fn validate(&self) -> Result<()> {
        if !(self.spacing > 0.0 && self.spacing.is_finite()) {
            return Err(Error::param("hierarchical.spacing", self.spacing, "a finite number > 0"));
        }
        if !(self.epsilon >= 0.0 && self.epsilon.is_finite()) {
            return Err(Error::param("hierarchical.epsilon", self.epsilon, "a finite number >= 0 (sr)"));
        }
        if self.light_samples == 0 || self.max_samples == 0 {
            return Err(Error::Invalid("hierarchical.light_samples and max_samples must be >= 1".into()));
        }
        if self.samples_per_exitance == 0 {
            return Err(Error::param_int("hierarchical.samples_per_exitance", 0, "an integer in [1, 4294967295]"));
        }
        Ok(())
    }
}

/// The hierarchical method: one octree per translucent object.
pub struct Hierarchical {
    pub trees: Vec<Option<Tree>>,
    pub params: HierarchicalParams,
    /// Per pixel of the scene's camera, its latest block's exitance
    /// ([`Hierarchical::block_exitance`]; empty when `samples_per_exitance` is 1).
    blocks: Vec<Mutex<Block>>,
    /// The exitances of the render's rays after a bounce (depth ≥ 1: a reflection off a
    /// translucent surface that meets one again, a gathering ray of the single scattering),
    /// shared over cells of [`CACHE_CELL`] at the render's cut ([`CellCache`]); `None` when
    /// `samples_per_exitance` is 1 (every point walked at itself).
    deep: Option<CellCache>,
    /// The trees' total power ([`power`]) after each gathering, the first included, when a
    /// gathering ray reached a translucent surface (else empty; for the tests).
    powers: Vec<Rgb>,
}

/// A pixel's latest block of [`HierarchicalParams::samples_per_exitance`] camera samples: its
/// first sample's index (`u32::MAX`: none yet) and that sample's object and [`Exitance`] in f32
/// (`u32::MAX`: its ray met no translucent surface first). A pixel's samples come in order, one
/// thread at a time, over however many passes (the mutex is never contended).
#[derive(Clone, Copy)]
struct Block {
    first: u32,
    object: u32,
    x: [f32; 15],
}

impl Block {
    const EMPTY: Block = Block { first: u32::MAX, object: u32::MAX, x: [0.0; 15] };

    fn new(first: u32, x: Option<(usize, Exitance)>) -> Block {
        let Some((o, x)) = x else { return Block { first, ..Block::EMPTY } };
        let mut f = [0.0f32; 15];
        let all = x.near.iter().chain(&x.far).chain(x.v.iter().flatten());
        for (d, v) in f.iter_mut().zip(all) {
            *d = *v as f32;
        }
        Block { first, object: o as u32, x: f }
    }

    fn get(&self) -> Option<(usize, Exitance)> {
        if self.object == u32::MAX {
            return None;
        }
        let f = |i: usize| self.x[i] as f64;
        let x = Exitance {
            near: [f(0), f(1), f(2)],
            far: [f(3), f(4), f(5)],
            v: std::array::from_fn(|c| std::array::from_fn(|k| f(6 + 3 * c + k))),
        };
        Some((self.object as usize, x))
    }
}

impl Hierarchical {
    /// Place the samples, compute their irradiance (in parallel, reproducibly: sample j uses
    /// the stream (seed ⊕ 0x4a42_2002, j), in the second gathering (seed ⊕ 0x4a42_2003, j)) and
    /// build the trees.
    pub fn new(scene: &Scene, params: &HierarchicalParams, seed: u64) -> Result<Hierarchical> {
        Ok(Self::new_with(scene, params, seed, &Control::default())?.expect("never cancelled"))
    }

    /// [`new`](Self::new), cancellable: adds the number of irradiance samples to `ctl.total`
    /// (again before each further gathering), counts the finished ones in `ctl.done` and polls
    /// `ctl.cancel` before each; `None` when cancelled.
    pub fn new_with(
        scene: &Scene,
        params: &HierarchicalParams,
        seed: u64,
        ctl: &Control,
    ) -> Result<Option<Hierarchical>> {
        params.validate()?;
        let spots: Vec<Option<(Spots, f64)>> = (0..scene.objects.len()).map(|oi| placed(scene, oi, params)).collect();
        let spots: Vec<Option<(Spots, f64)>> =
            spots.into_iter().enumerate().map(|(oi, sp)| sp.map(|(s, d)| (with_amplitudes(scene, oi, s), d))).collect();
        let n_all: usize = spots.iter().flatten().map(|(s, _)| s.len()).sum();
        ctl.total.fetch_add(n_all as u64, Ordering::Relaxed);
        // First gathering: translucent surfaces black; again with the last trees if a ray saw
        // one, each gathering one more bounce, until one changes the power by ≤ BOUNCE_TOLERANCE.
        let unlit = Unlit::default();
        let Some(trees) = gather(scene, params, &spots, seed ^ 0x4a42_2002, ctl, &unlit) else { return Ok(None) };
        let pixels =
            scene.camera.as_ref().filter(|_| params.samples_per_exitance > 1).map_or(0, |c| c.width * c.height);
        let blocks = (0..pixels).map(|_| Mutex::new(Block::EMPTY)).collect();
        let mut h = Hierarchical { trees, params: *params, blocks, deep: None, powers: vec![] };
        let reached = unlit.reached.load(Ordering::Relaxed);
        // the cells' grid, built once for the gatherings' caches and the render's
        let grid = (reached || params.samples_per_exitance > 1).then(|| {
            let cut = Cut { epsilon: h.params.epsilon.max(GATHER_EPSILON), sigma: true, coarse: 0.0 };
            CellCache::new(scene, &spots, cut, CACHE_CELL)
        });
        if let Some(grid) = grid.as_ref().filter(|_| reached) {
            ctl.total.fetch_add(n_all as u64, Ordering::Relaxed);
            h.powers.push(power(&h.trees));
            for g in 0..MAX_BOUNCES {
                if g > 0 {
                    ctl.total.fetch_add(n_all as u64, Ordering::Relaxed);
                }
                let cached = Cached { inner: &h, cache: grid.fresh(grid.cut) };
                let key = seed ^ (0x4a42_2003 + 0x100 * g);
                let Some(trees) = gather(scene, params, &spots, key, ctl, &cached) else { return Ok(None) };
                drop(cached);
                h.trees = trees;
                let (now, last) = (power(&h.trees), h.powers[h.powers.len() - 1]);
                h.powers.push(now);
                if (0..3).all(|c| (now[c] - last[c]).abs() <= BOUNCE_TOLERANCE * now[c]) {
                    break;
                }
            }
        }
        if params.samples_per_exitance > 1 {
            h.deep = grid.map(|g| g.fresh(h.render_cut()));
        }
        Ok(Some(h))
    }
}

/// The sample spacing Δ (mm) of translucent object `oi`: `spacing` × the smallest median
/// profile radius (over every texel material of a textured one), larger where the object would
/// get more than `max_samples`; `None` for an opaque object.
fn spacing(scene: &Scene, oi: usize, params: &HierarchicalParams) -> Option<f64> {
    let m = scene.material(oi).translucent()?;
    let median = match m.texture.as_ref().and_then(|t| t.radius_range(0.5)) {
        Some((lo, _)) => lo[0].min(lo[1]).min(lo[2]),
        None => (0..3).map(|k| m.profiles()[k].radius_for_fraction(0.5)).fold(f64::INFINITY, f64::min),
    };
    let total = scene.objects[oi].mesh.total_area();
    let delta = params.spacing * median;
    if !(delta > 0.0 && delta.is_finite()) || total / (delta * delta) > params.max_samples as f64 {
        return Some((total / params.max_samples as f64).sqrt());
    }
    Some(delta)
}

/// The irradiance samples of translucent object `oi` ([`place_samples`]) and their spacing Δ
/// ([`spacing`]), at most `max_samples` of them: where cutting the triangles (k = ⌈√A/Δ⌉ per
/// side) would place more, Δ grows by √(count/`max_samples`) until it does not. On the
/// validation matrix's spheres (20 480 facets) at the cap every side was cut in 4 (327 680
/// samples, 31 % over); now 247 040 (Δ 0.071 → 0.081 mm, the smaller facets cut in 3).
fn placed(scene: &Scene, oi: usize, params: &HierarchicalParams) -> Option<(Spots, f64)> {
    let mut delta = spacing(scene, oi, params)?;
    loop {
        let spots = place_samples(scene, oi, delta);
        if spots.len() <= params.max_samples {
            return Some((spots, delta));
        }
        // ends: once every triangle is under Δ², the count is the area over Δ² (± 1)
        delta *= (spots.len() as f64 / params.max_samples as f64).sqrt().max(1.0 + 1e-6);
    }
}

/// The hierarchical method's samples of translucent object `oi` with E_t = 1 and their octree
/// (default settings): [`Tree::exitance_with`] then integrates a kernel over the object's
/// surface (the `probe` method's normalisation of a tube's saddle, `render::adaptive`).
pub fn area_tree(scene: &Scene, oi: usize) -> Option<Tree> {
    let (spots, delta) = placed(scene, oi, &HierarchicalParams::default())?;
    let samples = spots
        .into_iter()
        .map(|(h, area, _)| Sample { p: h.p, area, e: [1.0; 3], n: h.n, m: Default::default(), d: Default::default() })
        .collect();
    Some(Tree::build(samples, delta))
}

/// The second gathering's cluster bound (sr; the pixels' is `epsilon`, default 0.05), its clusters
/// evaluated at their sigma points ([`Cut`]): the radiance a gathering ray brings back is
/// averaged over its sample's rays and over the samples under the profile, so it needs less
/// than a pixel's accuracy. Measured (`docs/render.md`, the validation matrix's bowl, 64², 4 spp):
/// object means +0.29, −0.52, −2.97 % with the pixels' clusters, +0.29, −0.51, −2.97 % with
/// these at 0.5 sr (−0.01, −0.82, −3.26 % at 0.5 evaluated at the centroids), the set-up's tree
/// walks evaluate 3× fewer samples. At 1 sr (same seed, against 0.5 sr): object means −0.035,
/// −0.02 and −0.002 points on the torus, the bowl and the blob, their set-up CPU time 0.93×,
/// 0.90× and 0.74× (`docs/render.md`, "The set-up's fixed cost").
const GATHER_EPSILON: f64 = 1.0;

/// The hierarchical method's radiance with other clusters (the second gathering's: sigma points
/// at [`GATHER_EPSILON`]), walked at each ray's own point: what [`Cached`] approximates.
#[cfg(test)]
struct Coarse<'a> {
    inner: &'a Hierarchical,
    cut: Cut,
}

#[cfg(test)]
impl Translucency for Coarse<'_> {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        self.inner.radiance_with(scene, hit, wo, depth, rng, self.cut)
    }
}

/// Most gatherings after the first (each one more bounce of light between translucent surfaces,
/// [`Hierarchical::new_with`]).
const MAX_BOUNCES: u64 = 8;

/// A gathering after the second follows while the last one changed the trees' total power by
/// more than this share of it in some channel. Each bounce adds about the last one's change
/// times the ratio r of successive bounces (0.2–0.4 on the validation matrix's marble bowl: its
/// gatherings change the power by +13.8, +3.0, +1.2, +0.26 %), so stopping leaves r/(1 − r) ≤ ⅔
/// of this share.
const BOUNCE_TOLERANCE: f64 = 0.01;

/// The trees' total transmitted power Σ E_t A per channel.
fn power(trees: &[Option<Tree>]) -> Rgb {
    let mut p = [0.0; 3];
    for s in trees.iter().flatten().flat_map(|t| &t.samples) {
        p = add(p, scale(s.e, s.area));
    }
    p
}

/// The second gathering's cache cell, in sample spacings Δ ([`Cached`]). Measured on the
/// validation matrix's bowl (seed 2, `docs/render.md`, "The set-up's noise"): 2 Δ moves the
/// object mean by +0.14, +0.12, +0.10 points against the walk at every ray (1 Δ: +0.09, +0.08,
/// +0.07 at 3.2× the walks), the set-up's walks 17 000 → 830 with every ray evaluated. 4 Δ
/// would halve the blob's set-up (its rays reach the object in 9 751 cells, 3.5 rays a cell) and
/// moves its object means by < 0.01 points, but fails `the_cached_exitance_is_the_walked_one`
/// (+2.6 % on the mean, the worst ray +60 %): not taken.
const CACHE_CELL: f64 = 2.0;

/// Exitances shared over a grid: the exitance ([`Exitance`], the walk at `cut`, independent of
/// the ray's direction) is computed once per cell of side `cell` × Δ, at the irradiance sample
/// nearest the mean of the cell's samples (so the error, first order in the offset from it,
/// cancels over the cell), and reused for every point in that cell whose normal is within 25°
/// of the sample's. A point whose cell holds no sample, or whose normal differs, or on a
/// textured object, is walked at its own point. A cell's value does not depend on which thread
/// computes it first (the walk draws nothing), so the same seed gives the same image for any
/// thread count. Used by the second gathering ([`Cached`]) and by the render's rays after a
/// bounce ([`Hierarchical::deep`]).
struct CellCache {
    cut: Cut,
    /// Per object (none where it is opaque or textured).
    cells: Vec<Cells>,
    /// Points walked at their own point.
    misses: std::sync::atomic::AtomicU64,
}

/// One object's cache: the cell side (mm; 0: none), per cell its sample (the grid, shared by
/// every cache over the same samples: [`CellCache::fresh`]) and its value.
#[derive(Default)]
struct Cells {
    side: f64,
    vals: Vec<std::sync::OnceLock<Exitance>>,
    map: std::sync::Arc<std::collections::HashMap<[i64; 3], (u32, Hit)>>,
}

impl CellCache {
    fn new(scene: &Scene, spots: &[Option<(Spots, f64)>], cut: Cut, cell: f64) -> CellCache {
        let cells = spots
            .iter()
            .enumerate()
            .map(|(oi, sp)| {
                let textured = scene.material(oi).translucent().is_some_and(|m| m.texture.is_some());
                let (Some((spots, delta)), false) = (sp, textured) else { return Cells::default() };
                let side = cell * delta;
                // each cell's samples' mean position, then the sample nearest it (first by index)
                let mut mean: std::collections::HashMap<[i64; 3], (V3, f64)> = Default::default();
                for (h, _, _) in spots {
                    let e = mean.entry(key(h.p, side)).or_insert(([0.0; 3], 0.0));
                    *e = (add(e.0, h.p), e.1 + 1.0);
                }
                let mut best: std::collections::HashMap<[i64; 3], (f64, usize)> = Default::default();
                for (j, (h, _, _)) in spots.iter().enumerate() {
                    let k = key(h.p, side);
                    let (c, n) = mean[&k];
                    let d = sub(h.p, scale(c, 1.0 / n));
                    let e = best.entry(k).or_insert((f64::INFINITY, j));
                    if dot(d, d) < e.0 {
                        *e = (dot(d, d), j);
                    }
                }
                let mut firsts: Vec<([i64; 3], usize)> = best.into_iter().map(|(k, (_, j))| (k, j)).collect();
                firsts.sort_unstable_by_key(|&(_, j)| j);
                let map = firsts.iter().enumerate().map(|(i, &(k, j))| (k, (i as u32, spots[j].0))).collect();
                Cells { side, vals: (0..firsts.len()).map(|_| Default::default()).collect(), map: Arc::new(map) }
            })
            .collect();
        CellCache { cut, cells, misses: Default::default() }
    }

    /// A cache over the same cells at `cut`, with no value computed yet (the grid is shared).
    fn fresh(&self, cut: Cut) -> CellCache {
        let cells = self
            .cells
            .iter()
            .map(|c| Cells {
                side: c.side,
                vals: c.vals.iter().map(|_| Default::default()).collect(),
                map: c.map.clone(),
            })
            .collect();
        CellCache { cut, cells, misses: Default::default() }
    }

    /// The exitance of `tree` (material `m`) at `hit`: its cell's, else walked there.
    fn exitance(&self, scene: &Scene, hit: &Hit, m: &Translucent, tree: &Tree) -> Exitance {
        let c = &self.cells[hit.object];
        let cell = if c.side > 0.0 { c.map.get(&key(hit.p, c.side)) } else { None };
        match cell {
            Some((i, h)) if dot(h.n, hit.n) >= CACHE_NORMAL_COS => {
                *c.vals[*i as usize].get_or_init(|| exitance_at(scene, h, m, tree, self.cut))
            }
            _ => {
                self.misses.fetch_add(1, Ordering::Relaxed);
                exitance_at(scene, hit, m, tree, self.cut)
            }
        }
    }
}

/// The grid cell of `p` for cells of side `side`.
fn key(p: V3, side: f64) -> [i64; 3] {
    p.map(|x| (x / side).floor() as i64)
}

/// cos 25°: the largest angle between a point's normal and its cell's sample's ([`CellCache`]).
const CACHE_NORMAL_COS: f64 = 0.906;

/// The second gathering's radiance with the tree walks (at [`GATHER_EPSILON`]) shared over cells
/// of [`CACHE_CELL`] ([`CellCache`]); the ray's own direction, point and normal give the rest
/// ([`Hierarchical::radiance_from`]). With the walks this cheap every ray that reaches a
/// translucent surface is evaluated (before: a quarter, weighted 4×, whose noise every pixel
/// shared).
struct Cached<'a> {
    inner: &'a Hierarchical,
    cache: CellCache,
}

impl Translucency for Cached<'_> {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let (Some(m), Some(tree)) = (shading_medium(scene, hit), self.inner.trees[hit.object].as_ref()) else {
            return [0.0; 3];
        };
        let x = self.cache.exitance(scene, hit, m, tree);
        self.inner.radiance_from(scene, hit, wo, depth, rng, m, &x)
    }
    fn adds_unscattered(&self) -> bool {
        true
    }
}

/// The trees of every translucent object, its samples' irradiance from
/// [`transmitted_irradiance`] with `tr` for the translucent surfaces the gathering rays reach
/// (sample j of all objects in order uses the stream (`key`, j)); `None` when cancelled.
fn gather(
    scene: &Scene,
    params: &HierarchicalParams,
    spots: &[Option<(Spots, f64)>],
    key: u64,
    ctl: &Control,
    tr: &dyn Translucency,
) -> Option<Vec<Option<Tree>>> {
    let mut trees = Vec::with_capacity(scene.objects.len());
    let mut base = 0u64;
    for (oi, spot) in spots.iter().enumerate() {
        let (Some(m), Some((spots, delta))) = (scene.material(oi).translucent(), spot) else {
            trees.push(None);
            continue;
        };
        // the exit coupling needs the lights' directions (`bssrdf::coupling`)
        let coupled = !scene.lights.is_empty() && m.adaptive.as_deref().is_some_and(|t| t.has_coupling());
        let samples: Option<Vec<Sample>> = spots
            .par_iter()
            .enumerate()
            .with_max_len(16) // small tasks: a sample's cost varies with the shape (second gathering)
            .map(|(j, (h, area, amps))| {
                if ctl.cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let mut rng = PhotonRng::new(key, base + j as u64);
                let (nl, nr) = (params.light_samples, params.env_samples);
                let (e, hm, d) = if amps.is_some() || coupled {
                    let (e, hm, d) =
                        irradiance_and_harmonic(scene, h, Entry::of(m), nl, nr, 0, &mut rng, tr, amps.as_ref());
                    (e, hm.map(|mc| mc.map(Lobe::new)), d)
                } else {
                    let e = transmitted_irradiance(scene, h, Entry::of(m), nl, nr, 0, &mut rng, tr);
                    (e, [[Lobe::default(); 3]; 2], [[0.0; 3]; 3])
                };
                ctl.done.fetch_add(1, Ordering::Relaxed);
                Some(Sample { p: h.p, area: *area, e, n: h.n, m: hm, d })
            })
            .collect();
        base += spots.len() as u64;
        trees.push(Some(Tree::build(samples?, *delta)));
    }
    Some(trees)
}

/// Irradiance sample positions (as hits) with their areas (mm²) and, for `adaptive` under
/// lights, their azimuthal-harmonic amplitudes.
type Spots = Vec<(Hit, f64, Option<[AtRho; 3]>)>;

/// `spots` of object `oi` with their amplitudes ([`super::adaptive::entry_amplitudes`] at the
/// centroid of the sample's triangle: probed once, used by both gatherings) where its material
/// is `adaptive` and the scene has lights.
fn with_amplitudes(scene: &Scene, oi: usize, spots: Spots) -> Spots {
    let Some(t) = scene.material(oi).translucent().and_then(|m| m.adaptive.as_deref()) else { return spots };
    if scene.lights.is_empty() {
        return spots;
    }
    // Probed once per triangle, at its centroid (the curvature varies on the scale of the mesh,
    // and several samples share a triangle where the profile is finer than the facets).
    let mut tris: Vec<u32> = spots.iter().map(|(h, _, _)| h.tri).collect();
    tris.sort_unstable();
    tris.dedup();
    let third = 1.0 / 3.0;
    let amps: Vec<Option<[AtRho; 3]>> = tris
        .par_iter()
        .map(|&gi| {
            let n = scene.accel.tris[gi as usize].n;
            let p = scene.accel.point(gi as usize, third, third);
            let h = Hit { t: 0.0, tri: gi, object: oi, b1: third, b2: third, p, n };
            super::adaptive::entry_amplitudes(scene, t, &h)
        })
        .collect();
    spots
        .into_iter()
        .map(|(h, a, _)| {
            let i = tris.binary_search(&h.tri).expect("every sample's triangle was probed");
            (h, a, amps[i])
        })
        .collect()
}

/// The irradiance samples of object `oi` as hits, with their areas: triangles larger than Δ²
/// are cut into k² congruent sub-triangles (a sample at each centroid); smaller ones are visited
/// in Morton order of their centroids and a sample is placed (at the centroid) each time the
/// running area passes a multiple of Δ² (systematic sampling along a space-filling curve), so a
/// finely tessellated mesh gets about area/Δ² evenly spread samples, not one per triangle.
fn place_samples(scene: &Scene, oi: usize, delta: f64) -> Spots {
    let acc = &scene.accel;
    let mut out = vec![];
    let mut small = vec![];
    for (gi, t) in acc.tris.iter().enumerate() {
        if t.object as usize != oi {
            continue;
        }
        let a = acc.area(gi);
        let k = ((a.sqrt() / delta).ceil() as usize).max(1);
        if k == 1 {
            small.push(gi);
            continue;
        }
        let sub_area = a / (k * k) as f64;
        let kf = k as f64;
        let mut push = |b1: f64, b2: f64| {
            let p = acc.point(gi, b1, b2);
            out.push((Hit { t: 0.0, tri: gi as u32, object: oi, b1, b2, p, n: t.n }, sub_area, None));
        };
        for i in 0..k {
            for j in 0..k - i {
                push((i as f64 + 1.0 / 3.0) / kf, (j as f64 + 1.0 / 3.0) / kf);
                if j + 1 < k - i {
                    push((i as f64 + 2.0 / 3.0) / kf, (j as f64 + 2.0 / 3.0) / kf);
                }
            }
        }
    }
    let third = 1.0 / 3.0;
    let key = |gi: usize| morton(acc, acc.point(gi, third, third));
    small.sort_by_cached_key(|&gi| key(gi));
    let cell = delta * delta;
    let (mut run, mut next, mut placed) = (0.0, 0.5 * cell, 0usize);
    let sample = |gi: usize, area: f64| {
        let p = acc.point(gi, third, third);
        (Hit { t: 0.0, tri: gi as u32, object: oi, b1: third, b2: third, p, n: acc.tris[gi].n }, area, None)
    };
    for &gi in &small {
        run += acc.area(gi);
        while run >= next {
            out.push(sample(gi, cell));
            placed += 1;
            next += cell;
        }
    }
    // The area not yet assigned (|·| ≤ Δ²/2) goes to the last sample, so the areas sum exactly.
    if placed > 0 {
        out.last_mut().expect("placed > 0").1 += run - placed as f64 * cell;
    } else if let Some(&gi) = small.first() {
        out.push(sample(gi, run));
    }
    out
}

/// 63-bit Morton code of `p` in the scene's bounding box (21 bits per axis).
fn morton(acc: &super::accel::Accel, p: V3) -> u64 {
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    let q = |k: usize| {
        let f = (p[k] - acc.lo[k]) / (acc.hi[k] - acc.lo[k]).max(1e-300);
        (f.clamp(0.0, 1.0) * 2_097_151.0) as u64
    };
    spread(q(0)) | spread(q(1)) << 1 | spread(q(2)) << 2
}

impl Translucency for Hierarchical {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let cut = self.render_cut();
        let (Some(m), Some(tree)) = (shading_medium(scene, hit), self.trees[hit.object].as_ref()) else {
            return [0.0; 3];
        };
        let shared = match (depth, &self.deep) {
            (0, _) => self.block_exitance(scene, hit, cut),
            (_, Some(deep)) => Some(deep.exitance(scene, hit, m, tree)),
            (_, None) => None,
        };
        let x = shared.unwrap_or_else(|| exitance_at(scene, hit, m, tree, cut));
        self.radiance_from(scene, hit, wo, depth, rng, m, &x)
    }
    fn adds_unscattered(&self) -> bool {
        true
    }
}

impl Hierarchical {
    /// The render's cut: clusters below `epsilon`, at their centroids.
    fn render_cut(&self) -> Cut {
        let e = self.params.epsilon;
        Cut { epsilon: e, sigma: false, coarse: COARSE_FACTOR * e }
    }

    /// For a camera sample's first surface `hit` ([`camera_sample`]): the exitance at the first
    /// sample of its block of [`HierarchicalParams::samples_per_exitance`], if that sample's ray
    /// meets the same object first (from the front, no light before it); else `None` (the
    /// caller walks the tree at `hit`). Deterministic in (seed, pixel, sample), whatever the
    /// passes: the block's exitance (rounded to f32) is kept per pixel only to not walk it again.
    fn block_exitance(&self, scene: &Scene, hit: &Hit, cut: Cut) -> Option<Exitance> {
        let b = self.params.samples_per_exitance;
        let cs = camera_sample().filter(|_| b > 1)?;
        let first = CameraSample { s: cs.s - cs.s % b, ..cs };
        let walk = || {
            let at = if first == cs { Some(*hit) } else { camera_hit(scene, first) };
            let x = at.and_then(|h| {
                let (m, tree) = (shading_medium(scene, &h)?, self.trees[h.object].as_ref()?);
                Some((h.object, exitance_at(scene, &h, m, tree, cut)))
            });
            Block::new(first.s, x)
        };
        let block = match self.blocks.get(cs.pixel as usize) {
            Some(slot) => {
                let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
                if slot.first != first.s {
                    *slot = walk();
                }
                *slot
            }
            None => walk(), // a camera other than the scene's: no store, the same numbers
        };
        block.get().filter(|(o, _)| *o == hit.object).map(|(_, x)| x)
    }
}

/// The first surface camera sample `cs`'s ray meets, if it meets it from the front with no
/// light before it (as [`super::shade::trace_seen`] would shade it).
fn camera_hit(scene: &Scene, cs: CameraSample) -> Option<Hit> {
    let cam = scene.camera.as_ref()?;
    let d = camera_ray(cam, cs);
    let h = scene.accel.intersect(cam.position, d, f64::INFINITY, u32::MAX)?;
    let lit = scene.light_hit(cam.position, d, h.t).is_some();
    (!lit && dot(d, h.n) < 0.0).then_some(h)
}

impl Hierarchical {
    /// [`Translucency::radiance`] with the trees walked at `cut` at the point itself (the
    /// reference of the caches' tests).
    #[cfg(test)]
    fn radiance_with(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng, cut: Cut) -> Rgb {
        // A textured material's profile is its texel's at the shading point x_o.
        let (Some(m), Some(tree)) = (shading_medium(scene, hit), self.trees[hit.object].as_ref()) else {
            return [0.0; 3];
        };
        let x = exitance_at(scene, hit, m, tree, cut);
        self.radiance_from(scene, hit, wo, depth, rng, m, &x)
    }

    /// The radiance leaving `hit` towards `wo` of the exitance `x` (the tree walk's, at `hit`
    /// or, [`Cached`], at a sample near it): L_o = F_t(η, ω_o) M_o /(π c(η)) with the adaptive
    /// model's exit term and coupling towards `wo`, plus the single scattering.
    #[allow(clippy::too_many_arguments)]
    fn radiance_from(
        &self,
        scene: &Scene,
        hit: &Hit,
        wo: V3,
        depth: u32,
        rng: &mut PhotonRng,
        m: &Translucent,
        x: &Exitance,
    ) -> Rgb {
        let mu_o = dot(wo, hit.n);
        let mo = match &m.adaptive {
            Some(t) => {
                let ot = sub(wo, scale(hit.n, mu_o));
                // the coupling and the flow (`bssrdf::flow`) are in `v`; the radiance held ≥ 0
                let near: Rgb = std::array::from_fn(|c| (x.near[c] + dot(x.v[c], ot)).max(0.0));
                add(mul(near, t.exit_factors(mu_o)), x.far)
            }
            None => add(x.near, x.far),
        };
        let f = ft(m.eta, mu_o) / (PI * m.c_norm);
        let mut l = scale(mul(mo, tint(scene, hit)), f);
        if m.single_scattering {
            l = add(l, single_scattering(scene, m, hit, wo, depth, rng, self));
        }
        l
    }
}

/// The tree walk's result at a shading point, before its direction: per class (the adaptive
/// model's near side and across; else all in `near`) M_o, and the near class' coupling sum V
/// ([`Tree::exitance_coupled`]; 0 without one).
#[derive(Clone, Copy, Debug, Default)]
struct Exitance {
    near: Rgb,
    far: Rgb,
    v: Coupled,
}

/// [`Exitance`] of `tree` (material `m`) at `hit`, its clusters those of `cut`.
fn exitance_at(scene: &Scene, hit: &Hit, m: &Translucent, tree: &Tree, cut: Cut) -> Exitance {
    match &m.adaptive {
        Some(t) => {
            // the exit term's angular shape on the near class (`bssrdf::exit`); across a part, none
            let k = super::adaptive::Kernel::at(scene, t, hit);
            if t.has_flow() {
                // its coupling to the light's direction (`bssrdf::coupling`) and its flow from
                // each entry point (`bssrdf::flow`), both vectors dotted with the exit direction
                let b = std::array::from_fn(|c| t.flow(c.min(t.channels() - 1)));
                let ([near, far], v, fl) = tree.exitance_flow(&k, hit.p, cut, &FlowAt { normal: hit.n, b });
                Exitance { near, far, v: std::array::from_fn(|c| add(v[c], fl[c])) }
            } else if tree.coupled {
                // and its coupling to the light's direction (`bssrdf::coupling`)
                let ([near, far], v) = tree.exitance_coupled(&k, hit.p, cut);
                Exitance { near, far, v }
            } else {
                let [near, far] = tree.exitance_cut(&k, hit.p, cut);
                Exitance { near, far, v: [[0.0; 3]; 3] }
            }
        }
        None => {
            Exitance { near: add_classes(tree.exitance_cut(&Flat(m.profiles()), hit.p, cut)), ..Default::default() }
        }
    }
}

#[cfg(test)]
#[path = "hierarchical_tests.rs"]
mod tests;
