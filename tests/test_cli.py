"""The `subsurf` command line: one-line errors, simulate, plot, merge, mcml, profile, demo.

Files, signals and full disks: ``test_cli_files.py``.
"""

import io
import pathlib

import h5py
import numpy as np
import pytest
import subsurf
from matplotlib import image
from subsurf import bssrdf, cli

GOOD = (pathlib.Path(__file__).parent / "data" / "slab.toml").read_text()


@pytest.mark.parametrize(
    "text, fragments",
    [
        (GOOD.replace("g = 0.8", "g = 1.8"), ["bad.toml:8: layers[0].g: 1.8 is out of range"]),
        (GOOD + "colour = 3\n", ["bad.toml:", "tallies.colour: unknown key"]),
        (GOOD.replace("photons = 3000", "photons = 3000 3"), ["bad.toml:2: invalid TOML"]),
        (GOOD.replace("nr = 20", "nr = -2"), ["bad.toml:11: tallies.nr: -2 is out of range"]),
        (GOOD.replace("photons = 3000", "photons = 18446744073709551616"), ["bad.toml:2: photons:", "out of range"]),
        (GOOD.replace("photons = 3000", "photons = " + "[" * 20_000 + "]" * 20_000), ["bad.toml", "nested"]),
    ],
)
def test_bad_config_is_one_line(tmp_path, error_here, text, fragments):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    error_here("simulate", p, fragments=fragments)


def test_bad_arguments_are_one_line(tmp_path, cli, run_here, one_line_error):
    one_line_error(cli("simulate", tmp_path / "missing.toml"), "missing.toml: no such file")  # a process
    one_line_error(run_here("simulate"), "required: CONFIG.toml")
    one_line_error(run_here("frobnicate"), "invalid choice")
    (tmp_path / "c.toml").write_text(GOOD)
    one_line_error(run_here("simulate", tmp_path / "c.toml", "--photons", "0"), "--photons = 0 is out of range")
    one_line_error(run_here("simulate", tmp_path / "c.toml", "--photons", "many"), "invalid int value")
    one_line_error(
        run_here("simulate", tmp_path / "c.toml", "--photons", "100000000000000000000"),
        "--photons = 100000000000000000000 is out of range: must be an integer in [1, 2^64 - 1]",
    )
    one_line_error(run_here("simulate", tmp_path / "c.toml", "--seed", str(2**64)), "--seed = 18446744073709551616")
    one_line_error(run_here("mcml", tmp_path / "x.mci", "--threads", "0"), "--threads = 0 is out of range")
    one_line_error(run_here("plot", tmp_path / "c.toml"), "c.toml: not an HDF5 results file")
    one_line_error(run_here("mcml", tmp_path / "none.mci"), "none.mci: no such file")
    (tmp_path / "b.mci").write_text("1.0\n1\nout.mco A\n-3\n")
    one_line_error(run_here("mcml", tmp_path / "b.mci"), "b.mci:4: number of photons = -3 is out of range")
    one_line_error(run_here("profile", "--sigma-a", "-1", "--sigma-s-prime", "1"), "--sigma-a = -1 is out of range")


def test_mci_photons_beyond_64_bits(tmp_path, error_here, sample_mci):
    (tmp_path / "s.mci").write_text(sample_mci.replace("1000                     # No.", "18446744073709551616 #"))
    line = error_here("mcml", tmp_path / "s.mci", fragments=["s.mci:12: number of photons"])
    assert "must be < 2^64" in line
    assert not (tmp_path / "first.mco").exists()


