//! The photon packet: plain data, no allocation, so the kernel can later run as SIMD lanes or
//! GPU threads.

/// A photon packet's state as the tallies see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Packet {
    /// Position, mm. z = 0 is the top surface, z grows downwards into the stack.
    pub pos: [f64; 3],
    /// Unit propagation direction; `dir[2] > 0` moves deeper into the stack.
    pub dir: [f64; 3],
    /// Weight (1 at launch before specular reflection).
    pub w: f64,
    /// Index of the layer the packet is in.
    pub layer: usize,
    /// Number of scattering events so far (the Neumann-series order, seed eq. 1.21).
    pub order: u32,
    /// Number of reflections at interfaces (Fresnel or total internal) so far.
    pub reflections: u32,
    /// Optical path length Σ nᵢ ℓᵢ travelled inside the stack, mm (time = path / c).
    pub path: f64,
}

/// Which face of the stack a packet leaves through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Through z = 0 into the medium above (reflectance).
    Top,
    /// Through the bottom of a finite stack into the medium below (transmittance).
    Bottom,
}
