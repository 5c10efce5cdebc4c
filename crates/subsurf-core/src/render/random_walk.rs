//! `random_walk`: brute-force volumetric path tracing inside the closed meshes, no diffusion
//! assumption (the ground truth the BSSRDF images are compared with).
//!
//! The camera path refracts into the object at x_o (Fresnel on the triangle's normal; the
//! reflected part is traced by [`super::shade::trace`]) and walks with the shared transport core
//! [`super::walk`] (the engine's physics, nested media). What this method carries is
//! `Radiance`:
//! - free paths with spectral MIS (one-sample balance heuristic over the RGB channels, with
//!   the channel chosen in proportion to the path throughput β, as Cycles' random walk and
//!   Chiang, Kutz & Burley 2016 §4): with w_k = β_k/Σβ a channel c ~ w is chosen,
//!   s ~ σt,c e^{−σt,c s}; at a collision β_k ← β_k σs,k T_k(s) / p̄(s), p̄ = Σ_j w_j σt,j T_j(s);
//!   reaching the boundary at t, β_k ← β_k T_k(t) / Σ_j w_j T_j(t). Unbiased in every channel,
//!   and Σβ never grows (for albedo ≤ 1), so colour-dependent σt gives no fireflies (a
//!   uniform channel choice makes β a product of many mean-one factors: heavy-tailed). In
//!   scenes lit by the environment alone w mixes in the carried channel of least σt
//!   (w ← mix·w + (1 − mix)·e_l, `flight_mix`): the same weights with that w, unbiased; Σβ may
//!   then grow at a collision, by at most 1/mix;
//! - in a heterogeneous medium (a voxel grid, [`super::grid`]) the free paths are those of the
//!   majorant σ̄ (the same spectral MIS with σ̄ for σt), and at a tentative collision x the
//!   path is real with probability P = Σ_k ŵ_k σt,k(x)/σ̄_k (ŵ ∝ β), β_k ← β_k σs,k(x)/(σ̄_k P),
//!   or null with 1 − P, β_k ← β_k (1 − σt,k(x)/σ̄_k)/(1 − P), straight on (delta tracking with
//!   per-channel weights, the spectral tracking of Kutz et al. 2017 with a per-channel
//!   majorant): unbiased per channel, Σβ never grows; a constant grid has P = 1 everywhere and
//!   is the homogeneous walk. Connections attenuate by the grid's exact optical depth;
//! - Russian roulette on max_k β_k below a threshold θ (survive with q = max β/θ, β ← β/q; a
//!   radiance estimator books no energy, so nothing is tallied for it); in scenes lit by the
//!   environment alone a walk per colour channel (or per pair, `walk_starts`) and θ = 0.1,
//!   else one walk and θ = 1 (`split_channels`, `rr_threshold`, `flight_mix`: chosen by
//!   measurement; the rules in [`super::env_walk`]);
//! - in scenes lit by the environment alone, where a walk leaves every object along a ray that
//!   escapes, the Fresnel coin's zero-mean control variate c β L_env (1\[reflected\] − F), c from a
//!   pilot before the render ([`super::fresnel_control`]).
//!
//! Light reaches the interior in two ways: the path leaves the objects and the ray continues
//! outside ([`super::shade::trace`]: environment, area lights, Lambertian surfaces with
//! next-event estimation to every light); and next-event estimation from every collision, at
//! any depth of the media stack, to every light through the boundaries ([`super::facet_nee`]):
//! straight through index-matched inner interfaces and refracted exactly at a flat facet of
//! the outermost boundary: for a point or directional light through every facet whose
//! refracted beam reaches the collision ([`super::beams`]: on a curved surface the beams of
//! neighbouring facets overlap), for a point sampled on an area light through the facet the
//! search finds and the facets of short walks from its edge neighbours.
//! In a scene that is not one convex body, area lights are also estimated along each
//! collision's next flight ([`super::flight`]: straight to the boundary, refracted, meeting the
//! light), combined with the connections by multiple importance sampling, and at the boundary
//! that a straight path from a collision reaches, along its reflection; a straight exit after a
//! collision (no scattering or reflection in between, index-matched crossings allowed), or one
//! after exactly that reflection, counts no light it meets directly. Elsewhere (a convex body,
//! guided walks) a straight exit that reaches an area light along the very connection the facet
//! search finds counts nothing (see `exit_counted_by_nee`); other exits (through another facet,
//! or after an internal reflection) count the light. Either way the estimators partition the
//! paths, so nothing is counted twice or lost. Connections are made with a probability q from
//! the distance bound (`nee_draw`) and weighted by 1/q. Not exact: a connection through an inner interface whose
//! indices differ is not made (it would need a refraction at each interface of the chain); area
//! lights and the environment stay unbiased there (their exits count), but point and
//! directional lights, which no exit can reach, miss the light that reaches such collisions.

use super::accel::{Hit, Tri};
use super::beams::Beams;
use super::distance::DistanceGrid;
pub(super) use super::env_walk::least_sigma_t;
pub use super::env_walk::{FLIGHT_MIX, MIX_ALBEDO, RR_THRESHOLD, SPLIT_ALBEDO};
use super::facet_nee::{self, Connection};
use super::fastmath::exp;
use super::flight::{light_next_flight, reflected_light, Reach};
use super::grid::Local;
use super::guide::Flight;
use super::light::Light;
use super::material::{Material, Translucent};
use super::math::{add, dot, madd, max3, mul, neg, normalize, scale, sub, Rgb, V3};
use super::scene::Scene;
use super::shade::{shade, tint, trace_seen, Seen, Translucency, MAX_DEPTH};
use super::walk::{walk, Carrier, Crossing, FirstFlight, Media};
use crate::optics::{fr_dielectric, refract};
use crate::rng::PhotonRng;

