//! Triangle meshes: validation, closedness (watertightness), areas and the optional per-vertex
//! albedo tint.
//!
//! Positions are in mm, already transformed to world space (the Python layer applies each
//! object's transform). Triangles are counter-clockwise seen from outside, so the geometric
//! normal (v1 − v0) × (v2 − v0) points out; a closed mesh with negative signed volume is
//! re-oriented on construction.

use super::math::{cross, dot, length, sub, Rgb, V3};
use crate::error::{Error, Result};

/// Largest |coordinate| of a vertex, mm: the BVH's single-precision boxes, their surface areas
/// and the meshes' areas and volumes stay finite (a 1 000 km scene is 10⁹ mm).
pub const MAX_COORDINATE: f64 = 1e15;

/// A triangle mesh in world space.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// Vertex positions, mm.
    pub positions: Vec<V3>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Optional per-vertex albedo tint (each channel in [0, 1]) scaling the light that leaves
    /// a translucent surface there (the seed's "spatial texture").
    pub tint: Option<Vec<Rgb>>,
    /// Whether every edge is shared by exactly two triangles of opposite orientation.
    pub closed: bool,
    /// Number of edges not shared by exactly two triangles (0 when `closed`).
    pub open_edges: usize,
    /// Optional texture coordinates (u, v) of each triangle's three corners (a surface
    /// texture's lookup, [`super::texture`]).
    pub uv: Option<Vec<[[f64; 2]; 3]>>,
    /// Whether the triangles were re-oriented outwards (corners 1 and 2 swapped).
    reoriented: bool,
}

impl Mesh {
    /// Validate and build. `name` labels errors (e.g. `objects[2]`). Errors: no triangles, an
    /// index out of range, a non-finite coordinate, zero total area, a tint of the wrong length
    /// or outside [0, 1].
    pub fn new(name: &str, positions: Vec<V3>, mut triangles: Vec<[u32; 3]>, tint: Option<Vec<Rgb>>) -> Result<Mesh> {
        if triangles.is_empty() {
            return Err(Error::Invalid(format!("{name}: the mesh has no triangles")));
        }
        for (i, p) in positions.iter().enumerate() {
            if p.iter().any(|c| !c.is_finite()) {
                return Err(Error::Invalid(format!("{name}: vertex {i} has a non-finite coordinate {p:?}")));
            }
            if let Some(&c) = p.iter().find(|c| c.abs() > MAX_COORDINATE) {
                return Err(Error::param(format!("{name}: vertex {i} coordinate"), c, "in [-1e15, 1e15] (mm)"));
            }
        }
        let nv = positions.len();
        if let Some(t) = triangles.iter().find(|t| t.iter().any(|&k| k as usize >= nv)) {
            return Err(Error::Invalid(format!(
                "{name}: triangle {t:?} refers to a vertex >= {nv} (the vertex count)"
            )));
        }
        if let Some(tint) = &tint {
            if tint.len() != nv {
                return Err(Error::Invalid(format!(
                    "{name}: tint has {} entries, one per vertex ({nv}) needed",
                    tint.len()
                )));
            }
            if let Some(c) = tint.iter().flatten().find(|c| !(c.is_finite() && (0.0..=1.0).contains(*c))) {
                return Err(Error::param(format!("{name}.tint"), *c, "in [0, 1] per channel"));
            }
        }
        let area: f64 = triangles.iter().map(|t| tri_area(&positions, t)).sum();
        if !(area > 0.0 && area.is_finite()) {
            return Err(Error::param(format!("{name}: mesh area"), area, "> 0 (the mesh has zero area)"));
        }
        let open_edges = count_open_edges(&triangles);
        let closed = open_edges == 0;
        let reoriented = closed && signed_volume(&positions, &triangles) < 0.0;
        if reoriented {
            for t in triangles.iter_mut() {
                t.swap(1, 2);
            }
        }
        Ok(Mesh { positions, triangles, tint, closed, open_edges, uv: None, reoriented })
    }

    /// The mesh with texture coordinates `uv`: (u, v) of each triangle's corners, in the order
    /// given to [`Mesh::new`]. Errors (naming `name`): a count other than one per triangle, a
    /// non-finite coordinate.
    pub fn with_uv(mut self, name: &str, mut uv: Vec<[[f64; 2]; 3]>) -> Result<Mesh> {
        if uv.len() != self.triangles.len() {
            return Err(Error::Invalid(format!(
                "{name}.uv: {} triangles of texture coordinates, one per triangle ({}) needed",
                uv.len(),
                self.triangles.len()
            )));
        }
        if let Some(c) = uv.iter().flatten().flatten().find(|c| !c.is_finite()) {
            return Err(Error::param(format!("{name}.uv"), *c, "finite texture coordinates"));
        }
        if self.reoriented {
            for t in uv.iter_mut() {
                t.swap(1, 2);
            }
        }
        self.uv = Some(uv);
        Ok(self)
    }

