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
# # 1. Fitting a fleet of balance wheels, one unit at a time
#
# Monday (1965) matched the recorded decay curves of five escapement units by eye against his
# computed charts.  Here a synthetic fleet of 20 units stands in for a production batch: each
# unit's C, R and X are drawn from a log-normal population that scatters like his Table I, and
# each unit is recorded as his rig did — notches of a 6° notched balance counted every second
# cycle after release from the banking pin, at three fixture loads.  The truth is known, so we
# can see how well each fit does.
#
# Every unit is fitted independently (emcee, escapement at balance angles) on a dask cluster:
# a local one by default, or a running cluster when `ESCFIT_STUDY_SCHEDULER` holds its address.
# From the shell the same batch is
#
# ```
# escfit fit-many datasets/fleet/angle/recordings.csv --scene datasets/fleet/scenes/angle.toml \
#     --out work/angle/angle --method emcee --walkers 16 --steps 600 [--scheduler tcp://host:8786]
# ```

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import escfit
import escfit.study as study
from escfit.study import plots

HERE = Path.cwd()
ROOT = HERE.parent if (HERE.parent / "datasets" / "fleet").is_dir() else HERE
settings = study.StudySettings.from_env(ROOT / "datasets" / "fleet", HERE / "work")
FIGURES = Path(os.environ.get("ESCFIT_STUDY_FIGURES", HERE / "figures"))
FIGURES.mkdir(parents=True, exist_ok=True)
settings

# %% [markdown]
# ## The fleet
#
# `datasets/fleet/angle` holds the recordings (`recordings.csv`, one `unit` column), each
# unit's true parameters (`truth.csv`) and the scene that generated it with its seed
# (`scenes/<unit>.toml`).

# %%
fleet = study.load_fleet(settings.fleets / "angle")
curve = escfit.read_recording(fleet.recordings)  # a balance unit curve: every unit, every load
print(fleet.spec.population)
fig, axes = plt.subplots(1, 3, figsize=(12, 3.3), sharey=True)
for ax, load in zip(axes, fleet.spec.rig.loads):
    for unit in fleet.units:
        rows = (curve.unit == unit) & (curve.load == load)
        ax.plot(curve.swing[rows] / 2, curve.value[rows], "-", lw=0.8, alpha=0.7)
    ax.set_title(f"fixture load {load:g} g")
    ax.set_xlabel("cycles after release")
    ax.grid(alpha=0.3)
axes[0].set_ylabel("notches (6° each)")
fig.suptitle("The recordings of the 20 units")
fig.tight_layout()
fig.savefig(FIGURES / "fleet_recordings.png", dpi=110)

# %% [markdown]
# ## Fitting every unit on a dask cluster
#
# One task per unit; a unit that fails is reported and the others go on; running the cell again
# skips the units already done.

# %%
# a dask client started only if some unit is left to fit: the settings' scheduler, or a local cluster
client = study.LazyClient(settings.scheduler, settings.workers)
units = fleet.units[: settings.units] if settings.units else None
batch = study.fit_fleet(fleet, "angle", study.results_dir(settings, "angle", "angle"), units=units,
                        walkers=settings.walkers, steps=settings.steps, seed=settings.seed, scheduler=client)
print(f"{len(batch.fitted)} fitted, {len(batch.skipped)} done before, {len(batch.failed)} failed "
      f"in {batch.elapsed:.0f} s")

# %% [markdown]
# The combined summary is an xarray Dataset with a `unit` dimension (also on disk as
# `summary.nc`):

# %%
s = batch.summary
table = s["median"].to_pandas()
table.columns = [study.scenes.SHORT.get(c, c) for c in table.columns]
table["rhat_max"] = s["rhat"].max("parameter").values
table["status"] = s["status"].values
table.round(3)

# %% [markdown]
# Each unit against its truth.  C is pinned to a few tens of per cent from a single unit's
# three curves; R and X trade off against each other and are known less well.

# %%
fig = plots.plot_unit_estimates(s, truth=fleet.truth, title="Each unit fitted alone (emcee, angle model)")
fig.savefig(FIGURES / "unit_estimates.png", dpi=110)

# %%
logs = np.log(fleet.truth_array())
inside = {}
for j, name in enumerate(study.POPULATION_PARAMS):
    sel = s.sel(parameter=name)
    truth = np.array([fleet.truth[str(u)][name] for u in s["unit"].values])
    inside[name] = float(np.mean((sel["lo95"].values < truth) & (truth < sel["hi95"].values)))
print("fraction of units whose 95 % interval holds the truth:", inside)

# %%
client.close()
