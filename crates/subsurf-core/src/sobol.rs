//! The Sobol sequence in [`DIMS`] dimensions with hash-based Owen scrambling: the randomized
//! quasi-Monte Carlo points of the renderer's camera samples ([`crate::rng::Qmc`],
//! `render::pixel`).
//!
//! - Direction numbers: S. Joe, F. Y. Kuo, "Constructing Sobol sequences with better
//!   two-dimensional projections", SIAM J. Sci. Comput. 30 (2008) 2635–2654 (the file
//!   new-joe-kuo-6.21201; `sobol_table.rs`, generated and checked against SciPy by
//!   `docs/scripts/sobol_directions.py`); dimension 0 is the van der Corput sequence. Point i's
//!   coordinate d is the XOR of the direction numbers of i's set bits (the natural order, so
//!   points k·2ᵐ … (k+1)·2ᵐ − 1 form a (t, m, s)-net).
//! - Scrambling: the nested uniform (Owen) scramble of each coordinate, by a hash (B. Burley,
//!   "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020; the hash is pbrt-v4's
//!   `FastOwenScrambler`, `util/lowdiscrepancy.h`). With independent random seeds per
//!   coordinate each scrambled point is uniform in [0, 1)^D, so an estimator fed with them is
//!   unbiased, while the points of a block keep the net's stratification.

/// Dimensions of the table (0 … DIMS − 1).
pub const DIMS: usize = crate::sobol_table::JOE_KUO.len() + 1;

/// The 32 direction numbers of every dimension, each bit-reversed (so that a point's reversed
/// coordinate, the input of the Owen scramble, is their XOR), built at compile time.
static REVERSED: [[u32; 32]; DIMS] = reversed_matrices();

const fn reversed_matrices() -> [[u32; 32]; DIMS] {
    let mut m = [[0u32; 32]; DIMS];
    let mut k = 0;
    while k < 32 {
        m[0][k] = 1 << k; // van der Corput: vₖ = 2^{31−k}, reversed
        k += 1;
    }
    let mut d = 1;
    while d < DIMS {
        let v = directions(crate::sobol_table::JOE_KUO[d - 1].0, crate::sobol_table::JOE_KUO[d - 1].1);
        let mut k = 0;
        while k < 32 {
            m[d][k] = v[k].reverse_bits();
            k += 1;
        }
        d += 1;
    }
    m
}

/// The direction numbers v₀ … v₃₁ of the dimension of primitive polynomial `poly` (its bits:
/// x^s + a₁x^{s−1} + … + a_{s−1}x + 1) and initial numbers m₁ … m_s (Bratley & Fox 1988):
/// vₖ = mₖ 2^{31−k} for k < s, then vₖ = v_{k−s} ⊕ (v_{k−s} ≫ s) ⊕ ⊕_{0<j<s} aⱼ v_{k−j}.
const fn directions(poly: u32, init: &[u32]) -> [u32; 32] {
    let s = (31 - poly.leading_zeros()) as usize;
    let mut v = [0u32; 32];
    let mut k = 0;
    while k < 32 {
        v[k] = if k < s {
            init[k] << (31 - k)
        } else {
            let mut x = v[k - s] ^ (v[k - s] >> s);
            let mut j = 1;
            while j < s {
                if (poly >> (s - j)) & 1 == 1 {
                    x ^= v[k - j];
                }
                j += 1;
            }
            x
        };
        k += 1;
    }
    v
}

/// Coordinate `dim` (< [`DIMS`]) of point `i` of the unscrambled sequence, a 32-bit fraction.
#[inline]
pub fn sobol(dim: usize, i: u32) -> u32 {
    sobol_reversed(dim, i).reverse_bits()
}

/// Dimension 1's reversed coordinate by bytes of the index: the XOR of its direction numbers
/// over the set bits of each byte, tabulated at compile time (the camera samples' pixel offsets
/// take dimensions 0 and 1 at a shuffled index whose ~16 set bits the loop below would visit).
static DIM1_BYTES: [[u32; 256]; 4] = byte_tables(1);

const fn byte_tables(dim: usize) -> [[u32; 256]; 4] {
    let v = reversed_matrices()[dim];
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut x = 0;
        while x < 256 {
            let mut acc = 0;
            let mut j = 0;
            while j < 8 {
                if (x >> j) & 1 == 1 {
                    acc ^= v[8 * b + j];
                }
                j += 1;
            }
            t[b][x] = acc;
            x += 1;
        }
        b += 1;
    }
    t
}

/// [`sobol`] bit-reversed. Dimension 0 (van der Corput) is the index itself; dimension 1 by
/// bytes ([`DIM1_BYTES`]); the others XOR the direction numbers of the index's set bits.
#[inline]
fn sobol_reversed(dim: usize, mut i: u32) -> u32 {
    match dim {
        0 => return i,
        1 => {
            let t = &DIM1_BYTES;
            let [a, b, c, d] = i.to_le_bytes();
            return t[0][a as usize] ^ t[1][b as usize] ^ t[2][c as usize] ^ t[3][d as usize];
        }
        _ => {}
    }
    let v = &REVERSED[dim];
    let mut x = 0;
    while i != 0 {
        x ^= v[i.trailing_zeros() as usize];
        i &= i - 1;
    }
    x
}

