//! The random walk's rules in scenes lit by the environment alone ([`super::random_walk`]):
//! which walks a camera path starts (one per channel, or channels grouped), towards which channel
//! their free paths mix, and the roulette threshold; each chosen by measurement (docs/render.md,
//! "Environment lighting: the levers measured", "The free paths of the least σt").

use super::material::Translucent;
use super::math::Rgb;

/// Whether one walk per channel pays for a walk entering `m` (with `split_channels` on): where
/// every channel's reduced albedo σs'/(σs' + σa) is at least `least` ([`SPLIT_ALBEDO`]). Measured in the
/// environment (docs/render.md): the split (with θ = 0.1) removes the chromatic noise of long
/// walks, marble (reduced albedo ≥ 0.998) 5×, ear-like skin2 (≥ 0.925) 1.8× the efficiency; on
/// skin1 (red 0.96, blue 0.68) the short blue and green walks gain nothing and the red one
/// dominates the variance: θ = 0.1 alone 1.3× against 0.95× with the split. A rule of the
/// material, fixed per walk: unbiased either way.
fn split_pays(m: &Translucent, least: f64) -> bool {
    (0..3).all(|k| {
        let sp = m.sigma_s[k] * (1.0 - m.g);
        sp >= least * (sp + m.sigma_a[k])
    })
}

/// The least reduced albedo of every channel for one walk per channel (see `split_pays`).
pub const SPLIT_ALBEDO: f64 = 0.9;

/// The share of spectral MIS in the free paths' channel choice in scenes lit by the environment
/// alone ([`super::random_walk::RandomWalk::flight_mix`]; the rest to the carried channel of least σt). Measured
/// (docs/render.md, "The free paths of the least σt"): on the skin scene of the Mitsuba comparison
/// (skin1, one walk for all channels: its blue reduced albedo is below [`SPLIT_ALBEDO`]) the
/// channel with the least σt (red) is also the one whose walks run longest, and its MIS weights
/// over those walks were most of the error (red's variance 1.9× the mean of the channels'); with
/// its flights sampled by its own σt its variance falls 6×, green's and blue's rise 1.2–1.5×:
/// mix 0 0.61× the variance, 0.25 0.59×, 0.5 0.64×, at the same cost. Where it applies is
/// `least_sigma_t`'s rule. Under the rect light the
/// least-σt flights (mix 0) cost efficiency (ear 0.7×, marble 0.12×: the connections of the
/// other channels), so lights keep spectral MIS.
pub const FLIGHT_MIX: f64 = 0.25;

/// The channel l towards which a walk mixes its free paths in `m` ([`super::random_walk::RandomWalk::flight_mix`]),
/// where that pays: among the channels the walk carries (β_k > 0, at least two), l has the least
/// σt (or majorant σ̄ of a grid) and the largest single-scattering albedo σs/σt, so its walks
/// run longest and its MIS weights are most of the error, and every other carried channel's
/// albedo is at most [`MIX_ALBEDO`], so their walks are short and the bounded factors
/// σs,k T_k/p̄ of l's long flights do not pile up over many collisions. None elsewhere (spectral
/// MIS alone). Measured (docs/render.md, "The free paths of the least σt"; the efficiency of mix
/// 0.25 against spectral MIS in a white environment): where it takes a channel, skin1 spheres of
/// 3 and 10 mm 1.8× and 1.2×, ketchup 2.5×, chicken1 1.8×, the benchmark's skin torus 1.7×,
/// the ear's green–blue walk 1.4× (against a walk each); where it does not, potato (least σt
/// blue, the shortest walks) 0.97×, a medium of albedo 0.995 / 0.968 / 0.909 (green's walks long
/// too) 0.73×, and marble's green–blue walk (albedo 0.998) 0.04×.
pub(super) fn least_sigma_t(m: &Translucent, beta: Rgb) -> Option<usize> {
    let carried = |k: &usize| beta[*k] > 0.0;
    if (0..3).filter(carried).count() < 2 {
        return None;
    }
    let l = (0..3).filter(carried).min_by(|&a, &b| m.sigma_bar[a].total_cmp(&m.sigma_bar[b]))?;
    let (al, ok) = (albedo(m, l), |k: usize| k == l || albedo(m, k) <= MIX_ALBEDO.min(albedo(m, l)));
    (al.is_finite() && (0..3).filter(carried).all(ok)).then_some(l)
}

/// The single-scattering albedo σs/σt of channel `k` of `m` (NaN where σt = 0).
fn albedo(m: &Translucent, k: usize) -> f64 {
    m.sigma_s[k] / m.sigma_t[k]
}

/// The largest single-scattering albedo of a channel that shares the free paths of a walk's
/// channel of least σt (see `least_sigma_t`): between the albedos measured to gain (≤ 0.925) and
/// to lose (≥ 0.968).
pub const MIX_ALBEDO: f64 = 0.95;

/// The walks of one camera path into `m` in a scene lit by the environment alone (with
/// `split_channels`), as start vectors β₀ (the first `n` of the array): one walk carrying every
/// channel where some channel's reduced albedo is below `split_albedo` (`split_pays`);
/// elsewhere a walk per channel, except that a channel whose albedo is at most [`MIX_ALBEDO`]
/// (a short walk) shares the walk of the channel next below it in σt when that one's albedo is
/// at least its own (skin2's blue joins its green: `least_sigma_t` then mixes that walk's free
/// paths towards green).
pub(super) fn walk_starts(m: &Translucent, split_albedo: f64) -> ([Rgb; 3], usize) {
    if !split_pays(m, split_albedo) {
        return ([[1.0; 3]; 3], 1);
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| m.sigma_t[a].total_cmp(&m.sigma_t[b]));
    let (mut starts, mut n) = ([[0.0; 3]; 3], 0);
    for (i, &k) in order.iter().enumerate() {
        let joins = i > 0 && {
            let below = order[i - 1];
            albedo(m, k) <= MIX_ALBEDO.min(albedo(m, below))
        };
        if !joins {
            n += 1;
        }
        starts[n - 1][k] = 1.0;
    }
    (starts, n)
}

/// The Russian roulette threshold θ on max_k β_k (see [`super::random_walk::RandomWalk::rr_threshold`]).
pub const RR_THRESHOLD: f64 = 0.1;
