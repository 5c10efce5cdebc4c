"""MCML drop-in: .mci parsing, .mco writing in MCML's layout and units, round trip, errors.

Power: no test here is statistical — every check is an identity of the same run's bins (to
10⁻⁹…10⁻¹²) or of the file format, so a wrong scale or layout fails at once whatever the photons.
"""

import math

import numpy as np
import pytest
from subsurf import mcml


def test_parse_sample(sample_mci):
    runs = mcml.parse_mci(sample_mci, "s.mci")
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
        (
            ("1000                     # No.", "18446744073709551616 #"),
            "s.mci:12: number of photons = 18446744073709551616",
        ),
    ],
)
def test_parse_errors(sample_mci, bad, expect):
    text = sample_mci.replace(*bad)
    with pytest.raises(mcml.McmlInputError) as e:
        mcml.parse_mci(text, "s.mci")
    assert expect in str(e.value) and "\n" not in str(e.value)


def _run_and_result(sample_mci, make_result):
    run = mcml.parse_mci(sample_mci)[0]
    res, raw = make_result(nr=run.nr, dr=run.dr * 10, nz=run.nz, dz=run.dz * 10, na=run.na)
    return run, res, raw


def test_unit_conversions_against_mcml_scaling(sample_mci, make_result):
    """Each MCML array equals the raw bin weights divided by mcmlio.c's ScaleRdTt/ScaleA measures (cm)."""
    run, res, raw = _run_and_result(sample_mci, make_result)
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


def test_mco_layout_and_round_trip(tmp_path, sample_mci, make_result):
    run, res, _ = _run_and_result(sample_mci, make_result)
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


def test_refuses_to_overwrite(tmp_path, sample_mci, make_result):
    run, res, _ = _run_and_result(sample_mci, make_result)
    p = tmp_path / "o.mco"
    p.write_text("precious")
    with pytest.raises(FileExistsError, match="--force"):
        mcml.write_mco(p, run, res)
    assert p.read_text() == "precious"
    mcml.write_mco(p, run, res, force=True)
    assert p.read_text().startswith("A1")
    res.photons = 0  # nothing traced (Ctrl-C at once): no .mco full of NAN
    with pytest.raises(ValueError, match="no photons were traced"):
        mcml.write_mco(tmp_path / "nan.mco", run, res)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["o.mco"]


def test_run_mci_end_to_end(tmp_path, sample_mci):
    mci = tmp_path / "s.mci"
    mci.write_text(sample_mci)
    done = mcml.run_mci(mci, out_dir=str(tmp_path), photons=2000)
    assert [d[0] for d in done] == [str(tmp_path / "first.mco"), str(tmp_path / "second.mco")]
    for (path, res), run in zip(done, mcml.parse_mci(sample_mci)):
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


def test_run_mci_interrupted_writes_a_partial_run_beside_an_existing_file(tmp_path, sample_mci):
    """A Ctrl-C (from the progress callback) ends the loop; the partial .mco states its photons and
    never replaces an existing file."""
    mci = tmp_path / "s.mci"
    mci.write_text(sample_mci.replace("1000                     # No.", "100000000 #"))
    (tmp_path / "first.mco").write_text("complete")

    def stop(done, total):
        if done > 4096:  # with one thread, the first chunk of photons is complete
            raise KeyboardInterrupt

    with pytest.warns(RuntimeWarning, match="interrupted"):
        done = mcml.run_mci(mci, out_dir=str(tmp_path), force=True, threads=1, progress_factory=lambda i, run: stop)
    assert [p for p, _ in done] == [str(tmp_path / "first.partial.mco")]
    assert (tmp_path / "first.mco").read_text() == "complete" and not (tmp_path / "second.mco").exists()
    back = mcml.read_mco(tmp_path / "first.partial.mco")
    assert 0 < back["photons"] == done[0][1].photons < 100_000_000
