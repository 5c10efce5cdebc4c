//! Surface textures: colour (reflectance) and mean-free-path maps on a mesh with texture
//! coordinates. A textured material is a palette of homogeneous materials, one per distinct
//! texel (σa, σs per channel; the binding's caller inverts each texel's reflectance at its mean
//! free path with `bssrdf::inverse`, the core's `material_from_reflectance`), sharing the
//! material's g, η and profile model; the texel at a surface point selects one:
//! - the random walk: the texel where a walk enters the object sets the medium of that walk
//!   (σs, σt, so free paths, boundary transmittances and next-event estimation through the
//!   boundary, `facet_nee`, are the texel's), as production renderers do (Cycles, Arnold: the
//!   albedo and radius textures at the entry point set the random walk's medium for that path).
//!   The texel rides on the walk's media stack ([`super::walk::Media`]), so a connection line
//!   from a collision sees the same medium;
//! - the BSSRDF methods (`hierarchical`, `probe`): the texel at the shading point x_o sets the
//!   profile R_d (and S⁽¹⁾), as pbrt's `SubsurfaceMaterial` and Cycles' BSSRDF evaluate their
//!   textures at the shading point.
//!
//! Profiles per texel cost nothing extra in most maps: a homogeneous semi-infinite medium's R_d
//! depends on the albedo α = σs/σt (with g, η) and scales with the length 1/σt exactly,
//! R_d(r; σt) = σt² R_d(σt r; σt = 1), so one profile of unit σt is built per distinct albedo
//! (an 8-bit colour map has at most 256 per channel) and each texel's is that one scaled
//! ([`Scaled`]); every profile model but `adaptive` (whose tables depend on geometry in mm)
//! has this property.
//!
//! Lookup: the nearest texel at (u, v) (repeat wrap; v = 0 is the image's bottom row, as OBJ and
//! glTF's flipped rows), so a texel's coefficients are exactly its inversion.

use super::accel::Hit;
use super::material::{Profiles, Translucent};
use super::math::{cross, dot, sub, Rgb, V3};
use super::scene::Scene;
use crate::bssrdf::RadialProfile;
use crate::error::{Error, Result};
use crate::medium::{Layer, Stack};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// A surface map as given: per texel σa, σs (mm⁻¹) and, for `normalized_diffusion`, the
/// reflectance (per incident power) it was inverted from; rows from the image's top.
#[derive(Clone, Debug)]
pub struct TextureSpec {
    pub width: usize,
    pub height: usize,
    pub sigma_a: Vec<Rgb>,
    pub sigma_s: Vec<Rgb>,
    pub reflectance: Option<Vec<Rgb>>,
}

/// A profile of unit σt: (albedo in steps of 1/`ALBEDO_STEPS`, reflectance bits or 0).
pub type UnitKey = (u64, u64);

/// Steps per unit albedo of a unit-profile key (2⁴⁴).
const ALBEDO_STEPS: f64 = 17_592_186_044_416.0;

