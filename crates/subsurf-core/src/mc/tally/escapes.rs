//! [`Escapes`]: the escapes a [`super::TallySet`] has been told of but not yet binned.
//!
//! Binning an escape costs a square root for its radius and another for its polar-angle guess,
//! each followed by a conversion to an integer bin and a dependent load of that bin: a chain of
//! latencies that, paid one escape at a time inside the lane kernel's loop, stalls it. Buffered,
//! the radii and angle guesses of [`ESCAPES`] escapes are computed in one vectorised pass and the
//! scores are then added in the order the escapes arrived, so every bin's f64 sum sees the same
//! additions in the same order as unbuffered binning (the same bits). Scoring each accumulator
//! in a pass of its own over the buffer instead was not faster (`docs/architecture.md`, "Engine
//! speed measurements").

use crate::mc::packet::{Packet, Side};

/// Escapes buffered before they are binned.
pub const ESCAPES: usize = 64;

/// The buffered escapes, field by field (what [`super::TallySet`]'s histograms need of each).
#[derive(Clone, Debug, PartialEq)]
pub struct Escapes {
    /// Escapes buffered (the entries at `n` and beyond are stale but finite).
    pub n: usize,
    /// Exit point, mm.
    pub x: [f64; ESCAPES],
    pub y: [f64; ESCAPES],
    /// |cos θ| of the exit direction in the ambient medium (at most 1).
    pub mu: [f64; ESCAPES],
    /// Exit direction's x and y in the ambient medium (for the BRDF/BTDF's φ).
    pub ox: [f64; ESCAPES],
    pub oy: [f64; ESCAPES],
    /// Optical path, mm.
    pub path: [f64; ESCAPES],
    /// Weight.
    pub w: [f64; ESCAPES],
    /// Scattering order.
    pub order: [u32; ESCAPES],
    /// Whether the path had order 1 and no interface reflection.
    pub direct1: [bool; ESCAPES],
    /// Whether it left through the bottom.
    pub bottom: [bool; ESCAPES],
}

impl Default for Escapes {
    fn default() -> Self {
        let z = [0.0; ESCAPES];
        Escapes {
            n: 0,
            x: z,
            y: z,
            mu: z,
            ox: z,
            oy: z,
            path: z,
            w: z,
            order: [0; ESCAPES],
            direct1: [false; ESCAPES],
            bottom: [false; ESCAPES],
        }
    }
}

impl Escapes {
    /// Buffer an escape (see [`super::Tally::escape`]); returns whether the buffer is
    /// now full.
    #[inline(always)]
    pub fn push(&mut self, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) -> bool {
        let k = self.n;
        self.x[k] = p.pos[0];
        self.y[k] = p.pos[1];
        self.mu[k] = dir_out[2].abs().min(1.0);
        self.ox[k] = dir_out[0];
        self.oy[k] = dir_out[1];
        self.path[k] = p.path;
        self.w[k] = w;
        self.order[k] = p.order;
        self.direct1[k] = p.order == 1 && p.reflections == 0;
        self.bottom[k] = side == Side::Bottom;
        self.n = k + 1;
        self.n == ESCAPES
    }
}
