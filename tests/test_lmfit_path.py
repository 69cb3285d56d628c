"""lmfit's minimisers on escfit's problems, against escfit's own least squares.

The reference is escfit's default fit (scipy's trust region called directly) of the same
recipe.  ``lmfit:least_squares`` wraps the same algorithm and ``lmfit:leastsq`` is MINPACK's
Levenberg-Marquardt (different code, same cost): both must give the estimates to 1e-6 relative.
``lmfit:nelder`` (no derivatives) and ``lmfit:differential_evolution`` (a global search, then
L-BFGS-B) stop on looser criteria: they must reach the same optimum within a small fraction of
a standard error and a cost within 1e-3 of its minimum (a chi-square of 1 is one standard error).
lmfit's method names are checked against lmfit's own table, and ``lmfit.conf_interval`` (a
profile of the cost) against escfit's delta-method interval.
"""

from __future__ import annotations

import functools
import math
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from escfit.core.scene import load_scene
from escfit.inference import registry
from escfit.inference.fit import fit_problem

lmfit = pytest.importorskip("lmfit")

ROOT = Path(__file__).resolve().parents[1]
FAST = ["monday_unit3.toml", "friction_monday_steel.toml", "geneva_trace.toml"]
PENDULUM = "real/string_pendulum_lab1.toml"


def recipe_problem(recipe: str):
    """The family entry and a freshly built problem of a fit recipe under fits/, as ``escfit fit`` builds it."""
    path = ROOT / "fits" / recipe
    doc = tomllib.loads(path.read_text())
    scene = load_scene(str((path.parent / doc["scene"]).resolve()))
    fam = registry.family(scene.model)
    return fam, fam.problem(scene, str((path.parent / doc["data"]).resolve()))


def run(recipe: str, method: str):
    fam, problem = recipe_problem(recipe)
    d = {**{"n_starts": 8, "n_refine": None}, **dict(getattr(fam, "fit_defaults", {}))}
    res = fit_problem(problem, method=method, n_starts=d["n_starts"], n_refine=d["n_refine"], seed=1)
    return res.group("least_squares"), res


@functools.lru_cache(maxsize=None)
def reference(recipe: str):
    return run(recipe, "leastsq")[0]


def _agree_exactly(recipe: str, method: str) -> None:
    ref = reference(recipe)
    lsq, res = run(recipe, method)
    assert res.attrs["method"] == method
    assert list(lsq["parameter"].values) == list(ref["parameter"].values)
    value, se = lsq["value"].values, ref["stderr"].values
    # relative agreement; an estimate on a bound (both fits flag it there) is compared at 1e-6 of
    # its standard error: there its value is the bound plus what a strictly feasible step leaves
    # (coulomb.R = 3e-27 on the pendulum), no figure to compare relatively
    np.testing.assert_array_equal(lsq["at_bound"].values, ref["at_bound"].values)
    on = ref["at_bound"].values != 0
    np.testing.assert_allclose(value[~on], ref["value"].values[~on], rtol=1e-6, atol=0)
    assert np.all(np.abs(value[on] - ref["value"].values[on]) <= 1e-6 * se[on]), (value[on], ref["value"].values[on])
    np.testing.assert_allclose(lsq["stderr"].values, se, rtol=1e-4)


def _same_optimum(recipe: str, method: str) -> None:
    ref = reference(recipe)
    lsq, res = run(recipe, method)
    assert res.attrs["method"] == method
    gap = np.abs(lsq["value"].values - ref["value"].values) / ref["stderr"].values
    assert np.all(gap < 0.05), dict(zip(lsq["parameter"].values, gap))
    # the cost no lower than the optimum's and above it by at most a hundredth of what one standard
    # error in one parameter costs (a chi-square of 1 in the noise's own scale, redchi)
    assert 0 <= lsq.attrs["chisqr"] - ref.attrs["chisqr"] < 1e-2 * max(1.0, ref.attrs["redchi"])


@pytest.mark.parametrize("recipe", FAST)
@pytest.mark.parametrize("method", ["lmfit:least_squares", "lmfit:leastsq"])
def test_lmfit_least_squares_agree_with_escfit(recipe, method):
    _agree_exactly(recipe, method)


