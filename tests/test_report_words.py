"""Reports in the words and numbers people use: plain names, held values, digits, derived
quantities, one sign for the centre, counts in words, captions true to what is drawn.

References are independent of the report code: the simulator for the amplitude lost in a half
swing, the truth of a synthetic record for the centre, Q and the decrement, hand-worked numbers
for the rounding.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from escfit.core.display import format_row
from escfit.core.names import plain_name
from escfit.balance.derived import half_swing_loss

pytest.importorskip("matplotlib")
pytest.importorskip("jinja2")


def test_digits_follow_the_interval_width():
    assert format_row(2029.03, (2024.1, 2034.8)) == ("2029", ["2024", "2035"])
    assert format_row(2.3493, (2.2353, 2.4476)) == ("2.35", ["2.24", "2.45"])
    assert format_row(1.4741, (0.6885, 2.7649)) == ("1.5", ["0.7", "2.8"])  # no 0.99169 beside 2029
    assert format_row(7.253e-5, (6.0e-5, 8.1e-5)) == ("7.3e-05", ["6.0e-05", "8.1e-05"])  # last digit 1e-6
    assert format_row(-1e-9, (-0.0043, 0.0041)) == ("0.0000", ["-0.0043", "0.0041"])  # no "-0.0000"
    assert format_row(4119.339) == ("4119.34", [])  # a held value: six significant digits


def test_plain_names_with_symbols():
    assert plain_name("viscous.C") == "viscous damping C"
    assert plain_name("coulomb.R[load=330.66]", loads_in="g") == "Coulomb friction R at 330.66 g"
    assert plain_name("escapement[2].X", "impulse torque per inertia of window 2") == "impulse torque X2 (window 2)"
    assert plain_name("escapement[1].X", "unlock torque per inertia of window 1") == "unlocking torque X1 (window 1)"
    assert plain_name("verge.phi_cut", "cumulative escape-wheel angle at which the rotor leaves the train, rad") == \
        "cumulative escape-wheel angle at which the rotor leaves the train"


def test_half_swing_loss_is_the_simulators(make_scene):
    """The closed form of the derived table against the piecewise-exact solver."""
    from escfit import simulate

    for c, r in ((0.3, 0.0), (0.0, 4.0), (0.3, 4.0)):
        effects = f"[effects.viscous]\nC = {c}\n[effects.coulomb]\nR = {r}\n"
        scene = make_scene(omega0=10.0, theta0=1.2, swings=3, effects=effects)
        amp = simulate(scene)["amplitude"].values
        assert float(half_swing_loss(1.2, 10.0, c, r)) == pytest.approx(1.2 - amp[0], rel=1e-9)
        assert float(half_swing_loss(amp[0], 10.0, c, r)) == pytest.approx(amp[0] - amp[1], rel=1e-9)


@pytest.fixture(scope="module")
def decay_fit(tmp_path_factory):
    """Least squares of a synthetic spring decay with a sensor centred at +0.5 deg drifting at -0.02 deg/s."""
    from escfit.balance.synthetic.instruments import record_timeseries
    from escfit.core.scene import load_scene
    from escfit.inference import fit

    d = tmp_path_factory.mktemp("words")
    truth = d / "truth.toml"
    truth.write_text('model = "balance"\n[oscillator]\nomega0 = 6.0\ntheta0 = 0.5\ninertia = "2e-4 kg*m^2"\n'
                     "[run]\nswings = 24\n[effects.viscous]\nC = 0.08\n[effects.coulomb]\nR = 0.05\n")
    ts = record_timeseries(load_scene(truth), rate_hz=40.0, sigma=math.radians(0.1), seed=4)
    theta = ts.theta + math.radians(0.5) - math.radians(0.02) * ts.time
    data = d / "decay.csv"
    data.write_text("time_s,theta_deg\n" + "\n".join(f"{t:.4f},{math.degrees(x):.5f}" for t, x in zip(ts.time, theta)))
    scene = d / "fit.toml"
    scene.write_text('model = "balance"\n[oscillator]\ninertia = "2e-4 kg*m^2"\n'
                     "omega0 = { value = 6.1, vary = true, min = 5, max = 7 }\n"
                     "[effects.viscous]\nC = { value = 0.05, vary = true, min = 0, max = 1 }\n"
                     "[effects.coulomb]\nR = { value = 0.02, vary = true, min = 0, max = 1 }\n"
                     '[observation]\nmodel = "waveform"\n')
    out = d / "fit.h5"
    fit(scene, str(data), out=out, n_starts=2)
    from escfit.results import load_fit

    return load_fit(out)


def _row(rows, name):
    return next(r for r in rows if r[-1] == name)


def _interval(text):
    lo, hi = (float(x) for x in text.strip("[]").split(","))
    return lo, hi


def test_centre_and_drift_have_the_sign_of_the_record(decay_fit):
    from escfit.report import parameter_table

    head, rows = parameter_table(decay_fit, plain=True)
    centre, drift = _row(rows, "observation.offset"), _row(rows, "observation.offset_rate")
    assert centre[0].startswith("centre of the swing") and drift[0].startswith("drift of the centre")
    lo, hi = _interval(centre[4])
    assert lo <= 0.5 <= hi  # the truth: +0.5 deg on the sensor's scale
    lo, hi = _interval(drift[4])
    assert lo <= -0.02 <= hi and float(drift[2]) < 0  # drifting down, as the truth and the record's note say
    notes = " ".join(decay_fit.notes)
    if "drifts by" in notes:
        assert "(-" in notes.split("drifts by")[1][:40]


def test_fit_paragraph_counts_the_table_rows(decay_fit):
    from escfit.report import parameter_table
    from escfit.report.tables import fit_statistics

    head, rows = parameter_table(decay_fit, plain=True)
    text = fit_statistics(decay_fit)
    assert f"{len(rows)} parameters fitted by least squares" in text
    assert "emcee" not in text and text.startswith("Balance wheel (spring) model")


def test_derived_quantities_cover_the_truth_and_use_the_inertia(decay_fit):
    from escfit.report.quantities import derived_rows

    head, rows, note = derived_rows(decay_fit)
    by = {r[0]: r for r in rows}
    q = by["quality factor Q (viscous damping alone)"]
    lo, hi = _interval(q[3])
    assert lo <= 6.0 / 0.08 <= hi  # omega0 / C of the truth
    lam = by["logarithmic decrement per period Λ (viscous)"]
    lo, hi = _interval(lam[3])
    assert lo <= math.pi * 0.08 / math.sqrt(36 - 0.0016) <= hi
    coulomb = by["amplitude lost per half swing to Coulomb friction"]
    lo, hi = _interval(coulomb[3])
    assert lo <= math.degrees(2 * 0.05 / 36) <= hi and coulomb[1] == "deg"
    torque = by["Coulomb friction torque"]
    lo, hi = _interval(torque[3])
    assert torque[1] == "N m" and lo <= 0.05 * 2e-4 <= hi
    assert "I = 0.0002 kg m²" in note


def test_held_parameters_are_listed_with_their_values(tmp_path):
    """Monday's unit 3: omega0, theta0 and both escapement torques are held by the scene."""
    from click.testing import CliRunner

    from escfit.cli.main import cli
    from escfit.report.params import held_table
    from escfit.results import load_fit

    from .conftest import DATASETS

    out = tmp_path / "u3.h5"
    res = CliRunner().invoke(cli, ["fit", str(DATASETS / "monday1965/synthetic/unit3.csv"), "--scene",
                                   str(DATASETS / "monday1965/unit3_fit.toml"), "--out", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    fit = load_fit(out)
    head, rows = held_table(fit)
    held = {r[-1]: r for r in rows}
    assert held["escapement[2].X"][0] == ("impulse torque X2 (window 2) at the reference load 330.66 g, in proportion "
                                          "to the load") and held["escapement[2].X"][2] == "4119.34"
    assert held["oscillator.omega0"][2] == "15.78" and held["oscillator.theta0"][1] == "deg"
    assert json.loads(fit.attrs["held"])["escapement[1].X"] == pytest.approx(473.07)


def test_failures_are_counted_in_words():
    from escfit.report.tables import failures_text

    class Fit:
        attrs = {"failures": json.dumps({"locked": 8, "non-finite likelihood": 1}), "method": "leastsq"}

    text = failures_text(Fit())
    assert text.startswith("9 parameter sets tried by the optimiser gave no prediction")
    assert "8 times: the pin jams in the slot" in text and "{" not in text


def test_one_curve_caption_and_legend_say_one_curve(decay_fit):
    from escfit.report.plots import report_figures

    figures, _ = report_figures(decay_fit)
    caption = figures["amplitude per swing"].caption
    assert "One colour per curve" not in caption
    assert "sensor's scale" in figures["data and fit"].caption


def test_corner_plot_keeps_all_nine_parameters_of_a_waveform_fit():
    """ArviZ draws at most 40 panels unless told: a 9-parameter corner plot (81 panels) crashed the report."""
    import xarray as xr

    from escfit.report.plots import report_figures
    from escfit.results import FitResult

    names = ["oscillator.omega0", "oscillator.theta0", "viscous.C", "coulomb.R", "observation.sigma",
             "observation.offset", "observation.offset_rate", "observation.rho", "observation.t_release"]
    units = dict(zip(names, ["1/s", "rad", "1/s", "1/s**2", "rad", "rad", "rad/s", "", "s"]))
    rng = np.random.default_rng(1)
    post = xr.Dataset({n: (("chain", "draw"), rng.normal(1.0 + k, 0.1, (4, 100))) for k, n in enumerate(names)})
    tree = xr.DataTree.from_dict({"/posterior": post})
    tree.attrs.update(model="friction_rig", parameters=json.dumps(names), units=json.dumps(units), burn=10)
    figures, _ = report_figures(FitResult(tree))
    assert figures["corner plot"][:8] == b"\x89PNG\r\n\x1a\n"
