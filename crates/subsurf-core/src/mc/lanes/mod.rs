//! The lane-batched (SIMD) photon kernel: [`LANES`] photon histories advance together, one
//! event per lane per step, in structure-of-arrays form; a lane whose photon ends is refilled
//! with the next photon index of the range.
//!
//! # Why plain arrays and `#[target_feature]` (and not `wide`, `pulp` or `std::simd`)
//! The kernel is written once as loops over fixed-width lane arrays with branch-free bodies
//! (`if c { a } else { b }` selects, bit tricks, no calls), which LLVM vectorises; the same
//! code is compiled for each instruction set with std's `#[target_feature]` and chosen at run
//! time ([`Isa::detect`], cached): AVX-512 (16 f32 or 8 f64 per register), AVX2 + FMA
//! (8 f32 or 4 f64), SSE4.2 on x86-64 (4 f32 or 2 f64: NEON's width, so that an x86 machine
//! can measure the narrow path), NEON on arm64, and the target's baseline as the fallback.
//! The environment variable `SUBSURF_ISA` ([`ISA_ENV`]) forces one for every run that does
//! not name one ([`Isa::selected`]). LLVM's cost model decides per loop and per width whether
//! to vectorise: a loop with a run-time branch or with f64, f32 and u32 lanes mixed around a
//! xoshiro step stayed scalar for 128-bit vectors while it vectorised for 256 and 512 bits, so
//! the loops are kept uniform (constant flags, one kind of work per loop); the instruction
//! counts per path are in `docs/architecture.md`. `std::simd` is unstable;
//! `wide` selects its instructions at *compile* time (no runtime dispatch without building
//! the crate several times); `pulp` dispatches at run time but offers no gathers nor mixed
//! u32/f64 lanes, which this kernel needs (per-lane layer tables, 32-bit random words). Plain
//! arrays need no dependency, run on every target, and make a property possible that a
//! crate's fused or approximate intrinsics would break: the kernel uses only correctly
//! rounded IEEE operations (no FMA contraction, no approximate reciprocal), so **every
//! instruction set produces the same bits** for the same photon ([`Isa::available`] lists the
//! ones a machine can run; the tests compare them).
//!
//! # Precision (f64 where it is needed, f32 where it pays)
//! The kernel is bound by vector throughput, and f32 doubles the lanes per register (16 per
//! AVX-512 register, [`LANES`] = 16), so each quantity is f32 unless it needs more:
//! - **f64: position, path, unused optical depth, weights, roulette threshold, every deposit
//!   and tally.** Interfaces sit at depths up to 10² mm (f32's spacing there is 8·10⁻⁶ mm, a
//!   thousandth of a mean free path in tissue) and packets are placed *exactly* on them;
//!   deposits span 10⁻⁸…1 and sum over 10⁹ events; the energy balance holds to 10⁻¹².
//! - **f64: interfaces** (Fresnel, refraction, the distance to the interface): rare next to
//!   interactions; the f32 direction is converted, the refracted one stored back as f32.
//! - **f32: the direction** (ux, uy, uz) and everything that makes a new one: the HG polar
//!   angle, the azimuth's cos/sin and MCML's direction update (`kernel::step::spin_word`), and
//!   −ln ξ for the optical depth (converted to f64 before it scales a step). A direction
//!   error of 10⁻⁷ rad moves a packet 10⁻⁷ of its step, far below any tally bin; the
//!   sampled distributions are what the tests check (χ² of 1 − cos θ × φ with cells down to
//!   10⁻⁵ in cos θ, at g up to 0.95 and next to the pole).
//!
//! Measured (tests in `math.rs` and `tests.rs`): −ln u in f32 within 0.83 ulp of f64's `ln`;
//! cos/sin 2πu within 1.2·10⁻⁷ absolute (2.6 ulp); 1 − cos θ is sampled in the
//! cancellation-free form (1 − g)(1 − ξ)(t + 1 − g)/(1 − g + 2gξ), within 4.1·10⁻⁷ *relative*
//! of f64 at every ξ (so sin θ = √(m(2 − m)) keeps its relative precision at the forward peak
//! of g = 0.9, where 1 − cos θ from the textbook cos θ would lose it to cancellation); the
//! direction update uses ρ² = ux² + uy² instead of 1 − uz² for the same reason near the
//! pole, and one Newton step u ← u(3 − |u|²)/2 renormalises it: |u| stays within 1.3·10⁻⁷
//! of 1 over 10⁶ successive scatterings (MCML's update renormalises nothing, and f32
//! rounding would random-walk |u| over a 10⁴-event history); dividing by √|u|² instead is no
//! faster (measurements: `docs/architecture.md`, "Engine speed measurements"). The
//! uniforms of the polar angle are (k + ½)·2⁻²³ from the top 23 bits of a word
//! ([`math::open01_f32`]); the optical depth's uses 31 bits ([`math::open01_f32_fine`],
//! relative spacing ≤ 2⁻²³ down to 2⁻³²): an optical depth is at most −ln 2⁻³² = 22.2, the
//! same cut as f64 uniforms of a 32-bit word (e⁻²²·² = 2.3·10⁻¹⁰ lost from the tail of the
//! exponential; 23 bits would cut at 16.6 and lose 6·10⁻⁸). The roulette ξ is compared as
//! an integer (exact). The random words stay 32-bit (xoshiro128++ as in [`crate::rng`]).
//!
//! The f32 sampling runs in a loop of its own (`kernel::sample`): in the mixed f32/f64 loop
//! LLVM vectorised it 8 wide (f32 in half registers), alone it runs 16 wide. (The speed of
//! these choices against the 8-lane all-f64 kernel is recorded in `docs/architecture.md`,
//! "Engine speed measurements".)
//! The results are not those of the all-f64 kernel bit for bit, but nearly: the same words
//! drive the same choices, so the published tables moved in their last digit only.
//!
//! Random-number order within a photon's stream (differs from the scalar reference kernel
//! only there): source draws, then three words per lane step, drawn whether or not the step
//! uses them (optical depth, phase ξ, azimuth φ = 2πu by [`math::cos_sin_2pi_f32`]), then a
//! Fresnel ξ at an interface hit with 0 < R < 1 or a roulette word (compared as an integer)
//! in a step that plays roulette, each drawn only there (see `kernel::draw_words`); the
//! clear-layer bounce sampling of `mc::kernel` draws its two uniforms from the lane's stream.

