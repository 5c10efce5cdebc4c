"""Hanrahan–Krueger first-order model (subsurf.hk) against independent references.

References used here are written from scratch in this file (textbook Fresnel and HG formulas,
numpy Gauss–Legendre quadrature) and are parameterised differently from the library: the
library integrates over *outside* directions with radiance η² factors, the power-counting
references integrate over directions *inside* the scattering layer and count flux only.
"""

import math

import numpy as np
import pytest
import subsurf
from subsurf import Layer, ParameterError, Stack, hk


# ---------------------------------------------------------------- independent helpers
def fresnel_T(ci, n1, n2):
    """Unpolarised Fresnel transmittance (Born & Wolf 1.5.21), from cos θi in n1; 0 on TIR."""
    ci = np.asarray(ci, dtype=float)
    s2 = (n1 / n2) ** 2 * (1 - ci**2)
    ct = np.sqrt(np.clip(1 - s2, 0, None))
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
    rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct)
    return np.where(s2 < 1, 1 - 0.5 * (rs**2 + rp**2), 0.0)


def hg(cos, g):
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * cos) ** 1.5)


def sph(theta, phi, up=True):
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    z = np.cos(theta) if up else -np.cos(theta)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), z], axis=-1)


def random_dirs(rng, n, up=True):
    mu = rng.uniform(0.02, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    return sph(np.arccos(mu), phi, up)


def outside_hemisphere_integral(f, n_mu=200, n_phi=128, up=True):
    """∫ f(wo) |cos θo| dωo with Gauss–Legendre in μ and the midpoint rule in φ (numpy)."""
    x, w = np.polynomial.legendre.leggauss(n_mu)
    mu = 0.5 * (x + 1)
    wmu = 0.5 * w
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    M, P = np.meshgrid(mu, phi, indexing="ij")
    wo = sph(np.arccos(M), P, up)
    vals = f(wo)
    return float(np.sum(vals * M * wmu[:, None]) * 2 * np.pi / n_phi)


def power_count(stack, theta_i, j, transmission=False, n_mu=300, n_phi=200):
    """Flux singly scattered in layer j that leaves the stack (above, or below if
    ``transmission``), per unit incident flux, for incidence θi (φi = 0): integrate over the
    scattered direction *inside layer j*; T·A products along the refracted paths (Snell
    invariant k = n sin θ); depth integral by Gauss–Legendre. No radiance factors anywhere."""
    media = [stack.n_above] + [l.n for l in stack.layers] + [stack.n_below]
    L = len(stack.layers)
    m = j + 1
    k_in = media[0] * math.sin(theta_i)

    def mu_of(k, n):
        s2 = (k / n) ** 2
        return np.sqrt(np.clip(1 - s2, 0, None)), s2 < 1

    # incident flux reaching the top of layer j
    F = 1.0
    mu_prev = math.cos(theta_i)
    for q in range(1, m + 1):
        mq, ok = mu_of(k_in, media[q])
        if not ok:
            return 0.0
        F *= float(fresnel_T(mu_prev, media[q - 1], media[q]))
        if q < m:
            lay = stack.layers[q - 1]
            F *= math.exp(-(lay.mua + lay.mus) * lay.thickness / float(mq))
        mu_prev = float(mq)
    lay = stack.layers[j]
    mu_i = mu_prev
    st = lay.mua + lay.mus
    # scattered directions in layer j: μ' ∈ (0, 1] up (reflection) or down
    # only μ' > μc can escape (TIR at the lowest index crossed); μ' = μc + (1 − μc) v² makes the
    # √ edge of the Fresnel factor at μc smooth in v.
    crossed = media[:m] if not transmission else media[m + 1 :]
    s_max = min(1.0, min(crossed) / media[m])
    mu_c = math.sqrt(1 - s_max**2)
    x, w = np.polynomial.legendre.leggauss(n_mu)
    v = 0.5 * (x + 1)
    mu = mu_c + (1 - mu_c) * v**2
    wmu = 0.5 * w * 2 * (1 - mu_c) * v
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    M, P = np.meshgrid(mu, phi, indexing="ij")
    S = np.sqrt(1 - M**2)
    sin_i = k_in / media[m]
    zsign = -1.0 if transmission else 1.0
    cos = sin_i * S * np.cos(P) + (-mu_i) * (zsign * M)  # d_in = (sin_i, 0, −μi)
    g_w = [(wt, gg) for wt, gg in lay.lobes]
    p = sum(wt * hg(cos, gg) for wt, gg in g_w)
    k_out = media[m] * S
    # escape factor through the interfaces (and layers) on the way out
    esc = np.ones_like(M)
    q_range = range(m - 1, -1, -1) if not transmission else range(m + 1, L + 2)
    mu_cur = M.copy()
    n_cur = media[m]
    for q in q_range:
        mq, ok = mu_of(k_out, media[q])
        esc *= np.where(ok, fresnel_T(mu_cur, n_cur, media[q]), 0.0)
        if 1 <= q <= L:
            lq = stack.layers[q - 1]
            esc *= np.where(ok, np.exp(-(lq.mua + lq.mus) * lq.thickness / np.where(ok, mq, 1.0)), 0.0)
        mu_cur, n_cur = np.where(ok, mq, 1.0), media[q]
    # depth integral ∫₀^d σs/μi e^{−σt z/μi} e^{−σt (path out)/μ'} dz in closed form: with the path
    # out z (reflection) or d − z (transmission), ∫₀^d e^{−a z} dz = −expm1(−a d)/a (d at a = 0)
    d = lay.thickness
    if math.isinf(d):
        depth = lay.mus / mu_i / (st / mu_i + st / M)
    else:
        # transmission: e^{−σt d/μ'} ∫₀^d e^{−a z} dz with a = σt(1/μi − 1/μ') of either sign, written
        # as e^{−σt d/max(μi, μ')} ∫₀^d e^{−|a| z} dz (no overflow)
        a = st / mu_i - st / M if transmission else st / mu_i + st / M
        factor = np.exp(-st * d / np.maximum(mu_i, M)) if transmission else 1.0
        a = np.abs(a)
        small = a * d < 1e-12
        integral = np.where(small, d, -np.expm1(-a * d) / np.where(small, 1.0, a))
        depth = lay.mus / mu_i * integral * factor
    integrand = F * p * esc * depth
    return float(np.sum(integrand * wmu[:, None]) * 2 * np.pi / n_phi)


def stack1(n=1.0, mua=0.1, mus=2.0, g=0.0, d=math.inf, n_above=1.0, n_below=1.0):
    return Stack([Layer(n, mua, mus, g, d)], n_above, n_below)


STACK3 = Stack(
    [Layer(1.3, 0.2, 5.0, 0.5, 0.2), Layer(1.6, 0.05, 2.0, -0.3, 0.3), Layer(1.1, 0.01, 8.0, 0.9, 0.5)],
    n_above=1.2,
    n_below=1.4,
)


# ---------------------------------------------------------------- closed forms and limits
def test_index_matched_semi_infinite_albedo_closed_form():
    """∫ f cos θo dωo = (α/2)(1 − ln 2) at normal incidence, n = 1, isotropic, semi-infinite."""
    albedo = 0.999
    s = stack1(mua=1 - albedo, mus=albedo)
    exact = albedo / 2 * (1 - math.log(2))
    assert exact == pytest.approx(0.15327, abs=5e-6)
    numeric = outside_hemisphere_integral(lambda wo: hk.single_scattering_brdf(s, [0, 0, 1.0], wo))
    assert numeric == pytest.approx(exact, rel=1e-10)
    assert hk.single_scattering_reflectance(s, [0, 0, 1.0]) == pytest.approx(exact, rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize(
    "stack, theta_i",
    [
        (stack1(n=1.45, mua=0.1, mus=0.9, g=0.4), 0.6),  # semi-infinite, mismatched
        (stack1(n=1.33, mua=0.3, mus=3.0, g=-0.2, d=0.4, n_below=1.5), 1.1),  # finite slab
        (stack1(n=1.0, mua=0.3, mus=3.0, g=0.3, d=0.4, n_above=1.5), 0.5),  # glass above a lower index
        (STACK3, 0.4),
    ],
)
def test_albedo_equals_inside_power_count(stack, theta_i):
    """Outside-angle integral of f_r (with its η² factors) = flux count inside each layer."""
    wi = sph(theta_i, 0.0)
    ref_r = sum(power_count(stack, theta_i, j) for j in range(len(stack)))
    ref_t = sum(power_count(stack, theta_i, j, transmission=True) for j in range(len(stack)))
    rho = hk.single_scattering_reflectance(stack, wi, n_theta=128, n_phi=128)
    tau = hk.single_scattering_transmittance(stack, wi, n_theta=128, n_phi=128)
    assert rho == pytest.approx(ref_r, rel=1e-8)
    if math.isinf(stack.thickness):
        assert tau == 0.0
    else:
        assert tau == pytest.approx(ref_t, rel=1e-8)


@pytest.mark.parametrize("theta_i, d", [(0.0, 0.5), (0.7, 0.5), (1.2, 0.05), (0.3, 3.0)])
def test_isotropic_slab_escape_probability_closed_form(theta_i, d):
    """Index-matched isotropic slab (Chandrasekhar): a photon scattered at optical depth t escapes
    upwards with probability E2(t)/2 and downwards with E2(τ − t)/2, so
    ρ₁ = (α/2) ∫₀^τ e^{−t/μi} E2(t) dt/μi and τ₁ = (α/2) ∫₀^τ e^{−t/μi} E2(τ − t) dt/μi."""
    from scipy.integrate import quad
    from scipy.special import expn

    albedo, st = 0.9, 2.0
    s = stack1(mua=st * (1 - albedo), mus=st * albedo, d=d)
    tau, mu = st * d, math.cos(theta_i)
    up = quad(lambda t: math.exp(-t / mu) / mu * expn(2, t), 0, tau, epsabs=0, epsrel=1e-12, limit=200)[0]
    dn = quad(lambda t: math.exp(-t / mu) / mu * expn(2, tau - t), 0, tau, epsabs=0, epsrel=1e-12, limit=200)[0]
    wi = sph(theta_i, 0.4)
    rho = hk.single_scattering_reflectance(s, wi, n_theta=256, n_phi=8)
    trans = hk.single_scattering_transmittance(s, wi, n_theta=256, n_phi=8)
    assert rho == pytest.approx(albedo / 2 * up, rel=1e-7)
    assert trans == pytest.approx(albedo / 2 * dn, rel=1e-7)


def test_thin_layer_limit(rng):
    """f ≈ σs d p (n0/n)² T_in T_out / (μi μo) to first order in d (reflection and transmission)."""
    n0, n, nb, g, d = 1.0, 1.4, 1.2, 0.6, 1e-5
    s = stack1(n=n, mua=0.5, mus=4.0, g=g, d=d, n_above=n0, n_below=nb)
    wi = random_dirs(rng, 50)
    wo = random_dirs(rng, 50)
    wt = random_dirs(rng, 50, up=False)
    mu0i, mu0o, mu0t = wi[:, 2], wo[:, 2], -wt[:, 2]
    sin_i = n0 * np.hypot(wi[:, 0], wi[:, 1]) / n
    mui = np.sqrt(1 - sin_i**2)
    d_in = np.stack([-n0 * wi[:, 0] / n, -n0 * wi[:, 1] / n, -mui], -1)
    # reflection
    muo = np.sqrt(1 - (n0 * np.hypot(wo[:, 0], wo[:, 1]) / n) ** 2)
    d_out = np.stack([n0 * wo[:, 0] / n, n0 * wo[:, 1] / n, muo], -1)
    p = hg(np.sum(d_in * d_out, -1), g)
    thin = 4.0 * d * p * (n0 / n) ** 2 * fresnel_T(mu0i, n0, n) * fresnel_T(mu0o, n0, n) / (mui * muo)
    f = hk.single_scattering_brdf(s, wi, wo)
    x = 4.5 * d * (1 / mui + 1 / muo)
    assert np.all(np.abs(f / thin - 1) <= x)
    assert np.all(np.abs(f / thin - 1) > 0.2 * x)  # the O(d) correction is really there
    # transmission
    muo = np.sqrt(1 - (nb * np.hypot(wt[:, 0], wt[:, 1]) / n) ** 2)
    d_out = np.stack([nb * wt[:, 0] / n, nb * wt[:, 1] / n, -muo], -1)
    p = hg(np.sum(d_in * d_out, -1), g)
    thin = 4.0 * d * p * (nb / n) ** 2 * fresnel_T(mu0i, n0, n) * fresnel_T(mu0t, nb, n) / (mui * muo)
    f = hk.single_scattering_btdf(s, wi, wt)
    x = 4.5 * d * (1 / mui + 1 / muo)
    assert np.all(np.abs(f / thin - 1) <= x)


def test_thick_layer_tends_to_semi_infinite(rng):
    wi, wo = random_dirs(rng, 100), random_dirs(rng, 100)
    semi = hk.single_scattering_brdf(stack1(n=1.3, g=0.5, d=math.inf), wi, wo)
    for d, tol in [(5.0, 1e-3), (20.0, 1e-15)]:  # τ = 10.5, 42: residual e^{-τ(1/μi+1/μo)} ≤ e^{-2τ}
        f = hk.single_scattering_brdf(stack1(n=1.3, g=0.5, d=d), wi, wo)
        assert np.all(np.abs(f - semi) <= tol * semi + 1e-300)
        assert np.all(f <= semi * (1 + 1e-15))


def test_two_identical_layers_equal_one(rng):
    for n, n0, nb in [(1.0, 1.0, 1.0), (1.4, 1.0, 1.5)]:
        one = Stack([Layer(n, 0.3, 4.0, 0.6, 0.5)], n0, nb)
        two = Stack([Layer(n, 0.3, 4.0, 0.6, 0.2), Layer(n, 0.3, 4.0, 0.6, 0.3)], n0, nb)
        wi, wo, wt = random_dirs(rng, 200), random_dirs(rng, 200), random_dirs(rng, 200, up=False)
        np.testing.assert_allclose(
            hk.single_scattering_brdf(two, wi, wo), hk.single_scattering_brdf(one, wi, wo), rtol=1e-13
        )
        np.testing.assert_allclose(
            hk.single_scattering_btdf(two, wi, wt), hk.single_scattering_btdf(one, wi, wt), rtol=1e-13
        )
        np.testing.assert_allclose(
            hk.unscattered_transmittance(two, wi), hk.unscattered_transmittance(one, wi), rtol=1e-13
        )


def test_no_scattering_gives_zero(rng):
    s = stack1(n=1.3, mua=0.5, mus=0.0, d=1.0)
    wi = random_dirs(rng, 20)
    assert np.all(hk.single_scattering_brdf(s, wi, random_dirs(rng, 20)) == 0)
    assert np.all(hk.single_scattering_btdf(s, wi, random_dirs(rng, 20, up=False)) == 0)
    # only the scattering layer of a stack contributes
    s = Stack([Layer(1.3, 0.5, 0.0, 0.0, 0.3), Layer(1.5, 0.1, 3.0, 0.2, 1.0)], 1.0, 1.0)
    terms = hk.single_scattering_brdf_layers(s, wi, wi)
    assert np.all(terms[:, 0] == 0) and np.all(terms[:, 1] > 0)


# ---------------------------------------------------------------- symmetries and energy
@pytest.mark.parametrize(
    "stack",
    [stack1(d=0.7, g=0.8), stack1(n=1.5, d=0.7, g=0.8, n_below=1.3), stack1(n=1.5, g=-0.4), STACK3],
    ids=["matched", "mismatched", "semi-infinite", "3 layers"],
)
def test_reciprocity(stack, rng):
    a, b = random_dirs(rng, 500), random_dirs(rng, 500)
    f1 = hk.single_scattering_brdf(stack, a, b)
    np.testing.assert_allclose(f1, hk.single_scattering_brdf(stack, b, a), rtol=1e-12, atol=0)
    assert np.all(f1 >= 0) and np.count_nonzero(f1) > 400
    if not math.isinf(stack.thickness):
        # generalised reciprocity: f_t(a → c)/n_below² = f_t(c → a)/n_above², the reversed path
        # seen from below is the flipped stack with mirrored directions.
        c = random_dirs(rng, 500, up=False)
        flipped = Stack(list(stack.layers)[::-1], stack.n_below, stack.n_above)
        mirror = np.array([1, 1, -1.0])
        ft = hk.single_scattering_btdf(stack, a, c)
        fr = hk.single_scattering_btdf(flipped, c * mirror, a * mirror)
        np.testing.assert_allclose(ft / stack.n_below**2, fr / stack.n_above**2, rtol=1e-12)


def test_btdf_equal_cosine_limit_is_smooth():
    """n = 1 everywhere, straight-through directions: μi = μo exactly; neighbours vary smoothly."""
    s = stack1(mua=0.2, mus=1.5, g=0.3, d=0.8)
    th = np.array([0.5, 0.5 + 1e-9, 0.5 + 1e-6, 0.5 + 1e-3])
    wi = sph(th[0], 0.0)
    wt = sph(th, np.pi, up=False)  # forward direction has φ + π in the "away" convention
    f = hk.single_scattering_btdf(s, wi, wt)
    mu = math.cos(0.5)
    tau = 1.7 * 0.8
    exact = 1.5 / 1.7 * hg(1.0, 0.3) * tau * math.exp(-tau / mu) / mu**2
    assert f[0] == pytest.approx(exact, rel=1e-13)
    assert f[1] == pytest.approx(exact, rel=1e-8)
    assert abs(f[2] / exact - 1) < 1e-4 and abs(f[3] / exact - 1) < 0.1


@pytest.mark.parametrize("theta_i", [0.0, 0.7, 1.4])
@pytest.mark.parametrize(
    "stack",
    [stack1(mua=0.0, mus=3.0, d=0.3), stack1(n=1.5, mua=0.0, mus=3.0, g=0.8, d=1.0), STACK3],
    ids=["thin-matched", "forward-mismatched", "3 layers"],
)
def test_energy_bound(stack, theta_i):
    wi = sph(theta_i, 0.2)
    r = hk.single_scattering_reflectance(stack, wi)
    t = hk.single_scattering_transmittance(stack, wi, n_theta=160, n_phi=160)
    t0 = hk.unscattered_transmittance(stack, wi)
    assert r > 0 and t > 0 and r + t + t0 <= 1.0


def test_unscattered_transmittance_closed_form():
    s = Stack([Layer(1.5, 0.2, 1.0, 0.0, 0.7), Layer(1.2, 0.1, 0.5, 0.0, 0.4)], 1.0, 1.33)
    th = 0.5
    t, wt = hk.unscattered_transmittance(s, sph(th, 0.3), return_direction=True)
    ci = math.cos(th)
    mu1 = math.sqrt(1 - (math.sin(th) / 1.5) ** 2)
    mu2 = math.sqrt(1 - (math.sin(th) / 1.2) ** 2)
    mu3 = math.sqrt(1 - (math.sin(th) / 1.33) ** 2)
    expect = fresnel_T(ci, 1.0, 1.5) * fresnel_T(mu1, 1.5, 1.2) * fresnel_T(mu2, 1.2, 1.33)
    expect *= math.exp(-1.2 * 0.7 / mu1 - 0.6 * 0.4 / mu2)
    assert t == pytest.approx(float(expect), rel=1e-13)
    np.testing.assert_allclose(
        wt, [-math.sin(th) / 1.33 * math.cos(0.3), -math.sin(th) / 1.33 * math.sin(0.3), -mu3], atol=1e-14
    )
    assert hk.unscattered_transmittance(stack1(), [0, 0, 1.0]) == 0.0  # semi-infinite
    # total internal reflection: glass above a layer of index 1
    tir = stack1(n=1.0, d=1.0, n_above=1.5, n_below=1.5)
    thc = math.asin(1 / 1.5)
    assert hk.unscattered_transmittance(tir, sph(thc + 0.01, 0)) == 0.0
    assert hk.unscattered_transmittance(tir, sph(thc - 0.01, 0)) > 0.0
    assert hk.single_scattering_brdf(tir, sph(thc + 0.01, 0), [0, 0, 1.0]) == 0.0


# ---------------------------------------------------------------- API
def test_shapes_and_broadcasting(rng):
    s = stack1(n=1.3, g=0.2, d=1.0)
    wi = random_dirs(rng, 6).reshape(2, 3, 3)
    wo = random_dirs(rng, 3)
    f = hk.single_scattering_brdf(s, wi, wo)
    assert f.shape == (2, 3)
    assert f[1, 2] == hk.single_scattering_brdf(s, wi[1, 2], wo[2])
    assert isinstance(hk.single_scattering_brdf(s, [0, 0, 1.0], [0, 0, 1.0]), float)
    layers = hk.single_scattering_brdf_layers(STACK3, wi, wo)
    assert layers.shape == (2, 3, 3)
    np.testing.assert_allclose(layers.sum(-1), hk.single_scattering_brdf(STACK3, wi, wo), rtol=1e-14)
    assert hk.single_scattering_reflectance(s, wi).shape == (2, 3)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda s: hk.single_scattering_brdf(s, [0, 0, 1.1], [0, 0, 1.0]), r"^\|wi\| = 1.1 .* unit vector"),
        (lambda s: hk.single_scattering_brdf(s, [[0, 0, 1.0], [0, 0, 0.5]], [0, 0, 1.0]), r"^\|wi\[1\]\| = 0.5"),
        (lambda s: hk.single_scattering_brdf(s, [0, 0, 1.0], [0, 0, -1.0]), r"^wo.z = -1.0 .* > 0"),
        (lambda s: hk.single_scattering_btdf(s, [0, 0, 1.0], [[0, 0, -1.0], [0, 0, 1.0]]), r"^wo\[1\].z = 1.0 .* < 0"),
        (lambda s: hk.single_scattering_btdf(s, [0, 0, -1.0], [0, 0, -1.0]), r"^wi.z"),
        (lambda s: hk.single_scattering_brdf(s, [np.nan, 0, 1.0], [0, 0, 1.0]), r"^\|wi\| = nan"),
        (lambda s: hk.single_scattering_brdf(s, [0, 1.0], [0, 0, 1.0]), r"^wi: expected shape"),
        (
            lambda s: hk.single_scattering_brdf(s, np.zeros((2, 3)) + [0, 0, 1], np.zeros((3, 3)) + [0, 0, 1]),
            "broadcast",
        ),
        (lambda s: hk.unscattered_transmittance(s, [1.0, 0, 0]), r"^wi.z = 0.0"),
        (lambda s: hk.single_scattering_reflectance(s, [0, 0, 1.0], n_theta=2), r"^n_theta = 2"),
        (lambda s: hk.single_scattering_brdf("stack", [0, 0, 1.0], [0, 0, 1.0]), r"^stack = "),
    ],
)
def test_validation(call, match):
    with pytest.raises(ParameterError, match=match):
        call(stack1(d=1.0))


