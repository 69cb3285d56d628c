"""Figures of a fleet study (matplotlib is imported here only).

Each function returns a matplotlib Figure and reads nothing but the objects it is given.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from .scenes import POPULATION_PARAMS, SHORT

__all__ = ["plot_unit_estimates", "plot_population", "plot_scatter_vs_noise", "plot_loo", "plot_chapter5",
           "plot_scaling", "plot_shrinkage", "MODEL_COLOURS"]

MODEL_COLOURS = {"phase": "tab:blue", "phase_drift": "tab:orange", "angle": "tab:green"}
UNITS = {"viscous.C": "1/s", "coulomb.R": "rad/s²", "escapement[2].X": "rad/s²"}


def _plt():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        try:
            import IPython  # noqa: F401

            if IPython.get_ipython() is None:
                matplotlib.use("Agg")
        except ImportError:
            matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _log_axis(axis, set_scale) -> None:
    """Log scale with plain numbers on the ticks."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    set_scale("log")
    axis.set_major_formatter(FormatStrFormatter("%g"))
    axis.set_minor_locator(LogLocator(subs=(2, 5)))
    axis.set_minor_formatter(FormatStrFormatter("%g"))


def _label(name: str) -> str:
    return f"{SHORT.get(name, name)} ({UNITS[name]})" if name in UNITS else SHORT.get(name, name)


def plot_unit_estimates(summary, *, truth: Mapping[str, Mapping[str, float]] | None = None,
                        population=None, params: Sequence[str] = POPULATION_PARAMS, title: str = ""):
    """Each unit's estimate (posterior median or best fit) and 95 % interval per parameter, with the
    truth and the population.

    Parameters
    ----------
    summary
        A fleet summary (:func:`escfit.study.fit_many`'s ``summary``).
    truth
        ``{unit: {name: value}}`` (a synthetic fleet's truth) drawn as crosses.
    population
        A :class:`~escfit.study.PopulationResult`: its median (line) and the interval for a new
        unit (band).
    """
    plt = _plt()
    units = [str(u) for u in summary["unit"].values]
    fig, axes = plt.subplots(1, len(params), figsize=(4.2 * len(params), 0.28 * len(units) + 1.6), sharey=True)
    axes = np.atleast_1d(axes)
    y = np.arange(len(units))[::-1]
    pop = population.summary() if population is not None else {}
    for ax, name in zip(axes, params):
        sel = summary.sel(parameter=name)
        # posterior median or least-squares best fit; summaries written before "estimate" hold "median"
        which = "estimate" if "estimate" in sel else "median"
        med, lo, hi = (sel[k].values.astype(float) for k in (which, "lo95", "hi95"))
        ax.errorbar(med, y, xerr=[med - lo, hi - med], fmt="o", ms=3, color="0.2", ecolor="0.5", lw=1,
                    label="unit: estimate, 95 %")
        if truth:
            ax.plot([truth[u][name] for u in units], y, "x", color="tab:red", ms=6, label="truth")
        if name in pop:
            p = pop[name]
            ax.axvspan(p["new_unit_lo"], p["new_unit_hi"], color="tab:green", alpha=0.12,
                       label="population: 95 % of units")
            ax.axvline(p["median"], color="tab:green", lw=1.5, label="population median")
        _log_axis(ax.xaxis, ax.set_xscale)
        ax.set_xlabel(_label(name))
        ax.grid(alpha=0.3, which="both")
    axes[0].set_yticks(y, units)
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle(title or "Per-unit estimates")
    fig.tight_layout()
    return fig


def plot_population(pop, *, truth=None, sample=None, title: str = ""):
    """Posterior of the population median and unit-to-unit spread of each parameter.

    Parameters
    ----------
    pop
        A :class:`~escfit.study.PopulationResult`.
    truth
        The generating :class:`~escfit.study.LogNormal` (dashed lines).
    sample
        The fleet's true values, shape (units, names): their geometric mean and log-sd (dotted).
    """
    plt = _plt()
    d = len(pop.names)
    fig, axes = plt.subplots(2, d, figsize=(4.0 * d, 5.6))
    meas = pop.measurement_sd()
    for j, name in enumerate(pop.names):
        a, b = axes[0, j], axes[1, j]
        a.hist(np.exp(pop.mu[:, j]), bins=50, color="tab:green", alpha=0.7, density=True)
        b.hist(pop.tau[:, j], bins=50, color="tab:purple", alpha=0.7, density=True, label="unit-to-unit scatter τ")
        b.axvline(meas[j], color="k", lw=1.5, label="measurement sd of one unit")
        if truth is not None:
            a.axvline(truth.median[j], color="tab:red", ls="--", label="generating population")
            b.axvline(truth.spread[j], color="tab:red", ls="--")
        if sample is not None:
            logs = np.log(np.asarray(sample)[:, j])
            a.axvline(math.exp(logs.mean()), color="tab:red", ls=":", label="these units")
            b.axvline(logs.std(ddof=1), color="tab:red", ls=":")
        a.set_xlabel(f"population median of {_label(name)}")
        b.set_xlabel(f"log-sd of {SHORT.get(name, name)} between units")
        a.set_yticks([])
        b.set_yticks([])
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    fig.suptitle(title or "Population estimates (posterior)")
    fig.tight_layout()
    return fig


