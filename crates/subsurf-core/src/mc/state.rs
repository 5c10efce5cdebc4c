//! [`TallyState`]: the raw, exact state of a run of photons [start, end) — what a partial run
//! keeps so that it can be resumed, and what a cluster worker returns for its photon range.
//!
//! A result is a pure function of (stack, source, tallies, seed, photons): photons are traced in
//! fixed chunks of [`CHUNK_PHOTONS`] (chunk c = photons [c·4096, (c+1)·4096), cut at the run's
//! last photon), each chunk's sums are formed in f64 in a fixed order, and chunk sums are added
//! exactly (see [`crate::mc::tally::exact`]). So any split of [0, N) into ranges at chunk
//! boundaries, traced by any number of threads or workers and merged with
//! [`TallyState::append`], gives bit-identical states and hence bit-identical results.
//!
//! Rules: a range starts at a multiple of [`CHUNK_PHOTONS`]; it may end anywhere, but only a
//! state that ends at a multiple of [`CHUNK_PHOTONS`] can be continued (a run of N photons cuts
//! its last chunk at N). States merge only with states of the same configuration
//! ([`fingerprint`]) and layout, in range order (`a.end == b.start`).

use super::config::CHUNK_PHOTONS;
use super::source::Source;
use super::tally::exact::Fixed;
use super::tally::{Channel, ChannelState, TallyConfig};
use crate::error::{Error, Result};
use crate::medium::Stack;

/// Version of the exact-state format (chunk size, fixed-point formats, and the order in which
/// a photon draws its random words, since a resumed run must continue the same streams); states
/// of another scheme are refused. Scheme 3: the lane kernel draws a roulette word only in a
/// step that plays roulette (scheme 2 drew one in every step).
pub const SCHEME: &str =
    "subsurf-state-3: chunks of 4096 photons; S1 4x64-bit fixed point (2^-176), S2 5x64 (2^-240); \
                          S2 of histograms over batches of 256 photons; lane words: 3 per step, \
                          roulette word only when played";

/// The exact state of photons [`start`, `end`) of a run.
///
/// [`start`]: TallyState::start
/// [`end`]: TallyState::end
#[derive(Clone, Debug, PartialEq)]
pub struct TallyState {
    /// First photon index.
    pub start: u64,
    /// One past the last photon index.
    pub end: u64,
    /// Scattering events of these photons.
    pub events: u64,
    /// [`fingerprint`] of the run's configuration.
    pub fingerprint: u64,
    /// The channels (names and sizes) of the run's tallies.
    pub layout: Vec<Channel>,
    /// The exact sums, one per channel of `layout`.
    pub channels: Vec<ChannelState>,
}

impl TallyState {
    /// An empty state at photon `start` (a multiple of [`CHUNK_PHOTONS`]).
    pub fn new(layout: Vec<Channel>, fingerprint: u64, start: u64) -> Result<Self> {
        check_chunk_boundary("start", start)?;
        let channels = layout.iter().map(ChannelState::new).collect();
        Ok(TallyState { start, end: start, events: 0, fingerprint, layout, channels })
    }

    /// Photons held.
    pub fn photons(&self) -> u64 {
        self.end - self.start
    }

    /// Total number of bins over all channels.
    pub fn bins(&self) -> usize {
        self.layout.iter().map(|c| c.len).sum()
    }

    /// Check that `other` comes from the same configuration and tallies.
    pub fn check_compatible(&self, other_fingerprint: u64, other_layout: &[Channel]) -> Result<()> {
        if self.fingerprint != other_fingerprint {
            return Err(Error::Invalid(
                "state: it was computed for another configuration (stack, source, seed or tallies differ)".into(),
            ));
        }
        if self.layout != other_layout {
            return Err(Error::Invalid("state: its tallies differ from this run's".into()));
        }
        Ok(())
    }

    /// Append the state of the photon range that follows this one (`next.start == self.end`,
    /// at a chunk boundary). Exact: the result does not depend on how the range was split.
    pub fn append(&mut self, next: &TallyState) -> Result<()> {
        self.check_compatible(next.fingerprint, &next.layout)?;
        if next.start != self.end {
            return Err(Error::Invalid(format!(
                "state: photons [{}, {}) do not follow [{}, {}); merge states in range order",
                next.start, next.end, self.start, self.end
            )));
        }
        check_chunk_boundary("end of the state to continue", self.end)?;
        for (a, b) in self.channels.iter_mut().zip(&next.channels) {
            a.merge(b);
        }
        self.end = next.end;
        self.events += next.events;
        Ok(())
    }

