//! Phases 1 and 2 of the lane step (see `super`): stepping, interaction and scattering, and
//! Fresnel at interfaces; and the f32 scattering samplers they inline.

use super::*;

/// 1 − cos θ from a Henyey–Greenstein lobe, in f32, by inverting its CDF (MCML eq. 3.28:
/// cos θ = (1 + g² − t²)/(2g), t = (1 − g²)/(1 − g + 2gξ)) in the cancellation-free form
/// 1 − cos θ = (t² − (1 − g)²)/(2g) = (1 − g)(1 − ξ)(t + 1 − g)/(1 − g + 2gξ)
/// (t − (1 − g) = 2g(1 − g)(1 − ξ)/(1 − g + 2gξ)), which keeps its relative precision as
/// θ → 0 (so does sin²θ = m(2 − m) computed from it: the forward peak at g = 0.9) and needs
/// no 1/g (g = 0 gives 2(1 − ξ) exactly: isotropic scattering without a special case).
/// Constants `k` = 1 − g, 2g, 1 − g² (f32); the result is clamped to ≤ 2 (rounding).
#[inline(always)]
pub(in crate::mc::lanes) fn hg_one_minus_cos(k: [f32; 3], u: f32) -> f32 {
    let [omg, two_g, omg2] = k;
    let d = omg + two_g * u;
    let t = omg2 / d;
    (omg * (1.0 - u) * (t + omg) / d).min(2.0)
}

/// |ux|² + |uy|² below which [`spin_word`] uses the normal-incidence form (the transverse
/// part of an f32 direction keeps full relative precision down to here).
const POLE_T2: f32 = 1e-12;

/// MCML's direction update (Wang et al. 1995, eq. 3.30; [`crate::optics::spin`]) in f32 of
/// the direction (ux, uy, uz) by the polar angle given as m = 1 − cos θ and the azimuth
/// φ = 2πu of the 32-bit `word` ([`cos_sin_2pi_f32`]), with one square root and one division:
/// ρ² = ux² + uy² (not 1 − uz², which loses its relative precision as |uz| → 1),
/// q = sin θ/ρ, u′x = q (ux uz cos φ − uy sin φ) + ux cos θ, u′y = q (uy uz cos φ +
/// ux sin φ) + uy cos θ, u′z = −q cos φ ρ² + uz cos θ; for ρ² < [`POLE_T2`] the
/// normal-incidence form (sin θ cos φ, sin θ sin φ, ± cos θ). Then one Newton step towards
/// |u′| = 1, u′ ← u′ (3 − |u′|²)/2, so that f32 rounding does not random-walk |u| over a
/// long history (see "Precision" in the module docs of `mc::lanes`).
#[inline(always)]
pub(in crate::mc::lanes) fn spin_word(ux: f32, uy: f32, uz: f32, m: f32, word: u32) -> (f32, f32, f32) {
    let (cp, sp) = cos_sin_2pi_f32(word);
    let cth = 1.0 - m;
    let t2 = ux * ux + uy * uy;
    let normal = t2 < POLE_T2;
    let den = sel_f32(normal, 1.0, t2);
    let q = (m * (2.0 - m) / den).sqrt();
    let (a, b) = (q * cp, q * sp);
    let gx = a * ux * uz - b * uy + ux * cth;
    let gy = a * uy * uz + b * ux + uy * cth;
    let gz = neg(a) * t2 + uz * cth;
    let nz_normal = sel_f32(uz > 0.0, cth, neg(cth));
    let (nx, ny, nz) = (sel_f32(normal, a, gx), sel_f32(normal, b, gy), sel_f32(normal, nz_normal, gz));
    let k = 1.5 - 0.5 * (nx * nx + ny * ny + nz * nz);
    (nx * k, ny * k, nz * k)
}

/// The largest roulette word that survives: u = (r + ½)·2⁻³² ≤ 1/M ⇔ r ≤ 2³²/M − ½ (an
/// integer comparison, exact).
const SURVIVE_MAX: u32 = (4_294_967_296.0 / ROULETTE_M - 0.5) as u32;