/// The random-walk method.
pub struct RandomWalk {
    /// Next-event estimation through facets (off only to test it against plain path tracing).
    pub nee: bool,
    /// The scale c of the connection probability ([`NEE_SCALE`]; other values in tests).
    pub nee_scale: f64,
    /// Next-flight estimation of the environment through the boundary (opt-in, off by default:
    /// measured to cost efficiency on every benchmark scene, docs/render.md "Random walk
    /// speed"; see `RandomWalk::env_next_flight`). Needs `nee`.
    pub env_nee: bool,
    /// Guided sampling towards the surface with MIS against the classic walk
    /// ([`super::guide`]).
    pub guided: bool,
    /// One walk per colour channel (β = e_k: the channel choice is then certain, and β_k the
    /// single-channel implicit-capture weight) instead of one walk carrying all three with
    /// spectral MIS, whose per-channel weights of long, high-albedo walks are heavy-tailed (95 %
    /// of the marble sphere's per-channel variance in an environment was that chromatic noise:
    /// the variance of the channels' mean was 5 % of theirs), where it pays; a channel of short
    /// walks shares its neighbour's (`walk_starts`). On by default in scenes lit by the
    /// environment alone.
    pub split_channels: bool,
    /// With `split_channels`: split only the walks entering a material whose every channel's
    /// reduced albedo σs'/(σs' + σa) is at least this ([`SPLIT_ALBEDO`]; 0 splits every walk).
    pub split_albedo: f64,
    /// Russian roulette threshold θ: a path whose largest β_k is below θ survives with
    /// probability max β/θ and is then weighted up to max β = θ. θ = 1 (the default under
    /// lights) makes every collision of an implicit-capture walk an analog absorption event
    /// (β = albedo < 1 at once), so a walk's score is all or nothing; θ = [`RR_THRESHOLD`] (the
    /// default in an environment alone) lets β decay continuously first.
    pub rr_threshold: f64,
    /// The share of the throughput-proportional channel choice in the free path's channel
    /// probabilities w (1: spectral MIS alone, the default under lights); the rest, 1 − mix, goes
    /// to the carried channel of least σt, in media where that pays (`least_sigma_t`; walks that
    /// carry two or three channels) ([`FLIGHT_MIX`] in an environment alone). The weights are
    /// those of the one-sample balance heuristic (Veach 1997, §9.2.4) with this w
    /// (p̄ = Σ_j w_j σt,j T_j): unbiased for any mix in (0, 1]; since p̄ ≥ mix Σ_j β_j σt,j T_j/Σβ,
    /// a collision multiplies Σβ by at most 1/mix (and since p̄ ≥ (1 − mix) σt,l T_l with σt,l the
    /// least σt and T_k ≤ T_l, a channel's factor σs,k T_k/p̄ is at most σs,k/((1 − mix) σt,l)).
    /// See [`FLIGHT_MIX`] for what it gains.
    pub flight_mix: f64,
    /// Next-flight estimation of the area lights, combined with the facet connections by
    /// multiple importance sampling (see `RandomWalk::light_next_flight`): on by default with
    /// `nee` in scenes with an area light; classic (unguided) walks only.
    pub light_flight: bool,
    /// The facet search's walks from the edge neighbours of the facet it finds, in facets
    /// ([`facet_nee::points_walked`]): [`NEE_WALK`], or 1 (the neighbours alone) in a scene that
    /// is one convex body.
    pub nee_walk: usize,
    /// With `light_flight`: the light after one reflection off the boundary as an expected value
    /// at the boundary (`RandomWalk::reflected_light`; on by default).
    pub reflected: bool,
    /// The scale c_f of the next-flight probability q_f = min(1, c_f e^{−τ_lb})
    /// ([`FLIGHT_SCALE`]).
    pub flight_scale: f64,
    /// The camera path's walks draw their first events from the sample's scrambled Sobol point
    /// ([`crate::rng::Qmc`]; on by default; off: the sample's stream alone).
    pub qmc: bool,
    /// Per object: the coefficients c (per channel) of the Fresnel coin's control variate where
    /// a walk leaves every object through that object's boundary ([`super::fresnel_control`]);
    /// empty (off) but in scenes lit by the environment alone.
    pub fresnel_control: Vec<Rgb>,
    /// Per object: how many times a camera path walks each of its walk groups (`walk_starts`;
    /// [`super::walk_alloc`]); empty (once each) but in scenes lit by the environment alone.
    pub walk_repeats: Vec<[u32; 3]>,
    /// Per light: the cone of directions (unit axis, cosine of the half-angle) outside which no
    /// straight flight from inside the translucent objects can leave towards it (the light's
    /// directions from the objects' box, widened by the largest deviation of a refraction out of
    /// any medium); None for point and directional lights.
    reach: Reach,
    /// A distance bound to the facets that can face a light (None: use the scene's bound).
    facing: Option<DistanceGrid>,
    /// The least σt over the translucent materials and channels, mm⁻¹.
    sigma_t_min: f64,
    /// Per light: the beams of a point or directional light ([`Beams`]; None for area lights).
    beams: Vec<Option<Beams>>,
}

