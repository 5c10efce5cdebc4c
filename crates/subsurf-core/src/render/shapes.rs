//! Built-in shapes as closed (or, for the plane, open) triangle meshes, counter-clockwise seen
//! from outside: icosphere, axis-aligned box, rectangle (plane) and torus.

use super::math::{add, box_corners, normalize, scale, V3};
use super::mesh::{Mesh, MAX_COORDINATE};
use crate::error::{Error, Result};

/// Most subdivisions of an icosphere (20·4⁸ = 1.3 million triangles).
pub const MAX_SUBDIVISIONS: u32 = 8;
/// The allowed range of the icosphere's subdivisions, as errors state it.
pub const SUBDIVISIONS_ALLOWED: &str = "an integer in [0, 8]";
use std::collections::HashMap;
use std::f64::consts::PI;

/// An icosphere: the icosahedron subdivided `level` times (20·4^level triangles), vertices
/// projected onto the sphere of `radius` (mm) about `center`.
pub fn icosphere(center: V3, radius: f64, level: u32) -> Result<Mesh> {
    if !(1e-100..=MAX_COORDINATE).contains(&radius) {
        return Err(Error::param("radius", radius, "a number in [1e-100, 1e15] (mm)"));
    }
    if level > MAX_SUBDIVISIONS {
        return Err(Error::param_int("subdivisions", level as i128, SUBDIVISIONS_ALLOWED));
    }
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<V3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .into_iter()
    .map(normalize)
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut cache: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<V3>| -> u32 {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(normalize(scale(add(v[a as usize], v[b as usize]), 0.5)));
                (v.len() - 1) as u32
            })
        };
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    let p = v.into_iter().map(|x| add(center, scale(x, radius))).collect();
    Mesh::new("sphere", p, f, None)
}

/// An axis-aligned box from corner `lo` to corner `hi` (mm), 12 triangles.
pub fn cuboid(lo: V3, hi: V3) -> Result<Mesh> {
    if let Some(k) = (0..3).find(|&k| !(hi[k] > lo[k])) {
        return Err(Error::Invalid(format!("hi[{k}] = {:?}: every coordinate of hi must exceed lo's", hi[k])));
    }
    let p = box_corners(lo, hi).to_vec();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let mut t = Vec::new();
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    Mesh::new("box", p, t, None)
}

/// A rectangle of size `sx` × `sy` (mm) in the plane z = `z`, centred on (cx, cy), normal +z.
pub fn rectangle(cx: f64, cy: f64, z: f64, sx: f64, sy: f64) -> Result<Mesh> {
    for (k, s) in [sx, sy].into_iter().enumerate() {
        if !(s > 0.0) {
            return Err(Error::param(format!("size[{k}]"), s, "a number > 0 (mm)"));
        }
    }
    let (hx, hy) = (sx / 2.0, sy / 2.0);
    let p = vec![[cx - hx, cy - hy, z], [cx + hx, cy - hy, z], [cx + hx, cy + hy, z], [cx - hx, cy + hy, z]];
    Mesh::new("plane", p, vec![[0, 1, 2], [0, 2, 3]], None)
}

/// A torus about the z axis through `center`: major radius `r_major`, tube radius `r_minor`
/// (mm), `nu` × `nv` quads.
pub fn torus(center: V3, r_major: f64, r_minor: f64, nu: u32, nv: u32) -> Result<Mesh> {
    if !(r_minor > 0.0) {
        return Err(Error::param("minor", r_minor, "a number > 0 (mm)"));
    }
    if !(r_major > r_minor) {
        return Err(Error::param("major", r_major, "a number > minor (mm)"));
    }
    if nu < 3 || nv < 3 || nu > 1 << 12 || nv > 1 << 12 {
        return Err(Error::Invalid(format!("torus: nu = {nu}, nv = {nv}: each must be in [3, 4096]")));
    }
    let mut p = Vec::with_capacity((nu * nv) as usize);
    for i in 0..nu {
        let u = 2.0 * PI * i as f64 / nu as f64;
        for j in 0..nv {
            let w = 2.0 * PI * j as f64 / nv as f64;
            let r = r_major + r_minor * w.cos();
            p.push(add(center, [r * u.cos(), r * u.sin(), r_minor * w.sin()]));
        }
    }
    let id = |i: u32, j: u32| (i % nu) * nv + (j % nv);
    let mut t = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            t.push([a, b, c]);
            t.push([a, c, d]);
        }
    }
    Mesh::new("torus", p, t, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_are_closed_with_the_right_volume() {
        let s = icosphere([1.0, 2.0, 3.0], 2.0, 5).unwrap();
        assert!(s.closed && s.triangles.len() == 20 * 4usize.pow(5));
        let v = 4.0 / 3.0 * PI * 8.0;
        assert!((s.volume() / v - 1.0).abs() < 2e-3, "{}", s.volume() / v);
        let b = cuboid([0.0; 3], [1.0, 2.0, 3.0]).unwrap();
        assert!(b.closed && (b.volume() - 6.0).abs() < 1e-12 && (b.total_area() - 22.0).abs() < 1e-12);
        let t = torus([0.0; 3], 3.0, 1.0, 64, 32).unwrap();
        assert!(t.closed && (t.volume() / (2.0 * PI * PI * 3.0) - 1.0).abs() < 1e-2);
        let r = rectangle(0.0, 0.0, 1.0, 2.0, 3.0).unwrap();
        assert!(!r.closed && (r.total_area() - 6.0).abs() < 1e-12);
    }

    /// Sizes that overflow or vanish are refused, never a panic.
    #[test]
    fn extreme_sizes_are_errors() {
        for r in [f64::INFINITY, 1e300, 1e-300, f64::NAN] {
            assert!(icosphere([0.0; 3], r, 2).is_err(), "radius {r}");
        }
        assert!(rectangle(0.0, 0.0, 0.0, 1e300, 1e300).is_err());
        assert!(cuboid([0.0; 3], [1e20, 1.0, 1.0]).unwrap_err().to_string().contains("[-1e15, 1e15]"));
    }
}
