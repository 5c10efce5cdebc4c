//! Monte Carlo photon-packet transport in layered media (Prahl et al. 1989; MCML, Wang,
//! Jacques & Zheng 1995; Hanrahan & Krueger 1993 §4).
//!
//! Coordinates: mm; z points *into* the stack (z = 0 is the top surface, light arrives from
//! z < 0), as in MCML. The kernel calls a [`tally::Tally`] (static dispatch) at each event.

pub mod packet;
pub mod tally;

pub use packet::{Packet, Side};
pub use tally::Tally;
