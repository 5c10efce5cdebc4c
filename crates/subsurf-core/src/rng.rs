//! Random numbers of the Monte Carlo engine: one Philox4x32-10 block per photon seeds a
//! xoshiro128++ generator that produces that photon's stream.
//!
//! - Philox4x32-10 (counter-based): J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw,
//!   "Parallel random numbers: as easy as 1, 2, 3", Proc. SC'11 (2011), §4.2 (the Philox S-box
//!   and key schedule); the constants and round structure are those of Random123's `philox.h`
//!   (also cuRAND's `curand_Philox4x32_10`). Checked against Random123's Known-Answer Test
//!   vectors (`tests/kat_vectors`, lines "philox4x32 10 …").
//! - xoshiro128++ 1.0: D. Blackman, S. Vigna, "Scrambled linear pseudorandom number
//!   generators", ACM Trans. Math. Softw. 47(4) 36 (2021); reference code
//!   <https://prng.di.unimi.it/xoshiro128plusplus.c> (checked against outputs of that C code).
//!   128-bit state, period 2¹²⁸ − 1, passes BigCrush; only 32-bit add/xor/shift/rotate, so it is
//!   as cheap on a GPU as on a CPU.
//!
//! Why the hybrid: Philox costs ~4.4 ns per 32-bit word on the CPU (10 rounds of two 32×32
//! multiplies per 4 words), a third of the kernel's time; a xoshiro128++ step is ~10 integer
//! instructions (the kernel went from 2.3·10⁷ to 3.6·10⁷ scattering events per CPU-second). Keying
//! the stream by (seed, photon) is what makes runs reproducible for any thread count (and on a
//! GPU, one thread per photon): Philox supplies that; xoshiro128++ then only has to produce a
//! few hundred to a few thousand numbers from a uniformly random 128-bit starting state, for
//! which it is statistically excellent. Streams of different photons start from Philox outputs
//! of distinct counters, i.e. from independent, uniformly random states (overlap of two
//! streams of length L in a period of 2¹²⁸ has probability ~ N²L/2¹²⁸, nil).
//!
//! # The stream of photon `photon` for `seed` (to reproduce it elsewhere, e.g. in CUDA)
//!
//! 1. key = `(seed as u32, (seed >> 32) as u32)`, counter = `(photon as u32, (photon >> 32) as
//!    u32, 0, 0)` (`photon` is the global photon index 0 … N−1);
//!    `(s0, s1, s2, s3) = philox4x32_10(counter, key)`;
//! 2. if s0 = s1 = s2 = s3 = 0 (probability 2⁻¹²⁸; xoshiro's one forbidden state), the state
//!    is replaced by [`ZERO_STATE_GUARD`];
//! 3. each 32-bit word is the next xoshiro128++ output from that state:
//!    `r = rotl(s0 + s3, 7) + s0; t = s1 << 9; s2 ^= s0; s3 ^= s1; s1 ^= s2; s0 ^= s3;
//!    s2 ^= t; s3 = rotl(s3, 11)` (wrapping u32 arithmetic), returning r;
//! 4. a uniform is `u = (r + 0.5) · 2⁻³²` computed in f64 (exact), so 0 < u < 1 strictly.
//!
//! With Random123 in CUDA: `philox4x32_10(ctr, key)` with the same `ctr`/`key` gives the same
//! state (cuRAND's `curand_init(seed, subsequence, offset)` lays out its counter differently,
//! so call the Random123 function — or the raw `Philox4x32_10` rounds — directly).

/// Philox multiplier for lanes 0/1 (Random123 `PHILOX_M4x32_0`).
const M0: u32 = 0xD251_1F53;
/// Philox multiplier for lanes 2/3 (Random123 `PHILOX_M4x32_1`).
const M1: u32 = 0xCD9E_8D57;
/// Weyl key increments (golden ratio and √3 − 1 in 0.32 fixed point; `PHILOX_W32_0/1`).
const W0: u32 = 0x9E37_79B9;
const W1: u32 = 0xBB67_AE85;

#[inline(always)]
fn mulhilo(a: u32, b: u32) -> (u32, u32) {
    let p = (a as u64) * (b as u64);
    ((p >> 32) as u32, p as u32)
}