    /// Flat arrays (for files and the network): see [`FlatState`].
    pub fn to_flat(&self) -> FlatState {
        let mut f = FlatState {
            scheme: SCHEME.to_string(),
            start: self.start,
            end: self.end,
            events: self.events,
            fingerprint: self.fingerprint,
            names: self.layout.iter().map(|c| c.name.clone()).collect(),
            lengths: self.layout.iter().map(|c| c.len as u64).collect(),
            extremes: self.layout.iter().map(|c| c.extremes).collect(),
            s1: Vec::with_capacity(4 * self.bins()),
            s2: Vec::with_capacity(5 * self.bins()),
            min: Vec::new(),
            max: Vec::new(),
        };
        for c in &self.channels {
            for v in &c.s1 {
                f.s1.extend_from_slice(&v.0);
            }
            for v in &c.s2 {
                f.s2.extend_from_slice(&v.0);
            }
            f.min.extend_from_slice(&c.min);
            f.max.extend_from_slice(&c.max);
        }
        f
    }

    /// The state of flat arrays made by [`TallyState::to_flat`] (checked for consistency).
    pub fn from_flat(f: &FlatState) -> Result<Self> {
        let bad = |what: &str| Error::Invalid(format!("state: {what}"));
        if f.scheme != SCHEME {
            return Err(bad(&format!(
                "format {:?} is not this version's ({SCHEME:?}): it was written by another engine \
                 version and cannot be resumed by this one (run it again from the start)",
                f.scheme
            )));
        }
        let n = f.names.len();
        if f.lengths.len() != n || f.extremes.len() != n {
            return Err(bad("names, lengths and extremes differ in length"));
        }
        if f.end < f.start {
            return Err(bad("end < start"));
        }
        check_chunk_boundary("start", f.start)?;
        let mut layout = Vec::with_capacity(n);
        for k in 0..n {
            let len = usize::try_from(f.lengths[k]).map_err(|_| bad("a channel length is too large"))?;
            layout.push(Channel { name: f.names[k].clone(), len, extremes: f.extremes[k] });
        }
        let bins: usize = layout.iter().map(|c| c.len).sum();
        let ext: usize = layout.iter().filter(|c| c.extremes).map(|c| c.len).sum();
        if f.s1.len() != 4 * bins || f.s2.len() != 5 * bins || f.min.len() != ext || f.max.len() != ext {
            return Err(bad("array sizes do not match the channel lengths"));
        }
        let (mut i1, mut i2, mut ie) = (0, 0, 0);
        let mut channels = Vec::with_capacity(n);
        for c in &layout {
            let mut s = ChannelState::new(c);
            for b in 0..c.len {
                s.s1[b] = Fixed(f.s1[i1 + 4 * b..i1 + 4 * b + 4].try_into().expect("4 limbs"));
                s.s2[b] = Fixed(f.s2[i2 + 5 * b..i2 + 5 * b + 5].try_into().expect("5 limbs"));
            }
            i1 += 4 * c.len;
            i2 += 5 * c.len;
            if c.extremes {
                s.min.copy_from_slice(&f.min[ie..ie + c.len]);
                s.max.copy_from_slice(&f.max[ie..ie + c.len]);
                ie += c.len;
            }
            channels.push(s);
        }
        Ok(TallyState { start: f.start, end: f.end, events: f.events, fingerprint: f.fingerprint, layout, channels })
    }
}

/// A [`TallyState`] as flat arrays: per channel (in order) its name, length and whether it
/// keeps extremes; `s1` holds 4 little-endian u64 limbs per bin (channels concatenated), `s2`
/// 5 limbs per bin, `min`/`max` one f64 per bin of the channels with extremes.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatState {
    /// [`SCHEME`] of the writer.
    pub scheme: String,
    /// First photon.
    pub start: u64,
    /// One past the last photon.
    pub end: u64,
    /// Scattering events.
    pub events: u64,
    /// [`fingerprint`] of the configuration.
    pub fingerprint: u64,
    /// Channel names.
    pub names: Vec<String>,
    /// Channel lengths (bins).
    pub lengths: Vec<u64>,
    /// Whether each channel keeps extremes.
    pub extremes: Vec<bool>,
    /// S₁ limbs.
    pub s1: Vec<u64>,
    /// S₂ limbs.
    pub s2: Vec<u64>,
    /// Per-photon minima of the channels with extremes.
    pub min: Vec<f64>,
    /// Per-photon maxima of the channels with extremes.
    pub max: Vec<f64>,
}

fn check_chunk_boundary(what: &str, photon: u64) -> Result<()> {
    if photon.is_multiple_of(CHUNK_PHOTONS) {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "state: {what} = photon {photon} is not a multiple of the chunk size {CHUNK_PHOTONS}: ranges of a run \
             start (and, to be continued, end) at chunk boundaries"
        )))
    }
}

/// FNV-1a hash of the words of a configuration.
struct Fnv(u64);

impl Fnv {
    fn word(&mut self, w: u64) {
        for b in w.to_le_bytes() {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01B3);
        }
    }
    fn num(&mut self, x: f64) {
        self.word(x.to_bits());
    }
}

