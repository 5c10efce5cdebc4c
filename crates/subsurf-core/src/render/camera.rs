//! The pinhole camera.

use super::math::{cross, dot, length, normalize, sub, V3};
use super::mesh::MAX_COORDINATE;
use super::primary::PixelLists;
use crate::error::{Error, Result};

/// Largest image width or height, pixels.
pub const MAX_RESOLUTION: usize = 1 << 15;
/// The allowed range of the width and height, as errors state it.
pub const RESOLUTION_ALLOWED: &str = "an integer in [1, 32768] (pixels)";
/// Bytes per pixel while rendering: the accumulator, one pass's sums, the mean image and the
/// caller's copy of it, 3 × f64 each, and at most the camera rays' per-pixel triangle lists
/// ([`PixelLists`]: a u32 row start and up to [`PixelLists::MAX_PAIRS_PER_PIXEL`] pairs of a u32 id
/// and an f32 distance bound).
pub const BYTES_PER_PIXEL: u64 = 4 * 3 * 8 + 4 * (1 + 2 * PixelLists::MAX_PAIRS_PER_PIXEL as u64);

/// A pinhole camera at `position` looking at `look_at`, `fov_deg` the vertical field of view.
#[derive(Clone, Debug)]
pub struct Camera {
    pub position: V3,
    pub width: usize,
    pub height: usize,
    /// Right, up and forward unit vectors.
    right: V3,
    up: V3,
    forward: V3,
    /// tan(fov/2).
    tan_half: f64,
}

impl Camera {
    /// Validate and build. Errors: non-finite vectors, `look_at` = `position`, `up` parallel to
    /// the view direction, fov outside (0, 180) degrees, a zero or huge resolution.
    pub fn new(position: V3, look_at: V3, up: V3, fov_deg: f64, width: usize, height: usize) -> Result<Camera> {
        for (name, v) in [("camera.position", position), ("camera.look_at", look_at), ("camera.up", up)] {
            if let Some(c) = v.iter().find(|c| !(c.abs() <= MAX_COORDINATE)) {
                return Err(Error::param(name, *c, "coordinates in [-1e15, 1e15] (mm)"));
            }
        }
        let f = sub(look_at, position);
        if !(length(f) > 0.0) {
            return Err(Error::Invalid("camera.look_at: must differ from camera.position".into()));
        }
        let forward = normalize(f);
        let r = cross(forward, up);
        if !(length(r) > 1e-9 * length(up)) || length(up) == 0.0 {
            return Err(Error::Invalid("camera.up: must be non-zero and not parallel to the view direction".into()));
        }
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(Error::param("camera.fov", fov_deg, "in (0, 180) degrees"));
        }
        for (name, n) in [("camera.width", width), ("camera.height", height)] {
            if n == 0 || n > MAX_RESOLUTION {
                return Err(Error::param_int(name, n as i128, RESOLUTION_ALLOWED));
            }
        }
        let right = normalize(r);
        let upv = cross(right, forward);
        Ok(Camera { position, width, height, right, up: upv, forward, tan_half: (fov_deg.to_radians() / 2.0).tan() })
    }

    /// Refuse an image whose buffers ([`BYTES_PER_PIXEL`]) exceed `available` bytes (default:
    /// the memory available now), before anything is allocated.
    pub fn check_memory(&self, available: Option<u64>) -> Result<()> {
        let need = (self.width * self.height) as u64 * BYTES_PER_PIXEL;
        let Some(have) = available.or_else(crate::mc::run::available_memory) else { return Ok(()) };
        if need <= have {
            return Ok(());
        }
        Err(Error::Invalid(format!(
            "camera: a {} × {} image needs about {:.3} GB of memory while rendering ({BYTES_PER_PIXEL} bytes per \
             pixel) but {:.3} GB is available: lower camera.width and camera.height",
            self.width,
            self.height,
            need as f64 / 1e9,
            have as f64 / 1e9
        )))
    }

    /// Unit direction through the image point (x, y) in pixels (x right, y down; pixel centres
    /// at k + 0.5).
    pub fn ray(&self, x: f64, y: f64) -> V3 {
        let aspect = self.width as f64 / self.height as f64;
        let sx = (2.0 * x / self.width as f64 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * y / self.height as f64) * self.tan_half;
        let d = [
            self.forward[0] + sx * self.right[0] + sy * self.up[0],
            self.forward[1] + sx * self.right[1] + sy * self.up[1],
            self.forward[2] + sx * self.right[2] + sy * self.up[2],
        ];
        normalize(d)
    }

    /// The image point (x, y) in pixels of [`Camera::ray`] through which `p` is seen: the
    /// inverse of `ray`. None when `p` is less than `near` (mm) in front of the camera's plane.
    pub fn project(&self, p: V3, near: f64) -> Option<(f64, f64)> {
        let q = sub(p, self.position);
        let z = dot(q, self.forward);
        if !(z > near) {
            return None;
        }
        let aspect = self.width as f64 / self.height as f64;
        let (sx, sy) = (dot(q, self.right) / z, dot(q, self.up) / z);
        let x = (sx / (self.tan_half * aspect) + 1.0) * 0.5 * self.width as f64;
        let y = (1.0 - sy / self.tan_half) * 0.5 * self.height as f64;
        Some((x, y))
    }

    /// The viewing direction.
    pub fn forward(&self) -> V3 {
        self.forward
    }

    /// Cosine between the viewing direction and `d`.
    pub fn cos_to(&self, d: V3) -> f64 {
        dot(self.forward, d)
    }
}