#[inline(always)]
fn round(c: [u32; 4], k: [u32; 2]) -> [u32; 4] {
    let (hi0, lo0) = mulhilo(M0, c[0]);
    let (hi1, lo1) = mulhilo(M1, c[2]);
    [hi1 ^ c[1] ^ k[0], lo1, hi0 ^ c[3] ^ k[1], lo0]
}

/// The Philox4x32-10 bijection: 10 rounds, the key bumped by (W0, W1) between rounds.
#[inline(always)]
pub fn philox4x32_10(counter: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let mut c = counter;
    let mut k = key;
    c = round(c, k);
    for _ in 1..10 {
        k = [k[0].wrapping_add(W0), k[1].wrapping_add(W1)];
        c = round(c, k);
    }
    c
}

/// 2⁻³²: maps a 32-bit word to [0, 1).
const INV_2_32: f64 = 1.0 / 4_294_967_296.0;

/// Map a 32-bit word to the open interval (0, 1): `(x + 0.5) · 2⁻³²` (exact in f64).
///
/// Computed without an int→float conversion: the f64 with exponent 0 and mantissa bits
/// `x · 2²⁰ + 2¹⁹` is 1 + (x + 0.5) · 2⁻³², and subtracting 1 is exact; the result is the
/// same number ([`u32_to_open01_ref`] is the plain formula, checked equal in the tests).
#[inline(always)]
pub fn u32_to_open01(x: u32) -> f64 {
    f64::from_bits(0x3FF0_0000_0000_0000 | ((x as u64) << 20) | (1 << 19)) - 1.0
}

/// `(x + 0.5) · 2⁻³²` by the plain formula (reference for [`u32_to_open01`]).
#[inline]
pub fn u32_to_open01_ref(x: u32) -> f64 {
    (x as f64 + 0.5) * INV_2_32
}

/// The state used instead of an all-zero Philox output (xoshiro's fixed point): the first
/// 128 bits of the fractional part of π.
pub const ZERO_STATE_GUARD: [u32; 4] = [0x243F_6A88, 0x85A3_08D3, 0x1319_8A2E, 0x0370_7344];

/// One xoshiro128++ 1.0 step (Blackman & Vigna 2021): advance `s`, return the output word.
#[inline(always)]
pub fn xoshiro128pp_next(s: &mut [u32; 4]) -> u32 {
    let r = s[0].wrapping_add(s[3]).rotate_left(7).wrapping_add(s[0]);
    let t = s[1] << 9;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = s[3].rotate_left(11);
    r
}

/// One photon's random stream (see the module docs for its exact definition), or a camera
/// sample's: the same stream, with the first events of the sample's random walks drawn from a
/// scrambled Sobol point where [`Qmc`] is armed.
#[derive(Clone, Debug)]
pub struct PhotonRng {
    s: [u32; 4],
    q: Qmc,
}

/// Randomized quasi-Monte Carlo coordinates for the first events of a camera sample's random
/// walks (`render::random_walk`): coordinate d ≥ [`Qmc::FIRST`] of the sample's Sobol point is
/// `owen(sobol(d, index), dim_seed(key, d))` ([`crate::sobol`]; `index` is the sample's index in
/// its pixel, so the samples 0 … 2ᵐ − 1 of a pixel are the sequence's first net, scrambled per
/// pixel). Event j < [`Qmc::EVENTS`] of walk w of the sample takes the block of [`Qmc::BLOCK`]
/// coordinates from FIRST + (w·EVENTS + j)·BLOCK (walk-major: walk 0's events take the first
/// coordinates, the best stratified; the renderer gives walk 0 to its noisiest walk, measured in
/// `render::random_walk`); draws beyond a block, after those events or the table's dimensions,
/// or while no walk is active come from the stream. Each coordinate is used at most once per
/// sample and every scrambled point is uniform in [0, 1)^D, so the estimator's expectation is
/// that of independent uniforms: unbiased, with the samples of a pixel stratified in the early
/// events' free paths, directions and channel choices.
#[derive(Clone, Copy, Debug, Default)]
pub struct Qmc {
    index: u32,
    key: u32,
    /// The Sobol index of the current walk's blocks (`index`, or a copy's, [`PhotonRng::qmc_walk_copy`]).
    at: u32,
    /// Whether the sample's coordinates are still unused ([`PhotonRng::qmc_arm`] takes them).
    ready: bool,
    /// The walks sharing the coordinates (0: none armed) and the one walking now.
    walks: u32,
    walk: u32,
    active: bool,
    /// The next coordinate and the end of the current block (equal: draws from the stream).
    dim: u32,
    end: u32,
    /// The current block's coordinates (computed together when its event starts).
    block: [u32; 4],
}

