"""Geneva fits on the one inference layer: readers, the fit problem, the shipped examples, Meyer's numbers.

References are independent of the fit: the truth of a simulation (the shipped trace is made by
datasets/geneva/make_trace.py from four_pin.toml: mu = 0.20, K = 0.08 lbf*inch, noise sd 1 rad/s),
Meyer's printed friction coefficients (Appendix E), the closed-form sqrt(K) scaling of terminal
speeds, and the adaptive DOP853 integrator for the rk4 the fits use.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.core.errors import DataError, FitError, SceneError
from escfit.core.scene import load_scene
from escfit.geneva import Geometry
from escfit.geneva.data import (SpeedTrace, TerminalSpeeds, detect_format, read_speed_trace, read_terminal_speeds,
                                write_speed_trace)
from escfit.geneva.family import FAMILY
from escfit.geneva.problem import FAIL_RESIDUAL, GenevaProblem
from escfit.geneva.simulate import forward
from escfit.geneva.synthetic import synthetic_trace
from escfit.inference import fit, least_squares
from escfit.results import load_fit

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "datasets" / "geneva"
FITS = ROOT / "fits"
LBF_IN = 0.1129848290276167  # N*m per lbf*inch
TRACE_TRUTH = {"geneva.mu": 0.20, "geneva.torque": 0.08 * LBF_IN, "observation.sigma": 1.0}

HEAD = """model = "geneva"
[geneva]
slots = 4
driver_inertia = "3e-6 lbf*inch*s^2"
follower_inertia = "50e-6 lbf*inch*s^2"
"""
FREE_MU = '{ value = 0.3, vary = true, prior = "uniform(0, 0.6)" }'
FREE_SIGMA = '[observation]\nsigma = { value = 1.0, vary = true, prior = "loguniform(0.01, 100)" }\n'


def scene(mu=FREE_MU, torque='"0.08 lbf*inch"', tail=""):
    return load_scene("fit.toml", text=HEAD + f"torque = {torque}\nmu = {mu}\n" + tail)


def run(*args):
    res = CliRunner().invoke(cli, [str(a) for a in args])
    assert res.exit_code == 0, res.output + repr(res.exception)
    return res


@pytest.fixture(autouse=True)
def quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


# -- readers ---------------------------------------------------------------------------------------------------
def test_shipped_trace_is_what_make_trace_makes():
    """The committed CSV is the generator's output (reading back what the writer wrote).

    The sample times are exact (multiples of 0.5 ms, computed the same way everywhere).  The
    speeds come from scipy's DOP853 at rtol 1e-11, whose rounding changes with the numpy and
    scipy versions: regenerated under numpy 2.4.6 / scipy 1.17.1 they differed from the file
    by up to 8.8e-11 of themselves (1.2e-8 rad/s).  They are compared to 1e-8 of themselves
    and 1e-6 rad/s: a hundred times that rounding, and a million times below the trace's
    noise (sd 1 rad/s), so another seed, noise level, scene or model still fails by far.
    """
    data = read_speed_trace(DATA / "synthetic_four_pin_trace.csv")
    made = synthetic_trace(load_scene(DATA / "four_pin.toml"), duration=0.1, interval=5e-4, sd=1.0, seed=1973)
    np.testing.assert_array_equal(data.time, made.time)
    np.testing.assert_allclose(data.speed, made.speed, rtol=1e-8, atol=1e-6)
    assert data.sd is None and data.meta["truth"].startswith("four_pin.toml, mu = 0.20")
    assert detect_format(DATA / "synthetic_four_pin_trace.csv") == "speed-trace"
    assert detect_format(DATA / "meyer1973_four_pin_mu020.csv") == "terminal-speeds"


def test_readers_convert_units_and_round_trip(tmp_path):
    p = tmp_path / "rpm.csv"
    p.write_text("# a trace in other units\ntime [ms],speed [rpm],sd [deg/s]\n0,0,6\n1,60,6\n2,120,6\n")
    tr = read_speed_trace(p)
    np.testing.assert_allclose(tr.time, [0, 1e-3, 2e-3], rtol=1e-15)
    np.testing.assert_allclose(tr.speed, [0, 2 * math.pi, 4 * math.pi], rtol=1e-15)  # 60 rpm = 2 pi rad/s
    np.testing.assert_allclose(tr.sd, math.radians(6), rtol=1e-15)
    out = tmp_path / "out.csv"
    write_speed_trace(out, tr)
    back = read_speed_trace(out)
    for a, b in ((back.time, tr.time), (back.speed, tr.speed), (back.sd, tr.sd)):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(Exception, match="exists"):
        write_speed_trace(out, tr)
    meyer = read_terminal_speeds(DATA / "meyer1973_four_pin_mu020.csv")
    np.testing.assert_allclose(meyer.torque, np.array([0.08, 0.10, 0.12, 0.14]) * LBF_IN, rtol=1e-12)
    np.testing.assert_array_equal(meyer.peak, [155, 174, 191, 206])
    np.testing.assert_array_equal(meyer.minimum, [19, 21, 23, 25])
    assert meyer.meta["source"].startswith("H. W. Meyer")


@pytest.mark.parametrize("text, where, match", [
    ("time [s],speed [rad/s]\n0,0\n0.2,1\n0.1,2\n", ":4 [time [s]]", "strictly increasing"),
    ("time [s],speed [rad/s]\n0,0\n0.1,x\n0.2,2\n", ":3 [speed [rad/s]]", "expected a number"),
    ("time [s],speed [m/s]\n0,0\n0.1,1\n0.2,2\n", ":1", "not an angular speed"),
    ("time,speed [rad/s]\n0,0\n0.1,1\n0.2,2\n", ":1", "name \\[unit\\]"),
    ("# c\ntime [s],speed [rad/s],sd [rad/s]\n0,0,1\n0.1,1,0\n0.2,2,1\n", ":4 [sd [rad/s]]", "must be positive"),
    ("time [s],speed [rad/s],volts [V]\n0,0,1\n", ":1", "unknown column 'volts'"),
])
def test_trace_reader_names_file_line_and_column(tmp_path, text, where, match):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(DataError, match=match) as err:
        read_speed_trace(p)
    assert str(err.value).startswith(f"{p}{where}")


def test_terminal_reader_and_detection_refuse_bad_files(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("K [lbf*inch],peak_speed [rad/s],min_speed [rad/s]\n0.08,155,19\n0.10,20,21\n")
    with pytest.raises(DataError, match="exceeds peak_speed") as err:
        read_terminal_speeds(p)
    assert str(err.value).startswith(f"{p}:3 [min_speed [rad/s]]")
    p.write_text("K [s],peak_speed [rad/s],min_speed [rad/s]\n0.08,155,19\n")
    with pytest.raises(DataError, match="'K': unit 's' is not a torque"):
        read_terminal_speeds(p)
    p.write_text("a [1],b [1]\n1,2\n")
    with pytest.raises(DataError, match="not a Geneva recording") as err:
        FAMILY.detect(p)
    assert str(err.value).startswith(f"{p}:1")
    with pytest.raises(DataError, match="sd must be positive"):
        SpeedTrace(np.array([0.0, 0.1, 0.2]), np.zeros(3), -1.0, "t.csv")


# -- the fit problem --------------------------------------------------------------------------------------------
def test_terminal_speeds_follow_sqrt_k_exactly_and_match_dop853():
    """One rk4 terminal cycle scaled by sqrt(K/I_f) against DOP853 runs at each torque."""
    ks = np.array([0.02, 0.08]) * LBF_IN  # 4x apart: speeds exactly 2x apart
    data = TerminalSpeeds(ks, np.array([50.0, 100.0]), np.array([5.0, 10.0]), 1.0, "k.csv")
    prob = GenevaProblem(scene(), data)
    vals = prob.values({"geneva.mu": 0.27})
    e = prob.expected(vals)
    assert e[1] / e[0] == pytest.approx(2.0, rel=1e-13) and e[3] / e[2] == pytest.approx(2.0, rel=1e-13)
    for i, k in enumerate(ks):
        term = forward(Geometry(4), {**vals, "geneva.torque": k}, duration=0.01, sample_times=np.array([0.0]),
                       solver="dop853").terminal
        assert e[i] == pytest.approx(term.peak_speed, rel=1e-6)
        assert e[2 + i] == pytest.approx(term.min_speed, rel=1e-6)
    assert prob.obs_coords()["curve"][1].tolist() == ["peak", "peak", "minimum", "minimum"]
    assert prob.obs_coords()["x"][2]["units"] == "N*m" and prob.noise_source == "data"


def test_locked_pin_is_counted_not_raised():
    """Four-pin with mu >= 0.5 locks (the pin jams): -inf, residuals 1e6, the reason counted."""
    trace = synthetic_trace(scene(0.2), duration=0.1, interval=2e-3, sd=1.0, seed=1)  # locks at 0.056 s
    wide = '{ value = 0.3, vary = true, prior = "uniform(0, 1)" }'
    for data in (trace, read_terminal_speeds(DATA / "meyer1973_four_pin_mu020.csv")):
        prob = GenevaProblem(scene(wide, tail=FREE_SIGMA), data)
        assert prob.log_prob(np.array([0.7, 1.0])) == -math.inf
        assert prob.failures == {"locked": 1}
        r = prob.residuals(prob.values(np.array([0.7, 1.0])))
        assert r.shape == (prob.n_data,) and np.all(r == FAIL_RESIDUAL) and prob.failures["locked"] == 2
        assert prob.log_prob(np.array([1.5, 1.0])) == -math.inf and prob.failures["locked"] == 2  # outside the prior
        assert math.isfinite(prob.log_prob(np.array([0.2, 1.0])))


def test_setup_errors_name_the_key():
    data = TerminalSpeeds(np.array([0.009]), np.array([155.0]), np.array([19.0]), 1.0)
    with pytest.raises(FitError, match="no free parameters"):
        GenevaProblem(scene("0.2"), data)
    with pytest.raises(FitError, match="torque_scale"):
        GenevaProblem(scene(torque='{ value = "0.06 lbf*inch", vary = true, min = 0.001, max = 0.1 }'), data)
    with pytest.raises(SceneError, match=r"\[geneva.mu\].*no prior"):
        GenevaProblem(scene("{ value = 0.2, vary = true }"), data)
    with pytest.raises(SceneError, match=r"\[observation\].*unknown key\(s\) \['noise'\]"):
        GenevaProblem(scene(tail='[observation]\nsigma = 1.0\nnoise = "ar1"\n'), data)
    nosd = TerminalSpeeds(np.array([0.009]), np.array([155.0]), np.array([19.0]))
    with pytest.raises(SceneError, match=r"\[observation\].sigma: the readings carry no sd"):
        GenevaProblem(scene(), nosd)
    whole = read_terminal_speeds(DATA / "meyer1973_four_pin.csv")
    with pytest.raises(FitError, match=r"several mu.*\[fit\] table_mu") as err:
        GenevaProblem(scene(tail=FREE_SIGMA), whole)
    assert "meyer1973_four_pin.csv" in str(err.value)
    with pytest.raises(SceneError, match=r"\[fit\].table_mu: no run has mu = 0.22"):
        GenevaProblem(scene(tail=FREE_SIGMA + "[fit]\ntable_mu = 0.22\n"), whole)
    with pytest.raises(SceneError, match=r"\[fit\].*terminal-speed data only"):
        GenevaProblem(scene(tail="[fit]\ntable_mu = 0.2\n"), synthetic_trace(scene("0.2"), duration=0.01,
                                                                              interval=1e-3, sd=1.0))
    with pytest.raises(FitError, match=r"no option\(s\) \['solver'\]"):
        FAMILY.problem(scene(), data, solver="rk4")


# -- Meyer's published numbers -------------------------------------------------------------------------------
@pytest.mark.parametrize("mu", [0.20, 0.25, 0.30, 0.35])
def test_meyer_four_pin_table_gives_back_his_mu(mu):
    """Each run family of his four-pin table (inertias as printed) gives his mu back within 0.01.

    The residual scatter is that of speeds printed to whole rad/s (rounding alone: sd 0.29), under
    1.5 rad/s even for mu 0.30, which holds his probable misprint (peak 128 at K 0.10, docs/geneva.md).
    """
    prob = GenevaProblem(scene(tail=FREE_SIGMA + f"[fit]\ntable_mu = {mu}\n"), read_terminal_speeds(
        DATA / "meyer1973_four_pin.csv"))
    assert prob.n_data == 2 * (5 if mu == 0.35 else 4)
    lsq = least_squares(prob, **{k: FAMILY.fit_defaults[k] for k in ("n_starts", "n_refine")}, seed=1973)
    assert lsq.values["geneva.mu"] == pytest.approx(mu, abs=0.01)
    assert lsq.sigma_hat < 1.5


def test_shipped_terminal_example_leastsq(tmp_path):
    out = tmp_path / "t.h5"
    res = run("fit", FITS / "geneva_terminal.toml", "--method", "leastsq", "--out", out)
    assert "geneva.mu" in res.output
    fitted = load_fit(out)
    lsq = fitted.group("least_squares")
    mu, se = float(lsq["value"].sel(parameter="geneva.mu")), float(lsq["stderr"].sel(parameter="geneva.mu"))
    assert mu == pytest.approx(0.20, abs=0.002) and abs(mu - 0.20) < 1.96 * se  # Meyer's printed mu
    # the scatter: rounding to whole rad/s alone gives 0.29; with 7 degrees of freedom the estimate of such
    # noise lies in [0.14, 0.41] with 95 % probability
    assert 0.14 < lsq.attrs["sigma_hat"] < 0.41
    assert fitted.attrs["model"] == "geneva" and fitted.attrs["data_kind"] == "terminal-speeds"


# -- the shipped trace example through the CLI -----------------------------------------------------------------
@pytest.fixture(scope="module")
def trace_fit(tmp_path_factory):
    out = tmp_path_factory.mktemp("trace") / "trace.h5"
    run("fit", FITS / "geneva_trace.toml", "--out", out, "--walkers", 8, "--steps", 200, "--quiet")
    return out


def test_shipped_trace_example_leastsq_contains_truth(tmp_path):
    out = tmp_path / "a.h5"
    run("fit", FITS / "geneva_trace.toml", "--method", "leastsq", "--out", out)
    lsq = load_fit(out).group("least_squares")
    for name in ("geneva.mu", "geneva.torque"):
        v, se = float(lsq["value"].sel(parameter=name)), float(lsq["stderr"].sel(parameter=name))
        assert abs(v - TRACE_TRUTH[name]) < 1.96 * se, (name, v, se)
    assert lsq.attrs["sigma_hat"] == pytest.approx(1.0, abs=0.1)  # 201 readings: sd of the estimate 0.05


def test_shipped_trace_example_emcee_summary_and_report(trace_fit, tmp_path):
    res = run("summary", trace_fit, "--json")
    js = json.loads(res.output)
    params = js["parameters"]
    assert list(params) == ["geneva.torque", "geneva.mu", "observation.sigma", "geneva.time_scale"]
    assert {n: p["unit"] for n, p in params.items()} == {"geneva.torque": "N*m", "geneva.mu": "",
                                                        "observation.sigma": "rad/s", "geneva.time_scale": "s"}
    # derived: the time scale sqrt(I_f/K) of the true mechanism, 0.025 s
    i_f = 50e-6 * LBF_IN
    assert params["geneva.time_scale"]["lo95"] < math.sqrt(i_f / TRACE_TRUTH["geneva.torque"]) < \
        params["geneva.time_scale"]["hi95"]
    for name, true in TRACE_TRUTH.items():
        assert params[name]["lo95"] < true < params[name]["hi95"], (name, params[name])
    assert params["geneva.mu"]["hi95"] - params["geneva.mu"]["lo95"] < 0.005
    assert js["method"] == "emcee" and js["data_file"].endswith("synthetic_four_pin_trace.csv")
    fitted = load_fit(trace_fit)
    assert fitted.group("posterior").sizes == {"chain": 8, "draw": 150}  # the first quarter of 200 steps discarded
    assert fitted.attrs["moves"] == "de-t" and fitted.attrs["data_sha256"]
    html = tmp_path / "r.html"
    run("report", trace_fit, "--out", html)
    text = html.read_text(encoding="utf-8")
    assert all(n in text for n in TRACE_TRUTH)


def test_interrupted_emcee_run_resumes_to_the_same_draws(tmp_path, monkeypatch):
    args = [FITS / "geneva_trace.toml", "--walkers", 8, "--steps", 40, "--seed", 5, "--quiet"]
    whole = tmp_path / "whole.h5"
    run("fit", *args, "--out", whole)
    out = tmp_path / "cut.h5"
    calls = {"n": 0}
    original = GenevaProblem.log_prob

    def dying(self, vec):
        calls["n"] += 1
        if calls["n"] > 8 + 8 + 8 * 15 + 3:  # walker placement, first log probs, 15 steps, then part of one
            raise KeyboardInterrupt
        return original(self, vec)

    monkeypatch.setattr(GenevaProblem, "log_prob", dying)
    res = CliRunner().invoke(cli, ["fit", *map(str, args), "--out", str(out)])
    assert res.exit_code != 0
    monkeypatch.setattr(GenevaProblem, "log_prob", original)
    assert not out.exists() and Path(f"{out}.emcee").exists()
    refused = CliRunner().invoke(cli, ["fit", *map(str, args), "--out", str(out)])
    assert refused.exit_code == 2 and "--resume" in refused.output
    run("fit", *args, "--out", out, "--resume")
    a, b = load_fit(out), load_fit(whole)
    assert a.attrs["resumed"] == 1 and a.group("posterior").sizes == {"chain": 8, "draw": 30}  # 40 steps, a quarter burnt
    for name in TRACE_TRUTH:
        np.testing.assert_array_equal(a.group("posterior")[name].values, b.group("posterior")[name].values)
    assert not Path(f"{out}.emcee").exists()


# -- recovery from synthetic terminal speeds ------------------------------------------------------------------
def test_terminal_speeds_recover_mu_and_torque_scale(tmp_path):
    """Synthetic terminal speeds (DOP853) at mu 0.27 with torques 1.1x the nominal, known sd 0.3 rad/s."""
    truth = {"geneva.mu": 0.27, "geneva.torque_scale": 1.1}
    ks = np.array([0.06, 0.09, 0.12, 0.15]) * LBF_IN
    vals = scene("0.2").params.values()
    terms = [forward(Geometry(4), {**vals, "geneva.mu": 0.27, "geneva.torque": 1.1 * k}, duration=0.01,
                     sample_times=np.array([0.0]), solver="dop853").terminal for k in ks]
    rng = np.random.default_rng(11)
    peak = np.array([t.peak_speed for t in terms]) + rng.normal(0, 0.3, 4)
    low = np.array([t.min_speed for t in terms]) + rng.normal(0, 0.3, 4)
    path = tmp_path / "terminal.csv"
    path.write_text("torque [N*m],peak_speed [rad/s],min_speed [rad/s],sd [rad/s]\n"
                    + "".join(f"{float(k)!r},{float(p)!r},{float(m)!r},0.3\n" for k, p, m in zip(ks, peak, low)))
    sc = scene(tail='[fit]\ntorque_scale = { value = 1.0, vary = true, prior = "uniform(0.5, 2)" }\n')
    res = fit(sc, path, method="emcee", walkers=8, steps=300, seed=3, moves="de")
    assert res.attrs["noise_source"] == "data"
    lsq = res.group("least_squares")
    s = res.summary()
    for name, true in truth.items():
        v, se = float(lsq["value"].sel(parameter=name)), float(lsq["stderr"].sel(parameter=name))
        assert abs(v - true) < 1.96 * se, (name, v, se)
        assert s[name]["lo95"] < true < s[name]["hi95"], (name, s[name])
    assert "observation.sigma" not in s and lsq.attrs["noise_profiled"] == 0  # known noise: no rescaling