/// Russian roulette of lane `i`, whose weight `st.w[i]` (after this step's absorption) fell
/// below its threshold, decided by a word drawn here from the lane's stream (only a step that
/// plays roulette draws it): it survives with probability 1/M with M times its weight, or
/// dies; the zero-mean control term (−(M − 1) w on survival, w on death) is returned for
/// `Tally::roulette`, with `st.w[i]` already updated. Returns (control term, survived).
#[inline(always)]
pub(super) fn roulette(st: &mut Lanes, i: usize) -> (f64, bool) {
    let w1 = st.w[i];
    let survive = draw(&mut st.s, i, true) <= SURVIVE_MAX;
    let (control, w) = if survive { (-(ROULETTE_M - 1.0) * w1, w1 * ROULETTE_M) } else { (w1, 0.0) };
    st.w[i] = w;
    (control, survive)
}

/// Phase 1a, a loop over the lanes in f32 only (so that LLVM vectorises it 16 wide, a whole
/// AVX-512 register of f32, where a loop that mixes in f64 runs 8 wide): for every lane,
/// whether it will use them or not, the fresh optical depth −ln ξ and the direction after a
/// scattering (1 − cos θ from the lane's Henyey–Greenstein lobe by [`hg_one_minus_cos`], or
/// `sc.one_minus_cos` when `MIXTURE`; azimuth from its word; MCML's update by
/// [`spin_word`]), into `sc.tau` and `sc.nx/ny/nz` for [`advance`]. (`MIXTURE` is a constant
/// so that the loop holds no branch: with a run-time flag, LLVM kept the loop scalar for
/// 128-bit vectors — SSE4.2 — judging the vector loop with its predicated load unprofitable.)
#[inline(always)]
pub(super) fn sample<const MIXTURE: bool>(st: &Lanes, sc: &mut Scratch) {
    for i in 0..L {
        sc.tau[i] = neg_ln_f32(open01_f32_fine(sc.words[0][i]));
        let m = if MIXTURE {
            sc.one_minus_cos[i]
        } else {
            let hg = &st.l.hg;
            hg_one_minus_cos([hg[0][i], hg[1][i], hg[2][i]], open01_f32(sc.words[1][i]))
        };
        (sc.nx[i], sc.ny[i], sc.nz[i]) = spin_word(st.ux[i], st.uy[i], st.uz[i], m, sc.words[2][i]);
    }
}