/// The renderer's carrier: RGB throughput β with spectral MIS, the radiance gathered so far,
/// and the last collision (for the exit/NEE partition).
struct Radiance<'a> {
    rw: &'a RandomWalk,
    depth: u32,
    beta: Rgb,
    /// The channel-choice probabilities of the current free path, and the chosen channel.
    w: Rgb,
    k: usize,
    l: Rgb,
    /// Whether the path since the last collision is straight (no reflection, no refraction at
    /// a mismatched interface; `last` holds that collision's point and media).
    straight: bool,
    /// Whether the path since the last collision made one reflection, off a boundary that
    /// leaves every object and at which `RandomWalk::reflected_light` was estimated, and
    /// nothing else (`pending`: estimated at the boundary being crossed).
    mirrored: bool,
    pending: bool,
    last: (V3, Media),
    /// How the current flight was sampled (guided walks).
    flight: Flight,
    /// The direction the path arrived along at the last real collision (the phase function's
    /// incident direction, for the next flight's and the connections' MIS weights).
    arrive: V3,
    /// The medium of the last free path (by address) and its channel of least σt where
    /// `least_sigma_t` takes it (`RandomWalk::flight_mix`).
    least: (*const Translucent, Option<usize>),
    /// The leaving crossing's Fresnel reflectance F and control coefficients c, where its exit
    /// scores the control variate (`RandomWalk::coin_control`).
    coin: Option<(f64, Rgb)>,
    /// Collisions and boundary hits so far (the walk-allocation pilot's cost, `super::walk_alloc`).
    events: u32,
}