impl TextureSpec {
    /// Validate. `field` names the texture in errors; every texel needs σa, σs finite and ≥ 0
    /// and σt = σa + σs > 0 in each channel (a finite mean free path), a reflectance in [0, 1].
    pub fn new(
        field: &str,
        width: usize,
        height: usize,
        sigma_a: Vec<Rgb>,
        sigma_s: Vec<Rgb>,
        reflectance: Option<Vec<Rgb>>,
    ) -> Result<TextureSpec> {
        let n = width.checked_mul(height);
        let lens = [Some(sigma_a.len()), Some(sigma_s.len()), reflectance.as_ref().map(Vec::len)];
        if width == 0 || height == 0 || lens.iter().flatten().any(|&l| Some(l) != n) {
            return Err(Error::Invalid(format!(
                "{field}: {} texels given for a {width} × {height} image (at least 1 × 1)",
                sigma_s.len()
            )));
        }
        let at = |name: &str, i: usize, k: usize| format!("{field}.{name}[{}, {}, {k}]", i / width, i % width);
        for i in 0..sigma_a.len() {
            for k in 0..3 {
                for (name, v) in [("sigma_a", sigma_a[i][k]), ("sigma_s", sigma_s[i][k])] {
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(Error::param(at(name, i, k), v, "finite and >= 0 (mm^-1)"));
                    }
                }
                if !(sigma_a[i][k] + sigma_s[i][k] > 0.0) {
                    return Err(Error::param(at("sigma_t", i, k), 0.0, "> 0 (a finite mean free path)"));
                }
                if let Some(r) = reflectance.as_ref().map(|r| r[i][k]) {
                    if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
                        return Err(Error::param(at("reflectance", i, k), r, "in [0, 1]"));
                    }
                }
            }
        }
        Ok(TextureSpec { width, height, sigma_a, sigma_s, reflectance })
    }

    /// The distinct texels (first-appearance order) and each texel's index among them.
    fn distinct(&self) -> (Vec<usize>, Vec<u32>) {
        let mut seen: HashMap<[u64; 9], u32> = HashMap::new();
        let (mut first, mut index) = (vec![], Vec::with_capacity(self.sigma_a.len()));
        for i in 0..self.sigma_a.len() {
            let r = self.reflectance.as_ref().map_or([0.0; 3], |r| r[i]);
            let key: [u64; 9] = std::array::from_fn(|j| [self.sigma_a[i], self.sigma_s[i], r][j / 3][j % 3].to_bits());
            let next = first.len() as u32;
            let id = *seen.entry(key).or_insert_with(|| {
                first.push(i);
                next
            });
            index.push(id);
        }
        (first, index)
    }

    /// The unit-σt profile key of texel `i`, channel `k` (`by_reflectance`: the profile also
    /// depends on the texel's reflectance, as `normalized_diffusion` made from one does).
    fn unit_key(&self, i: usize, k: usize, by_reflectance: bool) -> UnitKey {
        let (a, s) = (self.sigma_a[i][k], self.sigma_s[i][k]);
        let r = self.reflectance.as_ref().filter(|_| by_reflectance).map_or(0, |r| r[i][k].to_bits());
        // The albedo on a grid of 2⁻⁴⁴ (6·10⁻¹⁴): texels of one reflectance at different mean free
        // paths (σa, σs scaled) differ in the last bits of σs/σt and must share their profile.
        (((s / (a + s)) * ALBEDO_STEPS).round() as u64, r)
    }

    /// The albedo of a unit-profile key.
    pub fn key_albedo(key: UnitKey) -> f64 {
        key.0 as f64 / ALBEDO_STEPS
    }

    /// The distinct unit-σt profiles the BSSRDF methods need (sorted): one per distinct
    /// albedo (and reflectance, `by_reflectance`) over the texels and channels.
    pub fn unit_keys(&self, by_reflectance: bool) -> Vec<UnitKey> {
        let keys: std::collections::BTreeSet<UnitKey> = (0..self.sigma_a.len())
            .flat_map(|i| (0..3).map(move |k| (i, k)))
            .map(|(i, k)| self.unit_key(i, k, by_reflectance))
            .collect();
        keys.into_iter().collect()
    }
}

/// The unit-σt profile of albedo α (and reflectance, when the model's profile takes one): the
/// builder [`SurfaceTexture::build`] is given (`material::unit_profiles`).
pub type UnitProfiles = BTreeMap<UnitKey, Arc<dyn RadialProfile>>;

/// A profile of unit σt scaled to σt = `s` (mm⁻¹): R_d(r) = s² R_d,1(s r) (same total,
/// cdf(r) = cdf₁(s r), radii / s), exact for a homogeneous semi-infinite medium.
pub struct Scaled {
    pub unit: Arc<dyn RadialProfile>,
    pub s: f64,
}