/// Phase 1b, one loop over the lanes: step every live lane to its interaction point or to the
/// interface ahead; a lane that stays inside its layer then interacts: absorption by weight,
/// scattering into the direction [`sample`] prepared, and roulette. Lanes that hit an
/// interface go to [`interfaces`]. (`pending`, whether the tally takes per-lane sums of the deposits,
/// `positions`, whether it takes each deposit with its position, and `tracks`, whether it reads the
/// lateral position and the path (`Tally::TRACKS`), are constant per run: their branches are hoisted; `CLEAR` is false when no layer is clear, which removes the clear-layer rules' masks
/// from the loop, and then the trapping limit is checked by [`fresnel`], at the interface hits
/// only, instead of at every step.)
#[inline(always)]
pub(super) fn advance<const CLEAR: bool>(
    st: &mut Lanes,
    sc: &mut Scratch,
    pending: bool,
    positions: bool,
    tracks: bool,
) {
    for i in 0..L {
        // Step.
        let live = on(st.live[i]);
        let (sigma_t, inv_sigma_t, z0, z1) = (st.l.sigma_t[i], st.l.inv_sigma_t[i], st.l.z0[i], st.l.z1[i]);
        let clear = CLEAR && sigma_t == 0.0;
        let need = live & (st.s_left[i] <= 0.0) & !clear;
        let fresh = sc.tau[i] as f64;
        let sl = sel(need, fresh, st.s_left[i]);
        let s = sl * inv_sigma_t;
        let (x, y, z) = (st.x[i], st.y[i], st.z[i]);
        let (ux, uy, uz) = (st.ux[i], st.uy[i], st.uz[i]);
        let (uxd, uyd, uzd) = (ux as f64, uy as f64, uz as f64);
        let zn = z + s * uzd;
        let crossed = clear | (zn > z1) | (zn < z0);
        // `mc::kernel`'s termination rules: down a semi-infinite clear layer the packet is
        // transmitted; an interface hit counts towards the trapping limit (parallel to the
        // faces of a clear layer it is trapped at once); after `CLEAR_HITS_STEPWISE` hits in a
        // finite clear layer its remaining bounces are sampled at once. All three are rare
        // and handled lane by lane.
        // (without clear layers only the trapping limit is left, which `fresnel` checks)
        let h1 = st.hits[i].wrapping_add(1);
        let clear_down = CLEAR && live & clear & (uz > 0.0) & (z1 == f64::INFINITY);
        let trapped =
            CLEAR && live & !clear_down & ((clear & (uz == 0.0)) | (crossed & (h1 > MAX_HITS_WITHOUT_INTERACTION)));
        let bounces =
            CLEAR && live & clear & !clear_down & !trapped & (h1 > CLEAR_HITS_STEPWISE) & (z1 < f64::INFINITY);
        let moving = live & !clear_down & !trapped & !bounces;
        let h = moving & crossed;
        // A lane that reaches an interface is moved onto it by `interfaces` (the distance
        // needs a division, which the common path does without).
        let stp = sel(moving & !h, s, 0.0);
        if tracks {
            st.x[i] = x + stp * uxd;
            st.y[i] = y + stp * uyd;
            st.path[i] += st.l.n[i] * stp;
        }
        st.z[i] = z + stp * uzd;
        st.s_left[i] = sel(moving & !h, 0.0, sl);
        if CLEAR {
            st.hits[i] = selu(h | bounces, h1, selu(moving, 0, st.hits[i]));
        } // (else `fresnel` counts the hits, and starts again after a scattering)
        sc.hit[i] = mk(h);
        let f = selq(clear_down, fate::CLEAR_DOWN, fate::MOVING);
        let f = selq(trapped, fate::TRAPPED, f);
        let f = selq(bounces, fate::BOUNCES, f);
        // Interaction.
        let it = moving & !h;
        let w0 = st.w[i];
        let w1 = w0 * st.l.keep_frac[i];
        let dw = w0 - w1;
        let absorbed_all = w1 <= 0.0;
        let scatter = it & !absorbed_all;
        let (nx, ny, nz) = (sc.nx[i], sc.ny[i], sc.nz[i]);
        st.ux[i] = sel_f32(scatter, nx, ux);
        st.uy[i] = sel_f32(scatter, ny, uy);
        st.uz[i] = sel_f32(scatter, nz, uz);
        st.order[i] = st.order[i].wrapping_add(scatter as u32);
        // Russian roulette below `ROULETTE_THRESHOLD` × the entering weight: rare (about once
        // a history), so it is played lane by lane in the scalar pass ([`roulette`]).
        let low = scatter & (w1 < st.w_min[i]);
        let dep = sel(it, dw, 0.0);
        if positions {
            sc.dep[i] = dep;
            sc.deposit[i] = mk(dep != 0.0);
        }
        if pending {
            st.absorbed[i] += dep;
        }
        st.w[i] = sel(it, w1, w0);
        let died = it & absorbed_all;
        sc.fate[i] = selq(died, fate::DIED, selq(low, fate::ROULETTE, f));
        sc.att[i] = mk(died | clear_down | trapped | bounces | low);
    }
}

/// The sign bit of a lane mask: [`interfaces`] adds it to `Scratch::att` (OR-ing all ones
/// there makes LLVM emit a masked store, which the next load cannot forward from).
const SIGN: u64 = 1 << 63;

