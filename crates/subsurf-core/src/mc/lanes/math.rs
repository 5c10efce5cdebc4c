//! Branch-free elementary functions in f32 for the lane kernel: −ln u, (cos 2πu, sin 2πu),
//! the f32 uniform of a 32-bit word (see the "Precision" section of the module docs of
//! `mc::lanes`).
//!
//! Written with plain `+ − × ÷` and bit operations only (no FMA, no table, no branch), so that
//! LLVM vectorises the loops that call them, and so that every instruction set (scalar,
//! SSE2, AVX2, AVX-512, NEON) gives the *same bits*: IEEE-754 add, multiply and divide are
//! correctly rounded everywhere, and Rust never contracts `a * b + c` into an FMA.
//!
//! - [`neg_ln_f32`]: fdlibm's single-precision `__ieee754_logf` (e_logf.c, FreeBSD msun: the
//!   reduction u = 2ᵏ(1 + f), √2/2 ≤ 1 + f < √2, s = f/(2 + f), the degree-8 Remez polynomial
//!   Lg1…Lg4 in s², `ln2_hi` with 12 trailing zero bits), specialised to the normal numbers
//!   0 < u < 1 the kernel draws; measured ≤ 0.83 ulp of f32 against f64's `ln` (test below).
//! - [`cos_sin_2pi_f32`]: the quadrant reduction done in integers (exact), the argument
//!   x = 2π(2r′ + 1)·2⁻³³ rounded once, then Cephes' single-precision kernels (sinf.c,
//!   cosf.c, Moshier 1985–1989: sin x = x + x³ P(x²), cos x = 1 − x²/2 + x⁴ Q(x²), |x| ≤ π/4);
//!   measured ≤ 1.2·10⁻⁷ absolute (≤ 2.6 ulp of the f32 result) against f64's.
//! - [`open01_f32`]: a 32-bit word to the f32 uniform (k + ½)·2⁻²³, k = r >> 9, exact;
//!   [`open01_f32_fine`] the finer one of the optical depth (31 bits, spacing ≤ 2⁻²³ relative).

/// fdlibm e_logf.c: ln 2 = LN2_HI_F + LN2_LO_F (LN2_HI_F has 12 trailing zero bits, so
/// e · LN2_HI_F is exact for |e| < 2¹²), and the Remez coefficients Lg1…Lg4.
const LN2_HI_F: f32 = 6.931_381_225_6e-01; // 0x3f31_7180
const LN2_LO_F: f32 = 9.058_000_614_5e-06; // 0x3717_f7d1
const LGF: [f32; 4] = [0.666_666_626_93, 0.400_009_721_52, 0.284_987_866_88, 0.242_790_788_41];

/// The f32 uniform (k + ½)·2⁻²³ of the top 23 bits k = r >> 9 of a 32-bit word, in (0, 1):
/// 1 + k·2⁻²³ built from bits, minus 1 − 2⁻²⁴ (exact: the result needs 24 significant bits).
/// (No int→float conversion: AVX2 has none for unsigned words.)
#[inline(always)]
pub fn open01_f32(r: u32) -> f32 {
    f32::from_bits(0x3F80_0000 | (r >> 9)) - (1.0 - 0.5 / 8_388_608.0)
}

/// The f32 uniform of the top 31 bits k = r >> 1 of a 32-bit word for the optical depth
/// −ln u: u = (f32(k) + ½)·2⁻³¹ in [2⁻³², 1] (k converted with rounding to nearest — a signed
/// conversion, which every instruction set has and rounds alike — then ½ added with one more
/// rounding; within 2⁻²³ relative of (k + ½)·2⁻³¹). Relative spacing ≤ 2⁻²³ down to the
/// smallest u, so an optical depth reaches −ln 2⁻³² = 22.2 (the exponential's tail beyond it,
/// 2.3·10⁻¹⁰, is lost; with [`open01_f32`]'s 23 bits it would be 16.6 and 6·10⁻⁸). The top
/// 128 words (k ≥ 2³¹ − 64) round to u = 1, an optical depth of 0 (the mass of [0, 3·10⁻⁸)
/// moved to 0).
#[inline(always)]
pub fn open01_f32_fine(r: u32) -> f32 {
    ((r >> 1) as i32 as f32 + 0.5) * (1.0 / 2_147_483_648.0)
}

/// −ln u for a normal f32 0 < u ≤ 1 (see the module docs); ≥ 0 (−ln 1 = 0).
#[inline(always)]
pub fn neg_ln_f32(u: f32) -> f32 {
    let bits = u.to_bits();
    // The biased exponent as f32 without a conversion: bits 0x4B00_0000 + k is 2²³ + k.
    let mut e = f32::from_bits(0x4B00_0000 | (bits >> 23)) - (8_388_608.0 + 127.0);
    let mut m = f32::from_bits((bits & 0x007F_FFFF) | 0x3F80_0000);
    let big = m > std::f32::consts::SQRT_2;
    m = sel_f32(big, 0.5 * m, m);
    e = sel_f32(big, e + 1.0, e);
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LGF[1] + w * LGF[3]);
    let t2 = z * (LGF[0] + w * LGF[2]);
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    neg(e * LN2_HI_F - ((hfsq - (s * (hfsq + r) + e * LN2_LO_F)) - f))
}

