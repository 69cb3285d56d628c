"""Least-squares results say what the readings determine: bounded intervals, parameters on a bound,
underdetermined and singular fits, correlations, the summary rows, Monday's phase convention at
several loads."""

from __future__ import annotations

import math
import warnings
from collections import Counter

import numpy as np
import pytest
from scipy.stats import norm

from escfit.core.errors import FitError
from escfit.inference import least_squares, profile
from escfit.inference.fit import fit_problem
from escfit.inference.lsq import bounded_interval
from escfit.likelihood.priors import Prior
from escfit.likelihood.problem import ProblemBase
from escfit.results import load_fit

Z95 = norm.ppf(0.975)


class ToyProblem(ProblemBase):
    """Readings ``y_i = model(x, t_i) + e_i`` with known Gaussian noise ``sigma``, flat priors on bounds."""

    family = "toy"
    reading_units = "rad"

    def __init__(self, model, t, y, sigma, names, lower, upper, initial, data_file="toy.csv"):
        self.model, self.t, self.y, self.sigma = model, np.asarray(t, float), np.asarray(y, float), sigma
        self.names = list(names)
        self.priors = [Prior("uniform", (a, b), a, b) if math.isfinite(a) and math.isfinite(b)
                       else Prior("flat", (), a, b) for a, b in zip(lower, upper)]
        self._lower, self._upper = np.asarray(lower, float), np.asarray(upper, float)
        self._initial = np.asarray(initial, float)
        self.failures = Counter()
        self.notes, self.data_warnings = [], []
        self.data_file = data_file

    initial = property(lambda self: self._initial)
    bounds = property(lambda self: (self._lower, self._upper))
    observed = property(lambda self: self.y)
    units = property(lambda self: {n: "1/s" for n in self.names})
    meanings = property(lambda self: {n: n for n in self.names})

    def values(self, vec):
        if isinstance(vec, dict):
            return {**dict(zip(self.names, self._initial)), **vec}
        return dict(zip(self.names, np.asarray(vec, float)))

    def log_prior(self, vec):
        x = np.asarray(vec, float)
        return 0.0 if np.all((x >= self._lower) & (x <= self._upper)) else -math.inf

    def expected(self, vals):
        with np.errstate(all="ignore"):
            return np.asarray(self.model(np.array([vals[n] for n in self.names]), self.t), float)

    def residuals(self, vals):
        r = (self.y - self.expected(vals)) / self.sigma
        return np.where(np.isfinite(r), r, 1e6)

    def log_likelihood(self, vals):
        r = self.residuals(vals)
        return float(-0.5 * r @ r)

    def loglike_pointwise(self, vals):
        r = self.residuals(vals)
        return -0.5 * r * r - math.log(self.sigma * math.sqrt(2 * math.pi))

    def obs_coords(self):
        return {"obs": np.arange(self.y.size), "curve": ("obs", np.array(["toy"] * self.y.size))}

    def provenance(self):
        return {"scene": "", "scene_file": "toy.toml", "data_file": self.data_file, "data_sha256": "",
                "data_kind": "toy"}