/// Phase 2: Fresnel reflection or refraction of the lanes that hit an interface, in three
/// loops: [`fresnel`] (f64), [`draw_fresnel`] (the lanes' Fresnel words, u32 only) and
/// [`refract`]. (As one loop — f64, f32 and u32 lanes mixed, a xoshiro step inside — LLVM
/// vectorised it for 256- and 512-bit vectors but kept it scalar for 128-bit ones.) When at
/// most `few` lanes hit (the usual case in long histories, where one or two of 16 do), only
/// those lanes run the three phases' bodies, one after the other: the vector loops cost the
/// same whatever the number of hits (callgrind, case c, totals: avx2 −11 %, sse −12 %
/// instructions; `few` per instruction set in `run_lanes`'s entries).
#[inline(always)]
pub(super) fn interfaces<const MATCHED: bool, const TRAP: bool>(
    st: &mut Lanes,
    sc: &mut Scratch,
    last: u32,
    tracks: bool,
    few: u32,
) {
    let hit = lane_bits_full(&sc.hit);
    if hit.count_ones() <= few {
        // few lanes at an interface: theirs only, lane by lane (the same operations, so the
        // same bits; a lane without a hit would be left unchanged by the loops below)
        let mut rest = hit;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            fresnel_lane::<MATCHED, TRAP>(st, sc, tracks, i);
            if !MATCHED {
                sc.fword[i] = draw(&mut st.s, i, on(sc.need[i]));
            }
            refract_lane::<MATCHED>(st, sc, last, i);
        }
        return;
    }
    fresnel::<MATCHED, TRAP>(st, sc, tracks);
    if !MATCHED {
        draw_fresnel(st, sc);
    }
    refract::<MATCHED>(st, sc, last);
}

/// Phase 2a: move the lanes that hit an interface onto it, keeping the unused optical depth
/// (MCML's HitBoundary); Fresnel reflectance R and cos θt into `sc.fr`, `sc.cos_t` (as
/// `optics::fr_dielectric_cos_t`), and `sc.need` where a Fresnel word decides (0 < R < 1).
/// With `TRAP` (no clear layer: [`advance`] left it here) it first counts the hit and ends the
/// packet that exceeds `MAX_HITS_WITHOUT_INTERACTION` hits in a row (fate `TRAPPED`, not moved,
/// as `advance` does with clear layers); hits in a row are hits at the same scattering order
/// (`Lanes::hit_order`).
#[inline(always)]
fn fresnel<const MATCHED: bool, const TRAP: bool>(st: &mut Lanes, sc: &mut Scratch, tracks: bool) {
    for i in 0..L {
        fresnel_lane::<MATCHED, TRAP>(st, sc, tracks, i);
    }
}

#[inline(always)]
fn fresnel_lane<const MATCHED: bool, const TRAP: bool>(st: &mut Lanes, sc: &mut Scratch, tracks: bool, i: usize) {
    let l = &st.l;
    let mut h = on(sc.hit[i]);
    if TRAP {
        // (the count starts again at a hit after a scattering: the scattering order differs
        // from the one at the lane's last hit; an interaction that does not scatter ends the
        // history. `advance` then writes no counter at every step — on AVX2 LLVM made that
        // write a masked store.)
        let fresh = st.order[i] != st.hit_order[i];
        let h1 = selu(fresh, 1, st.hits[i].wrapping_add(1));
        let trapped = h & (h1 > MAX_HITS_WITHOUT_INTERACTION);
        st.hits[i] = selu(h, h1, st.hits[i]);
        st.hit_order[i] = selu(h, st.order[i], st.hit_order[i]);
        h &= !trapped;
        sc.hit[i] = mk(h);
        sc.fate[i] = selq(trapped, fate::TRAPPED, sc.fate[i]);
        sc.att[i] |= mk(trapped) & SIGN;
    }
    let uz = st.uz[i] as f64;
    let (ux, uy) = (st.ux[i] as f64, st.uy[i] as f64);
    let up = uz < 0.0;
    let zb = sel(up, l.z0[i], l.z1[i]);
    let db = (zb - st.z[i]) / uz;
    let d = sel(h, db, 0.0);
    if tracks {
        st.x[i] += d * ux;
        st.y[i] += d * uy;
        st.path[i] += l.n[i] * d;
    }
    st.z[i] = sel(h, zb, st.z[i]);
    st.s_left[i] -= d * l.sigma_t[i];
    if MATCHED {
        return; // every index equal: no reflection, no refraction, no draw
    }
    let n_t = sel(up, l.n_up[i], l.n_down[i]);
    let eta = sel(up, l.eta_up[i], l.eta_down[i]);
    let cc = sel(up, l.cc_up[i], l.cc_down[i]);
    let ni = l.n[i];
    let ci = uz.abs().min(1.0);
    // sin²θt = η²(1 − cos²θi)
    let st2 = eta * eta * (1.0 - ci * ci).max(0.0);
    let ct = (1.0 - st2).max(0.0).sqrt();
    let rs = (ni * ci - n_t * ct) / (ni * ci + n_t * ct);
    let rp = (n_t * ci - ni * ct) / (n_t * ci + ni * ct);
    let tir = (ci <= cc) | (st2 >= 1.0);
    let matched = ni == n_t;
    let rf = 0.5 * (rs * rs + rp * rp);
    let r = sel(matched, 0.0, rf);
    let r = sel(tir, 1.0, r);
    let cos_t = sel(matched, ci, ct);
    sc.fr[i] = r;
    sc.cos_t[i] = sel(tir, 0.0, cos_t);
    sc.need[i] = mk(h & (r > 0.0) & (r < 1.0));
}

