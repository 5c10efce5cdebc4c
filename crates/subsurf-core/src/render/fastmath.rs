//! e^x and ln x without a call into libm, for the random walk's per-collision weights and free
//! paths (docs/render.md, "Random walk speed"): inlined, they cost about a third of glibc's
//! `exp` and `log1p` with their wrappers (measured by callgrind on the 81,920-triangle marble
//! sphere: 51 and 69 instructions per call there), and the walk's independent exponentials
//! overlap. Accuracy: within 2 ulp of `f64::exp` / `f64::ln` (tested below); outside the
//! ranges handled here the std functions answer.
//!
//! - [`exp`]: x = (32 m + j) ln2/32 + r, |r| ≤ ln2/64 (Cody–Waite reduction with ln2/32 split
//!   into a head of 37 significant bits, exact times any k < 2¹⁶, and a tail), then
//!   e^x = 2^m · 2^{j/32} · e^r with 2^{j/32} from a table (the correctly rounded values) and
//!   e^r − 1 by its Taylor polynomial of degree 6 (remainder r⁷/7! < 4·10⁻¹⁸).
//! - [`ln`]: x = 2^e m with m ∈ [√½, √2), ln x = e ln2 + 2 atanh f, f = (m − 1)/(m + 1)
//!   (|f| ≤ 0.1716; m − 1 is exact), the atanh series to f²³ (remainder < 10⁻¹⁷).

/// 32/ln 2.
const INV_LN2_32: f64 = 46.16624130844683;
/// ln2/32, head (37 significant bits) and tail.
const LN2_32_HI: f64 = 0.021660849392446835;
const LN2_32_LO: f64 = 5.145609244655338e-14;
/// ln 2, head (37 significant bits) and tail.
const LN2_HI: f64 = 0.6931471805582987;
const LN2_LO: f64 = 1.6465949582897082e-12;

/// 2^{j/32}, j = 0 … 31, correctly rounded (bit patterns).
const EXP2_32: [u64; 32] = [
    0x3ff0000000000000,
    0x3ff059b0d3158574,
    0x3ff0b5586cf9890f,
    0x3ff11301d0125b51,
    0x3ff172b83c7d517b,
    0x3ff1d4873168b9aa,
    0x3ff2387a6e756238,
    0x3ff29e9df51fdee1,
    0x3ff306fe0a31b715,
    0x3ff371a7373aa9cb,
    0x3ff3dea64c123422,
    0x3ff44e086061892d,
    0x3ff4bfdad5362a27,
    0x3ff5342b569d4f82,
    0x3ff5ab07dd485429,
    0x3ff6247eb03a5585,
    0x3ff6a09e667f3bcd,
    0x3ff71f75e8ec5f74,
    0x3ff7a11473eb0187,
    0x3ff82589994cce13,
    0x3ff8ace5422aa0db,
    0x3ff93737b0cdc5e5,
    0x3ff9c49182a3f090,
    0x3ffa5503b23e255d,
    0x3ffae89f995ad3ad,
    0x3ffb7f76f2fb5e47,
    0x3ffc199bdd85529c,
    0x3ffcb720dcef9069,
    0x3ffd5818dcfba487,
    0x3ffdfc97337b9b5f,
    0x3ffea4afa2a490da,
    0x3fff50765b6e4540,
];

/// 1/(2i + 1), i = 0 … 11: the atanh series' coefficients (of f^{2i}, times f).
const ATANH_SERIES: [f64; 12] = [
    1.0,
    1.0 / 3.0,
    1.0 / 5.0,
    1.0 / 7.0,
    1.0 / 9.0,
    1.0 / 11.0,
    1.0 / 13.0,
    1.0 / 15.0,
    1.0 / 17.0,
    1.0 / 19.0,
    1.0 / 21.0,
    1.0 / 23.0,
];