def _png(path):
    """The pixels of a PNG (rows, columns, channels), after checking the file is a complete PNG."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[-8:-4] == b"IEND"
    return image.imread(io.BytesIO(data), format="png")


@pytest.mark.slow
def test_plot_and_merge_from_files(tmp_path, run_here, one_line_error, make_result):
    a, _ = make_result(seed=1)
    b, _ = make_result(seed=2)
    subsurf.save(a, tmp_path / "a.h5")
    subsurf.save(b, tmp_path / "b.h5")
    p = run_here("plot", tmp_path / "a.h5", "-o", tmp_path / "a.png", "--no-models")
    assert p.returncode == 0, p.stderr
    px = _png(tmp_path / "a.png")
    # the figure of a result with R(r), A(z), BRDF and orders: 2 × 3 panels of 6 × 4.5 in at 130 dpi
    assert px.shape[:2] == (round(3 * 4.5 * 130), round(2 * 6 * 130))
    ink = (px[..., :3] < 0.5).any(axis=-1).mean()
    assert 0.01 < ink < 0.6, ink  # drawn, not blank and not a solid block
    p = run_here("merge", tmp_path / "a.h5", tmp_path / "b.h5", "-o", tmp_path / "m.h5")
    assert p.returncode == 0, p.stderr
    m = subsurf.load(tmp_path / "m.h5")
    assert m.photons == a.photons + b.photons and m.config["seeds"] == [1, 2]
    assert m.diffuse_reflectance == pytest.approx(0.35) and m.rd_r.values.shape == a.rd_r.values.shape
    one_line_error(run_here("merge", tmp_path / "a.h5", tmp_path / "a.h5", "-o", tmp_path / "x.h5"), "seed 1")
    one_line_error(run_here("merge", tmp_path / "a.h5", tmp_path / "b.h5", "-o", tmp_path / "m.h5"), "--force")


def test_simulate_writes_result_and_table(tmp_path, cli, run_here):
    (tmp_path / "c.toml").write_text(GOOD)
    p = cli("simulate", tmp_path / "c.toml", "-o", tmp_path / "r.h5", "--seed", "9", "--threads", "1")
    assert p.returncode == 0, p.stderr
    r = subsurf.load(tmp_path / "r.h5")
    assert r.photons == 3000 and r.seed == 9 and not r.partial
    assert abs(r.energy_balance - 1) < 1e-12
    assert r.rd_r.values.shape == (20,)
    # the printed table is the result's own summary
    assert r.summary().splitlines()[:8] == p.stdout.splitlines()[:8]
    assert f"wrote {tmp_path / 'r.h5'}" in p.stdout and "events/s" in p.stdout
    # same seed, different thread count: bit-identical numbers
    p = run_here("simulate", tmp_path / "c.toml", "-o", tmp_path / "r2.h5", "--seed", "9", "--threads", "2", "-q")
    assert p.returncode == 0 and "diffuse reflectance" not in p.stdout
    assert subsurf.io.results_equal(subsurf.load(tmp_path / "r2.h5"), r, provenance=False)
    p = run_here("plot", tmp_path / "r.h5")
    assert p.returncode == 0 and _png(tmp_path / "r.png").shape[2] == 4


def test_mcml_drop_in(tmp_path, run_here, one_line_error, sample_mci):
    from subsurf import mcml

    (tmp_path / "s.mci").write_text(sample_mci)
    p = run_here("mcml", "s.mci", "--photons", "1000", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    for name in ("first.mco", "second.mco"):
        back = mcml.read_mco(tmp_path / name)
        assert back["photons"] == 1000
        assert back["Rsp"] + back["Rd"] + back["A"] + back["Tt"] == pytest.approx(1.0, abs=1e-5)
    before = (tmp_path / "first.mco").read_bytes()
    one_line_error(run_here("mcml", "s.mci", "--photons", "100", cwd=tmp_path), "first.mco: exists", "--force")
    assert (tmp_path / "first.mco").read_bytes() == before
    p = run_here("mcml", "s.mci", "--photons", "100", "--force", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert mcml.read_mco(tmp_path / "first.mco")["photons"] == 100


def test_profile_and_materials(run_here, one_line_error):
    from subsurf import diffusion

    p = run_here("materials")
    assert p.returncode == 0, p.stderr
    assert "marble" in p.stdout and "skin1" in p.stdout
    p = run_here("profile", "marble", "--photons", "3000")
    assert p.returncode == 0, p.stderr
    for m in bssrdf.MODELS:
        assert m in p.stdout
    p = run_here("profile", "--sigma-a", "0.01", "--sigma-s-prime", "1.0", "--eta", "1.3", "--model", "dipole")
    assert p.returncode == 0, p.stderr
    row = next(line for line in p.stdout.splitlines() if line.startswith("dipole"))
    # the dipole's total and R_d(1 mm): the library's own values, printed
    assert float(row.split()[1]) == pytest.approx(float(diffusion.total_diffuse_reflectance(1 / 1.01, 1.3)), abs=6e-5)
    assert "3.0312e-02" in row
    one_line_error(run_here("profile", "unobtainium"), "unknown material 'unobtainium'")
    # Photon beam diffusion printed 1.0125 for cream (red), above the light that enters.
    p = run_here("profile", "cream", "--model", "photon_beam_diffusion")
    assert p.returncode == 0, p.stderr
    totals = [float(line.split()[1]) for line in p.stdout.splitlines() if line.startswith("photon_beam_diffusion")]
    assert len(totals) == 3 and max(totals) <= 1.0, totals


@pytest.mark.slow
def test_demo_small(tmp_path, run_here, one_line_error):
    p = run_here("demo", "--quick", "--photons", "3000", "--out-dir", tmp_path / "out", "-q")
    assert p.returncode == 0, p.stderr
    r = subsurf.load(tmp_path / "out" / "demo.h5")
    assert len(r.absorbed_per_layer) == 3 and abs(r.energy_balance - 1) < 1e-12 and r.photons == 3000
    d = subsurf.load(tmp_path / "out" / "demo_dermis.h5")
    assert len(d.absorbed_per_layer) == 1 and d.photons == 3000
    assert _png(tmp_path / "out" / "demo.png").shape[:2] == (round(4.8 * 130), round(16 * 130))
    # the dipole total the demo prints is the closed form for the dermis (σa 0.049, σs' 2.53, η 1.4)
    want = subsurf.diffusion.total_diffuse_reflectance(2.53 / (0.049 + 2.53), 1.4)
    assert f"dipole {float(want):.4f}" in p.stdout
    (tmp_path / "f").write_text("x")
    one_line_error(run_here("demo", "--out-dir", tmp_path / "f", "-q"), "is a file, not a directory")


def test_every_command_is_registered():
    sub = next(a for a in cli.build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == [
        *("simulate", "sweep", "mcml", "profile", "fit", "materials", "plot", "merge", "demo", "render")
    ]
    assert [m.__name__.rpartition(".")[2] for m in cli.COMMANDS] == list(sub.choices)


def test_profile_plot_and_fit(tmp_path, run_here, one_line_error):
    out = tmp_path / "p.png"
    p = run_here("profile", "skin1", "--model", "dipole", "--model", "normalized_diffusion", "-o", out)
    assert p.returncode == 0, p.stderr
    assert out.exists() and "wrote" in p.stdout
    prof = bssrdf.Profile.from_model("dipole", 0.02, 1.0, 0.0, 1.4)
    r = np.geomspace(0.2, 5, 12)
    rows = "\n".join(f"{x},{y},{0.02 * y}" for x, y in zip(r, prof.rd(r)))
    (tmp_path / "m.csv").write_text("r,rd,sigma\n" + rows + "\n")
    p = run_here("fit", tmp_path / "m.csv", "--model", "dipole", "--eta", "1.4")
    assert p.returncode == 0, p.stderr
    assert "sigma_a" in p.stdout and "0.02 ±" in p.stdout
    (tmp_path / "s.csv").write_text("rd,tt,sigma_rd,sigma_tt\n0.2,0.4,0.005,0.005\n")
    p = run_here("fit", tmp_path / "s.csv", "--kind", "slab", "--thickness", "1.0")
    assert p.returncode == 0, p.stderr
    assert "mus_prime" in p.stdout
    one_line_error(run_here("fit", tmp_path / "s.csv", "--kind", "slab"), "--thickness")
    one_line_error(run_here("fit", tmp_path / "none.csv"), "none.csv: no such file")


_PROFILE = "r,rd,sigma\n" + "".join(f"{0.5 * i},{{rd}},{{sigma}}\n" for i in range(1, 9))


@pytest.mark.parametrize(
    "kind, text, fragments",
    [
        ("profile", _PROFILE.format(rd=1e-300, sigma=1e-302), ["χ² = inf at the initial parameters"]),
        ("profile", _PROFILE.format(rd=0.0, sigma=1e-3), ["the data hold no signal", "rd"]),
        ("slab", "rd,tt,sigma_rd,sigma_tt\n0,0,0.01,0.01\n", ["the data hold no signal"]),
        ("slab", "rd,tt,sigma_rd,sigma_tt\n-0.1,0.3,0.01,0.01\n", ["rd = -0.1 is out of range"]),
        ("profile", "r,rd,sigma\n0.5,0.01,0.001\n1.0,0.005\n", ["m.csv: data row 2: sigma is missing"]),
        ("profile", "r,rd,sigma\n0.5,0.01,x\n", ["m.csv: data row 1: sigma = 'x' is not a number"]),
    ],
)
def test_meaningless_fits_are_refused(tmp_path, error_here, kind, text, fragments):
    """Regression: fits the data cannot identify exited 0 with the start value "± 0" or
    uncertainties of 1e85; the core refuses them (bssrdf/inverse/lm.rs), and the CSV's own
    problems are named by row."""
    (tmp_path / "m.csv").write_text(text)
    extra = ["--thickness", "1.0"] if kind == "slab" else []
    error_here("fit", tmp_path / "m.csv", "--kind", kind, *extra, fragments=fragments)


def test_fit_reads_a_csv_with_a_byte_order_mark(tmp_path, cli_here):
    prof = bssrdf.Profile.from_model("dipole", 0.02, 1.0, 0.0, 1.4)
    r = np.geomspace(0.2, 5, 12)
    rows = "".join(f"{x},{y},{0.02 * y}\n" for x, y in zip(r, prof.rd(r)))
    (tmp_path / "m.csv").write_bytes(("\ufeffr,rd,sigma\n" + rows).encode("utf-8"))
    status, out, err = cli_here("fit", tmp_path / "m.csv", "--eta", "1.4")
    assert status == 0 and "0.02 ±" in out, err


# --- result files that are damaged or incomplete -------------------------------------------------


@pytest.mark.parametrize(
    "edit, fragment",
    [
        (lambda f: f.__delitem__("totals"), "/totals: missing"),
        (lambda f: f.attrs.__delitem__("format_version"), "attribute 'format_version' is missing"),
        (lambda f: f.attrs.__delitem__("photons"), "attribute 'photons' is missing"),
        (lambda f: f["histograms/rd_r"].__delitem__("edges_0"), "/histograms/rd_r/edges_0: missing"),
        (lambda f: f["histograms/a_rz"].attrs.__delitem__("axes"), "/histograms/a_rz: attribute 'axes' is missing"),
        (lambda f: f.attrs.__setitem__("config", "[1,2]"), "'config' is not a JSON object"),
        (lambda f: f.attrs.__setitem__("config", "{"), "'config' is not valid JSON"),
        (lambda f: f.attrs.__setitem__("photons", "many"), "attribute 'photons' = 'many' is not an integer"),
        (lambda f: f.attrs.__setitem__("seed", -3), "attribute 'seed' = -3 is out of range"),
        (lambda f: f["totals"].__delitem__("absorbed"), "/totals/absorbed: missing"),
        (lambda f: f["histograms/rd_r/values"].attrs.__setitem__("units", 3), None),  # harmless
    ],
)
def test_plot_and_merge_of_incomplete_files(tmp_path, error_here, make_result, as_format_1, edit, fragment):
    """Files without checksums (format 1, or written by hand) are checked for every piece."""
    res, _ = make_result(seed=1)
    p = subsurf.save(res, tmp_path / "a.h5")
    subsurf.save(make_result(seed=2)[0], tmp_path / "b.h5")
    as_format_1(p)
    with h5py.File(p, "r+") as f:
        edit(f)
    if fragment is None:
        with pytest.warns(subsurf.io.UnverifiedResultWarning):
            assert subsurf.io.results_equal(subsurf.load(p), res)
        return
    for args in (("plot", p, "-o", tmp_path / "a.png"), ("merge", tmp_path / "b.h5", p, "-o", tmp_path / "m.h5")):
        line = error_here(*args, fragments=[str(p), fragment])
        assert not (tmp_path / "a.png").exists() and not (tmp_path / "m.h5").exists(), line


def test_edited_v2_file_fails_its_checksum(tmp_path, error_here, make_result):
    p = subsurf.save(make_result(seed=1)[0], tmp_path / "a.h5")
    with h5py.File(p, "r+") as f:
        f.attrs["photons"] = 20_000
    error_here("plot", p, fragments=[f"{p}: its structure or attributes fail their checksum"])
    p = subsurf.save(make_result(seed=1)[0], tmp_path / "a.h5")
    with h5py.File(p, "r+") as f:
        f["histograms/a_rz/values"][3, 4] *= 1.0 + 2**-40
    error_here("merge", p, p, "-o", tmp_path / "m.h5", fragments=["/histograms/a_rz/values", "fails"])


def test_version_is_printed(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"subsurf {subsurf.__version__}"
