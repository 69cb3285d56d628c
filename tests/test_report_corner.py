"""The report's corner plot, read from the matplotlib figure (axes, labels, artists), not from pixels."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from escfit.report.corner import MAX_DOTS, corner_figure, thin
from escfit.report.plots import _corner, _display_draws, _sampled, report_figures
from escfit.results import FitResult

NAMES = ["oscillator.omega0", "oscillator.theta0", "viscous.C", "coulomb.R", "observation.sigma",
         "observation.offset", "observation.offset_rate", "observation.rho", "observation.t_release"]
UNITS = dict(zip(NAMES, ["1/s", "rad", "1/s", "1/s**2", "rad", "rad", "rad/s", "", "s"]))


def _fit(k: int, chains: int = 4, draws: int = 300, seed: int = 2) -> FitResult:
    rng = np.random.default_rng(seed)
    names = NAMES[:k]
    post = xr.Dataset({n: (("chain", "draw"), rng.normal(1.0 + i, 0.1, (chains, draws))) for i, n in enumerate(names)})
    tree = xr.DataTree.from_dict({"/posterior": post})
    tree.attrs.update(model="friction_rig", parameters=json.dumps(names), units=json.dumps(UNITS), burn=10)
    return FitResult(tree)


def _cells(fig) -> dict[tuple[int, int], object]:
    cells = {}
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        cells[(spec.rowspan.start, spec.colspan.start)] = ax
    return cells


@pytest.mark.parametrize("k", [2, 5, 9])
def test_corner_has_the_lower_triangle_and_every_free_parameter(k):
    res = _fit(k)
    draws, labels = _display_draws(res, _sampled(res))
    assert len(draws) == k
    fig = corner_figure(draws, labels)
    cells = _cells(fig)
    assert len(fig.axes) == k * (k + 1) // 2 and set(cells) == {(i, j) for i in range(k) for j in range(i + 1)}
    keys = list(draws)
    for j, key in enumerate(keys):  # each parameter names its column (bottom row) and its row (first column)
        name = labels[key].split("\n")[0]
        assert " ".join(cells[(k - 1, j)].get_xlabel().split()).startswith(" ".join(name.split()))
        if j > 0:
            assert " ".join(cells[(j, 0)].get_ylabel().split()).startswith(" ".join(name.split()))
    # the unit closes each label, and the draws are in it: theta0's 2.0 rad drawn at 114.6 deg
    assert cells[(k - 1, 1)].get_xlabel().endswith("(deg)") and cells[(k - 1, 0)].get_xlabel().endswith("(rad/s)")
    lo, hi = cells[(k - 1, 1)].get_xlim()
    assert lo < 2.0 * 180 / np.pi < hi and hi - lo < 0.2 * 180 / np.pi * 8
    for (i, j), ax in cells.items():
        if i == j:  # a histogram of the parameter on the diagonal
            assert any(type(p).__name__ == "StepPatch" for p in ax.patches)
        else:  # dots: x from the column's parameter, y from the row's
            dots = max(ax.lines, key=lambda ln: len(ln.get_xdata()))
            assert np.array_equal(dots.get_xdata(), thin(draws[keys[j]]))
            assert np.array_equal(dots.get_ydata(), thin(draws[keys[i]]))


def test_marginal_interval_and_median_match_the_normal_quantiles():
    """Normal draws: the shaded 95 % interval is mean -+ 1.96 sd and the median line the mean, within the
    sampling error of 40,000 draws (sd/100 for the median, ~sd/60 for the 2.5 % quantile: 5 sigma margins)."""
    res = _fit(2, chains=8, draws=5000, seed=7)
    draws, labels = _display_draws(res, _sampled(res))
    fig = corner_figure(draws, labels)
    ax = _cells(fig)[(0, 0)]
    mean, sd = 1.0, 0.1  # omega0 is 1/s: no unit conversion
    dashed = sorted(ln.get_xdata()[0] for ln in ax.lines if ln.get_linestyle() == "--")
    assert dashed == pytest.approx([mean - 1.96 * sd, mean + 1.96 * sd], abs=0.1 * sd)
    red = [ln.get_xdata()[0] for ln in ax.lines if ln.get_color() == "C3"]
    assert red == pytest.approx([mean], abs=0.05 * sd)


def test_dots_are_thinned_over_every_chain_and_the_caption_says_how_many():
    res = _fit(3, chains=32, draws=3001)  # 96,032 draws: every 25th of each chain, 121 a chain, 3872 dots
    draws, labels = _display_draws(res, _sampled(res))
    first = next(iter(draws.values()))
    kept = thin(first)
    assert kept.size == 32 * 121 <= MAX_DOTS
    # every chain contributes its share of the dots
    assert np.array_equal(kept.reshape(32, -1)[:, 0], first[:, 0])
    caption = _corner(draws, labels).caption
    assert f"one dot per draw for {kept.size} draws evenly spread over the {first.size} kept" in caption
    few = _fit(3, chains=4, draws=100)
    assert "one dot per draw (400 draws)" in _corner(*_display_draws(few, _sampled(few))).caption


def test_report_figures_of_nine_parameters_name_every_one():
    figures, diagnostics = report_figures(_fit(9))
    assert set(figures) == {"corner plot"} and set(diagnostics) == {"trace plots"}
    assert "every step" in diagnostics["trace plots"].caption  # 300 draws a walker: none thinned away
