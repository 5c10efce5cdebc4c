//! Running many photons: fixed chunks traced in parallel, merged exactly, always a prefix.
//!
//! Photons are split into chunks of [`CHUNK_PHOTONS`] (chunk c holds photons [c·4096,
//! (c+1)·4096), cut at the run's last photon). Worker threads take chunks in increasing order;
//! each chunk is traced into a tally of its own (made by the caller's factory) in a fixed
//! sequential order, and is then committed strictly in chunk order: a chunk finished early waits
//! (as a pending tally) until every chunk before it is committed. Committing only counts the
//! chunk into the run's prefix (under a lock); the worker that commits a chunk then adds its sums
//! exactly into its own fixed-point accumulator, outside the lock, at the cost of the bins the
//! chunk touched, and the workers' accumulators are added into the run's [`TallyState`] at the
//! end (fixed-point addition is associative and commutative: who drained what does not matter).
//! Hence:
//! - results are bit-identical for any number of threads, and for any split of the photons into
//!   ranges at chunk boundaries traced separately and appended (see [`crate::mc::state`]);
//! - the committed photons are always a prefix: a cancelled run holds exactly photons
//!   [start, N) for some chunk boundary N, so it can be resumed ([`extend`]) to the same bits.
//!
//! Memory: a worker starts chunk c only while c < (next chunk to commit) + 2·threads and fewer
//! than 3·threads chunk tallies are out (traced, pending or being drained), so at most 3·threads
//! chunk tallies and `threads` exact accumulators exist; [`check_memory`] refuses, before
//! anything is allocated, a tally configuration whose copies, exact sums and results would not
//! fit in the available memory.
//!
//! Each chunk is traced by the lane kernel (`mc::lanes`): a photon's history does not depend on
//! its lane or the instruction set, and the lanes' deposits into the chunk's tally are made in
//! an order fixed by the chunk alone, so chunk sums stay a pure function of the chunk.
//!
//! Cancellation: `cancel` is polled before each chunk, before each batch and every
//! [`STOP_POLL_STEPS`](super::kernel::STOP_POLL_STEPS) lane steps; a chunk interrupted midway
//! is discarded. `progress` counts traced photons (published after each batch or slice).

use super::config::{RunConfig, BATCH_PHOTONS, CHUNK_PHOTONS};
use super::kernel::Kernel;
use super::lanes::{trace_range, Isa};
use super::state::TallyState;
use super::tally::{Channel, ChannelState, Tally};
use crate::error::{Error, Result};
use crate::medium::Stack;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// What [`run`] returns.
#[derive(Clone, Debug)]
pub struct RunOutput<T> {
    /// The tally of all committed photons (exact sums, rounded).
    pub tally: T,
    /// Photons traced (= requested unless cancelled).
    pub photons: u64,
    /// Scattering events (for events/s).
    pub events: u64,
    /// Whether the run was cancelled before all photons were traced.
    pub cancelled: bool,
}

/// Bytes per bin of each chunk tally in flight (one `Accum` cell).
pub const CHUNK_BYTES_PER_BIN: u64 = 32;
/// Chunk tallies in flight per thread (being traced, waiting to be committed or being drained).
pub const CHUNKS_PER_THREAD: u64 = 3;
/// Bytes per bin of each thread's exact accumulator (S₁ and S₂ in fixed point).
pub const THREAD_BYTES_PER_BIN: u64 = 72;
/// Bytes per bin held once per run: exact sums (72), the tally they are loaded into (32), the
/// finished histogram (16) and, in Python, its arrays and the exported state (16 + 72).
pub const RUN_BYTES_PER_BIN: u64 = 208;

/// Bytes a run of `layout` on `threads` threads needs at most (see the module docs).
pub fn memory_estimate(layout: &[Channel], threads: usize) -> u64 {
    let bins: u64 = layout.iter().map(|c| c.len as u64).sum();
    let per_thread = CHUNK_BYTES_PER_BIN * CHUNKS_PER_THREAD + THREAD_BYTES_PER_BIN;
    bins.saturating_mul(per_thread * threads as u64 + RUN_BYTES_PER_BIN)
}

/// Memory available to a new allocation, bytes (Linux: `MemAvailable` of /proc/meminfo);
/// `None` where it cannot be read.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

fn gb(bytes: u64) -> String {
    format!("{:.3} GB", bytes as f64 / 1e9)
}

