//! Per-pixel triangle lists for the camera rays: every triangle in front of the camera is
//! listed in the pixels that its projected bounding box (padded by 10⁻³ pixel) overlaps, so a
//! camera ray through a point of pixel k tests only pixel k's triangles instead of descending the
//! BVH. A ray through the image point (x, y) meets a triangle only at a point whose projection is
//! (x, y), inside the projected triangle and so inside its box: the closest of the listed
//! triangles by [`Accel`]'s own f64 test is the BVH's hit (two triangles at exactly the same t, as
//! at a shared edge, are the one case where which one comes back depends on the order).
//! Built per renderer in O(triangles + pairs); none (the BVH as before) when a triangle reaches
//! behind the camera's plane or the lists would exceed [`PixelLists::MAX_PAIRS_PER_PIXEL`] pairs
//! per pixel on average (large triangles seen whole, as a floor under the object).

use super::accel::{Accel, Hit};
use super::camera::Camera;
use super::math::{f32_below, length, madd, sub, V3};

/// Triangle indices (global, as in [`Accel::tris`]) per pixel, in compressed rows, each row in
/// increasing order of a lower bound on the distance from the camera to the triangle (`near`,
/// beside `ids`): once the closest hit so far lies no farther than the next triangle's bound, the
/// rest of the row cannot come closer (on a closed object the back surface's triangles are not
/// tested where the front one is hit).
pub struct PixelLists {
    start: Vec<u32>,
    ids: Vec<u32>,
    near: Vec<f32>,
}

impl PixelLists {
    /// The most listed (pixel, triangle) pairs per pixel, on average, before the lists are
    /// given up for the BVH (128 bytes a pixel beside the image's 96; the benchmark's 64² scenes
    /// list 5.4–7.3).
    pub const MAX_PAIRS_PER_PIXEL: usize = 16;

