"""MCML drop-in: .mci parsing, .mco writing in MCML's layout and units, round trip, errors."""

import math

import numpy as np
import pytest
import subsurf
from subsurf import mcml
from synthetic import make_result

SAMPLE_MCI = """\
####
# Template of input files for Monte Carlo simulation (mcml).
# Anything in a line after "#" is ignored as comments.
####

1.0                      # file version
2                        # number of runs

#### SPECIFY DATA FOR RUN 1
#InParm                  # Input parameters. cm is used.
first.mco    A           # output file name, ASCII.
1000                     # No. of photons
0.0025  0.005            # dz, dr [cm]
15      20      6        # No. of dz, dr, da.

2                        # Number of layers
#n      mua     mus     g       d       # One line for each layer
1.0                      # n for medium above
1.37    1       100     0.9     0.1     # layer 1
1.37    0.5     150     0.8     0.2     # layer 2
1.0                      # n for medium below

#### SPECIFY DATA FOR RUN 2
second.mco A
500
0.01 0.01
10 10 5
1
1.0
1.4 10 90 0.75 0.02
1.0
"""


def test_parse_sample():
    runs = mcml.parse_mci(SAMPLE_MCI, "s.mci")
    assert len(runs) == 2
    r = runs[0]
    assert (r.out_fname, r.out_format, r.photons) == ("first.mco", "A", 1000)
    assert (r.dz, r.dr, r.nz, r.nr, r.na) == (0.0025, 0.005, 15, 20, 6)
    assert r.layers == [(1.37, 1.0, 100.0, 0.9, 0.1), (1.37, 0.5, 150.0, 0.8, 0.2)]
    assert r.n_above == 1.0 and r.n_below == 1.0 and r.line == 11
    assert runs[1].layers == [(1.4, 10.0, 90.0, 0.75, 0.02)]
    # cm -> mm: mu x 0.1, d x 10
    s = mcml.run_to_stack(r)
    assert s[0].mua == pytest.approx(0.1) and s[0].mus == pytest.approx(10.0) and s[1].thickness == pytest.approx(2.0)


@pytest.mark.parametrize(
    "bad, expect",
    [
        (("2                        # number of runs", "3"), "s.mci:31: file ends early: expected an output file name"),
        (("1000                     # No. of photons", "-5"), "s.mci:12: number of photons = -5 is out of range"),
        (
            ("1000                     # No. of photons", "many"),
            "s.mci:12: expected the number of photons: 'many' is not an integer",
        ),
        (("0.0025  0.005", "0.0025"), "s.mci:13: expected dz dr (cm)"),
        (("1.37    1       100     0.9     0.1", "1.37 1 100 1.2 0.1"), "s.mci:19: layer 1: g = 1.2 is out of range"),
        (("1.37    0.5     150     0.8     0.2", "1.37 0.5 150 0.8 0"), "s.mci:20: layer 2: d = 0 is out of range"),
        (("second.mco A", "first.mco A"), "s.mci:24: output file name first.mco is used by two runs"),
        (("1.0                      # n for medium above", "0.9"), "s.mci:18: n above = 0.9 is out of range"),
    ],
)
def test_parse_errors(bad, expect):
    text = SAMPLE_MCI.replace(*bad)
    with pytest.raises(mcml.McmlInputError) as e:
        mcml.parse_mci(text, "s.mci")
    assert expect in str(e.value) and "\n" not in str(e.value)


def _run_and_result():
    run = mcml.parse_mci(SAMPLE_MCI)[0]
    res, raw = make_result(nr=run.nr, dr=run.dr * 10, nz=run.nz, dz=run.dz * 10, na=run.na)
    return run, res, raw


def test_unit_conversions_against_mcml_scaling():
    """Each MCML array equals the raw bin weights divided by mcmlio.c's ScaleRdTt/ScaleA measures (cm)."""
    run, res, raw = _run_and_result()
    q = mcml.mcml_arrays(run, res)
    dr, dz, da = run.dr, run.dz, run.da
    ir = np.arange(run.nr) + 0.5
    ia = (np.arange(run.na) + 0.5) * da
    np.testing.assert_allclose(q["Rd_r"], raw["rd_r"] / (2 * math.pi * ir * dr * dr), rtol=1e-12)
    np.testing.assert_allclose(q["Tt_r"], raw["tt_r"] / (2 * math.pi * ir * dr * dr), rtol=1e-12)
    np.testing.assert_allclose(q["Rd_a"], raw["rd_a"] / (2 * math.pi * da * np.sin(ia)), rtol=1e-12)
    np.testing.assert_allclose(q["A_z"], raw["a_z"] / dz, rtol=1e-12)
    np.testing.assert_allclose(q["A_rz"], raw["a_rz"] / (2 * math.pi * ir[:, None] * dr * dr * dz), rtol=1e-12)
    np.testing.assert_allclose(
        q["Rd_ra"],
        raw["rd_ra"]
        / (
            2
            * math.pi
            * ir[:, None]
            * dr
            * dr
            * np.cos(ia)[None, :]
            * 2
            * math.pi
            * np.sin(ia)[None, :]
            * 2
            * math.sin(da / 2)
        ),
        rtol=1e-12,
    )
    # direct unit factors for the exact-measure quantities: mm^-1 -> cm^-1 x10, mm^-2 -> cm^-2 x100, mm^-3 x1000
    np.testing.assert_allclose(q["A_z"], res.a_z.values * 10, rtol=1e-12)
    np.testing.assert_allclose(q["Rd_r"], res.rd_r.values * 100, rtol=1e-12)
    np.testing.assert_allclose(q["A_rz"], res.a_rz.values * 1000, rtol=1e-12)
    # MCML's sums: Rd = sum Rd_r * 2 pi (i+1/2) dr^2 (cm^2)
    assert np.sum(q["Rd_r"] * 2 * math.pi * ir * dr * dr) == pytest.approx(res.diffuse_reflectance, rel=1e-12)
    assert np.sum(q["A_z"] * dz) == pytest.approx(res.absorbed, rel=1e-12)