@pytest.mark.parametrize("recipe", FAST)
def test_lmfit_nelder_reaches_the_optimum(recipe):
    _same_optimum(recipe, "lmfit:nelder")


@pytest.mark.slow  # a population of 15 per parameter for up to hundreds of generations: seconds to a minute each
@pytest.mark.parametrize("recipe", FAST)
def test_lmfit_differential_evolution_reaches_the_optimum(recipe):
    _same_optimum(recipe, "lmfit:differential_evolution")


@pytest.mark.slow  # the 116 s video record, two-stage correlated noise: several fits of it
def test_lmfit_least_squares_agrees_on_the_string_pendulum():
    _agree_exactly(PENDULUM, "lmfit:least_squares")


@pytest.mark.slow  # coulomb.R ends on its bound 0, where lmfit's bounds transform is flat (held there)
def test_lmfit_leastsq_agrees_on_the_string_pendulum():
    _agree_exactly(PENDULUM, "lmfit:leastsq")


@pytest.mark.slow
def test_lmfit_nelder_reaches_the_string_pendulum_optimum():
    _same_optimum(PENDULUM, "lmfit:nelder")


@pytest.mark.parametrize("start", [(0.0, 0.5, 0.0), (1.0, -1.0, 0.7), (-3.0, 0.4999999, 1e-9)])
def test_lmfit_leastsq_finds_an_optimum_on_its_bounds(start):
    """A linear least squares whose optimum lies on a lower and an upper bound, against scipy's
    bounded linear solver.  lmfit's bounds transform is flat on a bound, where MINPACK alone
    stays at a start on it (the first start) or crawls towards it (the others)."""
    from scipy.optimize import lsq_linear

    from escfit.inference.lmfit_path import lmfit_optimizer

    rng = np.random.default_rng(3)
    a = rng.normal(size=(60, 3))
    b = a @ np.array([0.8, 1.5, -0.6]) + 0.1 * rng.normal(size=60)  # unbounded optimum outside the box
    lower, upper = np.array([-10.0, -10.0, 0.0]), np.array([10.0, 0.5, 1.0])
    exact = lsq_linear(a, b, bounds=(lower, upper), tol=1e-12)
    assert exact.active_mask[1] == 1 and exact.active_mask[2] == -1  # the case meant: both bounds bind
    best = lmfit_optimizer(None, "leastsq")(lambda x: a @ x - b, np.array(start), lower, upper, names=["u", "v", "w"])
    np.testing.assert_allclose(best.x, exact.x, rtol=0, atol=1e-7)
    assert best.x[1] == upper[1] and best.x[2] == lower[2]
    assert best.chisqr == pytest.approx(float(np.sum((a @ exact.x - b) ** 2)), rel=1e-12)
    assert best.success and "held on a bound" in best.message


def test_method_names_are_lmfit_minimisers():
    """Every name escfit runs is one lmfit's Minimizer.minimize dispatches, and every lmfit
    minimiser is either run or refused with a reason."""
    from lmfit.minimizer import SCALAR_METHODS

    from escfit.inference.lmfit_path import LMFIT_METHODS, NOT_RUN

    lmfit_names = set(SCALAR_METHODS) | {"leastsq", "least_squares", "brute", "basinhopping", "ampgo", "shgo",
                                         "dual_annealing", "emcee"}
    assert set(LMFIT_METHODS) | set(NOT_RUN) == lmfit_names
    assert not set(LMFIT_METHODS) & set(NOT_RUN)


@pytest.mark.parametrize("method, words", [("lmfit:nope", "unknown lmfit method 'nope'"),
                                           ("lmfit:emcee", "is a sampler"), ("simplex", "method must be")])