    /// The lists of `acc`'s triangles seen by `cam`; None where they cannot be built (above).
    pub fn new(cam: &Camera, acc: &Accel) -> Option<PixelLists> {
        let (w, h) = (cam.width, cam.height);
        let near = acc.extent * 1e-6;
        let mut boxes = Vec::with_capacity(acc.tris.len());
        let mut pairs = 0usize;
        for t in &acc.tris {
            let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
            for v in [t.v0, madd(t.v0, t.e1, 1.0), madd(t.v0, t.e2, 1.0)] {
                let (x, y) = cam.project(v, near)?;
                b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
            }
            let pad = 1e-3;
            let span = |lo: f64, hi: f64, n: usize| {
                let lo = (lo - pad).floor().max(0.0);
                let hi = (hi + pad).floor().min(n as f64 - 1.0);
                (lo <= hi).then_some((lo as usize, hi as usize))
            };
            let cells = span(b[0], b[2], w).zip(span(b[1], b[3], h));
            if let Some(((x0, x1), (y0, y1))) = cells {
                pairs += (x1 - x0 + 1) * (y1 - y0 + 1);
                if pairs > Self::MAX_PAIRS_PER_PIXEL * w * h {
                    return None;
                }
            }
            boxes.push(cells);
        }
        // Counting sort of the pairs by pixel.
        let mut start = vec![0u32; w * h + 1];
        for ((x0, x1), (y0, y1)) in boxes.iter().flatten() {
            for y in *y0..=*y1 {
                for x in *x0..=*x1 {
                    start[y * w + x + 1] += 1;
                }
            }
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill = start.clone();
        let mut ids = vec![0u32; pairs];
        for (i, cells) in boxes.iter().enumerate() {
            if let Some(((x0, x1), (y0, y1))) = cells {
                for y in *y0..=*y1 {
                    for x in *x0..=*x1 {
                        let k = y * w + x;
                        ids[fill[k] as usize] = i as u32;
                        fill[k] += 1;
                    }
                }
            }
        }
        // The distance from the camera to a triangle's nearest point is at least that to the
        // centre of its vertices less their farthest distance from it (rounded down to f32).
        let bound = |t: &super::accel::Tri| {
            let vs = [t.v0, madd(t.v0, t.e1, 1.0), madd(t.v0, t.e2, 1.0)];
            let c = [0, 1, 2].map(|a| (vs[0][a] + vs[1][a] + vs[2][a]) / 3.0);
            let r = vs.iter().map(|v| length(sub(*v, c))).fold(0.0, f64::max);
            f32_below(((length(sub(c, cam.position)) - r) * (1.0 - 1e-9)).max(0.0))
        };
        let bounds: Vec<f32> = acc.tris.iter().map(bound).collect();
        for k in 0..w * h {
            let row = &mut ids[start[k] as usize..start[k + 1] as usize];
            row.sort_by(|&a, &b| bounds[a as usize].total_cmp(&bounds[b as usize]).then(a.cmp(&b)));
        }
        let near = ids.iter().map(|&i| bounds[i as usize]).collect();
        Some(PixelLists { start, ids, near })
    }

    /// The closest hit of the ray from the camera's position `o` along `d` through a point of
    /// pixel `pixel` (row-major): [`Accel::intersect`]'s with no triangle skipped.
    pub fn intersect(&self, acc: &Accel, pixel: usize, o: V3, d: V3) -> Option<Hit> {
        let tmin = acc.extent * 1e-10;
        let mut best = None;
        let mut tbest = f64::INFINITY;
        let row = self.start[pixel] as usize..self.start[pixel + 1] as usize;
        for (&i, &near) in self.ids[row.clone()].iter().zip(&self.near[row]) {
            if near as f64 >= tbest {
                break;
            }
            if let Some((t, b1, b2)) = acc.test(i as usize, o, d, tmin, tbest) {
                tbest = t;
                best = Some((t, i, b1, b2));
            }
        }
        best.map(|(t, i, b1, b2)| acc.hit(o, d, t, i, b1, b2))
    }

    /// Whether no triangle is listed in pixel `pixel`: no camera ray through it meets a surface.
    pub fn misses(&self, pixel: usize) -> bool {
        self.start[pixel] == self.start[pixel + 1]
    }

    /// Listed (pixel, triangle) pairs.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether no triangle is listed.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shapes::{icosphere, torus};

    /// Through random points of every pixel, the lists give the BVH's hit: the same triangle
    /// and distance (or the same distance where two triangles tie, at an edge), and none where
    /// it has none; the image covers the objects partly, so both cases occur.
    #[test]
    fn pixel_lists_give_the_bvh_hit() {
        let a = torus([0.0, 0.0, 0.0], 4.0, 1.5, 40, 20).unwrap();
        let b = icosphere([3.0, 1.0, 5.0], 1.2, 2).unwrap();
        let acc = Accel::new(&[&a, &b]);
        let cam = Camera::new([2.0, -14.0, 9.0], [0.5, 0.0, 1.0], [0.0, 0.0, 1.0], 40.0, 48, 32).unwrap();
        let lists = PixelLists::new(&cam, &acc).expect("every triangle in front");
        assert!(lists.len() >= acc.tris.len() / 2, "{} pairs", lists.len());
        let mut rng = crate::rng::PhotonRng::new(9, 0);
        let (mut hits, mut misses) = (0, 0);
        for k in 0..cam.width * cam.height {
            for _ in 0..4 {
                let (x, y) = ((k % cam.width) as f64 + rng.uniform(), (k / cam.width) as f64 + rng.uniform());
                let d = cam.ray(x, y);
                let want = acc.intersect(cam.position, d, f64::INFINITY, u32::MAX);
                let got = lists.intersect(&acc, k, cam.position, d);
                match (want, got) {
                    (None, None) => misses += 1,
                    (Some(w), Some(g)) => {
                        hits += 1;
                        assert!(
                            w.tri == g.tri || w.t == g.t,
                            "pixel {k}: {} at {} against {} at {}",
                            g.tri,
                            g.t,
                            w.tri,
                            w.t
                        );
                    }
                    (w, g) => panic!("pixel {k} ({x}, {y}): BVH {:?}, lists {:?}", w.map(|h| h.t), g.map(|h| h.t)),
                }
            }
        }
        assert!(hits > 500 && misses > 500, "{hits} hits, {misses} misses");
    }

    /// The projection inverts the camera's rays, and a triangle reaching behind the camera's
    /// plane leaves the camera rays to the BVH.
    #[test]
    fn projection_inverts_the_rays_and_behind_gives_none() {
        let cam = Camera::new([0.0, -10.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 50.0, 64, 48).unwrap();
        for (x, y) in [(0.5, 0.5), (63.2, 1.7), (31.0, 40.9)] {
            let p = madd(cam.position, cam.ray(x, y), 7.3);
            let (px, py) = cam.project(p, 0.0).unwrap();
            assert!((px - x).abs() < 1e-9 && (py - y).abs() < 1e-9, "({x}, {y}) -> ({px}, {py})");
        }
        let around = icosphere([0.0, -10.0, 0.0], 1.0, 1).unwrap(); // contains the camera
        assert!(PixelLists::new(&cam, &Accel::new(&[&around])).is_none());
    }
}
