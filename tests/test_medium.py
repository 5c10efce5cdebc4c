"""Layer, Stack and mix: derived quantities and validation errors."""

import math

import pytest
import subsurf
from subsurf import Component, Layer, ParameterError, Stack, mix


def test_derived_quantities():
    l = Layer(1.4, 0.1, 10.0, 0.9, 2.0)
    assert l.sigma_t == pytest.approx(10.1)
    assert l.albedo == pytest.approx(10.0 / 10.1)
    assert l.mus_prime == pytest.approx(1.0)
    assert l.transport_mfp == pytest.approx(1 / 1.1)
    assert l.optical_thickness == pytest.approx(20.2)
    glass = Layer(1.5, 0.0, 0.0, 0.0, 1.0)
    assert glass.albedo == 0.0 and glass.transport_mfp == math.inf


def test_parameter_error_is_value_error():
    assert issubclass(ParameterError, ValueError)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(n=1.4, mua=-0.1, mus=1, g=0, thickness=1), "mua"),
        (dict(n=1.4, mua=0.1, mus=-1, g=0, thickness=1), "mus"),
        (dict(n=1.4, mua=math.nan, mus=1, g=0, thickness=1), "mua"),
        (dict(n=1.4, mua=math.inf, mus=1, g=0, thickness=1), "mua"),
        (dict(n=1.4, mua=0.1, mus=1, g=1.0, thickness=1), "g"),
        (dict(n=1.4, mua=0.1, mus=1, g=-1.5, thickness=1), "g"),
        (dict(n=0.9, mua=0.1, mus=1, g=0, thickness=1), "n"),
        (dict(n=math.inf, mua=0.1, mus=1, g=0, thickness=1), "n"),
        (dict(n=1.4, mua=0.1, mus=1, g=0, thickness=0), "thickness"),
        (dict(n=1.4, mua=0.1, mus=1, g=0, thickness=-2), "thickness"),
        (dict(n=1.4, mua=0.1, mus=1, g=0, thickness=math.nan), "thickness"),
    ],
)
def test_layer_validation(kwargs, field):
    with pytest.raises(ValueError, match=rf"^{field} = .* must be"):
        Layer(**kwargs)


def test_layer_rejects_non_numbers():
    with pytest.raises(ValueError, match="mua"):
        Layer(1.4, "lots", 1.0, 0.0, 1.0)


def test_stack_validation():
    with pytest.raises(ValueError, match="empty"):
        Stack([])
    semi = Layer(1.4, 0.1, 10, 0.9, math.inf)
    thin = Layer(1.4, 0.1, 10, 0.9, 0.1)
    with pytest.raises(ValueError, match=r"layers\[0\]\.thickness.*only the last layer"):
        Stack([semi, thin])
    with pytest.raises(ValueError, match="n_above"):
        Stack([thin], n_above=0.5)
    with pytest.raises(ValueError, match="n_below"):
        Stack([thin], n_below=math.nan)
    with pytest.raises(ValueError, match=r"layers\[1\]"):
        Stack([thin, "not a layer"])
    s = Stack([thin, semi], n_above=1.0)
    assert s.boundaries[:2] == [0.0, 0.1] and math.isinf(s.thickness)
    assert len(s) == 2 and s[0] == thin


def test_mix_eq_1_5():
    layer = mix([Component(0.25, 2.0, 40.0, 0.9), (0.5, 0.2, 20.0, 0.0)], n=1.4, thickness=1.0)
    assert layer.mua == pytest.approx(0.6)
    assert layer.mus == pytest.approx(20.0)
    assert layer.g == pytest.approx(0.45)
    assert sorted(layer.lobes) == [(0.5, 0.0), (0.5, 0.9)]
    with pytest.raises(ValueError, match="fractions"):
        mix([(0.7, 0, 1, 0), (0.7, 0, 1, 0)])
    with pytest.raises(ValueError, match=r"components\[0\]\.g"):
        mix([(0.5, 0, 1, 1.2)])


def test_version_is_the_package_version():
    import importlib.metadata

    assert subsurf.__version__ == importlib.metadata.version("subsurf")
    assert subsurf.__version__.count(".") >= 2