def log_model_problem(n=6, sigma=0.5, seed=1):
    """``y = log(R - 1) + b t + noise`` with centred ``t``: the log-coordinate delta interval of R
    is the exact one (and so is the profile likelihood's)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) - (n - 1) / 2
    y = math.log(2.0 - 1.0) + 0.1 * t + sigma * rng.standard_normal(n)
    return ToyProblem(lambda x, t: np.log(x[0] - 1.0) + x[1] * t, t, y, sigma, ["coulomb.R", "drift"], [1.0, -np.inf],
                      [np.inf, np.inf], [3.0, 0.0])


def test_bounded_interval_is_exact_for_a_log_linear_model_and_matches_the_profile():
    problem = log_model_problem()
    lsq = least_squares(problem, n_starts=1)
    ybar, se_u = problem.y.mean(), problem.sigma / math.sqrt(problem.y.size)
    exact = (1.0 + math.exp(ybar - Z95 * se_u), 1.0 + math.exp(ybar + Z95 * se_u))
    got = (lsq.intervals["lo95"][0], lsq.intervals["hi95"][0])
    np.testing.assert_allclose(got, exact, rtol=2e-3)
    # second method: the profile likelihood (chi-square within 3.84 of its minimum)
    grid = np.linspace(exact[0] - 0.3, exact[1] + 0.6, 61)
    prof = profile(problem, "coulomb.R", grid, n_starts=1)
    inside = grid[prof["delta"] < Z95**2]
    # the profile brackets the interval to the grid spacing
    step = grid[1] - grid[0]
    assert abs(inside.min() - got[0]) < step and abs(inside.max() - got[1]) < step


def test_logit_interval_for_two_bounds_is_exact_for_a_logit_linear_model():
    rng = np.random.default_rng(4)
    sigma, n, p_true = 0.8, 5, 0.9
    y = math.log(p_true / (1 - p_true)) + sigma * rng.standard_normal(n)
    problem = ToyProblem(lambda x, t: np.log(x[0] / (1 - x[0])) + 0 * t, np.arange(n), y, sigma, ["friction.mu"],
                         [0.0], [1.0], [0.5])
    lsq = least_squares(problem, n_starts=1)
    u, s = y.mean(), sigma / math.sqrt(n)
    expit = lambda v: 1 / (1 + math.exp(-v))  # noqa: E731
    for level, z in ((68, 1.0), (95, Z95)):
        np.testing.assert_allclose([lsq.intervals[f"lo{level}"][0], lsq.intervals[f"hi{level}"][0]],
                                   [expit(u - z * s), expit(u + z * s)], rtol=2e-3)
    assert 0.0 < lsq.intervals["lo95"][0] < lsq.intervals["hi95"][0] < 1.0


def test_interval_near_a_bound_stays_inside_where_the_symmetric_one_crosses_it():
    # Coulomb R = 18 +- 11.86 with min 1: the symmetric 95 % interval reaches below zero
    lo, hi = bounded_interval(18.0, 11.86, 1.0, math.inf, Z95)
    assert 18.0 - Z95 * 11.86 < 0 and lo > 1.0 and hi > 18.0 + Z95 * 11.86
    # far from the bounds the interval is the symmetric one
    np.testing.assert_allclose(bounded_interval(500.0, 1.0, 0.0, 1e4, Z95), (500 - Z95, 500 + Z95), rtol=1e-5)
    np.testing.assert_allclose(bounded_interval(5.0, 1.0, -np.inf, np.inf, 1.0), (4.0, 6.0))
    lo, hi = bounded_interval(-0.2, 0.5, -np.inf, 0.0, Z95)  # upper bound only
    assert lo < -0.2 - Z95 * 0.5 and -0.2 < hi < 0.0
    # random cases: never outside the bounds
    rng = np.random.default_rng(0)
    for _ in range(300):
        a = rng.uniform(-5, 5)
        b = a + rng.uniform(1e-3, 10) if rng.random() < 0.6 else math.inf
        x = a + (min(b, a + 10) - a) * rng.random()
        lo, hi = bounded_interval(x, rng.lognormal(0, 2), a, b, Z95)
        assert a <= lo <= x <= hi <= b


def test_parameter_on_its_bound_is_flagged_with_a_one_sided_interval():
    # y = a + b t with b >= 0 while the data fall: b ends on 0
    t = np.linspace(0, 1, 8)
    y = 1.0 - 0.5 * t + 0.01 * np.sin(7 * t)
    problem = ToyProblem(lambda x, t: x[0] + x[1] * t, t, y, 0.05, ["base", "fit.kappa"], [-np.inf, 0.0],
                         [np.inf, np.inf], [1.0, 0.3])
    res = fit_problem(problem, n_starts=2)
    lsq = res.group("least_squares")
    assert int(lsq["at_bound"].sel(parameter="fit.kappa")) == -1
    assert int(lsq["at_bound"].sel(parameter="base")) == 0
    row = res.summary()["fit.kappa"]
    assert row["at_bound"] == "min" and row["lo95"] == 0.0 and row["lo68"] == 0.0
    se = row["stderr"]
    assert row["hi95"] == pytest.approx(Z95 * se, rel=1e-6) and row["hi68"] == pytest.approx(se, rel=1e-6)
    msg = [w for w in res.warnings if w.startswith("fit.kappa ends on its lower bound 0")]
    assert len(msg) == 1 and "one-sided" in msg[0]
    assert res.summary()["base"]["at_bound"] is None


def test_summary_rows_follow_the_contract(tmp_path):
    problem = log_model_problem(n=8)
    ls = fit_problem(problem, n_starts=1, out=tmp_path / "ls.h5")
    row = load_fit(tmp_path / "ls.h5").summary()["coulomb.R"]
    assert row["estimate_kind"] == "best fit" and "median" not in row
    assert row["estimate"] == row["best_fit"] and math.isfinite(row["stderr"]) and row["at_bound"] is None
    assert 1.0 < row["lo95"] < row["lo68"] < row["estimate"] < row["hi68"] < row["hi95"]
    assert row == ls.summary()["coulomb.R"]
    mc = fit_problem(problem, method="emcee", n_starts=1, walkers=8, steps=400, burn=100, seed=2, predictive_draws=8)
    post = mc.summary()["coulomb.R"]
    assert post["estimate_kind"] == "median" and post["estimate"] == post["median"] and "best_fit" not in post
    assert post["at_bound"] is None and {"mean", "sd", "rhat", "ess_bulk", "lo95", "hi95"} <= set(post)
    # the posterior (flat prior in R) and the least-squares interval agree to the sampling error
    assert post["median"] == pytest.approx(row["estimate"], rel=0.1)


def test_old_files_without_bounded_intervals_still_summarise(tmp_path):
    problem = log_model_problem(n=8)
    res = fit_problem(problem, n_starts=1)
    ls = res.tree["least_squares"].to_dataset()
    v, se = float(ls["value"][0]), float(ls["stderr"][0])
    res.tree["least_squares"] = res.tree["least_squares"].to_dataset().drop_vars(
        ["lo68", "hi68", "lo95", "hi95", "at_bound"])
    row = res.summary()["coulomb.R"]
    assert row["at_bound"] is None and row["best_fit"] == v
    assert row["hi95"] == pytest.approx(v + 1.96 * se) and row["lo95"] == max(v - 1.96 * se, 1.0)
    res.tree["least_squares"] = res.tree["least_squares"].to_dataset().drop_vars(["min", "max"])
    row = res.summary()["coulomb.R"]
    assert row["lo95"] == pytest.approx(v - 1.96 * se)


def test_fewer_readings_than_parameters_is_refused_before_any_evaluation():
    calls = []

    def model(x, t):
        calls.append(1)
        return x[0] + x[1] * t + x[2] * t * t

    problem = ToyProblem(model, [0.0], [1.0], 0.1, ["a", "b", "c"], [-np.inf] * 3, [np.inf] * 3, [0.0] * 3,
                         data_file="one_reading.csv")
    with pytest.raises(FitError) as info:
        fit_problem(problem)
    msg = str(info.value)
    assert "1 reading(s)" in msg and "3 free parameters" in msg and "one_reading.csv" in msg
    assert not calls


def test_underdetermined_fit_from_the_command_line_exits_2_with_one_line(tmp_path):
    from click.testing import CliRunner

    from escfit.cli.main import cli
    from .conftest import DATASETS

    data = tmp_path / "one.csv"
    data.write_text("# notch_deg: 6\nswing,notches\n4,40\n")
    out = tmp_path / "one.h5"
    r = CliRunner().invoke(cli, ["fit", str(data), "--scene", str(DATASETS / "scenes" / "monday_unit_angle_fit.toml"),
                                 "--method", "leastsq", "--out", str(out)])
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "1 reading(s)" in lines[0] and "one.csv" in lines[0], r.output
    assert not out.exists()


def test_singular_fit_has_undefined_errors_correlations_in_range_and_no_runtime_warning():
    # only the sum a + b enters: the curvature is singular in the difference
    t = np.linspace(0, 1, 6)
    y = 2.0 + 0.3 * t + 0.01 * np.cos(5 * t)
    problem = ToyProblem(lambda x, t: x[0] + x[1] + x[2] * t, t, y, 0.1, ["a", "b", "slope"], [-np.inf] * 3,
                         [np.inf] * 3, [0.5, 0.5, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lsq = least_squares(problem, n_starts=3)
        res = fit_problem(problem, n_starts=3)
    assert np.isnan(lsq.stderr[:2]).all() and math.isfinite(lsq.stderr[2])
    c = lsq.correlation
    assert np.all(np.isnan(c) | (np.abs(c) <= 1.0))
    assert np.isnan(c[0, 1]) and c[2, 2] == 1.0
    assert any("singular" in w and "'a'" in w and "'b'" in w for w in res.warnings)
    row = res.summary()["a"]
    assert math.isnan(row["lo95"]) and math.isnan(row["hi95"])
    stored = res.group("least_squares")["correlation"].values
    assert np.all(np.isnan(stored) | (np.abs(stored) <= 1.0))


def _unit3_scene(tmp_path, switching: str):
    from .conftest import DATASETS

    text = (DATASETS / "monday1965" / "unit3_fit.toml").read_text()
    text = text.replace("X = 4119.339", "X = { value = 4119.339, vary = true, min = 0.0, max = 20000.0 }")
    text = text.replace('friction = "free"', 'friction = "linear"').replace('switching = "phase"',
                                                                          f'switching = "{switching}"')
    path = tmp_path / f"unit3_{switching}.toml"
    path.write_text(text)
    return path, DATASETS / "monday1965" / "synthetic" / "unit3.csv"


def test_phase_convention_at_several_loads_warns_what_the_data_determine(tmp_path):
    from escfit import fit, load_scene
    from escfit.balance.problems.curves import FitProblem
    from escfit.analysis.recordings import read_unit_curve

    scene, data = _unit3_scene(tmp_path, "phase")
    res = fit(scene, data, method="leastsq", n_starts=2)
    msg = [w for w in res.warnings if w.startswith("phase switching at 3 loads")]
    assert len(msg) == 1, res.warnings
    assert "C/omega0 and Monday's combined K at its load" in msg[0]
    assert "fix 2 combination(s) of the 3 free forcing parameters coulomb.R, escapement[2].X, fit.kappa" in msg[0]
    # the least squares agree: R, X and kappa have no standard error, C keeps one
    s = res.summary()
    assert all(math.isnan(s[n]["stderr"]) for n in ("coulomb.R", "escapement[2].X", "fit.kappa"))
    assert math.isfinite(s["viscous.C"]["stderr"]) and s["viscous.C"]["lo95"] < s["viscous.C"]["hi95"]
    c = res.group("least_squares")["correlation"].values
    assert np.all(np.isnan(c) | (np.abs(c) <= 1.0))
    # K at each load is what the curves determine: the derived quantities name them
    problem = FitProblem(load_scene(scene), read_unit_curve(data))
    assert set(problem.derived(problem.values(problem.initial))) == {"K[load=330.66]", "K[load=661.32]",
                                                                     "K[load=991.98]"}
    # angle switching separates them (no warning), and so does phase switching with X fixed per load
    angle, _ = _unit3_scene(tmp_path, "angle")
    assert FitProblem(load_scene(angle), read_unit_curve(data)).phase_loads_warning() == []
    from .conftest import DATASETS

    fixed_x = FitProblem(load_scene(DATASETS / "monday1965" / "unit3_fit.toml"), read_unit_curve(data))
    assert fixed_x.phase_loads_warning() == [] and "K[load=330.66]" not in fixed_x.derived(
        fixed_x.values(fixed_x.initial))


def test_a_small_estimate_many_standard_errors_from_zero_is_not_on_its_bound():
    # an inertia-sized parameter (3e-7 in SI) fitted to 2 % is not "at 0": the distance to the bound
    # is measured in standard errors, not in the parameter's unit; one at 0 to rounding still is
    from escfit.inference.lsq import bound_flags

    flags = bound_flags([3e-7, 2e-8, 5.8e-17], [0.0] * 3, [np.inf] * 3, [6e-9, 2e-9, 2.6e-4])
    assert list(flags) == [0, 0, -1]
    lo, hi = bounded_interval(2e-8, 2e-9, 0.0, np.inf, Z95, 0)
    assert lo < 2e-8 < hi and lo == pytest.approx(2e-8 * math.exp(-Z95 * 0.1), rel=1e-12)


def test_informative_priors_let_a_posterior_run_start_where_least_squares_alone_is_refused():
    # one reading, two parameters: least squares alone is refused; with a normal prior pinning the
    # slope, the posterior run's least-squares start counts the prior and goes ahead
    problem = ToyProblem(lambda x, t: x[0] + x[1] * t, [1.0], [2.0], 0.1, ["a", "b"], [-10.0, -10.0], [10.0, 10.0],
                         [0.0, 0.0])
    problem.priors[1] = Prior("normal", (0.5, 0.01), -10.0, 10.0)
    with pytest.raises(FitError, match="1 reading"):
        least_squares(problem)
    start = least_squares(problem, priors_count=True)
    # the optimum: b at its prior mean, a + b = 2 from the reading
    assert start.values["b"] == pytest.approx(0.5, abs=1e-3) and start.values["a"] == pytest.approx(1.5, abs=1e-2)