def test_core_rejects_bad_directions_without_panicking():
    """The core validates every direction (the binding names it by its index in `shape`)."""
    s = stack1(d=1.0)._to_core()
    with pytest.raises(ParameterError, match=r"^wo\[0\].z"):
        subsurf._core.hk_brdf(s, np.array([0, 0, 1.0]), np.array([0, 0, -1.0]), [1])
    with pytest.raises(ParameterError, match=r"^\|wi\[1\]\|"):
        subsurf._core.hk_btdf(s, np.array([0, 0, 1.0, 0, 0, 2.0]), np.array([0, 0, -1.0, 0, 0, -1.0]), [2])
    with pytest.raises(ParameterError, match=r"^wo.z"):
        subsurf._core.hk_brdf(s, np.array([0, 0, 1.0]), np.array([0, 0, -1.0]))
    with pytest.raises(ParameterError, match="multiple of 3"):
        subsurf._core.hk_brdf(s, np.array([0, 0, 1.0, 0]), np.array([0, 0, 1.0, 0]))


# ---------------------------------------------------------------- Monte Carlo cross-check
# The MC tallies `*_single_direct` score exactly the paths of this model (order 1, no interface
# reflection); `brdf` bins are uniform in μ = |cos θ_out| × φ_out = atan2(y, x) of the exit
# direction, valued as the cosine-weighted bin average Σw/(N ∫_bin cos θ dω) (mc/tally/set.rs).
# MC frame: z into the stack, so pbrt's wo = (x, y, −z_MC); the pencil beam propagates along
# (sin θ cos φ, sin θ sin φ, cos θ), so wi = (−sin θ cos φ, −sin θ sin φ, cos θ).
MC_CASES = [
    ("matched slab", Stack([Layer(1.0, 0.5, 2.0, 0.5, 0.5)], 1.0, 1.0), 0.5, 0.0, 500_000),
    ("mismatched slab", Stack([Layer(1.4, 0.2, 1.0, 0.7, 1.0)], 1.0, 1.0), 0.8, 0.5, 1_000_000),
    (
        "two layers",
        Stack([Layer(1.3, 0.3, 2.0, 0.3, 0.3), Layer(1.5, 0.1, 1.5, -0.2, 0.4)], 1.0, 1.2),
        1.05,
        2.0,
        1_000_000,
    ),
    ("semi-infinite", Stack([Layer(1.33, 1.0, 2.0, 0.0, math.inf)], 1.0, 1.0), 0.0, 0.0, 500_000),
]


