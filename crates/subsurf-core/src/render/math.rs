//! Small vector helpers on `[f64; 3]` (mm for points, unit vectors for directions) and the
//! orthonormal frame of Duff et al. (2017), "Building an orthonormal basis, revisited", JCGT 6(1).

/// A point (mm) or a direction.
pub type V3 = [f64; 3];
/// One value per colour channel (R, G, B).
pub type Rgb = [f64; 3];

/// The 8 corners of the box `lo`–`hi`: corner i takes hi along axis k where bit k of i is set.
pub fn box_corners(lo: V3, hi: V3) -> [V3; 8] {
    std::array::from_fn(|i| std::array::from_fn(|k| if i >> k & 1 == 0 { lo[k] } else { hi[k] }))
}

#[inline(always)]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline(always)]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline(always)]
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// a + s·b.
#[inline(always)]
pub fn madd(a: V3, b: V3, s: f64) -> V3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}
#[inline(always)]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline(always)]
pub fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
#[inline(always)]
pub fn length(a: V3) -> f64 {
    dot(a, a).sqrt()
}
/// a/|a| (a must be non-zero).
#[inline(always)]
pub fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / length(a))
}
/// The unit vector along `a` for any finite non-zero `a` (scaled by its largest component
/// first, so 1e300 or 1e-300 components neither overflow nor vanish); `None` otherwise.
pub fn unit(a: V3) -> Option<V3> {
    let m = a.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    (m > 0.0 && a.iter().all(|c| c.is_finite())).then(|| normalize(scale(a, 1.0 / m)))
}
/// The largest f32 not above `x` (a bound stored in f32 that stays a lower bound).
pub fn f32_below(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) > x {
        y.next_down()
    } else {
        y
    }
}
/// The smallest f32 not below `x` (a bound stored in f32 that stays an upper bound).
pub fn f32_above(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) < x {
        y.next_up()
    } else {
        y
    }
}
#[inline(always)]
pub fn neg(a: V3) -> V3 {
    [-a[0], -a[1], -a[2]]
}
/// Component-wise product of two RGB triples.
#[inline(always)]
pub fn mul(a: Rgb, b: Rgb) -> Rgb {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}
/// Mean of the three channels.
#[inline(always)]
pub fn mean(a: Rgb) -> f64 {
    (a[0] + a[1] + a[2]) / 3.0
}
/// Largest channel.
#[inline(always)]
pub fn max3(a: Rgb) -> f64 {
    a[0].max(a[1]).max(a[2])
}

/// An orthonormal frame (t, b, n) around the unit vector n.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: V3,
    pub b: V3,
    pub n: V3,
}

impl Frame {
    /// The frame of Duff et al. (2017), listing 3 (branch-free, continuous except at n_z = −0).
    pub fn new(n: V3) -> Frame {
        let sign = 1.0f64.copysign(n[2]);
        let a = -1.0 / (sign + n[2]);
        let b = n[0] * n[1] * a;
        Frame { t: [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]], b: [b, sign + n[1] * n[1] * a, -n[1]], n }
    }
    /// Local (x, y, z) → world.
    #[inline]
    pub fn to_world(&self, v: V3) -> V3 {
        add(add(scale(self.t, v[0]), scale(self.b, v[1])), scale(self.n, v[2]))
    }
    /// World → local coordinates.
    #[inline]
    pub fn to_local(&self, v: V3) -> V3 {
        [dot(v, self.t), dot(v, self.b), dot(v, self.n)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], normalize([0.3, -0.7, 0.1]), normalize([-1.0, 2.0, -3.0])] {
            let f = Frame::new(n);
            for (a, b) in [(f.t, f.b), (f.b, f.n), (f.n, f.t)] {
                assert!(dot(a, b).abs() < 1e-14);
            }
            for a in [f.t, f.b, f.n] {
                assert!((length(a) - 1.0).abs() < 1e-14);
            }
            let v = [0.2, -0.4, 0.5];
            let w = f.to_local(f.to_world(v));
            assert!(length(sub(v, w)) < 1e-14);
        }
    }
}