/// Phase 2b: the Fresnel word of each lane where `sc.need` (its stream advances only there).
#[inline(always)]
fn draw_fresnel(st: &mut Lanes, sc: &mut Scratch) {
    for i in 0..L {
        sc.fword[i] = draw(&mut st.s, i, on(sc.need[i]));
    }
}

/// Phase 2c: reflection, refraction (the direction back to f32), layer changes and escapes.
#[inline(always)]
fn refract<const MATCHED: bool>(st: &mut Lanes, sc: &mut Scratch, last: u32) {
    for i in 0..L {
        refract_lane::<MATCHED>(st, sc, last, i);
    }
}

#[inline(always)]
fn refract_lane<const MATCHED: bool>(st: &mut Lanes, sc: &mut Scratch, last: u32, i: usize) {
    let l = &st.l;
    let h = on(sc.hit[i]);
    let uz = st.uz[i] as f64;
    let (ux, uy) = (st.ux[i] as f64, st.uy[i] as f64);
    let up = uz < 0.0;
    if MATCHED {
        let layer = st.layer[i];
        let out = (up & (layer == 0)) | (!up & (layer == last));
        let cross = h & !out;
        sc.ox[i] = ux;
        sc.oy[i] = uy;
        sc.oz[i] = uz;
        let (dn, upl) = (layer.wrapping_add(1), layer.wrapping_sub(1));
        st.layer[i] = selu(cross, selu(up, upl, dn), layer);
        let esc = selq(up, fate::ESCAPE_TOP, fate::ESCAPE_BOTTOM);
        sc.fate[i] = selq(h & out, esc, selq(cross, fate::CROSSED, sc.fate[i]));
        sc.att[i] |= mk(h) & SIGN;
        return;
    }
    let eta = sel(up, l.eta_up[i], l.eta_down[i]);
    let (r, cos_t, need) = (sc.fr[i], sc.cos_t[i], on(sc.need[i]));
    let u = u32_to_open01(sc.fword[i]);
    let transmit = (r <= 0.0) | (need & (u > r));
    let layer = st.layer[i];
    let out = transmit & ((up & (layer == 0)) | (!up & (layer == last)));
    let cross = h & transmit & !out;
    let refl = h & !transmit;
    let nz = sel(up, -cos_t, cos_t);
    let (ox, oy) = (ux * eta, uy * eta);
    sc.ox[i] = ox;
    sc.oy[i] = oy;
    sc.oz[i] = nz;
    // (back to f32: a refracted direction is (η ux, η uy, ±cos θt), unit to f64 rounding;
    // |uz| rounded up, see `to_f32_up`)
    st.ux[i] = sel_f32(cross, ox as f32, st.ux[i]);
    st.uy[i] = sel_f32(cross, oy as f32, st.uy[i]);
    let uz_new = sel_f32(refl, -st.uz[i], st.uz[i]);
    st.uz[i] = sel_f32(cross, to_f32_up(nz), uz_new);
    let (dn, upl) = (layer.wrapping_add(1), layer.wrapping_sub(1));
    let next = selu(up, upl, dn);
    st.layer[i] = selu(cross, next, layer);
    st.refl[i] = st.refl[i].wrapping_add(refl as u32);
    let esc = selq(up, fate::ESCAPE_TOP, fate::ESCAPE_BOTTOM);
    let f = selq(cross, fate::CROSSED, sc.fate[i]);
    sc.fate[i] = selq(h & out, esc, f);
    sc.att[i] |= mk(cross | (h & out)) & SIGN;
}