/// e^x within 2 ulp; |x| ≥ 700, infinities and NaN by `f64::exp`.
#[inline(always)]
pub fn exp(x: f64) -> f64 {
    if !(x.abs() < 700.0) {
        return x.exp();
    }
    // k = round(32 x/ln 2) by the 1.5·2⁵² shift (no libm `round` on baseline x86-64).
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let z = x * INV_LN2_32 + SHIFT;
    let kf = z - SHIFT;
    // The low bits of z's mantissa hold k (ulp 1 at 1.5·2⁵², |k| < 2¹⁶).
    let k = z.to_bits() as i32 as i64;
    let r = (x - kf * LN2_32_HI) - kf * LN2_32_LO;
    let q = r * (1.0 + r * (0.5 + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    let t = f64::from_bits(EXP2_32[(k & 31) as usize]);
    // 2^m with |m| ≤ 1010: a normal number, so the product is exact.
    let two_m = f64::from_bits(((1023 + (k >> 5)) as u64) << 52);
    (t + t * q) * two_m
}

/// ln x within 2 ulp for normal positive x; anything else (0, subnormals, negatives,
/// infinities, NaN) by `f64::ln`.
#[inline(always)]
pub fn ln(x: f64) -> f64 {
    if !(f64::MIN_POSITIVE..f64::INFINITY).contains(&x) {
        return x.ln();
    }
    // m = 1.mant, halved (exponent field 1022, exact) where it exceeds √2: decided on the
    // mantissa bits without a branch (a random walk's free paths make it a coin toss).
    const MANT: u64 = (1u64 << 52) - 1;
    let bits = x.to_bits();
    let mant = bits & MANT;
    let big = u64::from(mant > std::f64::consts::SQRT_2.to_bits() & MANT);
    let e = (bits >> 52) as i64 - 1023 + big as i64;
    let m = f64::from_bits(mant | ((1023 - big) << 52));
    let f = (m - 1.0) / (m + 1.0);
    let s = f * f;
    // 2 atanh f = 2f + 2f·s·P(s), P = 1/3 + s/5 + … + s¹⁰/23, by Estrin's scheme: pairs
    // c + c′s, then pairs of pairs with s², s⁴, s⁸ (four dependent multiply–adds after s
    // instead of Horner's eleven); 2f is added last, as the leading term.
    let c = &ATANH_SERIES;
    let (s2, pair) = (s * s, |i: usize| c[i] + c[i + 1] * s);
    let s4 = s2 * s2;
    let (q0, q1, q2) = (pair(1) + s2 * pair(3), pair(5) + s2 * pair(7), pair(9) + s2 * c[11]);
    let p = (q0 + s4 * q1) + (s4 * s4) * q2;
    let ef = e as f64;
    let t = 2.0 * f;
    ef * LN2_HI + (ef * LN2_LO + (t + t * s * p))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::PhotonRng;

    /// Relative error in units of the last place of the reference.
    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        (a - b).abs() / (b.abs() * f64::EPSILON)
    }

    #[test]
    fn exp_table_is_two_to_the_j_over_32() {
        for (j, &b) in EXP2_32.iter().enumerate() {
            assert!(ulps(f64::from_bits(b), (j as f64 / 32.0).exp2()) <= 1.0, "j = {j}");
        }
    }

    /// Within 2 ulp of `f64::exp` on random arguments over the whole handled range and densely
    /// near 0 (the walk's weights), and exact where the std function decides.
    #[test]
    fn exp_matches_std() {
        let mut rng = PhotonRng::new(5, 0);
        let mut worst = 0.0f64;
        for i in 0..400_000 {
            let span = if i % 2 == 0 { 699.9 } else { 20.0 };
            let x = span * (2.0 * rng.uniform() - 1.0);
            worst = worst.max(ulps(exp(x), x.exp()));
        }
        for x in [0.0, -0.0, 1e-300, -1e-300, 1.0, -1.0, 699.0, -699.0] {
            worst = worst.max(ulps(exp(x), x.exp()));
        }
        assert!(worst <= 2.0, "worst {worst} ulp");
        for x in [700.0, -700.0, 710.0, -746.0, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(exp(x), x.exp());
        }
        assert!(exp(f64::NAN).is_nan());
    }

    /// Within 2 ulp of `f64::ln` on random arguments across the exponent range and on the
    /// walk's uniforms (0, 1), and exact where the std function decides.
    #[test]
    fn ln_matches_std() {
        let mut rng = PhotonRng::new(6, 0);
        let mut worst = 0.0f64;
        for i in 0..400_000 {
            let x = if i % 2 == 0 { rng.uniform() } else { (1400.0 * (rng.uniform() - 0.5)).exp() };
            worst = worst.max(ulps(ln(x), x.ln()));
        }
        for x in [1.0, 2.0, 0.5, std::f64::consts::SQRT_2, f64::MIN_POSITIVE, f64::MAX, 1.0 - 1e-16, 1.0 + 1e-15] {
            let (a, b) = (ln(x), x.ln());
            assert!(ulps(a, b) <= 2.0 || (a - b).abs() < 1e-300, "x = {x}: {a} vs {b}");
        }
        assert!(worst <= 2.0, "worst {worst} ulp");
        for x in [0.0, 1e-310, f64::INFINITY] {
            assert_eq!(ln(x), x.ln());
        }
        assert!(ln(-1.0).is_nan() && ln(f64::NAN).is_nan());
    }
}
