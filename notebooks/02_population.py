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
# # 2. The population behind the fleet
#
# Monday found C ranging from 0.757 to 2.367 1/s over his five units and put it down to "the
# non-homogeneity of the sample".  Whether that spread is real unit-to-unit scatter or the
# blur of reading each curve to ±1 notch, five chart-matched units could not say.
#
# Here each unit was fitted alone (notebook 1) under a log-uniform prior.  If the units come
# from a log-normal population with unknown log-medians μ and log-sds τ, every unit's
# posterior draws can be *reweighted* by population density / fit prior, and μ, τ sampled
# (emcee) from the product over units of the average weight.  Nothing is refitted.

# %%
import os
from pathlib import Path

import numpy as np
import pandas as pd

import escfit.study as study
from escfit.study import plots

HERE = Path.cwd()
ROOT = HERE.parent if (HERE.parent / "datasets" / "fleet").is_dir() else HERE
settings = study.StudySettings.from_env(ROOT / "datasets" / "fleet", HERE / "work")
FIGURES = Path(os.environ.get("ESCFIT_STUDY_FIGURES", HERE / "figures"))
FIGURES.mkdir(parents=True, exist_ok=True)
fleet = study.load_fleet(settings.fleets / "angle")
results = study.results_dir(settings, "angle", "angle")

# %%
draws = study.collect_draws(results)
pop = study.fit_population(draws, steps=settings.population_steps, seed=1)
pop.write(results / "population.nc", force=True)
print("warnings:", pop.warnings or "none")
print("effective draws per unit under the population: min", round(float(pop.ess.min())), "median",
      round(float(np.median(pop.ess))))

# %% [markdown]
# ## Population estimates with 95 % intervals
#
# `median` is the population median exp(μ); `tau` the log-sd between units (0.1 ≈ 10 %);
# `measurement_sd` the posterior sd of log θ of one unit (what a single curve pins down);
# `fraction_real` = τ² / (τ² + s²), the share of the spread between units' estimates that is
# real; `new_unit` the interval for the next unit off the line.

# %%
logs = np.log(fleet.truth_array(draws.names))
rows = []
for j, (name, r) in enumerate(pop.summary().items()):
    rows.append({"parameter": study.scenes.SHORT[name],
                 "median [95 %]": f"{r['median']:.4g} [{r['median_lo']:.4g}, {r['median_hi']:.4g}]",
                 "true median (population / these units)": f"{fleet.spec.population.median[j]:.4g} / "
                                                           f"{np.exp(logs[:, j].mean()):.4g}",
                 "tau [95 %]": f"{r['tau']:.3f} [{r['tau_lo']:.3f}, {r['tau_hi']:.3f}]",
                 "true tau (population / these units)": f"{fleet.spec.population.spread[j]:.3f} / "
                                                        f"{logs[:, j].std(ddof=1):.3f}",
                 "measurement sd": f"{r['measurement_sd']:.3f}",
                 "fraction real [95 %]": f"{r['fraction_real']:.2f} [{r['fraction_real_lo']:.2f}, "
                                         f"{r['fraction_real_hi']:.2f}]",
                 "P(tau > noise)": f"{r['p_scatter_exceeds_noise']:.2f}",
                 "new unit 95 %": f"[{r['new_unit_lo']:.4g}, {r['new_unit_hi']:.4g}]"})
pd.DataFrame(rows).set_index("parameter")

# %%
fig = plots.plot_population(pop, truth=fleet.spec.population, sample=fleet.truth_array(draws.names),
                            title="Population of the 20-unit fleet (dashed: generating population; "
                                  "dotted: these 20 units)")
fig.savefig(FIGURES / "population.png", dpi=110)

# %% [markdown]
# ## Borrowing strength
#
# Under the population each unit's estimate moves toward the fleet, most for the units whose
# own curves say least.

# %%
fig = plots.plot_shrinkage(pop, truth=fleet.truth_array(draws.names))
fig.savefig(FIGURES / "shrinkage_C.png", dpi=110)

# %% [markdown]
# ## Monday's question: scatter or noise?
#
# The same estimate from the first five units only (Monday had five) against all twenty.
# C scatters between units far beyond what one curve can blur, with five units as with twenty;
# for R and X the measurement sd of one unit is as large as the scatter, and five units cannot
# tell how much of their spread is real.

# %%
few = study.collect_draws(results, units=draws.units[:5])
pop5 = study.fit_population(few, steps=settings.population_steps, seed=1)
fig = plots.plot_scatter_vs_noise({"5 units": pop5, f"{len(draws.units)} units": pop})
fig.savefig(FIGURES / "scatter_vs_noise.png", dpi=110)
pd.DataFrame({f"{n} units": {study.scenes.SHORT[k]: f"tau {v['tau']:.2f} [{v['tau_lo']:.2f}, {v['tau_hi']:.2f}], "
                                                     f"real {v['fraction_real']:.2f} [{v['fraction_real_lo']:.2f}, "
                                                     f"{v['fraction_real_hi']:.2f}]"
                             for k, v in p.summary().items()}
              for n, p in ((5, pop5), (len(draws.units), pop))})
