//! Branch-free elementary functions for the lane kernel: −ln u and (cos 2πu, sin 2πu).
//!
//! Written with plain `+ − × ÷` and bit operations only (no FMA, no table, no branch), so that
//! LLVM vectorises the loops that call them, and so that every instruction set (scalar,
//! SSE2, AVX2, AVX-512, NEON) gives the *same bits*: IEEE-754 add, multiply and divide are
//! correctly rounded everywhere, and Rust never contracts `a * b + c` into an FMA.
//!
//! - [`neg_ln`]: fdlibm's `__ieee754_log` (Sun Microsystems 1993, e_log.c: the reduction
//!   x = 2ᵏ(1 + f), √2/2 ≤ 1 + f < √2, s = f/(2 + f), and the degree-14 Remez polynomial
//!   Lg1…Lg7 in s²; error < 1 ulp), specialised to the normal numbers 0 < u < 1 the stream
//!   produces (no zero, subnormal, negative, infinite or NaN input is possible).
//! - [`cos_sin_2pi`]: the argument 2πu is reduced by quadrants exactly (u is a multiple of
//!   2⁻³³, so u − q/4 is exact), then fdlibm's kernels `__kernel_sin`/`__kernel_cos`
//!   (k_sin.c, k_cos.c: minimax polynomials on |x| ≤ π/4, error < 1 ulp) and a quadrant swap.

/// ln 2 split in a high part with 32 trailing zero bits and the rest (fdlibm `ln2_hi/ln2_lo`).
const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
/// fdlibm e_log.c Remez coefficients.
const LG: [f64; 7] = [
    6.666_666_666_666_735_130e-01,
    3.999_999_999_940_941_908e-01,
    2.857_142_874_366_239_149e-01,
    2.222_219_843_214_978_396e-01,
    1.818_357_216_161_805_012e-01,
    1.531_383_769_920_937_332e-01,
    1.479_819_860_511_658_591e-01,
];

/// −ln u for a normal number 0 < u < 1 (see the module docs); ≥ 0.
#[inline(always)]
pub fn neg_ln(u: f64) -> f64 {
    let bits = u.to_bits();
    // u = 2^e · m, 1 ≤ m < 2; fold m ≥ √2 into [√2/2, 1) so that |f| ≤ √2 − 1.
    // The biased exponent (0…2047) as f64 without an int→float conversion (exact): the double
    // with bits 0x433 · 2⁵² + k is 2⁵² + k.
    let mut e = f64::from_bits(0x4330_0000_0000_0000 | (bits >> 52)) - (4_503_599_627_370_496.0 + 1023.0);
    let mut m = f64::from_bits((bits & 0x000F_FFFF_FFFF_FFFF) | 0x3FF0_0000_0000_0000);
    let big = m > std::f64::consts::SQRT_2;
    m = sel(big, 0.5 * m, m);
    e = sel(big, e + 1.0, e);
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG[1] + w * (LG[3] + w * LG[5]));
    let t2 = z * (LG[0] + w * (LG[2] + w * (LG[4] + w * LG[6])));
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    // ln u = e ln2_hi − ((hfsq − (s (hfsq + R) + e ln2_lo)) − f)
    let ln = e * LN2_HI - ((hfsq - (s * (hfsq + r) + e * LN2_LO)) - f);
    -ln
}

/// fdlibm k_sin.c coefficients.
const S: [f64; 6] = [
    -1.666_666_666_666_663_243_48e-01,
    8.333_333_333_322_489_461_24e-03,
    -1.984_126_982_985_794_931_34e-04,
    2.755_731_370_707_006_767_89e-06,
    -2.505_076_025_340_686_341_95e-08,
    1.589_690_995_211_550_102_21e-10,
];
/// fdlibm k_cos.c coefficients.
const C: [f64; 6] = [
    4.166_666_666_666_660_190_37e-02,
    -1.388_888_888_887_410_957_49e-03,
    2.480_158_728_947_672_941_78e-05,
    -2.755_731_435_139_066_330_35e-07,
    2.087_572_321_298_174_827_90e-09,
    -1.135_964_755_778_819_482_65e-11,
];