mod kernel;
pub mod math;

pub(crate) use kernel::trace_range;
#[cfg(test)]
use kernel::{hg_one_minus_cos, spin_word};

/// Photon histories traced together by one core.
pub const LANES: usize = 16;

/// The environment variable that forces the lane kernel's instruction set for every run that
/// does not name one (`RunConfig::isa`): `avx512`, `avx2`, `sse` (128-bit lanes on x86-64),
/// `neon`, `baseline` (alias `scalar`); unset or empty: the best this machine has. A name this
/// machine cannot run, or no name at all, is refused with an error that lists the ones it can.
pub const ISA_ENV: &str = "SUBSURF_ISA";

/// An instruction set the lane kernel is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64; also the fallback on every other target).
    Scalar,
    /// x86-64 SSE4.2 + POPCNT (x86-64-v2): 128-bit vectors (4 f32 or 2 f64 per register), the
    /// width of arm64's NEON, which it stands in for on x86 machines.
    Sse4,
    /// x86-64 AVX2 + FMA with x86-64-v3's BMI1, BMI2, LZCNT and POPCNT (integer only: the
    /// lane loop's bit masks; every AVX2 processor has them).
    Avx2,
    /// x86-64 AVX-512 F/VL/DQ (x86-64-v4).
    Avx512,
    /// arm64 NEON (Advanced SIMD).
    Neon,
}

