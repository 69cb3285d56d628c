# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 4. A real record through lmfit
#
# escfit's fits run scipy's trust region directly; every fit problem is also an lmfit problem:
# `escfit.to_lmfit(scene, data)` gives its `lmfit.Parameters` (values, bounds, fixed
# parameters, units in `user_data`) and a ready `lmfit.Minimizer` of the residual escfit's own
# least squares minimises.  Here the Pohl wheel's scale readings (HeiLaut, every half period,
# a real record) are fitted by lmfit's differential evolution, Levenberg-Marquardt and Nelder-Mead, by escfit's least
# squares and by escfit's emcee, and lmfit's `conf_interval` profile of the damping C is drawn
# beside escfit's own profile of the cost.

# %%
import os
import tomllib
from pathlib import Path

import lmfit
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import escfit  # noqa: E402
from escfit.inference import make_problem, profile  # noqa: E402

HERE = Path.cwd()
ROOT = HERE.parent if (HERE.parent / "fits").is_dir() else HERE
RECIPE = ROOT / "fits" / "real" / "pohl_amplitudes.toml"
recipe = tomllib.loads(RECIPE.read_text())
SCENE = (RECIPE.parent / recipe["scene"]).resolve()
DATA = (RECIPE.parent / recipe["data"]).resolve()
FIGURES = Path(os.environ.get("ESCFIT_LMFIT_FIGURES", HERE / "figures"))
FIGURES.mkdir(parents=True, exist_ok=True)
STEPS = int(os.environ.get("ESCFIT_LMFIT_STEPS", "1500"))

# %% [markdown]
# ## The problem as lmfit sees it

# %%
params, minimizer = escfit.to_lmfit(SCENE, DATA)
params.pretty_print()
for p in params.values():
    print(f"{p.name:28s} {p.user_data['role']:6s} {p.user_data['unit']:8s} {p.user_data['meaning']}")

# %% [markdown]
# ## lmfit's methods, escfit's least squares and escfit's emcee
#
# From the scene's start (C = 0.2 1/s, R = 1 rad/s^2) Levenberg-Marquardt ends in a local
# optimum: C on its bound 0 and the wheel at rest a few swings early, its rest angle standing
# in for the last small readings.  escfit's own least squares ranks eight starts for this
# reason (`escfit fit --method lmfit:NAME` uses them too); in lmfit the global search is
# differential evolution over the scene's bounds, which the local methods then polish.

# %%
local = minimizer.minimize(method="leastsq")
print(f"leastsq from the scene's start: chi-square {local.chisqr:.6g}, C = {local.params['viscous__C'].value:.4g}, "
      f"R = {local.params['coulomb__R'].value:.4g}")
de = minimizer.minimize(method="differential_evolution", seed=1)
lm = minimizer.minimize(method="leastsq", params=de.params)
tr = minimizer.minimize(method="least_squares", params=de.params)
# Nelder-Mead from the scene's start, tight tolerances (C and R: r = -0.95)
nm = minimizer.minimize(method="nelder", options={"xatol": 1e-10, "fatol": 1e-10})
print(lmfit.fit_report(lm))
ls = escfit.fit(SCENE, DATA, method="leastsq", seed=1)
mc = escfit.fit(SCENE, DATA, method="emcee", seed=1, walkers=32, steps=STEPS, moves="de-t")
post = mc.group("posterior")

# %%
rows = []
for name in ls.parameter_names:
    if name == "observation.sigma":
        continue
    key = escfit.inference.lmfit_params.lmfit_key(name)
    sel = ls.group("least_squares").sel(parameter=name)
    draws = post[name].values.ravel()
    rows.append((name, lm.params[key].value, lm.params[key].stderr, tr.params[key].value, nm.params[key].value,
                 float(sel["value"]), float(sel["stderr"]), float(np.median(draws)), float(np.std(draws))))
print(f"{'parameter':20s} {'lmfit leastsq':>22s} {'least_squares':>13s} {'nelder':>10s} {'escfit lsq':>22s} "
      f"{'escfit emcee':>22s}")
