//! Exact sums: the fixed-point accumulator [`Fixed`] that makes merged results independent of
//! how the photons were split into ranges, threads or workers.
//!
//! Floating-point addition is not associative, so Σ over chunks formed in a different grouping
//! (threads, resume points, cluster workers) would give different bits. Each chunk of
//! [`crate::mc::config::CHUNK_PHOTONS`] photons is therefore accumulated in f64 as before (a
//! fixed, sequential order, so the chunk's sums are a pure function of the chunk), and the chunk
//! sums are then added *exactly* into fixed-point integers: integer addition is associative and
//! commutative, so any partition of the photon range at chunk boundaries, merged in any order,
//! gives the same integers and hence the same rounded f64 results, bit for bit.
//!
//! Format: a two's-complement integer of `L` little-endian 64-bit limbs scaled by 2^−FRAC with
//! FRAC = 64·L − [`INT_BITS`]: |value| < 2^79 (a run of 2⁶⁴ photons scoring up to 2¹⁵ each).
//! `Fixed<4>` (FRAC = 176, resolution 1.0e−53) holds the sums S₁ of the scores, `Fixed<5>`
//! (FRAC = 240, resolution 5.7e−73) the sums S₂ of their squares. A chunk sum is added exactly
//! when its magnitude is at least 2^(53 − FRAC) (S₁: 1.1e−37, S₂: 5.1e−57; every score a tally
//! keeps is a fraction of the launched weight 1, and the kernel's Russian roulette keeps
//! weights above 10⁻⁴ of the entering weight); smaller parts are rounded to the nearest
//! multiple of 2^−FRAC (ties to even), still deterministically. Conversion back to f64 rounds
//! to nearest (ties to even), so the result is the correctly rounded exact sum.
//!
//! Cost: a run drains every bin a chunk touched (case a of `make bench` with MCML's tally set:
//! 2900 bins per 4096-photon chunk, 1.4 (S₁, Q) pairs per photon). With [`Fixed::add_f64`]'s
//! 128-bit fast path the drain takes 37 instead of 62 instructions per value (callgrind).

/// Integer bits (including the sign bit) of every [`Fixed`].
pub const INT_BITS: u32 = 80;

/// A fixed-point number: two's-complement integer in `L` 64-bit limbs (least significant
/// first), value = integer × 2^−(64·L − [`INT_BITS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Fixed<const L: usize>(pub [u64; L]);

impl<const L: usize> Default for Fixed<L> {
    fn default() -> Self {
        Fixed([0; L])
    }
}

/// Exact sum of the scores S₁.
pub type Sum1 = Fixed<4>;
/// Exact sum of the squared per-photon scores S₂.
pub type Sum2 = Fixed<5>;

impl<const L: usize> Fixed<L> {
    /// Fraction bits: the value of the integer 1 is 2^−FRAC.
    pub const FRAC: i32 = 64 * L as i32 - INT_BITS as i32;

    /// Zero.
    pub const ZERO: Self = Fixed([0; L]);

    /// Whether the value is negative.
    #[inline]
    pub fn is_negative(&self) -> bool {
        self.0[L - 1] >> 63 == 1
    }

    /// Exact addition (wrapping on overflow, which [`Fixed::add_f64`]'s range check and
    /// [`INT_BITS`] make impossible for the sums of a run).
    #[inline]
    pub fn add(&mut self, o: &Self) {
        let mut carry = false;
        for (a, &b) in self.0.iter_mut().zip(&o.0) {
            let (s, c1) = a.overflowing_add(b);
            let (s, c2) = s.overflowing_add(carry as u64);
            *a = s;
            carry = c1 || c2;
        }
    }

    /// Add the 64-bit magnitude `m` placed at limb `i`, with carry (`neg`: subtract instead).
    #[inline]
    fn add_at(&mut self, mut i: usize, m: u64, neg: bool) {
        if neg {
            let (s, mut borrow) = self.0[i].overflowing_sub(m);
            self.0[i] = s;
            while borrow && i + 1 < L {
                i += 1;
                let (s, b) = self.0[i].overflowing_sub(1);
                self.0[i] = s;
                borrow = b;
            }
        } else {
            let (s, mut carry) = self.0[i].overflowing_add(m);
            self.0[i] = s;
            while carry && i + 1 < L {
                i += 1;
                let (s, c) = self.0[i].overflowing_add(1);
                self.0[i] = s;
                carry = c;
            }
        }
    }

