"""Geneva fits: mu (and K) with posteriors from a speed trace and from terminal speeds."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from escfit.core.errors import DataError, FitError
from escfit.geneva.inference import (GenevaProblem, SpeedTrace, TerminalSpeeds, fit_least_squares,
                                     sample_posterior, synthetic_trace)
from escfit.geneva.tables import meyer_table
from escfit.core.scene import load_scene

LBF_IN = 0.1129848290276167


def scene(mu="0.20", torque='"0.08 lbf*inch"'):
    return load_scene("fit.toml", text=f"""
model = "geneva"
[geneva]
slots = 4
driver_inertia = "3e-6 lbf*inch*s^2"
follower_inertia = "50e-6 lbf*inch*s^2"
torque = {torque}
mu = {mu}
""")


FREE_MU = '{ value = 0.3, vary = true, prior = "uniform(0, 0.6)" }'
FREE_K = '{ value = "0.06 lbf*inch", vary = true, prior = "loguniform(1e-3, 1e-1)" }'


def interval(idata, name, level=0.95):
    x = idata.posterior[name].values.ravel()
    return np.quantile(x, [(1 - level) / 2, (1 + level) / 2])


@pytest.fixture(autouse=True)
def quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def test_speed_trace_recovers_mu_and_torque():
    truth = scene()
    trace = synthetic_trace(truth, duration=0.1, interval=5e-4, sd=1.0, seed=3)
    problem = GenevaProblem(scene(FREE_MU, FREE_K), trace)
    lsq = fit_least_squares(problem)
    assert lsq.values["geneva.mu"] == pytest.approx(0.20, abs=4 * lsq.stderr["geneva.mu"])
    idata = sample_posterior(problem, start=lsq, nwalkers=8, nsteps=200, burn=60, seed=5)
    post = idata.posterior
    assert post["geneva.mu"].dims == ("chain", "draw") and post.sizes["chain"] == 8
    lo, hi = interval(idata, "geneva.mu")
    assert lo < 0.20 < hi and hi - lo < 0.01
    lo, hi = interval(idata, "geneva.torque")
    assert lo < 0.08 * LBF_IN < hi
    assert post.attrs["seed"] == 5 and post.attrs["noise_sd"] == 1.0
    assert "uniform(0, 0.6)" in post["geneva.mu"].attrs["prior"]
    assert idata.observed_data["speed"].size == trace.speed.size


def test_terminal_speeds_recover_mu_and_torque_scale():
    truth = 0.27
    ks = np.array([0.06, 0.09, 0.12, 0.15]) * LBF_IN
    from escfit.geneva import Geometry
    from escfit.geneva.simulate import forward

    vals = scene().params.values()
    peaks, mins = [], []
    for k in ks:
        term = forward(Geometry(4), {**vals, "geneva.mu": truth, "geneva.torque": 1.1 * k}, duration=0.01,
                       sample_times=np.array([0.0])).terminal
        peaks.append(term.peak_speed)
        mins.append(term.min_speed)
    rng = np.random.default_rng(11)
    data = TerminalSpeeds(ks, np.array(peaks) + rng.normal(0, 0.3, 4), np.array(mins) + rng.normal(0, 0.3, 4), 0.3,
                          "synthetic terminal speeds")
    problem = GenevaProblem(scene(FREE_MU), data, torque_scale="uniform(0.5, 2)")
    idata = sample_posterior(problem, nwalkers=8, nsteps=200, burn=60)
    lo, hi = interval(idata, "geneva.mu")
    assert lo < truth < hi
    lo, hi = interval(idata, "geneva.torque_scale")
    assert lo < 1.1 < hi


def test_meyer_four_pin_table_gives_back_his_mu():
    tab = meyer_table("four_pin")
    for mu in (0.20, 0.25, 0.35):
        sel = np.isclose(tab["mu"], mu)
        data = TerminalSpeeds(tab["K"][sel], tab["peak_speed"][sel], tab["min_speed"][sel], None, f"Meyer mu={mu}")
        fit = fit_least_squares(GenevaProblem(scene(FREE_MU), data))
        assert fit.sd_estimated and fit.sd < 1.5
        assert fit.values["geneva.mu"] == pytest.approx(mu, abs=0.01)


def test_same_seed_same_draws():
    data = TerminalSpeeds(np.array([0.08, 0.12]) * LBF_IN, np.array([155.0, 190.0]), np.array([19.0, 23.0]), 1.0)
    problem = GenevaProblem(scene(FREE_MU), data)
    a = sample_posterior(problem, nwalkers=4, nsteps=12, burn=2, seed=7)
    b = sample_posterior(problem, nwalkers=4, nsteps=12, burn=2, seed=7)
    np.testing.assert_array_equal(a.posterior["geneva.mu"], b.posterior["geneva.mu"])


def test_fit_setup_errors():
    data = TerminalSpeeds(np.array([0.009]), np.array([155.0]), np.array([19.0]), 1.0)
    with pytest.raises(FitError, match="no free parameter"):
        GenevaProblem(scene(), data)
    with pytest.raises(FitError, match="torque_scale instead"):
        GenevaProblem(scene(FREE_MU, FREE_K), data)
    with pytest.raises(FitError, match="finite min and max"):
        GenevaProblem(scene("{ value = 0.2, vary = true }"), data)
    with pytest.raises(DataError, match="strictly increasing"):
        SpeedTrace(np.array([0.0, 0.2, 0.1]), np.zeros(3), 1.0, "t.csv")
    with pytest.raises(DataError, match="t.csv: sd must be positive"):
        SpeedTrace(np.array([0.0, 0.1, 0.2]), np.zeros(3), -1.0, "t.csv")
    with pytest.raises(FitError, match="nwalkers"):
        sample_posterior(GenevaProblem(scene(FREE_MU), data), nwalkers=1)