/// Cephes sinf.c / cosf.c polynomial coefficients (|x| ≤ π/4).
const SF: [f32; 3] = [-1.951_529_589_1e-4, 8.332_160_873_6e-3, -1.666_665_461_1e-1];
const CF: [f32; 3] = [2.443_315_711_809_948e-5, -1.388_731_625_493_765e-3, 4.166_664_568_298_827e-2];

/// (cos 2πu, sin 2πu) in f32 for u = (r + ½)·2⁻³² (as [`crate::rng::u32_to_open01`]).
#[inline(always)]
pub fn cos_sin_2pi_f32(r: u32) -> (f32, f32) {
    // Quadrant q = round(4u) mod 4 and r′ = r − q·2³⁰ ∈ [−2²⁹, 2²⁹) in wrapping integer
    // arithmetic (exact), so 2π(u − q/4) = 2π(2r′ + 1)·2⁻³³ ∈ [−π/4, π/4]; the i32 → f32
    // conversion and the product round (correctly, on every instruction set).
    let q = r.wrapping_add(1 << 29) >> 30;
    let rr = r.wrapping_sub(q << 30) as i32;
    let x = (2 * rr + 1) as f32 * (std::f32::consts::TAU / 8_589_934_592.0);
    let z = x * x;
    let sin = x + x * z * ((SF[0] * z + SF[1]) * z + SF[2]);
    let cos = 1.0 - 0.5 * z + z * z * ((CF[0] * z + CF[1]) * z + CF[2]);
    let odd = q & 1 == 1;
    let (c1, s1) = (sel_f32(odd, neg(sin), cos), sel_f32(odd, cos, sin));
    let half = q & 2 == 2;
    (sel_f32(half, neg(c1), c1), sel_f32(half, neg(s1), s1))
}

/// −x as an exclusive or of the sign bit: the bits of `-x`, in a form LLVM keeps as an integer
/// operation. (With `-x` the lane kernel took more instructions, callgrind per event with the
/// totals: avx2 a +0.3 %, c +0.9 %, d +1.0 %; sse ≤ +0.2 %.)
#[inline(always)]
pub fn neg(x: f32) -> f32 {
    f32::from_bits(x.to_bits() ^ 0x8000_0000)
}

/// x rounded to f32 with its magnitude rounded up (away from zero) where nearest rounding
/// would lower it, for |x| ≤ 1. The kernel stores a launched or refracted direction's uz this
/// way: refraction is reversible (a packet refracted into a layer can always leave it the way
/// it came, |uz| > cos θc there), and a beam refracted to within f32's spacing of the critical
/// angle (the steepest allowed pencil beam) would otherwise be reflected totally forever.
#[inline(always)]
pub fn to_f32_up(x: f64) -> f32 {
    let v = x as f32;
    f32::from_bits(v.to_bits() + ((v as f64).abs() < x.abs()) as u32)
}