/// A 64-bit fingerprint (FNV-1a) of everything a run's result depends on besides the photon
/// count: the stack, the source, the seed, the tally configuration and [`SCHEME`].
pub fn fingerprint(stack: &Stack, source: &Source, seed: u64, tallies: Option<&TallyConfig>) -> u64 {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    for b in SCHEME.bytes() {
        h.word(b as u64);
    }
    h.num(stack.n_above);
    h.num(stack.n_below);
    h.word(stack.layers.len() as u64);
    for l in &stack.layers {
        for x in [l.n, l.mua, l.mus, l.thickness] {
            h.num(x);
        }
        h.word(l.phase.lobes().len() as u64);
        for lobe in l.phase.lobes() {
            h.num(lobe.weight);
            h.num(lobe.g);
        }
    }
    match *source {
        Source::Pencil { theta, phi } => {
            h.word(1);
            h.num(theta);
            h.num(phi);
        }
        Source::Diffuse => h.word(2),
    }
    h.word(seed);
    match tallies {
        None => h.word(0),
        Some(c) => {
            // Exhaustive: a new field of TallyConfig does not compile until it is hashed here
            // (in this order, so that saved states keep their fingerprints).
            let TallyConfig { nr, dr, nz, dz, na, nt, dt, brdf, max_order, spatial, angular, errors } = *c;
            h.word(1);
            for n in [nr, nz, na, nt] {
                h.word(n as u64);
            }
            for x in [dr, dz, dt] {
                h.num(x);
            }
            let (nc, np) = brdf.unwrap_or((0, 0));
            h.word(brdf.is_some() as u64);
            h.word(nc as u64);
            h.word(np as u64);
            h.word(max_order.map_or(u64::MAX, |k| k as u64));
            h.word(spatial as u64);
            h.word(angular as u64);
            h.word(errors as u64);
        }
    }
    h.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> Vec<Channel> {
        vec![
            Channel { name: "a".into(), len: 2, extremes: true },
            Channel { name: "b".into(), len: 3, extremes: false },
        ]
    }

    #[test]
    fn flat_round_trip_and_append_rules() {
        let mut s = TallyState::new(layout(), 7, 0).unwrap();
        s.channels[0].add(1, 0.5, 0.25);
        s.channels[0].add_extremes(1, -1.0, 2.0);
        s.channels[1].add(2, -3.0, 9.0);
        s.end = 4096;
        s.events = 11;
        let f = s.to_flat();
        assert_eq!((f.s1.len(), f.s2.len(), f.min.len()), (20, 25, 2));
        assert_eq!(TallyState::from_flat(&f).unwrap(), s);
        let mut g = f.clone();
        // the previous scheme (a roulette word in every lane step) is refused: its streams differ
        g.scheme = SCHEME.replace("subsurf-state-3", "subsurf-state-2");
        let e = TallyState::from_flat(&g).unwrap_err().to_string();
        assert!(e.contains("format") && e.contains("cannot be resumed"), "{e}");
        g = f.clone();
        g.s2.pop();
        assert!(TallyState::from_flat(&g).is_err());
        // append in range order, at chunk boundaries, same configuration only
        let mut next = TallyState::new(layout(), 7, 4096).unwrap();
        next.end = 5000;
        next.events = 4;
        let mut a = s.clone();
        a.append(&next).unwrap();
        assert_eq!((a.start, a.end, a.events), (0, 5000, 15));
        let after = TallyState::new(layout(), 7, 8192).unwrap();
        assert!(a.append(&after).unwrap_err().to_string().contains("range order"));
        let mut b = s.clone();
        assert!(b.append(&TallyState::new(layout(), 8, 4096).unwrap()).is_err());
        assert!(TallyState::new(layout(), 7, 100).unwrap_err().to_string().contains("chunk"));
        let mut c = TallyState::new(layout(), 7, 0).unwrap();
        c.end = 100;
        let mut d = TallyState::new(layout(), 7, 0).unwrap();
        d.start = 100; // forged: not at a boundary
        d.end = 200;
        assert!(c.append(&d).unwrap_err().to_string().contains("chunk"));
    }

    #[test]
    fn fingerprint_tells_configurations_apart() {
        let s = Stack::new(vec![crate::medium::Layer::new(1.4, 0.1, 10.0, 0.9, 1.0).unwrap()], 1.0, 1.0).unwrap();
        let src = Source::default();
        let base = fingerprint(&s, &src, 1, None);
        assert_eq!(base, fingerprint(&s, &src, 1, None));
        assert_ne!(base, fingerprint(&s, &src, 2, None));
        assert_ne!(base, fingerprint(&s, &Source::Diffuse, 1, None));
        assert_ne!(base, fingerprint(&s, &src, 1, Some(&TallyConfig::default())));
        let mut s2 = s.clone();
        s2.layers[0].mus = 10.000000001;
        assert_ne!(base, fingerprint(&s2, &src, 1, None));
    }
}