impl Carrier for Radiance<'_> {
    #[inline(always)]
    fn channel(&mut self, m: &Translucent, rng: &mut PhotonRng) -> Option<usize> {
        // Channel chosen with probability ∝ β_k (throughput-weighted spectral MIS), mixed with
        // the carried channel of least σt (`RandomWalk::flight_mix`).
        let bsum = self.beta[0] + self.beta[1] + self.beta[2];
        if !(bsum > 0.0) {
            return None;
        }
        self.w = scale(self.beta, 1.0 / bsum);
        let mix = self.rw.flight_mix;
        if mix < 1.0 {
            if !std::ptr::eq(self.least.0, m) {
                self.least = (m, least_sigma_t(m, self.beta));
            }
            if let Some(l) = self.least.1 {
                self.w = scale(self.w, mix);
                self.w[l] += 1.0 - mix;
            }
        }
        // Without branches (their outcome is random): u < w₀ ≤ w₀ + w₁ gives 0.
        let u = rng.uniform();
        self.k = usize::from(u >= self.w[0]) + usize::from(u >= self.w[0] + self.w[1]);
        Some(self.k)
    }

    #[inline(always)]
    fn collide(
        &mut self,
        scene: &Scene,
        m: &Translucent,
        media: &Media,
        s: f64,
        p: V3,
        d: V3,
        rng: &mut PhotonRng,
    ) -> bool {
        let f = self.flight;
        // A classic flight's β_k σs,k T_k / p̄ is computed divided through by T_c of the
        // sampled channel c: T_k/T_c = e^{(σt,c − σt,k) s} ≤ e^{−ln ξ} (no overflow), T_c/T_c
        // = 1 without an exponential (two instead of three per collision).
        // The two other channels by index (no branch on the random channel).
        // A walk of one channel (the environment's per-channel walks: the other β are 0) needs
        // neither: their weights stay 0 and p̄ = σt,c.
        let tr: Rgb = if f.gf > 0.0 {
            std::array::from_fn(|k| exp(-m.sigma_t[k] * s))
        } else {
            let (c, shift) = (self.k, m.sigma_t[self.k]);
            let (a, b) = ([1, 2, 0][c], [2, 0, 1][c]);
            // A channel the walk does not carry (β = 0: the environment's walks of one or two
            // channels) keeps T = 1: its weight and β stay 0 either way, one exponential fewer.
            let mut tr = [1.0; 3];
            if self.beta[a] != 0.0 {
                tr[a] = exp((shift - m.sigma_t[a]) * s);
            }
            if self.beta[b] != 0.0 {
                tr[b] = exp((shift - m.sigma_t[b]) * s);
            }
            tr
        };
        let mut pbar = dot(self.w, mul(m.sigma_t, tr));
        if f.gf > 0.0 {
            // The one-sample MIS mixture of the classic and the guided flight (per unit phase
            // pdf: the phase function cancels), balance heuristic (super::guide).
            let st: Rgb = std::array::from_fn(|k| m.sigma_t[k] * f.stretch);
            let trg: Rgb = std::array::from_fn(|k| exp(-st[k] * s));
            pbar = (1.0 - f.gf) * pbar + f.gf * f.factor * dot(self.w, mul(st, trg));
        }
        if !(pbar > 0.0) {
            return false;
        }
        self.events += 1;
        let inv = 1.0 / pbar;
        self.beta = std::array::from_fn(|k| self.beta[k] * m.sigma_s[k] * tr[k] * inv);
        self.connect(scene, m, media, p, d, rng);
        true
    }

    fn delta(
        &mut self,
        scene: &Scene,
        m: &Translucent,
        local: &Local,
        media: &Media,
        s: f64,
        p: V3,
        d: V3,
        rng: &mut PhotonRng,
    ) -> Option<bool> {
        self.events += 1;
        // The majorant process's event density, as `collide` weights a homogeneous medium of σ̄.
        let sb = m.sigma_bar;
        let tr: Rgb = std::array::from_fn(|k| exp(-sb[k] * s));
        let pbar = dot(self.w, mul(sb, tr));
        if !(pbar > 0.0) {
            return None;
        }
        self.beta = std::array::from_fn(|k| self.beta[k] * sb[k] * tr[k] / pbar);
        // Real with P = Σ_k ŵ_k σt,k(x)/σ̄_k (ŵ ∝ β: spectral MIS over the channels, Kutz et al.
        // 2017 §5), null otherwise; each channel weighted by its own probability over P, so
        // E[β_k] is exact per channel and Σβ never grows.
        let bsum = self.beta[0] + self.beta[1] + self.beta[2];
        if !(bsum > 0.0) {
            return None;
        }
        let ratio: Rgb = std::array::from_fn(|k| if sb[k] > 0.0 { (local.sigma_t[k] / sb[k]).min(1.0) } else { 0.0 });
        // Every channel at its majorant (a constant grid, a texture): real without a draw.
        let full = (0..3).all(|k| ratio[k] >= 1.0 || self.beta[k] == 0.0);
        let pr = if full { 1.0 } else { dot(self.beta, ratio) / bsum };
        let real = pr >= 1.0 || (pr > 0.0 && rng.uniform() < pr);
        if real {
            let f = pr.min(1.0);
            self.beta =
                std::array::from_fn(|k| if sb[k] > 0.0 { self.beta[k] * local.sigma_s[k] / (sb[k] * f) } else { 0.0 });
            self.connect(scene, m, media, p, d, rng);
        } else {
            // A null collision keeps the path straight (`last` stays the last real collision).
            self.beta = std::array::from_fn(|k| self.beta[k] * (1.0 - ratio[k]) / (1.0 - pr));
        }
        Some(real)
    }

    fn guided(&self) -> bool {
        self.rw.guided
    }

    fn flight(&mut self, f: &Flight) {
        self.flight = *f;
    }

    #[inline(always)]
    fn scattered(&mut self, scene: &Scene, m: &Translucent, media: &Media, p: V3, d: V3, rng: &mut PhotonRng) {
        if self.rw.env_nee && self.rw.nee && self.depth < MAX_DEPTH {
            let e = self.rw.env_next_flight(scene, m, media, p, d, rng);
            self.l = add(self.l, mul(self.beta, e));
        }
        if self.rw.flights() && self.depth < MAX_DEPTH && self.rw.reaches(d) {
            let tau = self.rw.tau_lb(scene, m, p);
            let qf = self.rw.flight_prob(tau);
            if qf >= 1.0 || rng.uniform() < qf {
                let q = (self.rw.nee_scale * exp(-tau)).min(1.0);
                let e = light_next_flight(scene, m, media, (p, self.arrive, d), (qf, q), self.rw.nee_walk);
                self.l = add(self.l, mul(self.beta, e));
            }
        }
    }

    #[inline(always)]
    fn roulette(&mut self, _p: V3, rng: &mut PhotonRng) -> bool {
        let theta = self.rw.rr_threshold;
        let q = max3(self.beta) / theta;
        if q < 1.0 {
            if rng.uniform() >= q {
                return false;
            }
            self.beta = scale(self.beta, 1.0 / q);
        }
        true
    }

    fn reach(&mut self, m: &Translucent, t: f64) -> bool {
        self.events += 1;
        // σt, or the majorant; 0 for a channel the walk does not carry (its weight and β are 0).
        let tr: Rgb = std::array::from_fn(|k| if self.beta[k] != 0.0 { exp(-m.sigma_bar[k] * t) } else { 0.0 });
        let mut pbar = dot(self.w, tr);
        let f = self.flight;
        if f.gf > 0.0 {
            let trg: Rgb = std::array::from_fn(|k| exp(-m.sigma_bar[k] * f.stretch * t));
            pbar = (1.0 - f.gf) * pbar + f.gf * f.factor * dot(self.w, trg);
        }
        if !(pbar > 0.0) {
            return false;
        }
        self.beta = std::array::from_fn(|k| self.beta[k] * tr[k] / pbar);
        true
    }

    fn boundary(&mut self, scene: &Scene, media: &Media, h: &Hit, d: V3) {
        // The light of the reflection off this boundary (where it leaves every object) after a
        // straight path from a collision, as an expected value (`RandomWalk::reflected_light`).
        self.pending = false;
        if self.straight && self.rw.flights() && self.rw.reflected && self.depth < MAX_DEPTH {
            if let Some(e) = reflected_light(scene, media, h, d, &self.rw.reach) {
                self.l = add(self.l, mul(self.beta, e));
                self.pending = true;
            }
        }
    }

    fn coin(&mut self, scene: &Scene, h: &Hit, t: V3, f: f64, reflected: bool) {
        // The control variate c β L_env(t) (1\[reflected\] − F) (super::fresnel_control): a
        // reflection adds c (1 − F) β L_env where the refracted ray escapes; an exit scores
        // (1 − c F) β L_env in place of β L_env where it does (`Radiance::exit`).
        let Some(c) = self.rw.coin_control(scene, h.object, self.depth) else { return };
        if !reflected {
            self.coin = Some((f, c));
        } else if scene.accel.intersect(h.p, t, f64::INFINITY, h.tri).is_none() {
            let w: Rgb = std::array::from_fn(|k| c[k] * (1.0 - f));
            self.l = add(self.l, mul(self.beta, mul(scene.environment, w)));
        }
    }

    fn bounced(&mut self, crossing: &Crossing) {
        // An index-matched crossing keeps the path straight (and ends a mirrored one).
        self.mirrored = self.straight && self.pending && matches!(crossing, Crossing::Reflected(_));
        if !matches!(crossing, Crossing::Transmitted { matched: true, .. }) {
            self.straight = false;
        }
    }

    fn exit(&mut self, scene: &Scene, h: &Hit, d: V3, rng: &mut PhotonRng) {
        // What is traced from here on is not this walk's: no more of its Sobol coordinates.
        rng.qmc_pause();
        // A straight exit after a collision: the lights it meets directly are what the
        // collision's next-flight estimator counted (`light_next_flight`), or else, for the
        // connections the facet search finds, the connections (`exit_counted_by_nee`).
        let direct = self.straight;
        let lights_counted = (self.straight && self.rw.flights()) || self.mirrored;
        if self.rw.nee && direct && !lights_counted && self.rw.exit_counted_by_nee(scene, &self.last, h, d) {
            return;
        }
        if let Some((f, c)) = self.coin.take() {
            // The Fresnel coin's control variate (no lights, no next flights: what `trace_seen`
            // would give, with the escape scored (1 − c F) β L_env).
            let hit = scene.accel.intersect(h.p, d, f64::INFINITY, h.tri);
            let li = match hit {
                None => mul(scene.environment, std::array::from_fn(|k| 1.0 - c[k] * f)),
                Some(_) => shade(scene, hit, d, self.depth + 1, rng, self.rw),
            };
            self.l = add(self.l, mul(self.beta, li));
            return;
        }
        if self.depth < MAX_DEPTH {
            // A straight exit after a collision: its escape to the environment is what the
            // collision's next-flight estimator counted (`env_next_flight`).
            let env_counted = self.rw.env_nee && self.rw.nee && direct;
            let seen = match (env_counted, lights_counted) {
                (true, true) => Seen::NoEmitters,
                (true, false) => Seen::NoEnvironment,
                (false, true) => Seen::NoLights,
                (false, false) => Seen::All,
            };
            let li = trace_seen(scene, (h.p, d, h.tri), self.depth + 1, rng, self.rw, seen);
            self.l = add(self.l, mul(self.beta, li));
        }
    }

    fn lost(&mut self, _p: V3, _capped: bool) {}
}