/// [`sel`] for f32.
#[inline(always)]
pub fn sel_f32(c: bool, a: f32, b: f32) -> f32 {
    let m = 0u32.wrapping_sub(c as u32);
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
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

    /// f32 ulps of the error of `a` against the f64 value `b`, in units of f32's spacing at |b|.
    fn ulps_f32(a: f32, b: f64) -> f64 {
        let ulp = (b.abs() as f32).max(f32::MIN_POSITIVE);
        let spacing = f32::from_bits(ulp.to_bits() + 1) - ulp;
        (a as f64 - b).abs() / spacing as f64
    }

    /// [`to_f32_up`] rounds to one of the two neighbouring f32, never below |x|.
    #[test]
    fn to_f32_up_never_lowers_the_magnitude() {
        let mut r = PhotonRng::new(13, 14);
        for k in 0..100_000 {
            let x = 2.0 * u32_to_open01(r.next_u32()) - 1.0;
            let x = if k == 0 {
                1.0
            } else if k == 1 {
                -1.0
            } else {
                x
            };
            let v = to_f32_up(x);
            assert!((v as f64).abs() >= x.abs() && ((v as f64) - x).abs() < 1.2e-7 && v.signum() as f64 == x.signum());
        }
    }

    /// The f32 uniform is (k + ½)·2⁻²³ exactly, k = r >> 9 (the extremes included).
    #[test]
    fn open01_f32_is_exact() {
        for r in [0u32, 1, 511, 512, 0x8000_0000, 0xFFFF_FDFF, u32::MAX] {
            assert_eq!(open01_f32(r) as f64, ((r >> 9) as f64 + 0.5) / 8_388_608.0, "r = {r:#x}");
        }
    }

    /// The optical depth's uniform: (f32(r >> 1) + ½)·2⁻³¹ within 2⁻²³ relative (two
    /// roundings of at most 2⁻²⁴) of the exact (k + ½)·2⁻³¹, in [2⁻³², 1], exact for k < 2²³,
    /// and 1 (−ln u = 0) exactly for the top 128 words.
    #[test]
    fn open01_f32_fine_is_within_an_ulp() {
        let mut r = PhotonRng::new(15, 16);
        let edges = (0..4096u32).chain((0..4096u32).map(|k| u32::MAX - k));
        for x in edges.chain((0..1_000_000).map(|_| r.next_u32())) {
            let u = open01_f32_fine(x);
            let exact = ((x >> 1) as f64 + 0.5) / 2_147_483_648.0;
            assert!(((u as f64 - exact) / exact).abs() <= 1.0 / 8_388_608.0, "r = {x:#x}: {u} vs {exact}");
            assert!(u > 0.0 && u <= 1.0);
            assert_eq!(u == 1.0, x >= u32::MAX - 127, "r = {x:#x}");
            if x >> 1 < 1 << 23 {
                assert_eq!(u as f64, exact);
            }
        }
        assert_eq!(open01_f32_fine(0) as f64, 2f64.powi(-32));
        assert_eq!(open01_f32_fine(u32::MAX), 1.0);
        assert!(open01_f32_fine(u32::MAX - 128) < 1.0);
        assert_eq!(neg_ln_f32(1.0), 0.0);
        assert_eq!(neg_ln_f32(open01_f32_fine(0)) as f64, (32.0 * std::f64::consts::LN_2) as f32 as f64);
    }

    /// −ln u in f32 within 1 ulp of f64's `ln` (rounded argument: the f32 uniform itself) over
    /// every uniform the kernel can draw near the ends, powers of two, both sides of √2 and
    /// 10⁶ random words; prints the largest error.
    #[test]
    fn neg_ln_f32_within_one_ulp() {
        let mut r = PhotonRng::new(5, 6);
        let edges = (0..4096u32).map(|k| k << 9).chain((0..4096u32).map(|k| u32::MAX - (k << 9)));
        let words = [0x6A09_E667u32, 0xB504_F333, 0xB504_F400, 0x8000_0000, 0x4000_0000];
        let mut worst = 0.0f64;
        for x in edges.chain(words).chain((0..1_000_000).map(|_| r.next_u32())) {
            for u in [open01_f32(x), open01_f32_fine(x), open01_f32_fine(x >> 9)] {
                let e = ulps_f32(neg_ln_f32(u), -(u as f64).ln());
                worst = worst.max(e);
            }
        }
        println!("neg_ln_f32: max error {worst:.3} ulp");
        assert!(worst <= 1.0, "{worst} ulp");
    }

    /// cos/sin in f32 within 2.5·10⁻⁷ absolute and 3 ulps of f64's at the same u, over 10⁶
    /// random words and the quadrant edges, and cos² + sin² = 1 to 4·10⁻⁷; prints the worst.
    #[test]
    fn cos_sin_f32_match_f64() {
        let mut r = PhotonRng::new(7, 8);
        let edges = [0u32, 1, 0x1FFF_FFFF, 0x2000_0000, 0x3FFF_FFFF, 0x4000_0000, 0x7FFF_FFFF, 0x8000_0000];
        let edges2 = [0xC000_0000u32, 0xDFFF_FFFF, 0xE000_0000, u32::MAX - 1, u32::MAX];
        let (mut abs, mut ulp, mut norm) = (0.0f64, 0.0f64, 0.0f64);
        for x in edges.into_iter().chain(edges2).chain((0..1_000_000).map(|_| r.next_u32())) {
            // Reference: f64 cos/sin of the exactly reduced argument, rotated by the quadrant
            // (2πu itself would carry an absolute error of 4·10⁻¹⁶, ~7 f32 ulps of a result
            // near 10⁻⁹); checked against std at 2πu to 10⁻¹⁵ as well.
            let q = x.wrapping_add(1 << 29) >> 30;
            let xr = std::f64::consts::TAU * (2 * x.wrapping_sub(q << 30) as i32 + 1) as f64 / 8_589_934_592.0;
            let (c0, s0) = [(xr.cos(), xr.sin()), (-xr.sin(), xr.cos()), (-xr.cos(), -xr.sin()), (xr.sin(), -xr.cos())]
                [q as usize];
            let t = std::f64::consts::TAU * u32_to_open01(x);
            assert!((c0 - t.cos()).abs() < 1e-15 && (s0 - t.sin()).abs() < 1e-15);
            let (c, s) = cos_sin_2pi_f32(x);
            abs = abs.max((c as f64 - c0).abs()).max((s as f64 - s0).abs());
            ulp = ulp.max(ulps_f32(c, c0)).max(ulps_f32(s, s0));
            norm = norm.max(((c as f64).powi(2) + (s as f64).powi(2) - 1.0).abs());
        }
        println!("cos_sin_2pi_f32: max error {abs:.3e} absolute, {ulp:.2} ulp; |cos² + sin² − 1| ≤ {norm:.2e}");
        assert!(abs < 2.5e-7 && ulp <= 3.0 && norm < 4e-7, "{abs} {ulp} {norm}");
    }
}
