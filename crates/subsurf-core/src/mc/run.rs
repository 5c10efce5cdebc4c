//! Running many photons: fixed chunks traced in parallel (rayon), merged in chunk order.
//!
//! Photons 0 … N−1 are split into chunks of [`CHUNK_PHOTONS`]; each chunk is traced into its
//! own tally (made by the caller's factory) and the chunk tallies are merged into the result
//! strictly in chunk order. Since each photon has its own random stream (see [`crate::rng`])
//! and floating-point sums are formed in the same order whatever the scheduling, results are
//! bit-identical for any number of threads. Chunks are scheduled in waves (a bounded number in
//! flight) so memory stays O(threads × tally size) for any N.
//!
//! Cancellation: `cancel` is polled before each chunk and every 256 photons inside one; a
//! chunk interrupted midway is discarded, so a cancelled run returns the completed chunks
//! (`photons` says how many photons they hold). `progress` is increased by each completed
//! chunk's photon count.

use super::config::{RunConfig, CHUNK_PHOTONS};
use super::kernel::Kernel;
use super::tally::Tally;
use crate::error::{Error, Result};
use crate::medium::Stack;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// What a run returns.
#[derive(Clone, Debug)]
pub struct RunOutput<T> {
    /// The merged tally of all completed chunks.
    pub tally: T,
    /// Photons traced (= requested unless cancelled).
    pub photons: u64,
    /// Scattering events (for events/s).
    pub events: u64,
    /// Whether the run was cancelled before all photons were traced.
    pub cancelled: bool,
}

/// How often (photons) a chunk polls the cancel flag.
const CANCEL_POLL: u64 = 256;

fn trace_chunk<T: Tally, const CLEAR: bool, const MIXTURE: bool>(
    k: &Kernel,
    seed: u64,
    range: std::ops::Range<u64>,
    tally: &mut T,
    cancel: &AtomicBool,
) -> Option<u64> {
    let mut events = 0;
    for i in range.clone() {
        if (i - range.start).is_multiple_of(CANCEL_POLL) && cancel.load(Ordering::Relaxed) {
            return None;
        }
        events += k.trace::<T, CLEAR, MIXTURE>(seed, i, tally);
    }
    Some(events)
}

/// Trace `cfg.photons` photons through `stack` into tallies made by `make_tally`.
///
/// Errors: an invalid configuration ([`RunConfig::validate`]) or a thread pool that cannot be
/// built. `cancel` stops the run early (see the module docs); `progress` counts photons done.
pub fn run<T, F>(
    stack: &Stack,
    cfg: &RunConfig,
    make_tally: F,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<RunOutput<T>>
where
    T: Tally,
    F: Fn() -> T + Sync,
{
    cfg.validate()?;
    stack.layers.first().ok_or_else(|| Error::Invalid("layers: the stack is empty; give at least one layer".into()))?;
    let kernel = Kernel::new(stack, cfg.source);
    let n = cfg.photons;
    let nchunks = n.div_ceil(CHUNK_PHOTONS);
    let seed = cfg.seed;

    let one_chunk = |c: u64| -> Option<(T, u64, u64)> {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let range = c * CHUNK_PHOTONS..((c + 1) * CHUNK_PHOTONS).min(n);
        let mut t = make_tally();
        let ev = match (kernel.any_clear, kernel.any_mixture) {
            (false, false) => trace_chunk::<T, false, false>(&kernel, seed, range.clone(), &mut t, cancel),
            (false, true) => trace_chunk::<T, false, true>(&kernel, seed, range.clone(), &mut t, cancel),
            (true, false) => trace_chunk::<T, true, false>(&kernel, seed, range.clone(), &mut t, cancel),
            (true, true) => trace_chunk::<T, true, true>(&kernel, seed, range.clone(), &mut t, cancel),
        }?;
        let done = range.end - range.start;
        progress.fetch_add(done, Ordering::Relaxed);
        Some((t, done, ev))
    };

    let body = || {
        // Chunks in flight per wave: any value gives the same result (merging is in chunk
        // order); a few per thread keeps the cores busy at the end of each wave.
        let wave = (8 * rayon::current_num_threads() as u64).max(16);
        let mut acc = make_tally();
        let (mut photons, mut events) = (0u64, 0u64);
        let mut c0 = 0;
        while c0 < nchunks && !cancel.load(Ordering::Relaxed) {
            let c1 = (c0 + wave).min(nchunks);
            let parts: Vec<Option<(T, u64, u64)>> = (c0..c1).into_par_iter().map(one_chunk).collect();
            for (t, done, ev) in parts.iter().flatten() {
                acc.merge(t);
                photons += done;
                events += ev;
            }
            c0 = c1;
        }
        RunOutput { tally: acc, photons, events, cancelled: photons < n }
    };

    match cfg.threads {
        None => Ok(body()),
        Some(t) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::Invalid(format!("threads = {t}: cannot start the thread pool: {e}")))?;
            Ok(pool.install(body))
        }
    }
}