impl RadialProfile for Scaled {
    fn rd(&self, r: f64) -> f64 {
        self.s * self.s * self.unit.rd(self.s * r)
    }
    fn total(&self) -> f64 {
        self.unit.total()
    }
    fn cdf(&self, r: f64) -> f64 {
        self.unit.cdf(self.s * r)
    }
    fn sample_r(&self, u: f64) -> f64 {
        self.unit.sample_r(u) / self.s
    }
    fn radius_for_fraction(&self, q: f64) -> f64 {
        self.unit.radius_for_fraction(q) / self.s
    }
}

/// A built surface map: the palette of texel materials and each texel's entry, rows from the top.
pub struct SurfaceTexture {
    pub width: usize,
    pub height: usize,
    index: Vec<u32>,
    palette: Vec<Translucent>,
    /// The unit-σt profiles (empty without profiles) and, per palette entry and channel, its
    /// unit profile's index and σt (its profile is that one scaled).
    units: Vec<Arc<dyn RadialProfile>>,
    scales: Vec<[(u32, f64); 3]>,
}

impl SurfaceTexture {
    /// The palette of `spec` over the material `base` (g, η, phase, model and S⁽¹⁾ setting are
    /// the material's): each distinct texel a homogeneous [`Translucent`], with its profiles
    /// scaled from `units` (keys from [`TextureSpec::unit_keys`] with `by_reflectance`) when
    /// given (the BSSRDF methods).
    pub fn build(
        field: &str,
        spec: &TextureSpec,
        base: &Translucent,
        units: Option<(&UnitProfiles, bool)>,
    ) -> Result<SurfaceTexture> {
        let (first, index) = spec.distinct();
        let mut palette = Vec::with_capacity(first.len());
        let unit_list: Vec<Arc<dyn RadialProfile>> = units.map_or(vec![], |(u, _)| u.values().cloned().collect());
        let unit_index: HashMap<UnitKey, u32> =
            units.map_or(HashMap::new(), |(u, _)| u.keys().enumerate().map(|(j, k)| (*k, j as u32)).collect());
        let mut scales = vec![];
        for &i in &first {
            let (sa, ss) = (spec.sigma_a[i], spec.sigma_s[i]);
            let mut m = base.clone();
            m.sigma_a = sa;
            m.sigma_s = ss;
            m.sigma_t = std::array::from_fn(|k| sa[k] + ss[k]);
            m.sigma_bar = m.sigma_t;
            m.stacks = std::array::from_fn(|k| {
                let layer = Layer::new(base.eta, sa[k], ss[k], base.g, f64::INFINITY).expect("validated");
                Stack::new(vec![layer], 1.0, 1.0).expect("a one-layer stack is valid")
            });
            m.texture = None;
            m.grid = None;
            m.adaptive = None;
            m.bssrdf = match units {
                None => None,
                Some((_, by_r)) => {
                    let mut sc = [(0, 0.0); 3];
                    let p: Vec<Arc<dyn RadialProfile>> = (0..3)
                        .map(|k| -> Result<Arc<dyn RadialProfile>> {
                            let j = *unit_index.get(&spec.unit_key(i, k, by_r)).ok_or_else(|| {
                                Error::Invalid(format!("{field}: no profile for texel {i}, channel {k}"))
                            })?;
                            sc[k] = (j, m.sigma_t[k]);
                            Ok(Arc::new(Scaled { unit: unit_list[j as usize].clone(), s: m.sigma_t[k] }))
                        })
                        .collect::<Result<_>>()?;
                    scales.push(sc);
                    let profiles: Profiles = [p[0].clone(), p[1].clone(), p[2].clone()];
                    Some(profiles)
                }
            };
            palette.push(m);
        }
        Ok(SurfaceTexture { width: spec.width, height: spec.height, index, palette, units: unit_list, scales })
    }