def test_an_unknown_method_is_one_line_and_exit_2(tmp_path, method, words):
    out = tmp_path / "fit.h5"
    run_ = subprocess.run([sys.executable, "-m", "escfit", "fit", str(ROOT / "fits" / "geneva_terminal.toml"),
                           "--method", method, "--out", str(out)], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run_.returncode == 2
    lines = run_.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "lmfit:differential_evolution" in lines[0], run_.stderr
    assert run_.stdout == "" and not out.exists()


_PROBE = """
import sys
from escfit.cli.main import cli
try:
    cli(sys.argv[1:], prog_name="escfit", standalone_mode=False)
finally:
    print("LMFIT-IMPORTED" if "lmfit" in sys.modules else "LMFIT-NOT-IMPORTED")
"""


@pytest.mark.parametrize("method, imported", [("leastsq", False), ("lmfit:leastsq", True)])
def test_only_the_lmfit_path_imports_lmfit(tmp_path, method, imported):
    out = tmp_path / "fit.h5"
    run_ = subprocess.run([sys.executable, "-c", _PROBE, "fit", str(ROOT / "fits" / "geneva_terminal.toml"),
                           "--method", method, "--out", str(out), "--quiet"], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run_.returncode == 0, run_.stderr
    assert ("LMFIT-IMPORTED" if imported else "LMFIT-NOT-IMPORTED") in run_.stdout and out.exists()


def test_a_results_file_of_an_lmfit_fit_reads_back_as_any_fit(tmp_path):
    from escfit.cli.main import cli
    from escfit.inference.lmfit_params import parameters_from_results
    from click.testing import CliRunner

    out = tmp_path / "lm.h5"
    runner = CliRunner()
    done = runner.invoke(cli, ["fit", str(ROOT / "fits" / "geneva_trace.toml"), "--method", "lmfit:leastsq",
                               "--out", str(out), "--quiet"])
    assert done.exit_code == 0, done.output
    summary = runner.invoke(cli, ["summary", str(out), "--json"])
    assert summary.exit_code == 0 and '"lmfit:leastsq"' in summary.output, summary.output
    report = runner.invoke(cli, ["report", str(out), "--out", str(tmp_path / "lm.html")])
    assert report.exit_code == 0 and (tmp_path / "lm.html").stat().st_size > 10_000, report.output
    other = tmp_path / "default.h5"
    assert runner.invoke(cli, ["fit", str(ROOT / "fits" / "geneva_trace.toml"), "--method", "leastsq", "--out", str(other),
                               "--quiet"]).exit_code == 0
    ranked = runner.invoke(cli, ["compare", str(out), str(other)])
    assert ranked.exit_code == 0 and "lm.h5" in ranked.output and "default.h5" in ranked.output, ranked.output
    ref = reference("geneva_trace.toml")
    params = parameters_from_results(out)
    for name, value, se in zip(ref["parameter"].values, ref["value"].values, ref["stderr"].values):
        p = params[name.replace(".", "__")]
        assert p.user_data["name"] == name and p.vary
        assert p.value == pytest.approx(value, rel=1e-6) and p.stderr == pytest.approx(se, rel=1e-4)
    assert params["observation__sigma"].vary is False


def test_a_global_search_box_is_said_in_the_optimisers_notes_not_set_on_the_problem():
    """A global search closes an open range at the prior's 0.1 and 99.9 % points (a normal prior
    of mean 2 and sd 0.5 here: 2 -+ 3.0902 sd), and says so in the optimiser's notes, which the
    fit adds to the results; the problem's own notes stay as they were."""
    from types import SimpleNamespace

    from escfit.inference.lmfit_path import _search_box
    from escfit.likelihood.priors import normal

    problem = SimpleNamespace(names=["a", "b"], priors=[normal(2.0, 0.5), normal(0.0, 1.0)], notes=[])
    notes: list[str] = []
    lo, hi = _search_box(problem, ["a", "b"], np.array([-np.inf, -1.0]), np.array([np.inf, 1.0]), "brute", notes)
    assert lo[0] == pytest.approx(2.0 - 0.5 * 3.090232306, rel=1e-6) and hi[0] == pytest.approx(2.0 + 0.5 * 3.090232306,
                                                                                             rel=1e-6)
    assert (lo[1], hi[1]) == (-1.0, 1.0)  # a closed range is the scene's
    assert len(notes) == 1 and notes[0].startswith("lmfit:brute searched a in [") and problem.notes == []
