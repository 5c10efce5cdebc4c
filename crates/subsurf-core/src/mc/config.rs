//! Run configuration of the Monte Carlo engine: photons, seed, threads, source.

use super::lanes::Isa;
use super::source::Source;
use crate::error::{Error, Result};

/// Photons per chunk: the unit of parallel work and of merging. Fixed (independent of the
/// thread count), so that results are bit-identical for any number of threads.
pub const CHUNK_PHOTONS: u64 = 4096;

/// Photons per batch of the batch-means standard errors of histograms (see
/// `mc::tally::accum`): batch k holds photons [k·256, (k+1)·256). It divides
/// [`CHUNK_PHOTONS`], so chunks hold whole batches and batches are the same for any thread
/// count or split of the photons; the lane kernel drains its lanes at each batch end.
pub const BATCH_PHOTONS: u64 = 256;

/// Russian roulette: packets lighter than this fraction of their entering weight 1 − R_sp play
/// roulette (MCML's `WEIGHT` = 10⁻⁴, there absolute; see `mc::kernel`).
pub const ROULETTE_THRESHOLD: f64 = 1e-4;

/// Most worker threads a run may use (each holds up to two chunk tallies; see `mc::run`).
pub const MAX_THREADS: usize = 1024;

/// The allowed values of `photons`, as messages state them.
pub const PHOTONS_ALLOWED: &str = "an integer in [1, 2**64 - 1]";
/// The allowed values of `seed`.
pub const SEED_ALLOWED: &str = "an integer in [0, 2**64 - 1]";
/// The allowed values of `threads`.
pub const THREADS_ALLOWED: &str = "an integer in [1, 1024] (or None for one per core)";

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
    /// Worker threads (1 … [`MAX_THREADS`]); `None` = one per core.
    pub threads: Option<usize>,
    /// The light source.
    pub source: Source,
    /// Instruction set of the lane kernel; `None` = the best this machine has
    /// ([`Isa::detect`]) or the one the environment variable `SUBSURF_ISA` forces
    /// ([`Isa::selected`]). Every choice gives the same bits (see `mc::lanes`).
    pub isa: Option<Isa>,
}

impl RunConfig {
    /// The number of worker threads the run uses.
    pub fn thread_count(&self) -> usize {
        self.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()).min(MAX_THREADS))
    }

    /// A run of `photons` packets with `seed`, all cores, a normal-incidence pencil beam.
    pub fn new(photons: u64, seed: u64) -> Self {
        RunConfig { photons, seed, threads: None, source: Source::default(), isa: None }
    }

    /// Check every field.
    pub fn validate(&self) -> Result<()> {
        if self.photons == 0 {
            return Err(Error::param_int("photons", 0, PHOTONS_ALLOWED));
        }
        if let Some(t) = self.threads {
            if !(1..=MAX_THREADS).contains(&t) {
                return Err(Error::param_int("threads", t as i128, THREADS_ALLOWED));
            }
        }
        if let Some(isa) = self.isa {
            if !Isa::available().contains(&isa) {
                return Err(Error::Invalid(format!("isa: {} is not available on this machine", isa.name())));
            }
        } else {
            Isa::forced()?; // the environment's choice (`mc::lanes::ISA_ENV`), if any
        }
        self.source.validate()
    }
}
