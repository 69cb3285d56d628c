"""The lmfit path against escfit's default least squares on the string pendulum, one run each.

Prints (1) wall and CPU seconds of ``fit_problem`` with ``method="leastsq"`` (scipy's trust
region called directly), ``"lmfit:least_squares"`` (the same algorithm through lmfit's
Parameters) and ``"lmfit:leastsq"`` (MINPACK through lmfit), with the ratio to the default, the
largest relative difference of the estimates off their bounds and the largest difference of
those on a bound (coulomb.R = 0) in standard errors; (2) 95 % intervals of two parameters:
escfit's stored delta-method interval, escfit's profile (the cost minimised over the other
parameters on a grid, the crossing of the F test's 95 % point interpolated) and
``lmfit.conf_interval`` at 0.95 -- both profiles of the same cost, with the noise scale and
the AR(1) rho held at the best fit's values.

Run:  PYTHONPATH=. python benchmarks/lmfit_path.py
"""

from __future__ import annotations

import time
import tomllib
from pathlib import Path

import numpy as np
from scipy import stats

from escfit.core.scene import load_scene
from escfit.inference import registry
from escfit.inference.fit import fit_problem
from escfit.inference.lmfit_params import lmfit_problem
from escfit.inference.lsq import least_squares
from escfit.inference.trf import minimize

ROOT = Path(__file__).resolve().parents[1]
RECIPE = ROOT / "fits" / "real" / "string_pendulum_lab1.toml"
PROFILED = ("viscous.C", "oscillator.omega0")


def problem():
    doc = tomllib.loads(RECIPE.read_text())
    scene = load_scene(str((RECIPE.parent / doc["scene"]).resolve()))
    return registry.family(scene.model).problem(scene, str((RECIPE.parent / doc["data"]).resolve()))


def timings() -> None:
    ref = None
    print(f"{'method':22s} {'wall s':>8s} {'CPU s':>8s} {'wall ratio':>10s} {'max rel. diff':>14s} "
          f"{'on a bound, SE':>15s}")
    for method in ("leastsq", "lmfit:least_squares", "lmfit:leastsq"):
        p = problem()
        wall, cpu = time.perf_counter(), time.process_time()
        res = fit_problem(p, method=method, n_starts=8, seed=1)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        lsq = res.group("least_squares")
        value = lsq["value"].values
        if ref is None:
            ref = (wall, value, lsq["stderr"].values, lsq["at_bound"].values != 0)
        on = ref[3]  # an estimate on its bound is the bound plus round-off: compared in standard errors
        rel = np.max(np.abs(value - ref[1])[~on] / np.maximum(np.abs(ref[1][~on]), 1e-300))
        gap = np.max(np.abs(value - ref[1])[on] / ref[2][on], initial=0.0)
        print(f"{method:22s} {wall:8.2f} {cpu:8.2f} {wall / ref[0]:10.2f} {rel:14.2e} {gap:15.1e}", flush=True)


def _crossing(grid, rise, level, side):
    """Where the profile's rise crosses ``level`` on one side of its minimum (linear interpolation)."""
    i0 = int(np.argmin(rise))
    idx = range(i0, -1, -1) if side < 0 else range(i0, len(grid))
    prev = i0
    for i in idx:
        if rise[i] > level:
            t = (level - rise[prev]) / (rise[i] - rise[prev])
            return grid[prev] + t * (grid[i] - grid[prev])
        prev = i
    return np.nan


def intervals() -> None:
    import lmfit

    p = problem()
    lsq = least_squares(p, n_starts=8, seed=1)
    lp = lmfit_problem(p, lsq.values)
    mini = lp.minimizer()
    best = mini.minimize(method="least_squares")
    dof = best.ndata - best.nvarys
    level = stats.f.ppf(0.95, 1, dof) * best.redchi
    keys = [lp.keys[n] for n in PROFILED]
    clock = time.process_time()
    ci = lmfit.conf_interval(mini, best, p_names=keys, sigmas=[0.95])
    ci_cpu = time.process_time() - clock
    print(f"\n95 % intervals (string pendulum; conf_interval took {ci_cpu:.1f} CPU s)")
    print(f"{'parameter':20s} {'best fit':>12s} {'escfit delta method':>26s} {'escfit profile':>26s} "
          f"{'lmfit conf_interval':>26s}")
    names = [n for n in lp.fitted]
    for name, key in zip(PROFILED, keys):
        i = lsq.names.index(name)
        x0, se = lsq.value[i], lsq.stderr[i]
        grid = x0 + se * np.linspace(-3, 3, 25)
        others = [n for n in names if n != name]
        lo_b = np.array([lp.params[lp.keys[n]].min for n in others])
        hi_b = np.array([lp.params[lp.keys[n]].max for n in others])
        start = np.array([best.params[lp.keys[n]].value for n in others])
        rise = []
        for g in grid:
            pars = best.params.copy()
            pars[key].set(value=g, vary=False)

            def fun(x, pars=pars):
                for n, v in zip(others, x):
                    pars[lp.keys[n]].value = v
                return lp.residual(pars)

            opt = minimize(fun, start, lo_b, hi_b)
            rise.append(opt.chisqr - best.chisqr)
        rise = np.array(rise)
        prof = (_crossing(grid, rise, level, -1), _crossing(grid, rise, level, +1))
        delta = (lsq.intervals["lo95"][i], lsq.intervals["hi95"][i])
        cil = (ci[key][0][1], ci[key][2][1])
        fmt = lambda a: f"[{a[0]:.6g}, {a[1]:.6g}]"  # noqa: E731
        print(f"{name:20s} {x0:12.6g} {fmt(delta):>26s} {fmt(prof):>26s} {fmt(cil):>26s}", flush=True)


if __name__ == "__main__":
    timings()
    intervals()
