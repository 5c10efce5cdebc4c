//! Monte Carlo photon-packet transport in layered media (Prahl et al. 1989; MCML, Wang,
//! Jacques & Zheng 1995; Hanrahan & Krueger 1993 §4).
//!
//! Coordinates: mm; z points *into* the stack (z = 0 is the top surface, light arrives from
//! z < 0), as in MCML. The kernel calls a [`tally::Tally`] (static dispatch) at each event.
//!
//! - [`config`]: [`RunConfig`] and the engine's constants (chunk size, roulette, threads);
//! - [`source`]: [`Source`] (pencil beam at any incidence, diffuse illumination);
//! - `kernel`: one photon history (MCML's hop–drop–spin–roulette) and its termination rules;
//! - [`cost`]: the expected length of a history, refusing stacks whose histories are endless;
//! - [`run`](mod@run): [`run()`](run::run) and [`extend`] (a photon range of a run, or the
//!   continuation of an interrupted one), parallel, reproducible, cancellable, memory-checked;
//! - [`state`]: [`TallyState`], the exact raw state of photons [start, end) of a run, mergeable in
//!   range order to the bits of a single run;
//! - [`tally`]: the [`Tally`] trait, [`tally::totals::Totals`] and the histograms.

pub mod config;
pub mod cost;
mod kernel;
pub mod lanes;
pub mod packet;
pub mod run;
pub mod source;
pub mod state;
pub mod tally;

#[cfg(test)]
mod validation_tests;

pub use config::RunConfig;
pub use kernel::{CLEAR_HITS_STEPWISE, MAX_HITS_WITHOUT_INTERACTION, STOP_POLL_STEPS};
pub use packet::{Packet, Side};
pub use run::{extend, finish, run, RunOutput};
pub use source::Source;
pub use state::{fingerprint, FlatState, TallyState};
pub use tally::Tally;
