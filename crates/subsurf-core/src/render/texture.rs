//! Surface textures for the random walk: a colour (reflectance) map on a mesh with texture
//! coordinates sets the medium seen by a walk that enters the object there, as production
//! renderers do (Cycles, Arnold: the albedo texture at the entry point sets the random walk's
//! albedo for that path).
//!
//! The texture holds σs per texel and channel (the binding's caller inverts each texel's
//! reflectance with `bssrdf::inverse`, the core's `material_from_reflectance`); σt is the
//! material's, the same for every texel (an extinction mean free path), so free paths,
//! boundary transmittances and the optical depths of next-event estimation are the material's,
//! and only the albedo σs/σt of a walk's collisions follows the texel. Lookup: the nearest texel
//! at (u, v) (repeat wrap; v = 0 is the image's bottom row, as OBJ and glTF's flipped rows),
//! so a texel's coefficients are exactly its inversion.

use super::accel::Hit;
use super::math::{cross, dot, sub, Rgb, V3};
use super::scene::Scene;
use super::walk::Media;
use crate::error::{Error, Result};

/// σs per texel (mm⁻¹), rows from the image's top.
#[derive(Clone, Debug)]
pub struct SurfaceTexture {
    pub width: usize,
    pub height: usize,
    sigma_s: Vec<Rgb>,
}

impl SurfaceTexture {
    /// Validate and build. `field` names the texture in errors; `sigma_s` row-major from the
    /// top row, each value in [0, σt] of its channel (`sigma_t`: the material's).
    pub fn new(field: &str, width: usize, height: usize, sigma_s: Vec<Rgb>, sigma_t: Rgb) -> Result<SurfaceTexture> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(sigma_s.len()) {
            return Err(Error::Invalid(format!(
                "{field}: {} texels given for a {width} × {height} image (at least 1 × 1)",
                sigma_s.len()
            )));
        }
        for (i, t) in sigma_s.iter().enumerate() {
            for k in 0..3 {
                if !(t[k].is_finite() && t[k] >= 0.0 && t[k] <= sigma_t[k]) {
                    return Err(Error::param(
                        format!("{field}.sigma_s[{}, {}, {k}]", i / width, i % width),
                        t[k],
                        "in [0, sigma_t] of the material (mm^-1)",
                    ));
                }
            }
        }
        Ok(SurfaceTexture { width, height, sigma_s })
    }

    /// σs at texture coordinates (u, v): the nearest texel, repeat wrap.
    pub fn at(&self, uv: [f64; 2]) -> Rgb {
        let wrap = |x: f64| if x.is_finite() { x - x.floor() } else { 0.0 };
        let (u, v) = (wrap(uv[0]), wrap(uv[1]));
        let col = ((u * self.width as f64) as usize).min(self.width - 1);
        let row = (((1.0 - v) * self.height as f64) as usize).min(self.height - 1);
        self.sigma_s[row * self.width + col]
    }
}

/// The texels a walk entered its textured objects at (object, σs), at most 8: the medium of a
/// textured object is the one of its entry point for the rest of the walk.
#[derive(Clone, Copy, Debug, Default)]
pub struct Texels {
    ids: [u32; 8],
    sigma_s: [Rgb; 8],
    len: usize,
}

impl Texels {
    /// The walk is at `p` on triangle `tri` (global index) having just entered the object on
    /// top of `media`: remember its texel if that object is textured.
    pub fn enter(&mut self, scene: &Scene, media: &Media, tri: u32, p: V3) {
        let Some(o) = media.top() else { return };
        let Some(tex) = scene.material(o).translucent().and_then(|m| m.texture.as_deref()) else { return };
        let Some(tr) = scene.accel.tris.get(tri as usize) else { return };
        if tr.object as usize != o {
            return;
        }
        let (b1, b2) = barycentrics(tr.e1, tr.e2, sub(p, tr.v0));
        let s = tex.at(scene.objects[o].mesh.uv_at(tr.local as usize, b1, b2));
        let i = self.ids[..self.len].iter().position(|&x| x as usize == o).unwrap_or(self.len.min(7));
        self.ids[i] = o as u32;
        self.sigma_s[i] = s;
        self.len = self.len.max(i + 1);
    }

    /// As [`enter`](Self::enter) for a boundary hit.
    pub fn enter_hit(&mut self, scene: &Scene, media: &Media, h: &Hit) {
        if media.top() == Some(h.object) {
            self.enter(scene, media, h.tri, h.p);
        }
    }

    /// σs of the texel the walk entered `object` at, if it is textured.
    #[inline]
    pub fn get(&self, object: Option<usize>) -> Option<&Rgb> {
        let o = object? as u32;
        (0..self.len).rev().find(|&i| self.ids[i] == o).map(|i| &self.sigma_s[i])
    }
}

/// (b1, b2) of the point v0 + w in the triangle's plane, edges e1 = v1 − v0, e2 = v2 − v0.
fn barycentrics(e1: V3, e2: V3, w: V3) -> (f64, f64) {
    let n = cross(e1, e2);
    let nn = dot(n, n);
    if !(nn > 0.0) {
        return (0.0, 0.0);
    }
    (dot(cross(w, e2), n) / nn, dot(cross(e1, w), n) / nn)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_texel_with_repeat_and_flipped_rows() {
        // 2 × 2: top row (v > 1/2) σs 1, 2; bottom row 3, 4 (channel 0).
        let t = SurfaceTexture::new("t", 2, 2, vec![[1.0; 3], [2.0; 3], [3.0; 3], [4.0; 3]], [5.0; 3]).unwrap();
        assert_eq!(t.at([0.25, 0.75])[0], 1.0);
        assert_eq!(t.at([0.75, 0.75])[0], 2.0);
        assert_eq!(t.at([0.25, 0.25])[0], 3.0);
        assert_eq!(t.at([1.75, -0.75])[0], 4.0);
        let e = SurfaceTexture::new("tex", 1, 1, vec![[6.0, 0.0, 0.0]], [5.0; 3]).unwrap_err().to_string();
        assert!(e.contains("tex.sigma_s[0, 0, 0] = 6") && e.contains("[0, sigma_t]"), "{e}");
        assert!(SurfaceTexture::new("t", 2, 1, vec![[1.0; 3]], [5.0; 3]).is_err());
    }

    #[test]
    fn barycentrics_invert_the_triangle() {
        let (e1, e2) = ([2.0, 0.0, 0.0], [0.5, 3.0, 1.0]);
        let w = [2.0 * 0.3 + 0.5 * 0.6, 3.0 * 0.6, 0.6];
        let (b1, b2) = barycentrics(e1, e2, w);
        assert!((b1 - 0.3).abs() < 1e-14 && (b2 - 0.6).abs() < 1e-14);
    }
}