impl Radiance<'_> {
    /// Next-event estimation at a (real) collision, made with probability q. Inlined into the
    /// walk (the draw and the bookkeeping run at every collision); the connections themselves
    /// ([`RandomWalk::nee`], a few collisions in a hundred) stay a call.
    #[inline(always)]
    fn connect(&mut self, scene: &Scene, m: &Translucent, media: &Media, p: V3, d: V3, rng: &mut PhotonRng) {
        (self.straight, self.mirrored) = (true, false);
        if !self.rw.nee || scene.lights.is_empty() {
            return; // `last` and `arrive` serve the lights' estimators only
        }
        let drawn = self.rw.nee_draw(scene, m, p, rng);
        self.last = (p, *media);
        self.arrive = d;
        if let Some((q, tau)) = drawn {
            // The next flight's probability at this collision (the MIS weights of the area lights).
            let qf = if self.rw.flights() && self.depth < MAX_DEPTH { self.rw.flight_prob(tau) } else { 0.0 };
            self.l = add(self.l, mul(self.beta, self.rw.nee(scene, m, media, (p, d), (q, qf), rng)));
        }
    }
}

impl RandomWalk {
    pub fn new(scene: &Scene) -> RandomWalk {
        RandomWalk::variant(scene, true, nee_scale(scene))
    }

    /// The method with next-event estimation on or off and a connection-probability scale c
    /// (tests compare variants). Builds the distance bound to the facets that can face a light.
    pub fn variant(scene: &Scene, nee: bool, nee_scale: f64) -> RandomWalk {
        let sigma_t_min = scene
            .materials
            .iter()
            .filter_map(|m| m.translucent())
            .map(Translucent::sigma_t_floor)
            .fold(f64::INFINITY, f64::min);
        let facing = (nee && !scene.lights.is_empty()).then(|| scene.translucent_box()).flatten().map(|(lo, hi)| {
            let tol = 1e-6 * scene.accel.extent;
            let tris: Vec<Tri> =
                scene.accel.tris.iter().filter(|t| scene.lights.iter().any(|l| may_face(l, t, tol))).copied().collect();
            DistanceGrid::new(&tris, lo, hi, sigma_t_min)
        });
        // Measured (docs/render.md, "Random walk speed"): in an environment alone, one walk per
        // channel with roulette below β = 0.1 is 1.0–5× as efficient on the benchmark scenes;
        // under lights it costs (three walks' light connections per camera path).
        let env_only = scene.lights.is_empty() && scene.environment != [0.0; 3];
        let reach = Reach::new(scene);
        let mut rw = RandomWalk {
            nee,
            nee_scale,
            env_nee: false,
            guided: false,
            split_channels: env_only,
            split_albedo: SPLIT_ALBEDO,
            rr_threshold: if env_only { RR_THRESHOLD } else { 1.0 },
            flight_mix: if env_only { FLIGHT_MIX } else { 1.0 },
            light_flight: nee && reach.any() && scene.accel.convex.is_none(),
            reflected: true,
            nee_walk: if scene.accel.convex.is_some() { 1 } else { NEE_WALK },
            flight_scale: FLIGHT_SCALE,
            reach,
            facing,
            sigma_t_min,
            beams: scene.lights.iter().map(|l| if nee { Beams::new(scene, l) } else { None }).collect(),
            fresnel_control: vec![],
            walk_repeats: vec![],
            qmc: true,
        };
        if env_only {
            rw.fresnel_control = super::fresnel_control::coefficients(scene, &rw);
            rw.walk_repeats = super::walk_alloc::repeats(scene, &rw);
        }
        rw
    }