def _bin_average(f, mu_edges, phi_edges, n=12):
    """Cosine-weighted bin averages ∫ f μ dμ dφ / ∫ μ dμ dφ of f(wo) (wo upper hemisphere)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1), 0.5 * w
    out = np.zeros((len(mu_edges) - 1, len(phi_edges) - 1))
    for i, (m0, m1) in enumerate(zip(mu_edges[:-1], mu_edges[1:])):
        mu = m0 + (m1 - m0) * x
        for j, (p0, p1) in enumerate(zip(phi_edges[:-1], phi_edges[1:])):
            M, P = np.meshgrid(mu, p0 + (p1 - p0) * x, indexing="ij")
            s = np.sqrt(1 - M**2)
            vals = f(np.stack([s * np.cos(P), s * np.sin(P), M], -1))
            out[i, j] = np.sum(vals * M * np.outer(w, w)) * (m1 - m0) * 2 / (m1**2 - m0**2)
    return out


@pytest.mark.parametrize("name, stack, theta, phi, photons", MC_CASES, ids=[c[0] for c in MC_CASES])
def test_monte_carlo_single_direct_matches(name, stack, theta, phi, photons):
    from scipy.stats import norm

    res = subsurf.simulate(
        stack,
        photons=photons,
        seed=20240 + len(name),
        source=subsurf.PencilBeam(theta, phi),
        tallies=subsurf.Tallies(brdf=(8, 12), max_order=1, spatial=False, angular=False),
    )
    h = res.histograms
    wi = np.array([-math.sin(theta) * math.cos(phi), -math.sin(theta) * math.sin(phi), math.cos(theta)])
    # totals: order-1 direct reflectance/transmittance vs the quadrature of the model (4σ).
    # Power (σ ≈ √(p(1−p)/N) at the case's photons): the 4σ band is ≈ 2.7 % of ρ and 1.3 % of τ
    # (matched slab), 4.9 % and 1.0 % (mismatched: ρ ≈ 0.0067 is small), 1.9 % and 1.4 % (two
    # layers), 2.6 % of ρ (semi-infinite): a 5 % bias of any single-scattering total fails.
    rho = hk.single_scattering_reflectance(stack, wi, n_theta=128, n_phi=128)
    tau = hk.single_scattering_transmittance(stack, wi, n_theta=160, n_phi=160)
    for key, model in (("rd_single_direct", rho), ("tt_single_direct", tau)):
        v, e = float(h[key].values[0]), float(h[key].stderr[0])
        if model == 0.0:
            assert v == 0.0, key
        else:
            assert abs(v - model) < 4 * e, f"{key}: MC {v} ± {e}, model {model}"
    # every BRDF/BTDF bin, Šidák-corrected family-wise significance 1e-3. Power: |z| < 4.56
    # (192 bins; 4.41 for 96), so with 90 % probability a bin fails once its bias exceeds
    # ≈ 5.8 σ_bin; a bin holding 1/96 of ρ has σ_bin/value ≈ 1/√(N ρ/96), i.e. a single-bin bias
    # of ≈ 15–40 % (70 % for the mismatched slab's faint reflection) is needed: the bins catch
    # shape errors confined to a few bins only when large; small ones are left to the totals.
    zs = []
    for key, fn, flip in (
        ("brdf_single_direct", hk.single_scattering_brdf, 1.0),
        ("btdf_single_direct", hk.single_scattering_btdf, -1.0),
    ):
        hist = h[key]
        model = _bin_average(
            lambda wo, fn=fn, flip=flip: fn(stack, wi, wo * np.array([1, 1, flip])), hist.edges[1], hist.edges[2]
        )
        val, err = hist.values[0], hist.stderr[0]
        if math.isinf(stack.thickness) and flip < 0:
            assert np.all(val == 0) and np.all(model == 0)
            continue
        assert np.all(err[model > 0] > 0), key
        # Standard error under the null hypothesis (Pearson): a bin's variance scales with its
        # expected count, so the sample error is rescaled by sqrt(model / value). The sample error
        # alone shrinks with a downward fluctuation and makes |z| heavy-tailed in sparse bins.
        err_null = np.where((val > 0) & (model > 0), err * np.sqrt(np.abs(model) / np.where(val > 0, val, 1.0)), err)
        zs.append(((val - model) / np.where(err_null > 0, err_null, 1.0)).ravel())
    z = np.concatenate(zs)
    zmax = norm.isf(0.5 * (1 - (1 - 1e-3) ** (1 / z.size)))
    assert np.max(np.abs(z)) < zmax, f"max |z| = {np.max(np.abs(z)):.2f} ≥ {zmax:.2f}; χ²/dof = {np.mean(z**2):.2f}"
    # order-1 paths with interface reflections (left out of the model): none when every index
    # matches, nor for a single semi-infinite layer (a reflected path cannot come back unscattered)
    extra = float(h["rd_order"].values[1] - h["rd_single_direct"].values[0])
    extra += float(h["tt_order"].values[1] - h["tt_single_direct"].values[0])
    if all(l.n == stack.n_above for l in stack.layers) or (len(stack) == 1 and math.isinf(stack.thickness)):
        assert extra == 0.0
    else:
        assert extra > 0.0