    /// (u, v) at barycentric (b1, b2) of triangle `i` ((0, 0) without texture coordinates).
    pub fn uv_at(&self, i: usize, b1: f64, b2: f64) -> [f64; 2] {
        match &self.uv {
            None => [0.0; 2],
            Some(uv) => {
                let [a, b, c] = uv[i];
                let b0 = 1.0 - b1 - b2;
                std::array::from_fn(|k| b0 * a[k] + b1 * b[k] + b2 * c[k])
            }
        }
    }

    /// Vertices of triangle `i`.
    #[inline]
    pub fn vertices(&self, i: usize) -> [V3; 3] {
        let t = self.triangles[i];
        [self.positions[t[0] as usize], self.positions[t[1] as usize], self.positions[t[2] as usize]]
    }

    /// Area of triangle `i`, mm².
    pub fn area(&self, i: usize) -> f64 {
        tri_area(&self.positions, &self.triangles[i])
    }

    /// Total area, mm².
    pub fn total_area(&self) -> f64 {
        (0..self.triangles.len()).map(|i| self.area(i)).sum()
    }

    /// The tint at barycentric (b1, b2) of triangle `i` (1 without a tint).
    pub fn tint_at(&self, i: usize, b1: f64, b2: f64) -> Rgb {
        match &self.tint {
            None => [1.0; 3],
            Some(c) => {
                let t = self.triangles[i];
                let b0 = 1.0 - b1 - b2;
                std::array::from_fn(|k| b0 * c[t[0] as usize][k] + b1 * c[t[1] as usize][k] + b2 * c[t[2] as usize][k])
            }
        }
    }

    /// Signed volume (mm³): positive for a closed mesh oriented outwards.
    pub fn volume(&self) -> f64 {
        signed_volume(&self.positions, &self.triangles)
    }

    /// `Ok` if closed, else an error naming the object and the number of open edges.
    pub fn require_closed(&self, name: &str, why: &str) -> Result<()> {
        if self.closed {
            Ok(())
        } else {
            Err(Error::Invalid(format!(
                "{name}: the mesh is not watertight ({} edges are not shared by exactly two consistently \
                 oriented triangles); {why} needs a closed mesh (repair it, e.g. trimesh's fill_holes)",
                self.open_edges
            )))
        }
    }
}

fn tri_area(p: &[V3], t: &[u32; 3]) -> f64 {
    let [a, b, c] = [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]];
    0.5 * length(cross(sub(b, a), sub(c, a)))
}

fn signed_volume(p: &[V3], tris: &[[u32; 3]]) -> f64 {
    tris.iter().map(|t| dot(p[t[0] as usize], cross(p[t[1] as usize], p[t[2] as usize])) / 6.0).sum()
}

/// Edges (a, b) are counted with orientation: a closed, consistently oriented 2-manifold has
/// each directed edge once and its reverse once.
fn count_open_edges(tris: &[[u32; 3]]) -> usize {
    // The directed edges (a, b) as a << 32 | b, sorted (a sort instead of a hash map: about
    // 10x faster on the 81,920-triangle benchmark sphere); a directed edge is open unless it
    // occurs once and its reverse once.
    let mut directed: Vec<u64> =
        tris.iter().flat_map(|t| (0..3).map(move |k| (t[k] as u64) << 32 | t[(k + 1) % 3] as u64)).collect();
    directed.sort_unstable();
    let count = |e: u64| directed.partition_point(|&x| x <= e) - directed.partition_point(|&x| x < e);
    let mut open = 0;
    for run in directed.chunk_by(|a, b| a == b) {
        let e = run[0];
        if run.len() != 1 || count(e.rotate_right(32)) != 1 {
            open += 1;
        }
    }
    open
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn tetra() -> (Vec<V3>, Vec<[u32; 3]>) {
        (
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
    }

    #[test]
    fn closed_tetra_and_open_one() {
        let (p, t) = tetra();
        let m = Mesh::new("t", p.clone(), t.clone(), None).unwrap();
        assert!(m.closed && (m.volume() - 1.0 / 6.0).abs() < 1e-15);
        // Reversed winding is re-oriented outwards.
        let rev: Vec<[u32; 3]> = t.iter().map(|x| [x[0], x[2], x[1]]).collect();
        let m2 = Mesh::new("t", p.clone(), rev, None).unwrap();
        assert!(m2.closed && m2.volume() > 0.0);
        let m3 = Mesh::new("t", p.clone(), t[..3].to_vec(), None).unwrap();
        assert!(!m3.closed && m3.open_edges == 3);
        let e = m3.require_closed("objects[0]", "random_walk").unwrap_err().to_string();
        assert!(e.contains("objects[0]") && e.contains("not watertight"), "{e}");
    }

    #[test]
    fn bad_meshes_are_refused() {
        let (p, t) = tetra();
        assert!(Mesh::new("m", p.clone(), vec![], None).is_err());
        assert!(Mesh::new("m", p.clone(), vec![[0, 1, 9]], None).is_err());
        let flat = vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let e = Mesh::new("m", flat, vec![[0, 1, 2]], None).unwrap_err().to_string();
        assert!(e.contains("zero area"), "{e}");
        assert!(Mesh::new("m", p.clone(), t.clone(), Some(vec![[0.5; 3]; 3])).is_err());
        assert!(Mesh::new("m", p, t, Some(vec![[1.5; 3]; 4])).is_err());
    }
}