impl Qmc {
    /// The first coordinate of the walks' blocks (0 and 1 place the sample in its pixel).
    pub const FIRST: u32 = 2;
    /// Coordinates per event: the channel, the free path, and the direction at a collision (an
    /// isotropic medium's disc point; under Henyey–Greenstein the phase ξ and the disc point's x,
    /// its y from the stream) or the Fresnel ξ at a boundary. Measured on the benchmark's
    /// environment scenes (isotropic media; `docs/scripts/walk_efficiency.py`, six renders):
    /// blocks of 4 against 5, per-pixel variance skin 2.33 → 2.17·10⁻⁴, ear 2.27 → 2.17·10⁻⁴,
    /// marble the same (6.20 → 6.18·10⁻⁴): the events' coordinates stay in the sequence's first
    /// dimensions; blocks of 3 (a direction half from the stream): 3.39 and 2.95·10⁻⁴.
    pub const BLOCK: u32 = 4;
    /// Events per walk that take a block (within the table's dimensions). Measured on the
    /// benchmark's environment scenes (`docs/scripts/walk_efficiency.py`, six renders), with
    /// blocks of 5 interleaved by walk: the skin torus's per-pixel variance 4.43 → 2.39, 2.32,
    /// 2.31·10⁻⁴ with 4, 8 and all events (25), the ear's 3.62 → 2.85, 2.66, 2.63·10⁻⁴; with
    /// blocks of 4, walk-major, 12 events: skin 2.16, ear 2.18·10⁻⁴ (8: 2.17, 2.17). Each event
    /// costs its draws.
    pub const EVENTS: u32 = 8;
}

impl PhotonRng {
    /// The stream of photon `photon` for `seed`.
    #[inline]
    pub fn new(seed: u64, photon: u64) -> Self {
        let key = [seed as u32, (seed >> 32) as u32];
        let s = philox4x32_10([photon as u32, (photon >> 32) as u32, 0, 0], key);
        PhotonRng::from_state(s)
    }

    /// A stream starting from the xoshiro128++ state `s` (all-zero replaced by
    /// [`ZERO_STATE_GUARD`]).
    #[inline]
    pub fn from_state(s: [u32; 4]) -> Self {
        PhotonRng { s: if s == [0; 4] { ZERO_STATE_GUARD } else { s }, q: Qmc::default() }
    }

    /// The xoshiro128++ state (the stream continues from it, see [`PhotonRng::from_state`]).
    #[inline]
    pub fn state(&self) -> [u32; 4] {
        self.s
    }

    /// The next 32-bit word of the stream.
    #[inline(always)]
    pub fn next_u32(&mut self) -> u32 {
        if self.q.dim < self.q.end {
            return self.q.next();
        }
        xoshiro128pp_next(&mut self.s)
    }

    /// This stream with the Sobol coordinates of a camera sample (`index`: its index in the
    /// pixel's sequence; `key`: the scrambling key), unarmed ([`Qmc`]).
    pub fn with_qmc(mut self, index: u32, key: u32) -> Self {
        self.q = Qmc { index, key, ready: true, ..Qmc::default() };
        self
    }

    /// Arm the sample's Sobol coordinates for `walks` walks (once per sample: a second call, or
    /// a stream without them, arms nothing). Returns whether armed.
    pub fn qmc_arm(&mut self, walks: u32) -> bool {
        let armed = self.q.ready && walks > 0;
        if armed {
            self.q.walks = walks;
        }
        self.q.ready = false;
        armed
    }