    /// Add `x` exactly (rounded to the grid 2^−FRAC, ties to even, when |x| < 2^(53 − FRAC)).
    /// Returns `false` (and adds nothing) when `x` is not finite or |x| ≥ 2^(INT_BITS − 2).
    ///
    /// Fast path (every chunk sum of a run in practice): a normal `x` whose significand's
    /// lowest bit lands at grid position 0 ≤ shift < 64 (L − 1) (2^(52 − FRAC) ≤ |x| < 2⁶⁸:
    /// S₁ from 4.7e−38, S₂ from 2.5e−57) spans two adjacent limbs and is added to them as one
    /// 128-bit integer (an add-with-carry pair; a carry loop only if the carry leaves those
    /// limbs); everything else takes `add_f64_general`. Same integers (tested against
    /// it over random values and carry-prone accumulators).
    #[inline(always)]
    pub fn add_f64(&mut self, x: f64) -> bool {
        let bits = x.to_bits();
        // the grid position of the significand's least significant bit (biased exponent
        // − 1075 + FRAC); subnormals, 0, ∞ and NaN all fall outside [0, 64 (L − 1))
        let shift = ((bits >> 52) & 0x7ff) as i32 - 1075 + Self::FRAC;
        if bits << 1 == 0 {
            return true; // ±0
        }
        if bits & (0x7ff << 52) == 0 || !(0..64 * (L as i32 - 1)).contains(&shift) {
            return self.add_f64_general(x);
        }
        let m = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
        let (li, v) = ((shift >> 6) as usize, (m as u128) << (shift & 63)); // v < 2¹¹⁷
        let cur = self.0[li] as u128 | (self.0[li + 1] as u128) << 64;
        let (s, c) = if bits >> 63 == 0 { cur.overflowing_add(v) } else { cur.overflowing_sub(v) };
        (self.0[li], self.0[li + 1]) = (s as u64, (s >> 64) as u64);
        if c {
            self.carry_from(li + 2, bits >> 63 == 1);
        }
        true
    }

    /// Propagate a carry (`neg`: a borrow) into limbs `i`, `i + 1`, … (wrapping at the top).
    #[cold]
    #[inline(never)]
    fn carry_from(&mut self, i: usize, neg: bool) {
        for limb in &mut self.0[i.min(L)..] {
            let (s, c) = if neg { limb.overflowing_sub(1) } else { limb.overflowing_add(1) };
            *limb = s;
            if !c {
                break;
            }
        }
    }

    /// [`Fixed::add_f64`] for any `x` (zeros, subnormals, values below the grid or out of
    /// range): limb by limb, with carry loops.
    #[inline(never)]
    fn add_f64_general(&mut self, x: f64) -> bool {
        if x == 0.0 {
            return true;
        }
        if !x.is_finite() {
            return false;
        }
        let bits = x.to_bits();
        let neg = bits >> 63 == 1;
        let biased = ((bits >> 52) & 0x7ff) as i32;
        let frac = bits & ((1u64 << 52) - 1);
        // x = m · 2^e with m < 2^53
        let (m, e) = if biased == 0 { (frac, -1074) } else { (frac | (1u64 << 52), biased - 1075) };
        let shift = e + Self::FRAC; // the grid position of m's least significant bit
        if shift >= 0 {
            if shift + 53 > 64 * L as i32 - 2 {
                return false;
            }
            let (li, bit) = ((shift / 64) as usize, (shift % 64) as u32);
            let lo = m << bit;
            let hi = if bit == 0 { 0 } else { m >> (64 - bit) };
            self.add_at(li, lo, neg);
            if hi != 0 {
                self.add_at(li + 1, hi, neg);
            }
        } else {
            let k = (-shift) as u32;
            if k > 54 {
                return true; // below half a unit of the grid: rounds to 0
            }
            let (q, rem) = (m >> k, m & ((1u64 << k) - 1));
            let half = 1u64 << (k - 1);
            let q = if rem > half || (rem == half && q & 1 == 1) { q + 1 } else { q };
            if q != 0 {
                self.add_at(0, q, neg);
            }
        }
        true
    }

