//! The lane-batched (SIMD) photon kernel: [`LANES`] photon histories advance together, one
//! event per lane per step, in structure-of-arrays form; a lane whose photon ends is refilled
//! with the next photon index of the range.
//!
//! # Why plain arrays and `#[target_feature]` (and not `wide`, `pulp` or `std::simd`)
//! The kernel is written once as loops over fixed-width lane arrays with branch-free bodies
//! (`if c { a } else { b }` selects, bit tricks, no calls), which LLVM vectorises; the same
//! code is compiled for each instruction set with std's `#[target_feature]` and chosen at run
//! time ([`Isa::detect`], cached): AVX-512 (8 f64 per register), AVX2 + FMA (2 × 4), NEON on
//! arm64 (4 × 2), and the target's baseline as the scalar fallback. `std::simd` is unstable;
//! `wide` selects its instructions at *compile* time (no runtime dispatch without building
//! the crate several times); `pulp` dispatches at run time but offers no gathers nor mixed
//! u32/f64 lanes, which this kernel needs (per-lane layer tables, 32-bit random words). Plain
//! arrays need no dependency, run on every target, and make a property possible that a
//! crate's fused or approximate intrinsics would break: the kernel uses only correctly
//! rounded IEEE operations (no FMA contraction, no approximate reciprocal), so **every
//! instruction set produces the same bits** for the same photon ([`Isa::available`] lists the
//! ones a machine can run; the tests compare them).
//!
//! # Precision (f64 throughout the state)
//! Position and path must be f64: interfaces sit at depths up to 10² mm (f32's step there is
//! 8·10⁻⁶ mm, a thousandth of a mean free path in tissue) and packets are placed *exactly* on
//! them. Weights and every tally accumulate in f64 (deposits span 10⁻⁸…1). Directions stay
//! f64 too: MCML's update renormalises nothing, so f32 round-off (6·10⁻⁸ per event) would
//! random-walk |u| by ~10⁻⁵ over the 10⁴ events of a thick-slab history; and f32 arithmetic
//! only pays with twice the lanes (16 per AVX-512 register), where every f64 quantity would
//! then take two registers and each step two conversions per quantity (not measured: a
//! possible next step for the direction update and the azimuth). The random words stay
//! 32-bit (xoshiro128++ as in [`crate::rng`]).
//!
//! Random-number order within a photon's stream (differs from the scalar reference kernel
//! only there): source draws, then four words per lane step, drawn whether or not the step
//! uses them (optical depth, phase ξ, azimuth φ = 2πu by [`math::cos_sin_2pi`], roulette ξ),
//! and a Fresnel ξ at an interface hit with 0 < R < 1 (see `kernel::draw_words`); the
//! clear-layer bounce sampling of `mc::kernel` draws its two uniforms from the lane's stream.

mod kernel;
pub mod math;

pub(crate) use kernel::trace_range;
#[cfg(test)]
use kernel::{hg_cos, spin_word};

/// Photon histories traced together by one core.
pub const LANES: usize = 8;

/// An instruction set the lane kernel is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64; also the fallback on every other target).
    Scalar,
    /// x86-64 AVX2 + FMA (x86-64-v3).
    Avx2,
    /// x86-64 AVX-512 F/VL/DQ (x86-64-v4).
    Avx512,
    /// arm64 NEON (Advanced SIMD).
    Neon,
}

impl Isa {
    /// Every instruction set this machine can run, best first.
    pub fn available() -> Vec<Isa> {
        let mut v = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                v.push(Isa::Avx512);
            }
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                v.push(Isa::Avx2);
            }
        }
        #[cfg(target_arch = "aarch64")]
        {
            if std::arch::is_aarch64_feature_detected!("neon") {
                v.push(Isa::Neon);
            }
        }
        v.push(Isa::Scalar);
        v
    }

    /// The best instruction set of this machine (detected once).
    pub fn detect() -> Isa {
        static BEST: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| Isa::available()[0])
    }

    /// Name as printed by the benchmark (`"avx512"`, `"avx2"`, `"neon"`, `"scalar"`).
    pub fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
            Isa::Neon => "neon",
        }
    }
}

#[cfg(test)]
mod tests;