    /// Walk `w` (< the armed count) starts: its events take their blocks until [`Self::qmc_pause`].
    pub fn qmc_walk(&mut self, w: u32) {
        self.qmc_walk_copy(w, 0, 1);
    }

    /// Copy `copy` of `copies` of walk `w` starts (a walk repeated on one camera sample,
    /// `render::walk_alloc`): its events take walk w's blocks at the Sobol index
    /// index·copies + copy, so the copies of a pixel's samples 0 … N − 1 are the sequence's
    /// points 0 … copies·N − 1 (stratified together) instead of independent ones. The index
    /// wraps modulo 2³² past 2³²/copies samples: each point is still uniform (scrambled).
    pub fn qmc_walk_copy(&mut self, w: u32, copy: u32, copies: u32) {
        self.q.active = w < self.q.walks;
        self.q.walk = w;
        self.q.at = self.q.index.wrapping_mul(copies).wrapping_add(copy);
        self.q.end = self.q.dim;
    }

    /// Event `j` of the active walk starts: the next draws are its block's coordinates.
    #[inline(always)]
    pub fn qmc_event(&mut self, j: u32) {
        if self.q.active {
            self.q.event(j);
        }
    }

    /// No more coordinates until the next [`Self::qmc_walk`] (the walk ended, or what follows
    /// is not its own: a path traced on after it leaves).
    #[inline]
    pub fn qmc_pause(&mut self) {
        self.q.active = false;
        self.q.end = self.q.dim;
    }

    /// A uniform number in the open interval (0, 1) (never exactly 0 or 1, so `ln u` is finite).
    #[inline(always)]
    pub fn uniform(&mut self) -> f64 {
        u32_to_open01(self.next_u32())
    }

    /// `2u − 1` for the next uniform u (open interval (−1, 1)), computed as
    /// 2·(1 + (r + 0.5)·2⁻³²) − 3 from the exponent bits: the same number as
    /// `2.0 * self.uniform() - 1.0`, one multiplication fewer.
    #[inline(always)]
    pub fn symmetric(&mut self) -> f64 {
        let r = self.next_u32() as u64;
        f64::from_bits(0x4000_0000_0000_0000 | (r << 20) | (1 << 19)) - 3.0
    }

    /// A point (x, y) uniform in the open unit disc, by rejection from the square (−1, 1)²:
    /// x then y from [`PhotonRng::symmetric`], repeated until x² + y² < 1 (acceptance π/4).
    /// x² + y² > 0 always (x, y are odd multiples of 2⁻³², never both 0). Used for the
    /// scattering azimuth (`mc::kernel`) and for Malley's cosine-weighted directions (`mc::source`).
    #[inline(always)]
    pub fn disc_point(&mut self) -> (f64, f64) {
        if self.q.end >= self.q.dim + 2 {
            // Sobol coordinates: the concentric map (no rejection, which would shift them).
            return concentric(self.uniform(), self.uniform());
        }
        loop {
            let x = self.symmetric();
            let y = self.symmetric();
            if x * x + y * y < 1.0 {
                return (x, y);
            }
        }
    }
}

// A block is one `sobol::scrambled_block`.
const _: () = assert!(Qmc::BLOCK == 4);

impl Qmc {
    #[inline(always)]
    fn next(&mut self) -> u32 {
        let k = (self.dim + Self::BLOCK - self.end) as usize;
        self.dim += 1;
        self.block[k % Self::BLOCK as usize]
    }

    fn event(&mut self, j: u32) {
        if j >= Self::EVENTS {
            return self.pause_blocks();
        }
        let block = (self.walk as u64 * Self::EVENTS as u64 + j as u64) * Self::BLOCK as u64 + Self::FIRST as u64;
        if block + Self::BLOCK as u64 <= crate::sobol::DIMS as u64 {
            self.dim = block as u32;
            self.end = self.dim + Self::BLOCK;
            self.block = crate::sobol::scrambled_block(block as usize, self.at, self.key);
        } else {
            self.pause_blocks();
        }
    }

    fn pause_blocks(&mut self) {
        self.active = false;
        self.end = self.dim;
    }
}