/// A nested uniform (Owen) scramble of the 32-bit fraction `v` by `seed`: each output bit
/// depends only on the bits above it, bijectively (pbrt-v4's `FastOwenScrambler`).
#[inline]
pub fn owen(v: u32, seed: u32) -> u32 {
    owen_reversed(v.reverse_bits(), seed)
}

/// [`owen`] of the fraction whose bit reversal is `r`.
#[inline]
fn owen_reversed(v: u32, seed: u32) -> u32 {
    owen_hash(v, seed).reverse_bits()
}

/// The reversed direction numbers by bit, then dimension (`BY_BIT[k][d] = REVERSED[d][k]`): a
/// block of consecutive dimensions reads one contiguous row per set bit of the index.
static BY_BIT: [[u32; DIMS]; 32] = by_bit();

const fn by_bit() -> [[u32; DIMS]; 32] {
    let m = reversed_matrices();
    let mut t = [[0u32; DIMS]; 32];
    let mut k = 0;
    while k < 32 {
        let mut d = 0;
        while d < DIMS {
            t[k][d] = m[d][k];
            d += 1;
        }
        k += 1;
    }
    t
}

/// Coordinates `dim … dim + 3` (`dim + 4 ≤` [`DIMS`]) of point `i`, each Owen-scrambled by its
/// [`dim_seed`] of `key`: `[scrambled(d, i, dim_seed(key, d)) for d in dim..dim + 4]`, computed
/// as four lanes (one row of the bit-major direction table per set bit of `i`; the hashes and the
/// bit reversal lane-wise, which the compiler vectorises).
#[inline]
pub fn scrambled_block(dim: usize, i: u32, key: u32) -> [u32; 4] {
    let mut x = [0u32; 4];
    if dim > 1 {
        let mut b = i;
        while b != 0 {
            let row = &BY_BIT[b.trailing_zeros() as usize];
            let v: &[u32; 4] = row[dim..dim + 4].try_into().expect("dim + 4 <= DIMS");
            for k in 0..4 {
                x[k] ^= v[k];
            }
            b &= b - 1;
        }
    } else {
        for (k, x) in x.iter_mut().enumerate() {
            *x = sobol_reversed(dim + k, i);
        }
    }
    let mut out = [0u32; 4];
    for k in 0..4 {
        let seed = dim_seed(key, (dim + k) as u32);
        out[k] = reverse_lanewise(owen_hash(x[k], seed));
    }
    out
}

/// The hash of [`owen_reversed`] before its final bit reversal.
#[inline(always)]
fn owen_hash(mut v: u32, seed: u32) -> u32 {
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v
}

/// `v.reverse_bits()` by shifts and masks only (vectorisable, unlike x86's scalar byte swap).
#[inline(always)]
fn reverse_lanewise(mut v: u32) -> u32 {
    v = v.rotate_left(16);
    v = ((v >> 8) & 0x00ff_00ff) | ((v & 0x00ff_00ff) << 8);
    v = ((v >> 4) & 0x0f0f_0f0f) | ((v & 0x0f0f_0f0f) << 4);
    v = ((v >> 2) & 0x3333_3333) | ((v & 0x3333_3333) << 2);
    ((v >> 1) & 0x5555_5555) | ((v & 0x5555_5555) << 1)
}

/// Coordinate `dim` of point `i`, Owen-scrambled by `seed`.
#[inline]
pub fn scrambled(dim: usize, i: u32, seed: u32) -> u32 {
    owen_reversed(sobol_reversed(dim, i), seed)
}