    /// Per channel, the least and the largest radius (mm) holding a fraction `q` of a texel
    /// profile's energy over the palette (profiles of total 0 left out; each unit profile's
    /// radius found once, divided by each texel's σt); `None` without profiles.
    pub fn radius_range(&self, q: f64) -> Option<(Rgb, Rgb)> {
        if self.units.is_empty() {
            return None;
        }
        let r: Vec<f64> =
            self.units.iter().map(|u| if u.total() > 0.0 { u.radius_for_fraction(q) } else { f64::NAN }).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [0.0f64; 3]);
        for e in &self.scales {
            for k in 0..3 {
                let x = r[e[k].0 as usize] / e[k].1;
                if x.is_finite() {
                    lo[k] = lo[k].min(x);
                    hi[k] = hi[k].max(x);
                }
            }
        }
        Some((lo, hi))
    }

    /// The palette entry at texture coordinates (u, v): the nearest texel, repeat wrap.
    pub fn texel(&self, uv: [f64; 2]) -> usize {
        let wrap = |x: f64| if x.is_finite() { x - x.floor() } else { 0.0 };
        let (u, v) = (wrap(uv[0]), wrap(uv[1]));
        let col = ((u * self.width as f64) as usize).min(self.width - 1);
        let row = (((1.0 - v) * self.height as f64) as usize).min(self.height - 1);
        self.index[row * self.width + col] as usize
    }

    /// The material of palette entry `i`.
    #[inline]
    pub fn medium(&self, i: usize) -> &Translucent {
        &self.palette[i]
    }

    /// Every texel material (each distinct texel once).
    pub fn media(&self) -> &[Translucent] {
        &self.palette
    }
}

/// The palette entry of the textured material of the object on triangle `tri` (global index)
/// at the point `p` of it; `None` if that object's material has no texture.
pub fn texel_at(scene: &Scene, tri: u32, p: V3) -> Option<u32> {
    let tr = scene.accel.tris.get(tri as usize)?;
    let o = tr.object as usize;
    let tex = scene.material(o).translucent()?.texture.as_deref()?;
    let (b1, b2) = barycentrics(tr.e1, tr.e2, sub(p, tr.v0));
    Some(tex.texel(scene.objects[o].mesh.uv_at(tr.local as usize, b1, b2)) as u32)
}