/// Shirley & Chiu's concentric map of (u, v) ∈ (0, 1)² onto the open unit disc (P. Shirley, K.
/// Chiu, "A low distortion map between disk and square", J. Graph. Tools 2(3), 1997): uniform
/// to uniform, and never the centre (2u − 1 ≠ 0 for the stream's uniforms). Its angle is
/// (π/4)(b/a) or π/2 − (π/4)(a/b), so one [`sin_cos_quarter`] of an angle in [−π/4, π/4].
#[inline]
fn concentric(u: f64, v: f64) -> (f64, f64) {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a.abs() > b.abs() {
        let (s, c) = sin_cos_quarter(std::f64::consts::FRAC_PI_4 * (b / a));
        (a * c, a * s)
    } else {
        let (s, c) = sin_cos_quarter(std::f64::consts::FRAC_PI_4 * (a / b));
        (b * s, b * c)
    }
}

/// (sin t, cos t) for |t| ≤ π/4 by fdlibm's minimax kernels (`k_sin.c`, `k_cos.c`: degree 13
/// and 14, |error| < 2⁻⁵⁸ of the polynomial on [−π/4, π/4]; tested within 2·10⁻¹⁶ of
/// `f64::sin_cos`): six coefficients each, a multiply–add per term (Taylor to t¹⁷ and t¹⁸ took
/// eight and nine terms of three operations each).
#[inline]
fn sin_cos_quarter(t: f64) -> (f64, f64) {
    const S: [f64; 6] = [
        -1.666_666_666_666_663_243_48e-1,
        8.333_333_333_322_489_461_24e-3,
        -1.984_126_982_985_794_931_34e-4,
        2.755_731_370_707_006_767_89e-6,
        -2.505_076_025_340_686_341_95e-8,
        1.589_690_995_211_550_102_21e-10,
    ];
    const C: [f64; 6] = [
        4.166_666_666_666_660_190_37e-2,
        -1.388_888_888_887_410_957_49e-3,
        2.480_158_728_947_672_941_78e-5,
        -2.755_731_435_139_066_330_35e-7,
        2.087_572_321_298_174_827_90e-9,
        -1.135_964_755_778_819_482_65e-11,
    ];
    let z = t * t;
    let poly = |k: &[f64; 6]| k[..5].iter().rev().fold(k[5], |acc, &c| c + z * acc);
    let s = t + t * z * poly(&S);
    let c = (1.0 - 0.5 * z) + z * z * poly(&C);
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera sample's Sobol coordinates: armed once, each walk's events take their own blocks
    /// (walk w, event j: FIRST + (w·EVENTS + j)·BLOCK), a block's draws beyond BLOCK, the walk's
    /// events from EVENTS on and everything after a pause come from the stream, and a stream without
    /// coordinates (or armed a second time) is the plain stream.
    #[test]
    fn sobol_coordinates_are_used_once() {
        use crate::sobol::{dim_seed, scrambled};
        let (index, key) = (5u32, 0x1234_5678u32);
        let want = |d: u32| u32_to_open01(scrambled(d as usize, index, dim_seed(key, d)));
        let mut plain = PhotonRng::new(3, 4);
        let mut r = PhotonRng::new(3, 4).with_qmc(index, key);
        assert!(r.qmc_arm(2) && !r.qmc_arm(2));
        r.qmc_walk(1);
        r.qmc_event(0);
        let walk1 = Qmc::FIRST + Qmc::EVENTS * Qmc::BLOCK;
        for d in walk1..walk1 + Qmc::BLOCK {
            assert_eq!(r.uniform(), want(d));
        }
        assert_eq!(r.uniform(), plain.uniform(), "after the block: the stream");
        r.qmc_event(3);
        assert_eq!(r.uniform(), want(walk1 + 3 * Qmc::BLOCK));
        r.qmc_pause();
        r.qmc_event(4);
        assert_eq!(r.uniform(), plain.uniform(), "paused: the stream");
        r.qmc_walk(0);
        r.qmc_event(0);
        assert_eq!(r.uniform(), want(2));
        r.qmc_event(Qmc::EVENTS);
        assert_eq!(r.uniform(), plain.uniform(), "after EVENTS: the stream");
        r.qmc_event(1);
        assert_eq!(r.uniform(), plain.uniform(), "and for the rest of the walk");
        let mut never = PhotonRng::new(3, 4);
        assert!(!never.qmc_arm(1));
        never.qmc_walk(0);
        never.qmc_event(0);
        assert_eq!(never.uniform(), PhotonRng::new(3, 4).uniform());
    }

    /// Over the keys (pixels), a coordinate of one sample is uniform (χ² over 32 cells, 31
    /// degrees of freedom: 70 is beyond its 99.99 % point) and two coordinates are
    /// uncorrelated (|r| < 5/√n), for the first sample (the unscrambled point 0) and others.
    #[test]
    fn scrambled_coordinates_are_uniform_over_pixels() {
        use crate::sobol::{dim_seed, scrambled};
        let n = 16_384u32;
        for (index, d) in [(0u32, 2u32), (0, 41), (1, 3), (77, 100), (255, 127)] {
            let u: Vec<(f64, f64)> = (0..n)
                .map(|k| {
                    let key = philox4x32_10([k, 0, 0, 0], [9, 9])[3];
                    let f = |d: u32| u32_to_open01(scrambled(d as usize, index, dim_seed(key, d)));
                    (f(d), f(d - 1))
                })
                .collect();
            let mut cells = [0.0f64; 32];
            for &(a, _) in &u {
                cells[(a * 32.0) as usize] += 1.0;
            }
            let e = n as f64 / 32.0;
            let chi2: f64 = cells.iter().map(|c| (c - e) * (c - e) / e).sum();
            assert!(chi2 < 70.0, "sample {index} dimension {d}: chi2 {chi2:.1}");
            let m = |f: &dyn Fn(&(f64, f64)) -> f64| u.iter().map(f).sum::<f64>() / n as f64;
            let cov = m(&|p| (p.0 - 0.5) * (p.1 - 0.5));
            assert!(
                (12.0 * cov).abs() < 5.0 / (n as f64).sqrt(),
                "sample {index} dimensions {d}, {}: r {}",
                d - 1,
                12.0 * cov
            );
        }
    }

    /// The concentric map's sine and cosine agree with `f64::sin_cos` over [−π/4, π/4].
    #[test]
    fn quarter_sin_cos_is_exact() {
        let q = std::f64::consts::FRAC_PI_4;
        for i in 0..=20_000 {
            let t = q * (i as f64 / 10_000.0 - 1.0);
            let ((s, c), (s0, c0)) = (sin_cos_quarter(t), t.sin_cos());
            assert!((s - s0).abs() < 2e-16 && (c - c0).abs() < 2e-16, "{t}: {s} {s0} {c} {c0}");
        }
    }

    /// Random123 `tests/kat_vectors`, the three "philox4x32 10" lines (counter, key → output).
    #[test]
    fn known_answer_vectors() {
        let kat: [([u32; 4], [u32; 2], [u32; 4]); 3] = [
            ([0, 0, 0, 0], [0, 0], [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8]),
            ([u32::MAX; 4], [u32::MAX; 2], [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd]),
            (
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0],
                [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1],
            ),
        ];
        for (ctr, key, want) in kat {
            assert_eq!(philox4x32_10(ctr, key), want);
        }
    }

    /// Outputs of the reference C code (prng.di.unimi.it/xoshiro128plusplus.c, compiled with
    /// gcc) from the states (1, 2, 3, 4) and, after 1000 steps, (0xdeadbeef, 0x01234567,
    /// 0x89abcdef, 0xfeedface).
    #[test]
    fn xoshiro_known_answers() {
        let mut s = [1, 2, 3, 4];
        let want = [0x00000281, 0x00180387, 0xc0183387, 0xd1ae3b02, 0x31e2310a, 0xfd275ab0, 0xe67f7cec, 0x50d07f0f];
        for w in want {
            assert_eq!(xoshiro128pp_next(&mut s), w);
        }
        let mut s = [0xdeadbeef, 0x01234567, 0x89abcdef, 0xfeedface];
        for _ in 0..1000 {
            xoshiro128pp_next(&mut s);
        }
        for w in [0x6c202fe7, 0x26e8f4f8, 0xcaa63f56, 0x51faa527] {
            assert_eq!(xoshiro128pp_next(&mut s), w);
        }
    }

    #[test]
    fn stream_layout_matches_doc() {
        let seed = 0x0123_4567_89ab_cdefu64;
        let photon = (7u64 << 32) | 42;
        let mut r = PhotonRng::new(seed, photon);
        let mut s = philox4x32_10([42, 7, 0, 0], [0x89ab_cdef, 0x0123_4567]);
        for _ in 0..100 {
            assert_eq!(r.next_u32(), xoshiro128pp_next(&mut s));
        }
        // The forbidden all-zero state is replaced, and the stream is not stuck at 0.
        let mut z = PhotonRng::from_state([0; 4]);
        let mut g = ZERO_STATE_GUARD;
        assert_eq!(z.next_u32(), xoshiro128pp_next(&mut g));
        assert!((0..8).any(|_| z.next_u32() != 0));
    }

    /// χ² of 10⁶ uniforms (10⁴ photons × 100 draws) in 100 equal bins: 99 degrees of freedom,
    /// mean 99, sd √198 ≈ 14.1; the test fails above 99 + 4·14.1 ≈ 155 (p ≈ 10⁻⁴ under a
    /// normal approximation; the exact χ²₉₉ tail at 155 is ≈ 2·10⁻⁴). Power: a relative deviation
    /// ±δ of the bins holding a fraction f of the probability adds λ ≈ N f δ² to χ²; it exceeds
    /// 155 with probability 0.9 once λ ≳ 85 (non-central χ²₉₉): δ ≈ 0.9 % over all bins, 2.9 %
    /// over ten of them, 9 % in a single bin.
    #[test]
    fn uniforms_chi2_100_bins() {
        let mut bins = [0u64; 100];
        let (np, per) = (10_000u64, 100);
        for p in 0..np {
            let mut r = PhotonRng::new(17, p);
            for _ in 0..per {
                bins[(r.uniform() * 100.0) as usize] += 1;
            }
        }
        let e = (np * per) as f64 / 100.0;
        let chi2: f64 = bins.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 99.0 + 4.0 * 198f64.sqrt(), "chi2 = {chi2}");
        assert!(chi2 > 99.0 - 4.0 * 198f64.sqrt(), "chi2 = {chi2} (too uniform)");
    }

    /// Streams of neighbouring photons are uncorrelated: the sample correlation of the k-th
    /// draws of photons p and p+1 (k = 0, 1, 2, 9), and of photon p's first draw with photon
    /// p+1's second, over 10⁵ pairs, is 0 within 4σ (σ = 1/√n for independent uniforms).
    /// Also checks two seeds against each other for the same photon.
    #[test]
    fn neighbouring_streams_uncorrelated() {
        let n = 100_000u64;
        let draws = |seed: u64, p: u64| -> [f64; 10] {
            let mut r = PhotonRng::new(seed, p);
            std::array::from_fn(|_| r.uniform())
        };
        let corr = |pairs: &[(f64, f64)]| -> f64 {
            let m = pairs.len() as f64;
            let (mut sx, mut sy, mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for &(x, y) in pairs {
                sx += x;
                sy += y;
                sxy += x * y;
                sxx += x * x;
                syy += y * y;
            }
            let cov = sxy / m - sx * sy / (m * m);
            cov / ((sxx / m - (sx / m).powi(2)) * (syy / m - (sy / m).powi(2))).sqrt()
        };
        let mut prev = draws(3, 0);
        let mut sets: Vec<Vec<(f64, f64)>> = (0..6).map(|_| Vec::with_capacity(n as usize)).collect();
        for p in 1..=n {
            let cur = draws(3, p);
            let other_seed = draws(4, p);
            for (j, &k) in [0usize, 1, 2, 9].iter().enumerate() {
                sets[j].push((prev[k], cur[k]));
            }
            sets[4].push((prev[0], cur[1]));
            sets[5].push((cur[0], other_seed[0]));
            prev = cur;
        }
        let sigma = 1.0 / (n as f64).sqrt();
        for (j, s) in sets.iter().enumerate() {
            let r = corr(s);
            assert!(r.abs() < 4.0 * sigma, "pair set {j}: correlation {r} (σ = {sigma})");
        }
    }

    #[test]
    fn uniform_is_open_and_unbiased() {
        assert!(u32_to_open01(0) > 0.0);
        assert!(u32_to_open01(u32::MAX) < 1.0);
        assert_eq!(u32_to_open01(0), 2f64.powi(-33));
        assert_eq!(u32_to_open01(u32::MAX), 1.0 - 2f64.powi(-33));
        let mut s = [9, 8, 7, 6];
        for x in [0, 1, 2, 0x8000_0000, 0x7fff_ffff, u32::MAX - 1, u32::MAX]
            .into_iter()
            .chain((0..100_000).map(|_| xoshiro128pp_next(&mut s)))
        {
            assert_eq!(u32_to_open01(x), u32_to_open01_ref(x), "{x}");
            let mut a = PhotonRng::from_state([x, 1, 2, 3]);
            let mut b = a.clone();
            assert_eq!(a.symmetric(), 2.0 * b.uniform() - 1.0, "{x}");
        }
        // Mean and variance of 4·10⁵ draws: 1/2 and 1/12 within 5σ.
        let n = 400_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for p in 0..(n / 100) {
            let mut r = PhotonRng::new(5, p as u64);
            for _ in 0..100 {
                let u = r.uniform();
                assert!(u > 0.0 && u < 1.0);
                s += u;
                s2 += u * u;
            }
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!((mean - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt(), "{mean}");
        // Var of u² is 4/45; var of the sample variance ≈ (1/80 − 1/144)/n.
        assert!((var - 1.0 / 12.0).abs() < 5.0 * ((1.0 / 80.0 - 1.0 / 144.0) / n as f64).sqrt(), "{var}");
    }

    /// The copies of a repeated walk (`qmc_walk_copy`) over a pixel's samples 0 … N − 1 are
    /// the first copies·N points of the walk's scrambled Sobol coordinates: the first event's
    /// coordinates of 4 copies × 16 samples put one point in each of 64 equal intervals, in
    /// every coordinate of the block and for any walk slot; a walk slot per copy (`qmc_walk`)
    /// does not (each slot alone is a 16-point net).
    #[test]
    fn walk_copies_are_stratified_together() {
        let first = |slot: u32, copy: u32, copies: u32, s: u32, own_slots: bool| {
            let mut r = PhotonRng::new(3, s as u64).with_qmc(s, 0x5eed);
            assert!(r.qmc_arm(8));
            if own_slots {
                r.qmc_walk(slot + copy);
            } else {
                r.qmc_walk_copy(slot, copy, copies);
            }
            r.qmc_event(0);
            [r.next_u32(), r.next_u32(), r.next_u32(), r.next_u32()]
        };
        let strata = |own: bool, slot: u32, k: usize| {
            let mut seen = [0u32; 64];
            for s in 0..16 {
                for copy in 0..4 {
                    seen[(first(slot, copy, 4, s, own)[k] >> 26) as usize] += 1;
                }
            }
            seen.iter().all(|&c| c == 1)
        };
        for slot in [0, 1, 3] {
            for k in 0..4 {
                assert!(strata(false, slot, k), "slot {slot}, coordinate {k}: copies not stratified");
            }
        }
        assert!((0..4).any(|k| !strata(true, 0, k)), "separate slots stratified alike");
    }
}

#[cfg(test)]
mod bench {
    /// Not a test: `cargo test -p subsurf-core bench_rng -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn bench_rng() {
        let t0 = std::time::Instant::now();
        let mut s = 0.0;
        let n = 100_000_000u64;
        for p in 0..n / 64 {
            let mut r = super::PhotonRng::new(1, p);
            for _ in 0..64 {
                s += r.uniform();
            }
        }
        let dt = t0.elapsed().as_secs_f64();
        println!("{:.2} ns per uniform ({s})", dt * 1e9 / n as f64);
    }
}