def test_mco_layout_and_round_trip(tmp_path):
    run, res, _ = _run_and_result()
    p = tmp_path / "first.mco"
    mcml.write_mco(p, run, res)
    text = p.read_text()
    lines = text.splitlines()
    assert lines[0] == "A1 \t# Version number of the file format."
    assert "# User time:        1 sec =     0.00 hr.   Simulation time of this run." in lines
    assert "InParm \t\t\t# Input parameters. cm is used." in lines
    assert "first.mco \tA\t\t# output file name, ASCII." in lines
    assert "0.0025\t0.005\t\t# dz, dr [cm]" in lines
    assert "1.37\t1\t100\t0.9\t0.1\t# layer 1" in lines
    assert "0.35           \t#Diffuse reflectance [-]" in lines
    i = lines.index("Rd_r #Rd[0], [1],..Rd[nr-1]. [1/cm2]")
    assert len(lines[i + 1]) == 12 and "E" in lines[i + 1]
    # order of sections as in MCML's WriteResult
    order = [
        text.index(s)
        for s in (
            "\nInParm",
            "\nRAT",
            "\nA_l",
            "\nA_z",
            "\nRd_r",
            "\nRd_a",
            "\nTt_r",
            "\nTt_a",
            "\nA_rz",
            "\nRd_ra",
            "\nTt_ra",
        )
    ]
    assert order == sorted(order)
    # 2-D sections: five numbers a line
    j = lines.index("A_rz")
    assert len(lines[j + 1].split()) == 5
    back = mcml.read_mco(p)
    q = mcml.mcml_arrays(run, res)
    assert back["photons"] == run.photons and back["layers"] == run.layers
    assert (back["nz"], back["nr"], back["na"]) == (15, 20, 6)
    assert back["Rd"] == pytest.approx(res.diffuse_reflectance, rel=1e-5)
    assert back["Tt"] == pytest.approx(res.transmittance, rel=1e-5)
    for k in ("A_z", "Rd_r", "Rd_a", "Tt_r", "Tt_a", "A_rz", "Rd_ra", "Tt_ra", "A_l"):
        np.testing.assert_allclose(back[k], q[k], rtol=6e-4, err_msg=k)  # 4 significant digits
        assert back[k].shape == q[k].shape


def test_refuses_to_overwrite(tmp_path):
    run, res, _ = _run_and_result()
    p = tmp_path / "o.mco"
    p.write_text("precious")
    with pytest.raises(FileExistsError, match="--force"):
        mcml.write_mco(p, run, res)
    assert p.read_text() == "precious"
    mcml.write_mco(p, run, res, force=True)
    assert p.read_text().startswith("A1")


@pytest.mark.skipif(not hasattr(subsurf, "Tallies"), reason="needs the Monte Carlo tallies")
def test_run_mci_end_to_end(tmp_path):
    mci = tmp_path / "s.mci"
    mci.write_text(SAMPLE_MCI)
    done = mcml.run_mci(mci, out_dir=str(tmp_path), photons=2000)
    assert [d[0] for d in done] == [str(tmp_path / "first.mco"), str(tmp_path / "second.mco")]
    for (path, res), run in zip(done, mcml.parse_mci(SAMPLE_MCI)):
        back = mcml.read_mco(path)
        assert back["Rsp"] + back["Rd"] + back["A"] + back["Tt"] == pytest.approx(1.0, abs=1e-4)
        # MCML's identities (its 1-D and 2-D arrays are sums of the same raw bins, the last r/z bins
        # holding the overflow): they hold only if subsurf's normalisation is undone correctly.
        q = mcml.mcml_arrays(run, res)
        dr, dz, da = run.dr, run.dz, run.da
        ir = np.arange(run.nr) + 0.5
        ia = (np.arange(run.na) + 0.5) * da
        for key, total in (("Rd", res.diffuse_reflectance), ("Tt", res.transmittance)):
            assert np.sum(q[key + "_r"] * 2 * math.pi * ir * dr * dr) == pytest.approx(total, rel=1e-9)
            assert np.sum(q[key + "_a"] * 2 * math.pi * np.sin(ia) * da) == pytest.approx(total, rel=1e-9)
            scale = 4 * math.pi**2 * dr * dr * math.sin(da / 2) * ir[:, None] * np.sin(2 * ia)[None, :]
            assert np.sum(q[key + "_ra"] * scale) == pytest.approx(total, rel=1e-9)
            np.testing.assert_allclose(
                (q[key + "_ra"] * scale).sum(1), q[key + "_r"] * 2 * math.pi * ir * dr * dr, rtol=1e-9, atol=1e-15
            )
        # MCML's A, A_l and A_z hold the physical absorption (without subsurf's roulette term)
        assert np.sum(q["A_z"] * dz) == pytest.approx(q["A"], rel=1e-9)
        assert np.sum(q["A_l"]) == pytest.approx(q["A"], rel=1e-12)
        assert q["A"] + res.roulette == pytest.approx(res.absorbed, abs=1e-12)
        np.testing.assert_allclose(
            (q["A_rz"] * 2 * math.pi * ir[:, None] * dr * dr * dz).sum(0), q["A_z"] * dz, rtol=1e-9, atol=1e-15
        )
    with pytest.raises(FileExistsError):
        mcml.run_mci(mci, out_dir=str(tmp_path), photons=100)
