//! Counter-based random numbers: Philox4x32-10.
//!
//! Reference: J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw, "Parallel random numbers:
//! as easy as 1, 2, 3", Proc. SC'11 (2011), §4.2 (the Philox S-box and key schedule); the
//! constants and round structure are those of Random123's `philox.h` (also cuRAND's
//! `curand_Philox4x32_10`). Checked against Random123's Known-Answer Test vectors
//! (`tests/kat_vectors`, lines "philox4x32 10 …").
//!
//! # The streams of the Monte Carlo engine (to reproduce them elsewhere, e.g. in CUDA)
//!
//! - key = the 64-bit seed: `key = (seed as u32, (seed >> 32) as u32)`;
//! - counter = `(photon as u32, (photon >> 32) as u32, block, 0)` where `photon` is the global
//!   photon index (0 … N−1) and `block` = 0, 1, 2, … counts the 4-word blocks this photon has
//!   used;
//! - the four output words of a block are used in order x0, x1, x2, x3, then the next block;
//! - a uniform is `u = (x + 0.5) · 2⁻³²` computed in f64 (exact), so 0 < u < 1 strictly.
//!
//! With Random123 in CUDA: `philox4x32_10(ctr, key)` with the same `ctr`/`key` gives the same
//! words (cuRAND's `curand_init(seed, subsequence, offset)` lays out its counter differently,
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
#[inline(always)]
pub fn u32_to_open01(x: u32) -> f64 {
    (x as f64 + 0.5) * INV_2_32
}

/// One photon's random stream (see the module docs for its exact definition).
///
/// Blocks are generated two at a time (blocks 2k and 2k+1: two independent Philox chains,
/// which the CPU overlaps) into an 8-word buffer; the stream itself is as documented above.
#[derive(Clone, Debug)]
pub struct PhotonRng {
    key: [u32; 2],
    ctr_lo: u32,
    ctr_hi: u32,
    block: u32,
    buf: [u32; 8],
    next: u32,
}

impl PhotonRng {
    /// The stream of photon `photon` for `seed`.
    #[inline]
    pub fn new(seed: u64, photon: u64) -> Self {
        PhotonRng {
            key: [seed as u32, (seed >> 32) as u32],
            ctr_lo: photon as u32,
            ctr_hi: (photon >> 32) as u32,
            block: 0,
            buf: [0; 8],
            next: 8,
        }
    }

    /// The next 32-bit word of the stream.
    #[inline(always)]
    pub fn next_u32(&mut self) -> u32 {
        if self.next == 8 {
            self.refill();
        }
        let x = self.buf[self.next as usize];
        self.next += 1;
        x
    }

    #[inline(always)]
    fn refill(&mut self) {
        let a = philox4x32_10([self.ctr_lo, self.ctr_hi, self.block, 0], self.key);
        let b = philox4x32_10([self.ctr_lo, self.ctr_hi, self.block.wrapping_add(1), 0], self.key);
        self.buf = [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]];
        self.block = self.block.wrapping_add(2);
        self.next = 0;
    }

    /// A uniform number in the open interval (0, 1) (never exactly 0 or 1, so `ln u` is finite).
    #[inline(always)]
    pub fn uniform(&mut self) -> f64 {
        u32_to_open01(self.next_u32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn stream_layout_matches_doc() {
        let seed = 0x0123_4567_89ab_cdefu64;
        let photon = (7u64 << 32) | 42;
        let mut r = PhotonRng::new(seed, photon);
        let key = [0x89ab_cdef, 0x0123_4567];
        for block in 0..3u32 {
            let want = philox4x32_10([42, 7, block, 0], key);
            for w in want {
                assert_eq!(r.next_u32(), w);
            }
        }
    }

    #[test]
    fn uniform_is_open_and_unbiased() {
        assert!(u32_to_open01(0) > 0.0);
        assert!(u32_to_open01(u32::MAX) < 1.0);
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
