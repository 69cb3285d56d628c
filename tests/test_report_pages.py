"""Fit reports as a horologist reads them: display units, headers, titles, escaping, figures.

Small results files are made once per session (least squares, and short emcee runs); the
checks compare the report's text with numbers computed here from the results file.
"""

from __future__ import annotations

import json
import math
import re
import struct
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.core.display import curve_label, display_name, display_unit, load_unit, to_display
from escfit.core.errors import ResultsError
from escfit.report import make_report, parameter_table
from escfit.results import FitResult, load_fit

pytest.importorskip("matplotlib")
pytest.importorskip("jinja2")
pytest.importorskip("arviz")

ROOT = Path(__file__).resolve().parents[1]
HOSTILE = "<script>alert('tick')</script>"


def run(*args):
    res = CliRunner().invoke(cli, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res


@pytest.fixture(scope="session")
def fits(tmp_path_factory):
    """Results files of every family: least squares for balance (a hostile scene title),
    geneva and verge; short emcee runs for balance and the friction rig."""
    d = tmp_path_factory.mktemp("report_fits")
    scene = (ROOT / "datasets/monday1965/unit3_fit.toml").read_text()
    scene = re.sub(r'(?m)^title = .*$', f'title = "Unit 3 {HOSTILE}"', scene) + f"\n# notes {HOSTILE}\n"
    (d / "hostile.toml").write_text(scene)
    out = {"balance": d / "u3_lsq.h5", "balance_emcee": d / "u3_mc.h5", "friction_rig": d / "rig.h5",
           "geneva": d / "geneva.h5", "verge": d / "verge.h5"}
    run("fit", ROOT / "datasets/monday1965/synthetic/unit3.csv", "--scene", d / "hostile.toml", "--out",
        out["balance"], "--quiet")
    run("fit", ROOT / "fits/monday_unit3.toml", "--walkers", 12, "--steps", 60, "--burn", 20, "--out",
        out["balance_emcee"], "--quiet")
    run("fit", ROOT / "fits/friction_monday_steel.toml", "--walkers", 12, "--steps", 60, "--burn", 20, "--out",
        out["friction_rig"], "--quiet")
    run("fit", ROOT / "fits/geneva_terminal.toml", "--method", "leastsq", "--out", out["geneva"], "--quiet")
    run("fit", ROOT / "fits/verge_m739.toml", "--method", "leastsq", "--out", out["verge"], "--quiet")
    return out


@pytest.fixture(scope="session")
def html_reports(fits, tmp_path_factory):
    d = tmp_path_factory.mktemp("html")
    return {k: make_report(p, d / f"{k}.html").read_text(encoding="utf-8") for k, p in fits.items()}


# --- the display mapping -------------------------------------------------------------------


def test_angles_convert_by_180_over_pi_and_intervals_with_them():
    # closed forms: pi/3 rad is 60 deg, a full turn 360 deg, one radian 57.2957795... deg
    assert to_display(math.pi / 3, "rad", "oscillator.theta0") == (pytest.approx(60.0, rel=1e-15), "deg")
    ends, label = to_display(np.array([-2 * math.pi, 1.0]), "rad", "observation.lift_angle")
    assert label == "deg" and np.allclose(ends, [-360.0, 57.29577951308232], rtol=1e-15)
    assert to_display(0.01, "rad/s", "observation.offset_rate")[1] == "deg/s"


def test_unit_labels_people_read():
    assert to_display(981.4, "1/s**2", "coulomb.R") == (981.4, "rad/s^2")
    assert display_unit("1/s**2", "escapement[2].X") == "rad/s^2"
    assert to_display(15.78, "1/s", "oscillator.omega0") == (15.78, "rad/s")
    assert to_display(2.3, "1/s", "viscous.C") == (2.3, "1/s")
    assert to_display(0.1, "", "friction.mu") == (0.1, "dimensionless")
    # the friction rig's table reads in the rig's units: gram-force, inches, ft/s
    assert to_display(9.80665e-3, "N", "observation.sigma")[0] == pytest.approx(1.0)
    assert to_display(0.0254, "m", "rig.k") == (pytest.approx(1.0), "in")
    assert to_display(1.0, "1/N", "friction.mu_w") == (pytest.approx(9.80665e-3), "1/gf")
    assert to_display(1.0, "s/m", "friction.mu_v") == (pytest.approx(0.3048), "s/ft")
    assert to_display(None, "rad", "x") == (None, "deg")
    assert display_unit("kg*m**2") == "kg m^2" and display_unit("rad/s", "geneva.speed") == "rad/s"
    assert to_display(math.pi, "rad/s", "verge.spin") == (pytest.approx(30.0), "rpm")  # the source's spin unit


def test_loads_get_their_unit():
    meanings = {"coulomb.R[load=330.66]": "Coulomb friction ... opposes the motion at load 330.66 g"}
    assert load_unit(meanings) == "g"
    assert display_name("coulomb.R[load=330.66]", "g") == "coulomb.R[load=330.66 g]"
    assert curve_label("unit3 load 991.98", "g") == "unit3, 991.98 g"
    assert display_name("viscous.C", "g") == "viscous.C"


# --- the parameter table (report and command line) ----------------------------------------


def _shows(text: str, value: float) -> bool:
    """Whether ``text`` is ``value`` rounded to the digits it shows."""
    digits = len(text.split(".")[1]) if "." in text and "e" not in text else 0
    return abs(float(text) - value) <= 0.5 * 10.0 ** -digits * (1 + 1e-9) + 1e-12 * abs(value)


def test_least_squares_table_says_best_fit_with_display_units(fits):
    res = load_fit(fits["balance"])
    head, rows = parameter_table(res)
    assert head[2] == "best fit" and "median" not in head and "R-hat" not in head
    by_name = {r[0]: r for r in rows}
    r330 = by_name["coulomb.R[load=330.66 g]"]
    assert r330[1] == "rad/s^2"
    value = float(res.group("least_squares")["value"].sel(parameter="coulomb.R[load=330.66]"))
    assert _shows(r330[2], value)
    assert all("1/s**2" not in c for r in rows for c in r)


def test_posterior_table_shows_angles_in_degrees_and_labels_the_noise(fits, html_reports):
    res = load_fit(fits["balance_emcee"])
    head, rows = parameter_table(res)
    assert head[2] == "median"
    sigma = next(r for r in rows if r[0] == "observation.sigma")
    draws = res.group("posterior")["observation.sigma"].values.ravel()
    assert sigma[1] == "deg"
    assert _shows(sigma[2], math.degrees(float(np.median(draws))))
    lo95 = sigma[4].strip("[]").split(",")[0]
    assert _shows(lo95, math.degrees(float(np.quantile(draws, 0.025))))
    assert "reading noise, posterior" in sigma[-1]  # the note column
    html = html_reports["balance_emcee"]
    assert "Least-squares reading scatter" in html
    sigma_hat = float(res.group("least_squares").attrs["sigma_hat"])
    assert f"{math.degrees(sigma_hat):.3g} deg" in html


def test_command_line_table_uses_display_units(fits):
    out = run("summary", fits["balance_emcee"]).output
    header = next(line for line in out.splitlines() if line.startswith("parameter"))  # after the plain sentences
    assert "median" in header
    assert "rad/s^2" in out and "1/s**2" not in out
    assert re.search(r"observation\.sigma\s+deg\s", out)
    assert re.search(r"R-hat", out) and not re.search(r"\b1\.\d{4}\b", out.split("note:")[0])  # R-hat: 3 decimals
    # JSON keeps the stored units
    js = json.loads(run("summary", fits["balance_emcee"], "--json").output)
    assert js["parameters"]["observation.sigma"]["unit"] == "rad"


class _Rows:
    """A fit whose summary rows follow the documented contract (least squares, one on a bound)."""

    attrs = {"meanings": "{}"}

    def summary(self):
        row = {"unit": "rad", "estimate": 0.0, "estimate_kind": "best fit", "best_fit": 0.0, "at_bound": "min",
               "lo68": 0.0, "hi68": 0.01, "lo95": 0.0, "hi95": 0.02, "stderr": 0.01}
        return {"observation.offset": row, "coulomb.R": {**row, "unit": "1/s**2", "at_bound": None}}


def test_bound_flag_and_best_fit_from_the_summary_contract():
    head, rows = parameter_table(_Rows())
    assert head[2] == "best fit" and head[-1] == "note"
    # a zero offset on its lower bound is the centre of the swing (minus the offset) on its upper bound
    assert rows[0][0] == "centre [observation.offset]"
    assert rows[0][-1] == "at upper bound" and rows[0][1] == "deg"
    assert rows[0][4] == f"[{-math.degrees(0.02):.1f}, 0]"
    assert rows[1][-1] == "" and rows[1][1] == "rad/s^2"
    assert rows[1][4] == "[0, 0.020]"  # the last digit: the interval's width to two digits


# --- the page --------------------------------------------------------------------------------


def test_title_is_the_given_one_else_the_scene_one_escaped(fits, html_reports, tmp_path):
    given = make_report(fits["balance"], tmp_path / "t.html", title="Monday unit 3 & friends").read_text()
    assert "<title>Monday unit 3 &amp; friends</title>" in given and "<h1>Monday unit 3 &amp; friends</h1>" in given
    page = html_reports["balance"]  # no title given: the scene's, which holds a script tag
    assert "<h1>Unit 3 &lt;script&gt;alert(&#39;tick&#39;)&lt;/script&gt;</h1>" in page
    assert "<script>" not in page and "&lt;script&gt;" in page
    assert "unit3.csv" not in page.split("<h1>")[1].split("</h1>")[0]


def test_every_family_report_has_a_data_versus_model_figure(html_reports):
    for family, page in html_reports.items():
        found = re.search(r'<img alt="data and fit" src="data:image/png;base64,([A-Za-z0-9+/=]+)">\s*'
                          r"<figcaption>(.*?)</figcaption>", page, re.S)
        assert found, family
        import base64

        assert base64.b64decode(found.group(1))[:8] == b"\x89PNG\r\n\x1a\n", family
        assert "best fit" in found.group(2), family  # the caption says what the lines are
        assert "data curve" not in page


def test_sections_and_units_on_the_page(html_reports):
    page = html_reports["balance_emcee"]
    for section in ("Parameters", "Warnings", "Figures", "Sampler diagnostics", "Provenance", "Scene"):
        assert f"<h2>{section}" in page
    assert "rad/s^2" in page and "1/s**2" not in page.split("<h2>Provenance")[0]
    assert 'alt="corner plot"' in page and 'alt="trace plots"' in page
    assert "notch interval" in page and "error bar spans it" in page  # the bars are explained


def _png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_corner_plot_of_six_parameters_fits_the_page():
    from escfit.report.plots import report_figures

    rng = np.random.default_rng(0)
    names = ["oscillator.omega0", "oscillator.theta0", "viscous.C", "coulomb.R", "escapement[2].X",
             "observation.sigma"]
    units = {"oscillator.omega0": "1/s", "oscillator.theta0": "rad", "viscous.C": "1/s", "coulomb.R": "1/s**2",
             "escapement[2].X": "1/s**2", "observation.sigma": "rad"}
    post = xr.Dataset({n: (("chain", "draw"), rng.normal(1.0 + k, 0.1, (8, 150))) for k, n in enumerate(names)})
    tree = xr.DataTree.from_dict({"/posterior": post})
    tree.attrs.update(model="friction_rig", parameters=json.dumps(names), units=json.dumps(units), burn=50)
    figures, diagnostics = report_figures(FitResult(tree))
    width, height = _png_size(figures["corner plot"])
    assert 600 <= width <= 1000 and height <= 1000
    assert _png_size(diagnostics["trace plots"])[0] <= 1000


def test_markdown_writes_nothing_when_an_output_exists(fits, tmp_path):
    md = tmp_path / "r.md"
    make_report(fits["balance"], md, fmt="md")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.md", "r_data_and_fit.png", "r_decrement_per_half_swing.png"]
    text = md.read_text()
    assert "![data and fit](r_data_and_fit.png)" in text
    assert text.startswith("# Unit 3 &lt;script&gt;") and "<script>" not in text.split("## Scene")[0]
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    with pytest.raises(ResultsError, match="exists"):
        make_report(fits["balance"], md, fmt="md")
    # a new report whose figure file is in the way: refused before any file is written
    (tmp_path / "s_data_and_fit.png").write_bytes(b"keep")
    before["s_data_and_fit.png"] = (tmp_path / "s_data_and_fit.png").stat().st_mtime_ns
    with pytest.raises(ResultsError, match="exists"):
        make_report(fits["balance"], tmp_path / "s.md", fmt="md")
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == before
    assert (tmp_path / "s_data_and_fit.png").read_bytes() == b"keep"