/// Refuse a tally layout whose memory for `threads` threads exceeds `available` bytes (default:
/// [`available_memory`]), naming the largest histograms and the size needed.
pub fn check_memory(layout: &[Channel], threads: usize, available: Option<u64>) -> Result<()> {
    let need = memory_estimate(layout, threads);
    let Some(have) = available.or_else(available_memory) else { return Ok(()) };
    if need <= have {
        return Ok(());
    }
    let mut big: Vec<&Channel> = layout.iter().collect();
    big.sort_by_key(|c| std::cmp::Reverse(c.len));
    let names: Vec<String> = big.iter().take(4).map(|c| format!("{} {} bins", c.name, c.len)).collect();
    Err(Error::Invalid(format!(
        "tallies: the histograms ({}, …) need about {} of memory ({} bytes per bin for each of the {} × {threads} chunk \
         copies and {} for the exact sums of each of {threads} thread(s), {} for the run's exact sums and results) but \
         {} is available: use coarser grids (tallies.nr, nz, na, nt, brdf, max_order) or fewer threads",
        names.join(", "),
        gb(need),
        CHUNK_BYTES_PER_BIN,
        CHUNKS_PER_THREAD,
        THREAD_BYTES_PER_BIN,
        RUN_BYTES_PER_BIN,
        gb(have)
    )))
}

/// Photons between two progress updates of a run without batches (the lanes drain there).
const SLICE_PHOTONS: u64 = 1024;

/// Trace photons `range` into `tally` with the lane kernel (`mc::lanes`), batch by batch
/// ([`BATCH_PHOTONS`]) when the tally keeps batch means, else in slices of
/// [`SLICE_PHOTONS`]; `None` if cancelled midway.
fn trace_chunk<T: Tally>(
    isa: Isa,
    k: &Kernel,
    seed: u64,
    range: std::ops::Range<u64>,
    tally: &mut T,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Option<u64> {
    let batched = tally.batched();
    let slice = if batched { BATCH_PHOTONS } else { SLICE_PHOTONS };
    let mut events = 0;
    let mut a = range.start;
    while a < range.end {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        // Batches start at multiples of their size (chunks are multiples of it).
        let b = ((a / slice + 1) * slice).min(range.end);
        events += trace_range(isa, k, seed, a..b, tally, cancel)?;
        if batched {
            tally.end_batch(b - a);
        }
        progress.fetch_add(b - a, Ordering::Relaxed);
        a = b;
    }
    Some(events)
}

/// The committer shared by the workers (under a mutex). It only orders chunks: the sums of a
/// committed chunk are drained by the worker that committed it, outside the lock, into that
/// worker's own exact accumulator (fixed-point addition is associative and commutative, so the
/// final sum of the workers' accumulators does not depend on which worker drained which chunk).
struct Commit<'a, T> {
    state: &'a mut TallyState,
    /// The next chunk to commit.
    frontier: u64,
    /// Chunks traced but not yet committed: (tally, photons, events).
    pending: BTreeMap<u64, (T, u64, u64)>,
    /// Drained tallies, cleared and ready for reuse.
    spare: Vec<T>,
    /// Tallies handed out (being traced, pending or being drained).
    out: usize,
}

impl<T: Tally> Commit<'_, T> {
    /// Commit every pending chunk that continues the prefix (photon and event counts), moving
    /// its tally to `ready` for the caller to drain.
    fn advance(&mut self, ready: &mut Vec<T>) {
        while let Some((t, photons, events)) = self.pending.remove(&self.frontier) {
            self.state.end += photons;
            self.state.events += events;
            self.frontier += 1;
            ready.push(t);
        }
    }
}

