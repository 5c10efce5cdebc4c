//! Run configuration of the Monte Carlo engine: photons, seed, threads, source.

use super::lanes::Isa;
use super::source::Source;
use crate::error::{Error, Result};

/// Photons per chunk: the unit of parallel work and of merging. Fixed (independent of the
/// thread count), so that results are bit-identical for any number of threads.
pub const CHUNK_PHOTONS: u64 = 4096;

/// Photons per batch of the batch-means standard errors of histograms (see
/// `mc::tally::accum`): the largest power of two ≤ N/64, between 1 and 1024, so that a run has
/// at least 64 batches (a good variance estimate) and long runs trace 1024 photons between
/// batch ends (where the lanes drain). Batches start at multiples of their size, which
/// divides [`CHUNK_PHOTONS`], so they are the same for any thread count.
pub fn batch_photons(photons: u64) -> u64 {
    let target = (photons / 64).clamp(1, 1024);
    1 << (63 - target.leading_zeros())
}

/// Russian roulette: packets lighter than this weight play roulette (MCML's `WEIGHT`).
pub const ROULETTE_THRESHOLD: f64 = 1e-4;

/// Russian roulette: a packet survives with probability 1/m and its weight is multiplied by m
/// (MCML's `CHANCE` = 1/m = 0.1).
pub const ROULETTE_M: f64 = 10.0;

/// Everything a run needs besides the stack and the tally.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunConfig {
    /// Number of photon packets to trace (≥ 1).
    pub photons: u64,
    /// The 64-bit seed (the Philox key that seeds each photon's xoshiro128++ stream; see [`crate::rng`]).
    pub seed: u64,
    /// Worker threads; `None` = all cores (rayon's global pool).
    pub threads: Option<usize>,
    /// The light source.
    pub source: Source,
    /// Instruction set of the lane kernel; `None` = the best this machine has
    /// ([`Isa::detect`]). Every choice gives the same bits (see `mc::lanes`).
    pub isa: Option<Isa>,
}

impl RunConfig {
    /// A run of `photons` packets with `seed`, all cores, a normal-incidence pencil beam.
    pub fn new(photons: u64, seed: u64) -> Self {
        RunConfig { photons, seed, threads: None, source: Source::default(), isa: None }
    }

    /// Check every field.
    pub fn validate(&self) -> Result<()> {
        if self.photons == 0 {
            return Err(Error::param("photons", 0.0, "an integer >= 1"));
        }
        if let Some(t) = self.threads {
            if t == 0 {
                return Err(Error::param("threads", 0.0, "an integer >= 1 (or None for all cores)"));
            }
        }
        if let Some(isa) = self.isa {
            if !Isa::available().contains(&isa) {
                return Err(Error::Invalid(format!("isa: {} is not available on this machine", isa.name())));
            }
        }
        self.source.validate()
    }
}