/// The material at the surface point of `hit` on a translucent object: its texel's for a
/// textured material (the BSSRDF methods' shading point), else the object's material.
pub fn shading_medium<'a>(scene: &'a Scene, hit: &Hit) -> Option<&'a Translucent> {
    let m = scene.material(hit.object).translucent()?;
    let Some(tex) = m.texture.as_deref() else { return Some(m) };
    let local = scene.accel.tris[hit.tri as usize].local as usize;
    Some(tex.medium(tex.texel(scene.objects[hit.object].mesh.uv_at(local, hit.b1, hit.b2))))
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
    use crate::bssrdf::{medium_profile, Medium, Model};

    fn base() -> Translucent {
        Translucent::new("m", [0.1; 3], [1.0; 3], 0.0, 1.3, None, false).unwrap()
    }

    #[test]
    fn nearest_texel_with_repeat_and_flipped_rows() {
        // 2 × 2: top row (v > 1/2) σs 1, 2; bottom row 3, 4 (channel 0); σa 1.
        let ss = vec![[1.0; 3], [2.0; 3], [3.0; 3], [4.0; 3]];
        let spec = TextureSpec::new("t", 2, 2, vec![[1.0; 3]; 4], ss, None).unwrap();
        let t = SurfaceTexture::build("t", &spec, &base(), None).unwrap();
        let s = |uv| t.medium(t.texel(uv)).sigma_s[0];
        assert_eq!((s([0.25, 0.75]), s([0.75, 0.75]), s([0.25, 0.25]), s([1.75, -0.75])), (1.0, 2.0, 3.0, 4.0));
        assert_eq!(t.medium(t.texel([0.25, 0.25])).sigma_t, [4.0; 3]);
        let e = |sa: Rgb, ss: Rgb| TextureSpec::new("tex", 1, 1, vec![sa], vec![ss], None).unwrap_err().to_string();
        let msg = e([0.0; 3], [-1.0, 0.0, 0.0]);
        assert!(msg.contains("tex.sigma_s[0, 0, 0] = -1") && msg.contains(">= 0"), "{msg}");
        let msg = e([0.0, 1.0, 1.0], [0.0, 1.0, 1.0]);
        assert!(msg.contains("tex.sigma_t[0, 0, 0]") && msg.contains("> 0"), "{msg}");
        assert!(TextureSpec::new("t", 2, 1, vec![[1.0; 3]], vec![[1.0; 3]], None).is_err());
    }

    /// Equal texels share one palette entry; the albedos give the unit-profile keys.
    #[test]
    fn palette_and_unit_keys() {
        let sa = vec![[0.1, 0.2, 0.1], [0.2, 0.4, 0.2], [0.1, 0.2, 0.1]];
        let ss = vec![[1.0, 2.0, 1.0], [2.0, 4.0, 2.0], [1.0, 2.0, 1.0]];
        let spec = TextureSpec::new("t", 3, 1, sa, ss, None).unwrap();
        let t = SurfaceTexture::build("t", &spec, &base(), None).unwrap();
        assert_eq!(t.media().len(), 2);
        // Every texel and channel has the albedo 1/1.1: one unit profile serves all, also at mean
        // free paths scaled by awkward factors (σs/σt then differs in the last bits).
        assert_eq!(spec.unit_keys(false).len(), 1);
        let c = [1.0, 0.3, 7.1, 1.0 / 3.0, 1e-3];
        let sa = c.iter().map(|&c| [0.1 * c, 0.2 * c, 0.3 * c]).collect();
        let ss = c.iter().map(|&c| [1.0 * c, 2.0 * c, 3.0 * c]).collect();
        let spec = TextureSpec::new("t", 5, 1, sa, ss, None).unwrap();
        assert_eq!(spec.unit_keys(false).len(), 1);
        assert!((TextureSpec::key_albedo(spec.unit_keys(false)[0]) - 1.0 / 1.1).abs() < 1e-13);
    }

    /// A scaled unit profile is the profile at σt: R_d(r; σt) = σt² R_d(σt r; 1).
    #[test]
    fn scaled_unit_profile_is_the_profile() {
        let (sa, ss) = (0.03, 2.5);
        let st = sa + ss;
        for model in [Model::Dipole, Model::BetterDipole] {
            let exact = medium_profile(model, &Medium::new(sa, ss, 0.2, 1.4).unwrap()).unwrap();
            let unit = medium_profile(model, &Medium::new(sa / st, ss / st, 0.2, 1.4).unwrap()).unwrap();
            let sc = Scaled { unit: Arc::from(unit), s: st };
            for r in [1e-3, 0.05, 0.4, 2.0, 9.0] {
                assert!((sc.rd(r) / exact.rd(r) - 1.0).abs() < 1e-9, "{model:?} r {r}");
                assert!((sc.cdf(r) - exact.cdf(r)).abs() < 1e-9);
            }
            assert!((sc.total() - exact.total()).abs() < 1e-12);
            let (a, b) = (sc.radius_for_fraction(0.5), exact.radius_for_fraction(0.5));
            assert!((a / b - 1.0).abs() < 1e-6, "{a} {b}");
        }
    }

    #[test]
    fn barycentrics_invert_the_triangle() {
        let (e1, e2) = ([2.0, 0.0, 0.0], [0.5, 3.0, 1.0]);
        let w = [2.0 * 0.3 + 0.5 * 0.6, 3.0 * 0.6, 0.6];
        let (b1, b2) = barycentrics(e1, e2, w);
        assert!((b1 - 0.3).abs() < 1e-14 && (b2 - 0.6).abs() < 1e-14);
    }
}