/// Trace photons [`state.end`, `cfg.photons`) of the run through `stack` into tallies made by
/// `make_tally` and add them to `state` (which may be empty or a prefix from an earlier,
/// interrupted run). Returns whether the run was cancelled (the state then holds a shorter
/// prefix).
///
/// Errors: an invalid configuration ([`RunConfig::validate`]), a stack refused by
/// [`crate::mc::cost::check`], too little memory ([`check_memory`]), a state that does not
/// end at a chunk boundary or holds more photons than asked for, or tallies whose layout differs
/// from the state's.
///
/// [`state.end`]: TallyState::end
pub fn extend<T, F>(
    stack: &Stack,
    cfg: &RunConfig,
    state: &mut TallyState,
    make_tally: F,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<bool>
where
    T: Tally,
    F: Fn() -> T + Sync,
{
    cfg.validate()?;
    stack.layers.first().ok_or_else(|| Error::Invalid("layers: the stack is empty; give at least one layer".into()))?;
    super::cost::check(stack)?;
    let end = cfg.photons;
    if state.end > end {
        return Err(Error::Invalid(format!(
            "photons = {end} is fewer than the {} photons the state to continue already holds",
            state.end
        )));
    }
    if state.end == end {
        return Ok(false);
    }
    if !state.end.is_multiple_of(CHUNK_PHOTONS) {
        return Err(Error::Invalid(format!(
            "state: it ends at photon {}, inside a chunk of {CHUNK_PHOTONS} photons, so it cannot be continued \
             (only interrupted runs and ranges ending at a multiple of {CHUNK_PHOTONS} can)",
            state.end
        )));
    }
    let threads = cfg.thread_count();
    check_memory(&state.layout, threads, None)?;
    let first = make_tally();
    let mut layout = Vec::new();
    first.channels(&mut layout);
    if layout != state.layout {
        return Err(Error::Invalid("state: its tallies differ from this run's".into()));
    }
    let kernel = Kernel::new(stack, cfg.source);
    let isa = match cfg.isa {
        Some(isa) => isa,
        None => Isa::selected()?,
    };
    let (c0, c1) = (state.end / CHUNK_PHOTONS, end.div_ceil(CHUNK_PHOTONS));
    let (window, cap) = (2 * threads as u64, 3 * threads);
    let next = AtomicU64::new(c0);
    let commit = Mutex::new(Commit { state, frontier: c0, pending: BTreeMap::new(), spare: vec![first], out: 0 });
    let turn = Condvar::new();
    let seed = cfg.seed;

    // `failed`: a sum left the exact range, or a worker panicked (a bug): it raises `failed` as
    // it unwinds, so that the others stop waiting for its chunk and the panic reaches the
    // caller instead of a hang.
    let failed = AtomicBool::new(false);
    struct OnPanic<'a>(&'a AtomicBool);
    impl Drop for OnPanic<'_> {
        fn drop(&mut self) {
            if std::thread::panicking() {
                self.0.store(true, Ordering::Relaxed);
            }
        }
    }
    let stop = || cancel.load(Ordering::Relaxed) || failed.load(Ordering::Relaxed);
    // Each worker returns its exact accumulator (empty if it drained nothing). Committed chunks
    // are always drained, even after a cancel, so the union is exactly the committed prefix.
    let worker = || {
        let _guard = OnPanic(&failed);
        let mut acc: Vec<ChannelState> = Vec::new();
        let mut ready = Vec::new();
        loop {
            if stop() {
                break;
            }
            let c = next.fetch_add(1, Ordering::Relaxed);
            if c >= c1 {
                break;
            }
            let spare = {
                let mut g = commit.lock().expect("no panics while committing");
                while (c >= g.frontier + window || g.out >= cap) && !stop() {
                    g = turn.wait_timeout(g, Duration::from_millis(20)).expect("no panics").0;
                }
                if stop() {
                    break;
                }
                g.out += 1;
                g.spare.pop()
            };
            let mut tally = spare.unwrap_or_else(&make_tally);
            let range = c * CHUNK_PHOTONS..((c + 1) * CHUNK_PHOTONS).min(end);
            let photons = range.end - range.start;
            let ev = trace_chunk(isa, &kernel, seed, range, &mut tally, cancel, progress);
            let Some(events) = ev else { break }; // cancelled midway: the chunk is dropped
            {
                let mut g = commit.lock().expect("no panics while committing");
                g.pending.insert(c, (tally, photons, events));
                g.advance(&mut ready);
            }
            turn.notify_all();
            if ready.is_empty() {
                continue;
            }
            if acc.is_empty() {
                acc = layout.iter().map(ChannelState::new).collect();
            }
            for t in &mut ready {
                if t.drain_into(&mut acc).is_none() {
                    failed.store(true, Ordering::Relaxed);
                }
            }
            let mut g = commit.lock().expect("no panics while committing");
            g.out -= ready.len();
            g.spare.append(&mut ready);
            drop(g);
            turn.notify_all();
        }
        acc
    };
    let spawn = threads.min((c1 - c0) as usize).max(1);
    let accs: Vec<Vec<ChannelState>> = std::thread::scope(|s| {
        let handles: Vec<_> = (1..spawn).map(|_| s.spawn(worker)).collect();
        let mut accs = vec![worker()];
        accs.extend(handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))));
        accs
    });
    let g = commit.into_inner().expect("no panics while committing");
    if failed.load(Ordering::Relaxed) {
        return Err(Error::Invalid("a tally sum left the range of the exact accumulators".into()));
    }
    for acc in accs.iter().filter(|a| !a.is_empty()) {
        for (s, a) in g.state.channels.iter_mut().zip(acc) {
            s.merge(a);
        }
    }
    Ok(g.state.end < end)
}

/// A tally made by `make_tally` holding the (rounded) exact sums of `state`, ready for
/// normalisation.
pub fn finish<T: Tally>(state: &TallyState, make_tally: impl Fn() -> T) -> T {
    let mut t = make_tally();
    t.load_from(&state.channels, state.photons());
    t
}

/// Trace `cfg.photons` photons through `stack` into tallies made by `make_tally` (from photon
/// 0, see [`extend`]) and return the finished tally.
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
    let mut layout = Vec::new();
    make_tally().channels(&mut layout);
    let mut state = TallyState::new(layout, 0, 0)?;
    let cancelled = extend(stack, cfg, &mut state, &make_tally, cancel, progress)?;
    Ok(RunOutput { tally: finish(&state, &make_tally), photons: state.photons(), events: state.events, cancelled })
}