    /// The value rounded to the nearest f64 (ties to even).
    pub fn to_f64(&self) -> f64 {
        let neg = self.is_negative();
        let mut mag = self.0;
        if neg {
            // two's-complement negation
            let mut carry = true;
            for limb in mag.iter_mut() {
                let (s, c) = (!*limb).overflowing_add(carry as u64);
                *limb = s;
                carry = c;
            }
        }
        let Some(k) = mag.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        // 128 bits from the top non-zero limb down, with a sticky bit for anything below (the
        // rounding position is at least 11 bits above bit 0, so this rounds the exact value).
        let lo = if k > 0 { mag[k - 1] } else { 0 };
        let sticky = k > 1 && mag[..k - 1].iter().any(|&l| l != 0);
        let v = ((mag[k] as u128) << 64) | lo as u128 | sticky as u128;
        let scale = 64 * (k as i32 - 1) - Self::FRAC;
        let f = (v as f64) * 2f64.powi(scale);
        if neg {
            -f
        } else {
            f
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::SplitMix64;

    fn random_f64(rng: &mut SplitMix64) -> f64 {
        // magnitudes from 1e-30 to 1e6, both signs
        let m = rng.next_f64() * 2.0 - 1.0;
        m * 10f64.powf(rng.next_f64() * 36.0 - 30.0)
    }

    #[test]
    fn round_trip_is_exact_for_representable_values() {
        let mut rng = SplitMix64::new(1);
        for _ in 0..10_000 {
            let x = random_f64(&mut rng);
            let mut a = Sum1::ZERO;
            assert!(a.add_f64(x));
            assert_eq!(a.to_f64(), x, "{x:e}");
            let mut b = Sum2::ZERO;
            assert!(b.add_f64(x));
            assert_eq!(b.to_f64(), x, "{x:e}");
        }
        for x in [1.0, -1.0, 2f64.powi(70), -(2f64.powi(77)), 2f64.powi(-123), f64::EPSILON] {
            let mut a = Sum1::ZERO;
            assert!(a.add_f64(x));
            assert_eq!(a.to_f64(), x);
        }
    }

    #[test]
    fn sums_are_exact_and_order_independent() {
        // 1 + 2^-100 − 1 is 2^-100 exactly (f64 arithmetic would give 0).
        let mut a = Sum1::ZERO;
        for x in [1.0, 2f64.powi(-100), -1.0] {
            assert!(a.add_f64(x));
        }
        assert_eq!(a.to_f64(), 2f64.powi(-100));
        // Any grouping and order of the same values gives the same bits.
        let mut rng = SplitMix64::new(2);
        let xs: Vec<f64> = (0..2000).map(|_| random_f64(&mut rng)).collect();
        let mut fwd = Sum1::ZERO;
        for &x in &xs {
            fwd.add_f64(x);
        }
        let mut parts = [Sum1::ZERO; 3];
        for (i, &x) in xs.iter().rev().enumerate() {
            parts[(i * 7) % 3].add_f64(x);
        }
        let mut grouped = parts[2];
        grouped.add(&parts[0]);
        grouped.add(&parts[1]);
        assert_eq!(fwd, grouped);
        // and the result is the correctly rounded exact sum (compared with a compensated sum)
        let (mut s, mut c) = (0.0f64, 0.0f64);
        for &x in &xs {
            let t = s + x;
            c += if s.abs() >= x.abs() { (s - t) + x } else { (x - t) + s };
            s = t;
        }
        assert!((fwd.to_f64() - (s + c)).abs() <= 1e-15 * (s + c).abs(), "{} {}", fwd.to_f64(), s + c);
    }

    #[test]
    fn tiny_values_round_to_the_grid_and_huge_are_refused() {
        let mut a = Sum1::ZERO;
        assert!(a.add_f64(2f64.powi(-177))); // exactly half a unit: ties to even → 0
        assert_eq!(a.to_f64(), 0.0);
        assert!(a.add_f64(3.0 * 2f64.powi(-177))); // 1.5 units → 2 units
        assert_eq!(a.to_f64(), 2f64.powi(-175));
        assert!(a.add_f64(1e-300)); // far below the grid: nothing
        assert_eq!(a.to_f64(), 2f64.powi(-175));
        assert!(!a.add_f64(2f64.powi(79)) && !a.add_f64(f64::NAN) && !a.add_f64(f64::INFINITY));
        assert_eq!(a.to_f64(), 2f64.powi(-175));
        let mut n = Sum2::ZERO;
        assert!(n.add_f64(-3.5));
        assert!(n.is_negative());
        assert_eq!(n.to_f64(), -3.5);
    }

    /// A random f64 from every region the fast and general paths treat differently: the fast
    /// range, just outside it, below the grid (ties included), subnormals, ±0, ±∞, NaN, and
    /// values past the exact range; both signs.
    fn tricky_f64(rng: &mut SplitMix64, frac: i32) -> f64 {
        let sign = if rng.next_u64() & 1 == 1 { -1.0 } else { 1.0 };
        let m = (1u64 << 52 | rng.next_u64() >> 12) as f64; // a full 53-bit significand
        let x = match rng.next_u64() % 10 {
            0 => f64::from_bits(rng.next_u64() & ((1 << 52) - 1)), // subnormal (or 0)
            1 => [0.0, f64::INFINITY, f64::NAN, f64::MAX, f64::MIN_POSITIVE][(rng.next_u64() % 5) as usize],
            // an odd multiple of half a grid unit (a rounding tie) or a few units
            2 => (2 * (rng.next_u64() % 8) + 1) as f64 * 2f64.powi(-frac - 1),
            3 => (rng.next_u64() % 64) as f64 * 2f64.powi(-frac - (rng.next_u64() % 8) as i32),
            // any exponent from far below the grid to past the range
            4 | 5 => m * 2f64.powi((rng.next_u64() % 400) as i32 - frac - 120),
            // around the fast path's edges: shift near 0 and near 64 (L − 1)
            6 => m * 2f64.powi(-frac - 52 + (rng.next_u64() % 5) as i32 - 2),
            7 => m * 2f64.powi(INT_BITS as i32 - 119 + (rng.next_u64() % 9) as i32 - 4),
            _ => m * 2f64.powi(-52 - (rng.next_u64() % 80) as i32), // chunk-sum-like
        };
        sign * x
    }

    /// The fast path of `add_f64` gives the same integers (and the same refusals) as the
    /// general one, over random accumulators (limbs near all-ones and all-zeros, so carries and
    /// borrows cross limbs and the top) and tricky values.
    fn fast_path_matches_general<const L: usize>(seed: u64) {
        let mut rng = SplitMix64::new(seed);
        for _ in 0..200_000 {
            let limb = |r: &mut SplitMix64| match r.next_u64() % 4 {
                0 => u64::MAX,
                1 => 0,
                2 => u64::MAX - (r.next_u64() % 4096),
                _ => r.next_u64(),
            };
            let mut a = Fixed::<L>([0; L]);
            for l in a.0.iter_mut() {
                *l = limb(&mut rng);
            }
            let x = tricky_f64(&mut rng, Fixed::<L>::FRAC);
            let mut b = a;
            let (fa, fb) = (a.add_f64(x), b.add_f64_general(x));
            assert_eq!((fa, a), (fb, b), "{x:e} = {:#x}", x.to_bits());
        }
    }

    #[test]
    fn fast_path_matches_general_sum1() {
        fast_path_matches_general::<4>(3);
    }

    #[test]
    fn fast_path_matches_general_sum2() {
        fast_path_matches_general::<5>(4);
    }
}