    /// The Fresnel coin's control coefficients for a walk leaving every object through the
    /// boundary of `object` on a camera path at `depth` (None where off: lights in the scene,
    /// the environment's next flights, the depth limit, or c = 0).
    #[inline]
    fn coin_control(&self, scene: &Scene, object: usize, depth: u32) -> Option<Rgb> {
        let c = *self.fresnel_control.get(object)?;
        (c != [0.0; 3] && !self.env_nee && scene.lights.is_empty() && depth < MAX_DEPTH).then_some(c)
    }

    /// One walk from `hit` into its object along `t` at `depth` with start throughput `beta`:
    /// its radiance and its events (collisions and boundary hits, the pilot's cost). `first`:
    /// what the earlier walks from `hit` along `t` found on their first flights
    /// ([`FirstFlight`]; a new one for a walk of its own).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn walk_one(
        &self,
        scene: &Scene,
        hit: &Hit,
        t: V3,
        depth: u32,
        beta: Rgb,
        rng: &mut PhotonRng,
        first: &mut FirstFlight,
    ) -> (Rgb, u32) {
        let mut c = Radiance {
            rw: self,
            depth,
            beta,
            w: [0.0; 3],
            k: 0,
            l: [0.0; 3],
            straight: false,
            mirrored: false,
            pending: false,
            last: (hit.p, Media::empty()),
            flight: Flight::CLASSIC,
            arrive: t,
            least: (std::ptr::null(), None),
            coin: None,
            events: 0,
        };
        walk(scene, Media::inside(hit.object), hit.p, t, hit.tri, &mut c, rng, first);
        rng.qmc_pause();
        (c.l, c.events)
    }

    /// Whether the walks estimate the area lights by their next flights (`light_flight` with
    /// `nee`, unguided walks: the MIS weights take the phase function as the direction's pdf).
    #[inline]
    fn flights(&self) -> bool {
        self.light_flight && self.nee && !self.guided
    }

    /// Whether a straight flight along `d` may leave towards an area light (`reach`).
    #[inline]
    fn reaches(&self, d: V3) -> bool {
        self.reach.reaches(d)
    }

    /// The optical-depth bound τ_lb = max(σt,min(m) r, σt,min r_f) at `p` (see `nee_draw`):
    /// every straight path from `p` to a facet through which a light can be seen is at least
    /// this deep.
    fn tau_lb(&self, scene: &Scene, m: &Translucent, p: V3) -> f64 {
        let tau = m.sigma_t_floor() * scene.accel.clear_radius(p);
        self.facing.as_ref().map_or(tau, |g| tau.max(self.sigma_t_min * g.cell_bound(p)))
    }

    /// The probability q_f = min(1, c_f e^{−τ_lb}) of a next-flight estimate of the lights at a
    /// collision with bound `tau` (whose new direction `reaches` a light).
    #[inline]
    fn flight_prob(&self, tau: f64) -> f64 {
        (self.flight_scale * exp(-tau)).min(1.0)
    }

    /// Whether a straight exit (from the collision `last` = (point, media) through the
    /// boundary at `h`, leaving along `d`) reaches an area light along a connection that
    /// next-event estimation at that collision counts: the facet search from the collision to
    /// the light point finds this very facet. Those exits count nothing, whether or not the
    /// collision made its connections (made with probability q, they are weighted by 1/q);
    /// every other exit (other facets, failed searches, exits after a reflection) counts the
    /// light, so the two estimators partition the paths exactly.
    /// The nearest light along the exit first (no ray where there is none, as in a scene lit
    /// by the environment alone), then whether a surface hides it.
    fn exit_counted_by_nee(&self, scene: &Scene, last: &(V3, Media), h: &Hit, d: V3) -> bool {
        let Some((tl, _)) = scene.light_hit(h.p, d, f64::INFINITY) else { return false };
        if scene.accel.intersect(h.p, d, tl, h.tri).is_some() {
            return false;
        }
        let y = super::math::madd(h.p, d, tl);
        facet_nee::points_walked(scene, &last.1, last.0, y, self.nee_walk).iter().flatten().any(|c| c.hit.tri == h.tri)
    }

    /// Whether the connections are made at the collision `p` (in `m`): with probability
    /// q = min(1, c e^{−τ_lb}), τ_lb = max(σt,min(m) r, σt,min r_f) (c = `nee_scale`; r the
    /// scene's distance bound to every surface, [`super::distance`]; r_f the bound to the facets
    /// that can face a light, the only ones the facet search connects through; σt,min(m) the
    /// least σt of `m`, σt,min that of every medium, which a connection may cross through
    /// index-matched interfaces), drawn with one ξ; no ray is cast to decide. Returns q where
    /// they are made ([`Self::nee`] weights them by 1/q). Every connection's optical depth is at
    /// least τ_lb, so its transmittance is at most q/c: the weighted connections of deep
    /// collisions stay bounded, and no exit counts what they count (see `exit_counted_by_nee`).
    /// (Measured and replaced: q from τ of the straight line to each light's centre, with area
    /// lights left to the exits of collisions that skipped their connections. It cost a ray per
    /// light and collision, and it was far below the transmittance of refracted connections
    /// through nearby facets facing away from the light: those exits carried 30 % of a marble
    /// sphere's light as rare, bright hits on the area light, > 90 % of the squared error.)
    #[inline(always)]
    fn nee_draw(&self, scene: &Scene, m: &Translucent, p: V3, rng: &mut PhotonRng) -> Option<(f64, f64)> {
        if !self.nee || scene.lights.is_empty() {
            return None;
        }
        // The same decision as u < q with q = min(1, c e^{−max(τ₁, τ₂)}), cheapest test first:
        // q ≤ min(1, c) and q ≤ min(1, c e^{−τ₁}) (no exponential or second lookup where u
        // exceeds a bound already). Returns (q, τ_lb) where made.
        let u = rng.uniform();
        if u >= self.nee_scale.min(1.0) {
            return None;
        }
        let tau = m.sigma_t_floor() * scene.accel.clear_radius(p);
        let q = (self.nee_scale * exp(-tau)).min(1.0);
        let Some(g) = &self.facing else { return (u < q).then_some((q, tau)) };
        let tau_f = self.sigma_t_min * g.cell_bound(p);
        if u >= q || tau_f <= tau {
            return (u < q).then_some((q, tau));
        }
        let q = (self.nee_scale * exp(-tau_f)).min(1.0);
        (u < q).then_some((q, tau_f))
    }

    /// The environment seen through the boundary along the next flight (an expected-value,
    /// "next-flight" estimator: Spanier & Gelbard 1969 §3; the collision estimators of pbrt-v4's
    /// and Cycles' volume integrators for surfaces): after a real collision at `p` (in `m` on
    /// top of `media`) drew the new direction `d`, the walk leaves the objects along the straight
    /// line (through index-matched interfaces, [`facet_nee::chain`]) with probability
    /// T(ℓ)·F_t per channel (free path past the boundary, refraction at the outer facet), and
    /// its refracted ray ω_out then escapes the scene or meets a light or a surface. This
    /// returns that escape's expected radiance per unit β, T_k F_t(cos θ) L_env / q: the
    /// Fresnel transmittance as a weight, not a choice; no η² factor (the walk's own exits
    /// carry none: entry and exit factors cancel). The direction is the walk's own (pdf = the
    /// phase function, so phase/pdf = 1), and the walk's straight exit after such a collision
    /// that escapes counts no environment (`Radiance::exit`): the two estimators partition the
    /// paths (exits after a reflection or a mismatched inner interface, or meeting a light or
    /// a surface, still count). Made with probability q = min(1, e^{−σt,min(m) r}) (r: the
    /// distance bound, [`super::distance`]; every flight's transmittance is ≤ e^{−σt,min r}, so
    /// T/q ≤ 1), weighted by 1/q, one ξ where q < 1; two rays where made (the chain and the
    /// escape test).
    #[allow(clippy::too_many_arguments)]
    fn env_next_flight(&self, scene: &Scene, m: &Translucent, media: &Media, p: V3, d: V3, rng: &mut PhotonRng) -> Rgb {
        let q = (-m.sigma_t_floor() * scene.accel.clear_radius(p)).exp().min(1.0);
        if q < 1.0 && !(rng.uniform() < q) {
            return [0.0; 3];
        }
        let Some(c) = facet_nee::chain(scene, media, p, d) else { return [0.0; 3] };
        let (h, eta) = (c.hit, media.index(scene));
        let Some(out) = refract(d, h.n, eta, 1.0) else { return [0.0; 3] }; // total internal reflection
        if scene.accel.intersect(h.p, out, f64::INFINITY, h.tri).is_some()
            || scene.light_hit(h.p, out, f64::INFINITY).is_some()
        {
            return [0.0; 3];
        }
        let w = (1.0 - fr_dielectric(dot(d, h.n).abs(), eta, 1.0)) / q;
        std::array::from_fn(|k| w * (-c.tau[k]).exp() * scene.environment[k])
    }

    /// Next-event estimation of every light from the collision at `p` (camera path direction
    /// `d`) in the medium `m` on top of `media`, through the boundaries ([`super::facet_nee`]);
    /// area lights by one uniformly sampled point each; every light weighted by 1/`q` (the
    /// probability the connections are made here). Returns the in-scattered radiance per unit
    /// β, times 1/η² (η of the collision's medium: the radiance change from there to the outside
    /// at x_o, which the walk's paired entry/exit factors otherwise cancel).
    ///
    /// With next-flight estimation of the lights (`qf` > 0: its probability at this collision,
    /// for directions that [`Self::reaches`]), an area light's connection is weighted by the
    /// balance heuristic of the two strategies' expected densities at v, a_c = q p_c (p_c the
    /// connection's solid-angle pdf, the light's area pdf × η²/(G cos θ_l)) and a_f = q_f p(ω)
    /// (the phase function's): f/(q p_c) × a_c/(a_c + a_f) = f/(p_c (q + a_f/p_c)).
    #[inline(never)]
    fn nee(
        &self,
        scene: &Scene,
        m: &Translucent,
        media: &Media,
        (p, d): (V3, V3),
        (q, qf): (f64, f64),
        rng: &mut PhotonRng,
    ) -> Rgb {
        // One connection's in-scattered radiance per unit β.
        let through = |c: &Connection, power: Rgb| -> Rgb {
            let w = c.factor * m.phase.eval(dot(c.d_in, neg(d))) / (m.eta * m.eta);
            std::array::from_fn(|k| w * power[k] * exp(-c.tau[k]))
        };
        let eta = media.index(scene);
        let mut l = [0.0; 3];
        for (i, light) in scene.lights.iter().enumerate() {
            match *light {
                Light::Directional { irradiance: power, .. } | Light::Point { intensity: power, .. } => {
                    let Some(beams) = &self.beams[i] else { continue };
                    facet_nee::delta_connections(scene, beams, media, p, light, |c| l = add(l, through(&c, power)));
                }
                Light::Sphere { .. } | Light::Rect { .. } => {
                    let Some((y, ny, le, pdf)) = light.sample_point(rng.uniform(), rng.uniform()) else { continue };
                    for c in facet_nee::points_walked(scene, media, p, y, self.nee_walk).iter().flatten() {
                        let cos_l = dot(ny, normalize(sub(c.hit.p, y)));
                        if cos_l > 0.0 {
                            let out = neg(c.d_in);
                            let af = if qf > 0.0 && self.reaches(out) { qf * m.phase.eval(dot(out, d)) } else { 0.0 };
                            // a_f/(q p_c): the next flight's share relative to this strategy's.
                            let share = af * c.geometry * cos_l / (pdf * eta * eta * q);
                            l = add(l, through(c, scale(le, cos_l / (pdf * (1.0 + share)))));
                        }
                    }
                }
            }
        }
        scale(l, 1.0 / q)
    }
}