impl Isa {
    /// Every instruction set the lane kernel knows, best first (whatever this machine runs).
    pub const ALL: [Isa; 5] = [Isa::Avx512, Isa::Avx2, Isa::Sse4, Isa::Neon, Isa::Scalar];

    /// Every instruction set this machine can run, best first.
    pub fn available() -> Vec<Isa> {
        Isa::ALL.into_iter().filter(|i| i.runs_here()).collect()
    }

    /// Whether this machine can run `self` (its features are detected at run time).
    pub fn runs_here(self) -> bool {
        match self {
            Isa::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Sse4 => std::arch::is_x86_feature_detected!("sse4.2") && std::arch::is_x86_feature_detected!("popcnt"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("bmi1")
                    && std::arch::is_x86_feature_detected!("bmi2")
                    && std::arch::is_x86_feature_detected!("lzcnt")
                    && std::arch::is_x86_feature_detected!("popcnt")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && Isa::Avx2.runs_here()
            }
            #[cfg(target_arch = "aarch64")]
            Isa::Neon => std::arch::is_aarch64_feature_detected!("neon"),
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }

    /// The best instruction set of this machine (detected once).
    pub fn detect() -> Isa {
        static BEST: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| Isa::available()[0])
    }

    /// The instruction set a run uses when it names none: the one [`ISA_ENV`] forces, else
    /// [`Isa::detect`]'s. Errors name the variable, its value and the choices this machine has.
    pub fn selected() -> crate::Result<Isa> {
        Ok(Isa::forced()?.unwrap_or_else(Isa::detect))
    }

    /// The instruction set [`ISA_ENV`] forces (`None` when it is unset or empty).
    pub fn forced() -> crate::Result<Option<Isa>> {
        match std::env::var(ISA_ENV) {
            Ok(v) => Isa::parse_forced(&v),
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(_)) => Isa::parse_forced("(not UTF-8)"),
        }
    }

    /// [`Isa::forced`] for the value `value` of [`ISA_ENV`].
    pub fn parse_forced(value: &str) -> crate::Result<Option<Isa>> {
        let name = value.trim().to_ascii_lowercase();
        if name.is_empty() {
            return Ok(None);
        }
        let here = Isa::available().iter().map(|i| i.name()).collect::<Vec<_>>().join(", ");
        match Isa::from_name(&name) {
            Some(isa) if isa.runs_here() => Ok(Some(isa)),
            Some(isa) => Err(crate::Error::Invalid(format!(
                "{ISA_ENV}: {value:?} ({}) is not supported by this CPU; it runs: {here}",
                isa.describe()
            ))),
            None => Err(crate::Error::Invalid(format!(
                "{ISA_ENV}: {value:?} is not an instruction set (one of avx512, avx2, sse, neon, baseline); \
                 this CPU runs: {here}"
            ))),
        }
    }

    /// The instruction set of a [`Isa::name`] (`"scalar"` also as `"baseline"`).
    pub fn from_name(name: &str) -> Option<Isa> {
        match name {
            "baseline" => Some(Isa::Scalar),
            _ => Isa::ALL.into_iter().find(|i| i.name() == name),
        }
    }

    /// Name as printed by the benchmark and read from [`ISA_ENV`] (`"avx512"`, `"avx2"`,
    /// `"sse"`, `"neon"`, `"scalar"`).
    pub fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Sse4 => "sse",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
            Isa::Neon => "neon",
        }
    }

    /// The features and the vector width, in words.
    pub fn describe(self) -> &'static str {
        match self {
            Isa::Scalar => "the target's baseline: SSE2 on x86-64",
            Isa::Sse4 => "x86-64 SSE4.2 + POPCNT, 128-bit vectors",
            Isa::Avx2 => "x86-64 AVX2 + FMA, 256-bit vectors",
            Isa::Avx512 => "x86-64 AVX-512 F/VL/DQ, 512-bit vectors",
            Isa::Neon => "arm64 NEON, 128-bit vectors",
        }
    }
}

#[cfg(test)]
mod tests;
