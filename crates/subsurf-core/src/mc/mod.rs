//! Monte Carlo photon-packet transport in layered media (Prahl et al. 1989; MCML, Wang,
//! Jacques & Zheng 1995; Hanrahan & Krueger 1993 §4).
//!
//! Coordinates: mm; z points *into* the stack (z = 0 is the top surface, light arrives from
//! z < 0), as in MCML. The kernel calls a [`tally::Tally`] (static dispatch) at each event.
//!
//! - [`config`]: [`RunConfig`] and the engine's constants (chunk size, roulette);
//! - [`source`]: [`Source`] (pencil beam at any incidence, diffuse illumination);
//! - `kernel`: one photon history (MCML's hop–drop–spin–roulette);
//! - [`run`](mod@run): [`run()`](run::run), parallel, reproducible, cancellable;
//! - [`tally`]: the [`Tally`] trait and [`tally::totals::Totals`].

pub mod config;
mod kernel;
pub mod lanes;
pub mod packet;
pub mod run;
pub mod source;
pub mod tally;

#[cfg(test)]
mod validation_tests;

pub use config::RunConfig;
pub use packet::{Packet, Side};
pub use run::{run, RunOutput};
pub use source::Source;
pub use tally::Tally;