def plot_scatter_vs_noise(pops: Mapping[str, object], *, title: str = ""):
    """Unit-to-unit scatter (tau, 95 % interval) against each unit's measurement sd, for several
    population estimates (e.g. five units as Monday had, and the whole fleet)."""
    plt = _plt()
    labels = list(pops)
    names = list(next(iter(pops.values())).names)
    fig, axes = plt.subplots(1, len(names), figsize=(4.0 * len(names), 3.4), sharey=False)
    for j, (ax, name) in enumerate(zip(np.atleast_1d(axes), names)):
        for i, lab in enumerate(labels):
            s = pops[lab].summary()[name]
            ax.errorbar([i], [s["tau"]], yerr=[[s["tau"] - s["tau_lo"]], [s["tau_hi"] - s["tau"]]], fmt="o",
                        color="tab:purple", capsize=4)
            ax.plot([i - 0.25, i + 0.25], [s["measurement_sd"]] * 2, color="k", lw=2)
            ax.text(i, s["tau_hi"], f" {100 * s['fraction_real']:.0f}% real\n "
                                    f"[{100 * s['fraction_real_lo']:.0f}-{100 * s['fraction_real_hi']:.0f}]",
                    fontsize=7, ha="center", va="bottom")
        ax.set_xticks(range(len(labels)), labels)
        ax.set_xlim(-0.6, len(labels) - 0.4)
        ax.set_ylabel(f"log-sd of {SHORT.get(name, name)}")
        top = max(max(pops[lab].summary()[name]["tau_hi"], pops[lab].summary()[name]["measurement_sd"])
                  for lab in labels)
        ax.set_ylim(0, 1.3 * top)
        ax.grid(alpha=0.3, axis="y")
    fig.suptitle(title or "Unit-to-unit scatter τ (purple, 95 %) vs measurement sd of one unit (black)")
    fig.tight_layout()
    return fig


def plot_shrinkage(pop, *, truth: np.ndarray | None = None, name: str = "viscous.C", title: str = ""):
    """One unit at a time versus partial pooling: per-unit estimates alone and under the population."""
    plt = _plt()
    j = pop.names.index(name)
    alone = np.median(pop.draws.theta[:, :, j], axis=1)
    lo_a, hi_a = np.quantile(pop.draws.theta[:, :, j], [0.025, 0.975], axis=1)
    sh = pop.shrunk()
    x = np.arange(len(pop.draws.units))
    fig, ax = plt.subplots(figsize=(max(6, 0.35 * x.size + 2), 3.6))
    ax.errorbar(x - 0.15, alone, yerr=[alone - lo_a, hi_a - alone], fmt="o", ms=3, color="0.4", label="unit alone")
    ax.errorbar(x + 0.15, sh["median"][:, j], yerr=[sh["median"][:, j] - sh["lo"][:, j], sh["hi"][:, j] -
                sh["median"][:, j]], fmt="o", ms=3, color="tab:green", label="under the population")
    if truth is not None:
        ax.plot(x, np.asarray(truth)[:, j], "x", color="tab:red", label="truth")
    _log_axis(ax.yaxis, ax.set_yscale)
    ax.set_xticks(x, pop.draws.units, rotation=90, fontsize=7)
    ax.set_ylabel(_label(name))
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax.set_title(title or f"{SHORT.get(name, name)}: each unit alone and with the fleet's help (95 %)")
    fig.tight_layout()
    return fig


