//! Running many photons: fixed chunks traced in parallel (rayon), merged in chunk order.
//!
//! Photons 0 … N−1 are split into chunks of [`CHUNK_PHOTONS`]; each chunk is traced by the
//! lane kernel (`mc::lanes`) into its own tally (made by the caller's factory) and the chunk
//! tallies are merged into the result strictly in chunk order. Since each photon has its own
//! random stream (see [`crate::rng`]), a photon's history does not depend on its lane or the
//! instruction set, and floating-point sums are formed in the same order whatever the
//! scheduling, results are bit-identical for any number of threads. A tally with batch-means
//! errors ([`Tally::batched`]) gets its batches ([`batch_photons`]) traced one after the
//! other, each closed by [`Tally::end_batch`]. Chunks are scheduled in waves (a bounded number
//! in flight) so memory stays O(threads × tally size) for any N.
//!
//! Cancellation: `cancel` is polled before each chunk and every few thousand lane steps inside
//! one; a chunk interrupted midway is discarded, so a cancelled run returns the completed
//! chunks (`photons` says how many photons they hold). `progress` is increased by each
//! completed chunk's photon count.

use super::config::{batch_photons, RunConfig, CHUNK_PHOTONS};
use super::kernel::Kernel;
use super::lanes::{trace_range, Isa};
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

/// Trace photons `range` into `t`, batch by batch if the tally keeps batch means.
fn trace_chunk<T: Tally>(
    isa: Isa,
    k: &Kernel,
    seed: u64,
    batch: u64,
    range: std::ops::Range<u64>,
    t: &mut T,
    cancel: &AtomicBool,
) -> Option<u64> {
    if !t.batched() {
        return trace_range(isa, k, seed, range, t, cancel);
    }
    let mut events = 0;
    let mut a = range.start;
    while a < range.end {
        let b = (a + batch).min(range.end);
        events += trace_range(isa, k, seed, a..b, t, cancel)?;
        t.end_batch(b - a);
        a = b;
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
    let isa = cfg.isa.unwrap_or_else(Isa::detect);
    let n = cfg.photons;
    let batch = batch_photons(n);
    let nchunks = n.div_ceil(CHUNK_PHOTONS);
    let seed = cfg.seed;

    let one_chunk = |c: u64| -> Option<(T, u64, u64)> {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let range = c * CHUNK_PHOTONS..((c + 1) * CHUNK_PHOTONS).min(n);
        let mut t = make_tally();
        let ev = trace_chunk(isa, &kernel, seed, batch, range.clone(), &mut t, cancel)?;
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