for name, a, ae, t, b, c, ce, d, dse in rows:
    print(f"{name:20s} {a:12.6g} +- {ae:7.2g} {t:13.6g} {b:10.5g} {c:12.6g} +- {ce:7.2g} {d:12.6g} +- {dse:7.2g}")
    assert abs(a - c) <= 1e-6 * abs(c) and abs(t - c) <= 1e-6 * abs(c)  # one cost, minimised by three codes
    assert abs(d - c) < 2 * ce  # the posterior median near the best fit (flat priors)
print(f"chi-square: leastsq {lm.chisqr:.8g}, least_squares {tr.chisqr:.8g}, nelder {nm.chisqr:.8g}")
assert nm.chisqr >= lm.chisqr - 1e-9 * lm.chisqr

# %% [markdown]
# ## conf_interval beside escfit's profile
#
# lmfit's `conf_interval` refits with C held at trial values and turns the rise of the cost
# into a probability with an F test; escfit's `profile` refits on a grid (eight starts at each
# value) and reads the 95 % set where the cost has risen by less than the 95 % point of that
# same F distribution (times the reduced chi-square: the noise scale is profiled).
#
# The wheel comes to rest within this record: its last readings (0.4 and 0.2 scale divisions,
# about the 2 deg reading noise) are where friction holds it.  Above the best C the model's last
# small swings pass the scale's displaced zero, where an amplitude reading folds, and a second
# local optimum opens at C near 0.14 1/s whose cost is only about 0.2 above the best.  The 95 %
# set of C is then wider above than the curvature at the best fit says.

# %%
ci, trace = lmfit.conf_interval(minimizer, tr, p_names=["viscous__C"], sigmas=[0.95], trace=True)
lmfit.printfuncs.report_ci(ci)
problem = make_problem(SCENE, DATA)
sel = ls.group("least_squares").sel(parameter="viscous.C")
best, se = float(sel["value"]), float(sel["stderr"])
grid = np.linspace(best - 3 * se, best + 6 * se, 37)
prof = profile(problem, "viscous.C", grid, n_starts=8)
lsq_attrs = ls.group("least_squares").attrs
dof = lsq_attrs["n_data"] - lm.nvarys
from scipy import stats  # noqa: E402

level = stats.f.ppf(0.95, 1, dof) * lsq_attrs["redchi"]
inside = grid[prof["delta"] <= level]
step = grid[1] - grid[0]
c_draws = post["viscous.C"].values.ravel()
print(f"escfit delta method 95 %: [{float(sel['lo95']):.5g}, {float(sel['hi95']):.5g}]")
print(f"escfit profile 95 %: [{inside.min():.5g}, {inside.max():.5g}] (grid step {step:.2g})")
print(f"lmfit conf_interval 95 %: [{ci['viscous__C'][0][1]:.5g}, {ci['viscous__C'][2][1]:.5g}]")
print(f"escfit emcee 2.5-97.5 %: [{np.quantile(c_draws, 0.025):.5g}, {np.quantile(c_draws, 0.975):.5g}]")
assert abs(ci["viscous__C"][0][1] - inside.min()) < 1.5 * step  # below the best: one optimum, one answer
# above it the second optimum carries the 95 % set beyond the delta method's end; conf_interval,
# which walks up until the probability first falls, stops where the cost turns down towards it
# (lmfit warns and reports +inf, or the first crossing)
assert inside.max() > float(sel["hi95"]) + step
if np.isfinite(ci["viscous__C"][2][1]):
    assert ci["viscous__C"][2][1] < inside.max() + 1.5 * step

# %%
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(grid, prof["delta"] / lsq_attrs["redchi"], "o-", label="escfit profile (cost rise / reduced chi-square)")
t = trace["viscous__C"]
ax.plot(t["viscous__C"], stats.f.ppf(t["prob"], 1, dof), "x", label="lmfit conf_interval trace (as F quantile)")
ax.axhline(stats.f.ppf(0.95, 1, dof), color="grey", lw=0.8, label="95 %")
ax.axvspan(float(sel["lo95"]), float(sel["hi95"]), color="C2", alpha=0.15, label="escfit delta method 95 %")
for x in (ci["viscous__C"][0][1], ci["viscous__C"][2][1]):
    if np.isfinite(x):
        ax.axvline(x, color="C1", ls=":")
ax.set_xlabel("viscous.C (1/s)")
ax.set_ylabel("rise of the cost")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(FIGURES / "lmfit_profile.png", dpi=120)