def plot_loo(comparisons: Mapping[str, object], *, title: str = ""):
    """Per fleet: each unit's elpd_loo of every other model relative to the fleet's best model.

    Parameters
    ----------
    comparisons
        Fleet label -> :class:`~escfit.study.ModelComparison`.
    """
    plt = _plt()
    fig, axes = plt.subplots(1, len(comparisons), figsize=(4.6 * len(comparisons), 4.0), sharey=False)
    handles = {}
    for ax, (label, cmp) in zip(np.atleast_1d(axes), comparisons.items()):
        x = np.arange(len(cmp.units))
        others = [m for m in cmp.models if m != cmp.best]
        rows = {r["model"]: r for r in cmp.fleet()}
        for i, m in enumerate(others):
            d, se = cmp.unit_diff(m)
            off = (i - (len(others) - 1) / 2) * 0.25
            h = ax.errorbar(x + off, d, yerr=2 * se, fmt="o", ms=4, capsize=2, color=MODEL_COLOURS.get(m),
                            label=f"{m}")
            handles[m] = h
        ax.axhline(0, color=MODEL_COLOURS.get(cmp.best, "k"), lw=2)
        ax.set_xticks(x, cmp.units, rotation=90, fontsize=7)
        fleet_line = "; ".join(f"{m} {rows[m]['d_elpd']:.0f} ± {rows[m]['d_se']:.0f}" for m in others)
        ax.set_title(f"generated by {label}: LOO picks {cmp.best}\nfleet Δelpd: {fleet_line}", fontsize=9)
        ax.set_ylabel(f"elpd_loo − elpd_loo({cmp.best}), ± 2 se")
        ax.grid(alpha=0.3, axis="y")
    for m, colour in MODEL_COLOURS.items():
        if m not in handles:
            handles[m] = plt.Line2D([], [], color=colour, lw=2)
    fig.legend([handles[m] for m in MODEL_COLOURS], list(MODEL_COLOURS), loc="upper right", ncol=3, fontsize=8,
               title="model (line at 0: the fleet's best)", title_fontsize=8)
    fig.suptitle(title or "PSIS-LOO model comparison, unit by unit", x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    return fig


def plot_chapter5(residuals: Mapping[str, object], *, example: Mapping[str, object] | None = None,
                  unit: str | None = None, curve: int = 0, title: str = ""):
    """Monday's Chapter V pattern: observed minus fitted amplitude per reading, per model.

    Parameters
    ----------
    residuals
        Model -> :func:`escfit.study.decay_residuals` of the same units.
    example
        Model -> the same datasets, to draw one unit's curve (default: ``residuals``).
    unit, curve
        The example unit (default: the first) and curve (load) index.
    """
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    for m, ds in residuals.items():
        r = ds["residual"].mean("curve")  # (unit, reading)
        mean = r.mean("unit").values
        se = r.std("unit", ddof=1).values / math.sqrt(r.sizes["unit"])
        cycles = np.nanmedian(ds["swing"].values, axis=(0, 1)) / 2
        a.errorbar(cycles, mean, yerr=2 * se, marker="o", ms=3, capsize=3, color=MODEL_COLOURS.get(m), label=m)
    a.axhline(0, color="k", lw=0.8)
    a.set_xlabel("cycles after release")
    a.set_ylabel("recorded − fitted amplitude (rad), mean ± 2 se")
    a.set_title("Residuals over the fleet (above 0: the record has decayed less than the model)", fontsize=9)
    a.legend(fontsize=8, title="fitted model", title_fontsize=8)
    a.grid(alpha=0.3)
    ex = example or residuals
    first = next(iter(ex.values()))
    u = unit or str(first["unit"].values[0])
    sel = first.sel(unit=u).isel(curve=curve)
    cyc = sel["swing"].values / 2
    b.plot(cyc, sel["observed"].values, "s", color="k", ms=5, label="recorded (notch middle)")
    for m, ds in ex.items():
        s = ds.sel(unit=u).isel(curve=curve)
        b.plot(cyc, s["fitted"].values, "-", color=MODEL_COLOURS.get(m), label=m)
    b.set_xlabel("cycles after release")
    b.set_ylabel("amplitude (rad)")
    b.set_title(f"unit {u}, load {float(sel['load']):g} g", fontsize=10)
    b.legend(fontsize=8)
    b.grid(alpha=0.3)
    fig.suptitle(title or "Monday's Chapter V discrepancy on recordings with angle switching")
    fig.tight_layout()
    return fig


def plot_scaling(rows: Sequence[Mapping[str, float]], *, title: str = ""):
    """Wall time of the same batch on 1, 2, ... workers (rows with ``workers`` and ``seconds``)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(4.5, 3.2))
    w = [r["workers"] for r in rows]
    s = [r["seconds"] for r in rows]
    ax.bar([str(x) for x in w], s, color="tab:blue")
    for x, v in zip(w, s):
        ax.text(str(x), v, f"{v:.0f} s\n×{s[0] / v:.2f}", ha="center", va="bottom", fontsize=8)
    ax.set_xlabel("workers")
    ax.set_ylabel("wall time (s)")
    ax.margins(y=0.2)
    ax.set_title(title or "Scaling of a batch", fontsize=10)
    fig.tight_layout()
    return fig