/// (cos 2πu, sin 2πu) for the uniform u = (r + ½)·2⁻³² of the 32-bit word `r` (see the
/// module docs and [`crate::rng::u32_to_open01`]).
#[inline(always)]
pub fn cos_sin_2pi(r: u32) -> (f64, f64) {
    let u = crate::rng::u32_to_open01(r);
    // q = round(4u) = (r + 2²⁹) >> 30 ∈ 0…4 (integer arithmetic: no rounding call), then
    // u − q/4 ∈ [−1/8, 1/8] is exact and x = 2π(u − q/4) ∈ [−π/4, π/4].
    let q = ((r as u64 + (1 << 29)) >> 30) as u32;
    let x = (u - 0.25 * q as f64) * std::f64::consts::TAU;
    let z = x * x;
    let v = z * x;
    let ps = S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5])));
    let sin = x + v * (S[0] + z * ps);
    let pc = z * (C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5])))));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let cos = w + (((1.0 - w) - hz) + z * pc);
    // Rotate by q quarter turns: q = 0: (c, s); 1: (−s, c); 2: (−c, −s); 3: (s, −c); 4 ≡ 0.
    let odd = q & 1 == 1;
    let (c1, s1) = (sel(odd, -sin, cos), sel(odd, cos, sin));
    let half = q & 2 == 2;
    (sel(half, -c1, c1), sel(half, -s1, s1))
}

/// `if c { a } else { b }` on the bit patterns: a select LLVM vectorises reliably (a plain
/// `if` on floats is often turned back into a branch when an operand is expensive).
#[inline(always)]
pub fn sel(c: bool, a: f64, b: f64) -> f64 {
    let m = 0u64.wrapping_sub(c as u64);
    f64::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{u32_to_open01, PhotonRng};

    fn ulps(a: f64, b: f64) -> f64 {
        ((a - b) / (b.abs().max(f64::MIN_POSITIVE) * f64::EPSILON)).abs()
    }

    /// −ln u within 1 ulp of std's `ln` over the whole range of the stream's uniforms
    /// (the extremes, powers of two, both sides of √2, and 10⁶ random words).
    #[test]
    fn neg_ln_matches_std() {
        let mut r = PhotonRng::new(1, 2);
        let words = [0u32, 1, 2, 3, 0x6A09_E667, 0x6A09_E668, 0x8000_0000, 0xB504_F333, u32::MAX - 1, u32::MAX];
        for x in words.into_iter().chain((0..1_000_000).map(|_| r.next_u32())) {
            let u = u32_to_open01(x);
            let (a, b) = (neg_ln(u), -u.ln());
            assert!(ulps(a, b) <= 1.0, "u = {u}: {a} vs {b}");
        }
        for k in 1..60 {
            let u = 0.5f64.powi(k);
            assert_eq!(neg_ln(u), -u.ln());
        }
    }

    /// cos/sin within 10⁻¹⁵ absolute of std's over 10⁶ random words and the quadrant edges
    /// (std's own argument 2πu carries a rounding error up to 4.4·10⁻¹⁶), and
    /// cos² + sin² = 1 to 3·10⁻¹⁶.
    #[test]
    fn cos_sin_match_std() {
        let mut r = PhotonRng::new(3, 4);
        let edges = [0u32, 1, 0x2000_0000, 0x3FFF_FFFF, 0x4000_0000, 0x7FFF_FFFF, 0x8000_0000, 0xC000_0000, u32::MAX];
        for x in edges.into_iter().chain((0..1_000_000).map(|_| r.next_u32())) {
            let u = u32_to_open01(x);
            let (c, s) = cos_sin_2pi(x);
            let t = std::f64::consts::TAU * u;
            assert!((c - t.cos()).abs() < 1e-15, "u = {u}: cos {c} vs {}", t.cos());
            assert!((s - t.sin()).abs() < 1e-15, "u = {u}: sin {s} vs {}", t.sin());
            assert!((c * c + s * s - 1.0).abs() < 3e-16);
        }
        // Quadrant boundaries: the word nearest u = 1/4 rounds to q = 1 from both sides.
        assert!((cos_sin_2pi(0x3FFF_FFFF).1 - 1.0).abs() < 1e-16);
        assert!((cos_sin_2pi(0x4000_0000).1 - 1.0).abs() < 1e-16);
        assert!((cos_sin_2pi(u32::MAX).0 - 1.0).abs() < 1e-16);
    }
}