/// The scramble seed of dimension `dim` for a sample's `key`: MurmurHash3's 32-bit finaliser of
/// key ⊕ (dim + 1)·φ (independent-looking seeds for every dimension).
#[inline]
pub fn dim_seed(key: u32, dim: u32) -> u32 {
    let mut h = key ^ (dim + 1).wrapping_mul(0x9e37_79b9);
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Coordinates of points 1, 2, 3, 5, 77, 255 in a few dimensions, as SciPy's unscrambled
    /// `qmc.Sobol(128)` gives them (it lists point i at row r with r ⊕ (r ≫ 1) = i, Gray-code
    /// order), times 2³²; dimension 0 is the bit reversal of i.
    #[test]
    fn matches_the_reference_points() {
        let idx = [1u32, 2, 3, 5, 77, 255];
        let want: [(usize, [u32; 6]); 6] = [
            (2, [2147483648, 3221225472, 1073741824, 3758096384, 4261412864, 1325400064]),
            (3, [2147483648, 3221225472, 1073741824, 2684354560, 1375731712, 2365587456]),
            (10, [2147483648, 1073741824, 3221225472, 536870912, 2919235584, 2835349504]),
            (100, [2147483648, 3221225472, 1073741824, 3758096384, 3523215360, 352321536]),
            (64, [2147483648, 1073741824, 3221225472, 2684354560, 3925868544, 788529152]),
            (127, [2147483648, 3221225472, 1073741824, 3758096384, 1845493760, 520093696]),
        ];
        for (d, w) in want {
            assert_eq!(idx.map(|i| sobol(d, i)), w, "dimension {d}");
        }
        for i in [1u32, 6, 77, 1 << 20] {
            assert_eq!(sobol(0, i), i.reverse_bits());
        }
        assert_eq!(DIMS, 128);
    }

    /// A block of four coordinates is the four scrambled coordinates one by one, in every
    /// dimension of the table and at indices with few and many set bits.
    #[test]
    fn blocks_are_the_scrambled_coordinates() {
        let mut r = crate::rng::PhotonRng::new(9, 9);
        for n in 0..20_000u32 {
            let i = if n % 2 == 0 { n / 2 } else { r.next_u32() };
            let key = r.next_u32();
            let dim = (n as usize * 7) % (DIMS - 3);
            let want: [u32; 4] = std::array::from_fn(|k| scrambled(dim + k, i, dim_seed(key, (dim + k) as u32)));
            assert_eq!(scrambled_block(dim, i, key), want, "dim {dim}, index {i}, key {key}");
        }
    }

    /// The fast paths of dimensions 0 and 1 against the XOR of the direction numbers of the
    /// index's set bits, at 100,000 pseudo-random indices.
    #[test]
    fn byte_tables_and_van_der_corput_match_the_bit_loop() {
        let mut i = 0x9e37_79b9u32;
        for _ in 0..100_000 {
            i = i.wrapping_mul(0x2c1b_3c6d).wrapping_add(0x297a_2d39) ^ (i >> 15);
            for d in [0, 1] {
                let mut want = 0;
                for k in 0..32 {
                    if (i >> k) & 1 == 1 {
                        want ^= REVERSED[d][k];
                    }
                }
                assert_eq!(sobol_reversed(d, i), want, "dimension {d}, index {i}");
            }
        }
    }

    /// Points far past the first 2⁸, where the direction numbers from the recurrence (not the
    /// initial m's) set the bits: `scipy.stats.qmc.Sobol(128, scramble=False, bits=32)` (SciPy
    /// 1.17.1), fast-forwarded to the Gray-code position of index i, times 2³².
    #[test]
    fn matches_scipy_at_high_indices() {
        let idx = [1000u32, 65535, (1 << 20) + 12345, (1 << 24) + 99];
        let want: [(usize, [u32; 4]); 7] = [
            (1, [692060160, 65536, 4165240832, 2793439360]),
            (2, [1933574144, 2969501696, 2359093248, 302049408]),
            (3, [3904897024, 1123221504, 813795328, 3464495232]),
            (10, [994050048, 2657681408, 2463205376, 3313862784]),
            (64, [3972005888, 2175205376, 1020430336, 2634987136]),
            (100, [2822766592, 1705050112, 474232832, 2812291712]),
            (127, [650117120, 3565879296, 2929166336, 2581736064]),
        ];
        for (d, w) in want {
            assert_eq!(idx.map(|i| sobol(d, i)), w, "dimension {d}");
        }
        // All 32 bits of the index: (2³¹ + 777) and 2³² − 1.
        let top = [(1, [3485466623u32, 1]), (2, [557864277, 1325465599]), (3, [2110062739, 806158221])];
        for (d, w) in top {
            assert_eq!([(1u32 << 31) + 777, u32::MAX].map(|i| sobol(d, i)), w, "dimension {d}");
        }
    }

    /// Each coordinate of the first 2⁸ points is a (0, 8, 1)-net (one point in each interval of
    /// 2⁻⁸), in every dimension; and the pair of dimensions (0, 1) is a (0, 8, 2)-net.
    #[test]
    fn the_first_points_are_nets() {
        let n = 256u32;
        for d in 0..DIMS {
            let mut seen = vec![false; n as usize];
            for i in 0..n {
                let c = (sobol(d, i) >> 24) as usize;
                assert!(!seen[c], "dimension {d}: two of the first 256 points in one interval of 1/256");
                seen[c] = true;
            }
        }
        for a in 0..=8 {
            let mut boxes = vec![0u32; 256];
            for i in 0..n {
                let (x, y) = ((sobol(0, i) as u64) >> (32 - a), (sobol(1, i) as u64) >> (24 + a));
                boxes[(x << (8 - a) | y) as usize] += 1;
            }
            assert!(boxes.iter().all(|&b| b == 1), "boxes 2^{a} × 2^{}", 8 - a);
        }
    }

    /// The scramble is a bijection on 8-bit prefixes and leaves lower bits out of higher ones.
    #[test]
    fn owen_scramble_is_nested() {
        for seed in [0u32, 1, 0xdead_beef] {
            let mut hi: Vec<u32> = (0..256u32).map(|v| owen(v << 24, seed) >> 24).collect();
            hi.sort_unstable();
            assert_eq!(hi, (0..256).collect::<Vec<_>>(), "seed {seed}");
            for v in [0u32, 0x1234_5678, u32::MAX] {
                assert_eq!(owen(v, seed) >> 20, owen(v & 0xfff0_0000, seed) >> 20, "seed {seed}");
            }
        }
    }
}