/// Whether triangle `t`'s plane may have a point of `light` in front of it (the facet search
/// connects only through such facets: [`facet_nee::point`] needs h_y > 0, a directional
/// connection cos θ > 0); `tol` (mm) widens the test.
fn may_face(light: &Light, t: &Tri, tol: f64) -> bool {
    let front = |y: V3| dot(sub(y, t.v0), t.n) > -tol;
    match *light {
        Light::Directional { to_light, .. } => dot(to_light, t.n) > -1e-9,
        Light::Point { position, .. } => front(position),
        Light::Sphere { center, radius, .. } => dot(sub(center, t.v0), t.n) > -radius - tol,
        Light::Rect { center, u, v, .. } => [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .iter()
            .any(|&(a, b)| front(madd(madd(center, u, a), v, b))),
    }
}

/// The length of the facet search's walks from the neighbours of the facet found (see
/// [`RandomWalk::nee_walk`]). Measured on the benchmark's skin torus under the rect light: the
/// next-flight estimates through facets the search does not find were 97 % of that estimator's
/// second moment, 70 % of it through facets two steps from the one found; walks of 3 facets
/// (the neighbours' Fermat points step across the edge they lie beyond) took the variance from
/// 1.40 to 1.20·10⁻³ at 1.9 % more instructions (ear −2.5 % at +1.1 %); on the convex marble
/// sphere they found no more light and cost 5 %.
pub const NEE_WALK: usize = 3;

/// The scale c_f of the lights' next-flight probability q_f = min(1, c_f e^{−τ_lb})
/// ([`RandomWalk::flight_scale`]; any c_f > 0 is unbiased).
pub const FLIGHT_SCALE: f64 = 1.0;

/// The scale c of the connection probability q = min(1, c e^{−σt,min r}) with point or
/// directional lights in the scene (any c > 0 is unbiased: a connection's transmittance is at
/// most e^{−σt,min r}, so its weight T/q ≤ 1/c). Measured (docs/render.md, "Random walk
/// speed"): on the 5,120-triangle marble sphere c = 1 has the noise of c = 4 and 20 at 23 % and
/// 39 % fewer walk instructions; with a point or directional light on a small sphere (the
/// nested-sphere tests) c = 0.25 multiplies the variance by 2.4 at 2.2× less time: neutral, so
/// those scenes keep c = 1.
pub const NEE_SCALE: f64 = 1.0;

/// The scale c in scenes lit by area lights only (sphere, rect) and the environment. Measured:
/// the 81,920-triangle marble sphere (32×32 px, 6 renders of 4 spp, callgrind) renders with
/// 51 % fewer instructions than c = 1 at 1.22× the per-pixel variance (1.7× the efficiency);
/// the benchmark scenes under the rect light (docs/scripts/walk_efficiency.py) 1.4–2× the
/// efficiency of c = 1 (variance ×1.25 marble, ×1.14 skin, ×0.99 ear, at 0.5–0.6× the CPU
/// seconds); c = 0.1: 18 % fewer instructions again at 1.4× the variance of c = 0.25.
pub const NEE_SCALE_AREA: f64 = 0.25;

/// The default scale c of `scene` ([`NEE_SCALE_AREA`] when every light is an area light, else
/// [`NEE_SCALE`]).
pub fn nee_scale(scene: &Scene) -> f64 {
    if scene.lights.iter().all(|l| matches!(l, Light::Sphere { .. } | Light::Rect { .. })) {
        NEE_SCALE_AREA
    } else {
        NEE_SCALE
    }
}

impl Translucency for RandomWalk {
    fn reflected_trace_q(&self, fr: f64) -> f64 {
        (fr / super::shade::REFLECTED_F0).min(1.0)
    }

    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let Material::Translucent(m) = scene.material(hit.object) else { return [0.0; 3] };
        let d = neg(wo);
        let f = fr_dielectric(dot(wo, hit.n), 1.0, m.eta);
        let Some(t) = refract(d, hit.n, 1.0, m.eta) else { return [0.0; 3] };
        scale(mul(self.walks(scene, hit, t, depth, rng), tint(scene, hit)), 1.0 - f)
    }
}
