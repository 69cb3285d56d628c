"""The report's figures: the family's data-versus-model figures, a generic one for families
without their own, the corner plot (ArviZ) and the sampler's trace plots.

Every figure is :class:`escfit.core.figures.CaptionedPNG` (PNG bytes with a caption); draws
are converted to display units (deg, rad/s^2 ...) before plotting.
"""

from __future__ import annotations

import json
import warnings

import numpy as np

from ..core.display import load_unit, to_display
from ..core.names import plain_name
from ..core.figures import LEGEND_PT, CaptionedPNG, fit_figure, png, pyplot

__all__ = ["report_figures", "CORNER_MAX_INCHES", "CORNER_DPI"]

CORNER_DPI = 100
CORNER_MAX_INCHES = 9.6  # corner plots stay within ~1000 px at CORNER_DPI, whatever the parameter count


def report_figures(res) -> tuple[dict[str, CaptionedPNG], dict[str, CaptionedPNG]]:
    """``(figures, diagnostics)``: data-versus-model and corner plot; the sampler's trace plots."""
    from ..inference.registry import family

    plt = pyplot()
    figs: dict[str, CaptionedPNG] = {}
    draw = getattr(family(res.attrs.get("model", "balance")), "figures", None)
    if draw is not None:
        figs.update({title: image if isinstance(image, CaptionedPNG) else CaptionedPNG(image)
                     for title, image in draw(res).items()})
    lsq = res.group("least_squares")
    if "data and fit" not in figs and lsq is not None and "expected" in lsq:
        figs["data and fit"] = _generic_figure(res, plt)
    diagnostics: dict[str, CaptionedPNG] = {}
    post = res.group("posterior")
    names = _sampled(res)
    if post is not None and names:
        if len(names) > 1:
            figs["corner plot"] = _corner(res, names)
        diagnostics["trace plots"] = _traces(res, names)
    return figs, diagnostics


def _sampled(res) -> list[str]:
    post = res.group("posterior")
    if post is None:
        return []
    return [n for n in res.parameter_names if n in post and np.ptp(post[n].values) > 0]


def _units(res) -> dict[str, str]:
    return json.loads(res.attrs.get("units", "{}") or "{}")


# What the readings of a family's data kind are, for axis labels (the generic figure's y axis)
READING_WORDS = {"terminal-speeds": "driver speed", "speed-trace": "driver speed",
                 "turns-to-arm": "turns to arm", "rig-readings": "extra load dw"}


def _generic_figure(res, plt) -> CaptionedPNG:
    """Readings against their plotting coordinate ``x`` (else their index), the model at the
    least-squares optimum and the 95 % posterior band, one colour per curve; residuals below."""
    obs = res.group("observed_data")
    model = res.group("least_squares")["expected"].values.astype(float)
    pp = res.group("posterior_predictive")
    family = str(res.attrs.get("model", ""))
    y = obs["reading"].values.astype(float)
    y_disp, y_unit = to_display(y, obs["reading"].attrs.get("units", ""), "reading")
    model_disp = to_display(model, obs["reading"].attrs.get("units", ""), "reading")[0]
    what = obs["reading"].attrs.get("long_name") or READING_WORDS.get(str(res.attrs.get("data_kind", "")), "reading")
    if "x" in obs.coords:
        # the family's own display rule applies to its coordinate (a Geneva torque in lbf in)
        x, x_unit = to_display(obs["x"].values.astype(float), obs["x"].attrs.get("units", ""), f"{family}.x")
        xlabel = f"{obs['x'].attrs.get('long_name', 'x')} ({x_unit})"
    else:
        x, xlabel = np.arange(y.size, dtype=float), "reading number"
    curves = obs["curve"].values.astype(str) if "curve" in obs.coords else np.full(y.size, "readings")
    band = None
    if pp is not None:
        e = pp["expected"].values.reshape(-1, y.size)
        e = e[np.all(np.isfinite(e), axis=1)]
        if e.size:
            band = tuple(to_display(np.quantile(e, q, axis=0), obs["reading"].attrs.get("units", ""), "reading")[0]
                         for q in (0.025, 0.975))
    connect = len(np.unique(x)) < x.size or x.size > 2
    fig = fit_figure(plt, x=x, y=y_disp, model=model_disp, curves=curves, band=band, xlabel=xlabel,
                     ylabel=f"{what} ({y_unit})", connect=connect, figsize=(9.0, 5.6))
    series = list(dict.fromkeys(curves))
    colours = (f"one colour per series ({', '.join(series)}); " if len(series) > 1 else "")
    caption = (f"{what[0].upper() + what[1:]} ({y_unit}) against {xlabel}; {colours}"
               + ("lines" if connect else "crosses") + ": the model at the least-squares best fit" +
               (("; shaded" if connect else "; bar") + ": 95 % band of the model over the posterior draws"
                if band is not None else "") + ". Lower panel: reading minus best fit.")
    return png(fig, caption=caption)


def _display_draws(res, names: list[str]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Posterior draws (chain, draw) in display units, keyed by display name; and axis labels."""
    post = res.group("posterior")
    units = _units(res)
    loads_in = load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}"))
    meanings = json.loads(res.attrs.get("meanings", "{}") or "{}")
    draws, labels = {}, {}
    for name in names:
        values, unit = to_display(post[name].values, units.get(name, ""), name)
        if name in ("observation.offset", "observation.offset_rate"):  # shown as the centre, as in the table
            from .params import CENTRE_BASE

            values = float(res.attrs.get(CENTRE_BASE[name], 0.0) or 0.0) * (180 / np.pi) - values
        key = plain_name(name, meanings.get(name, ""), loads_in)
        draws[key] = values
        labels[key] = f"{key}\n({unit})" if unit and unit not in ("1", "dimensionless") else key
    return draws, labels


def _corner(res, names: list[str]) -> CaptionedPNG:
    """ArviZ pair plot with marginals, medians and 95 % intervals marked, in display units."""
    import arviz as az
    import xarray as xr
    from matplotlib.ticker import MaxNLocator

    pyplot()  # the file-only Agg backend before ArviZ draws
    draws, labels = _display_draws(res, names)
    # the cloud and the marginals from at most ~4000 draws (evenly thinned): the picture is the same and
    # drawing 100,000 dots per panel took seconds; medians and intervals below use every draw
    first = next(iter(draws.values()))
    stride = max(1, -(-first.size // 4000))
    ds = xr.Dataset({k: (("chain", "draw"), v[:, ::stride]) for k, v in draws.items()})
    k = len(draws)
    side = min(CORNER_MAX_INCHES, 1.9 * k + 1.2)
    text = 8.5 if k <= 4 else 7.5
    n = ds[next(iter(draws))].size
    with warnings.catch_warnings():  # ArviZ's keyword handling is deprecated in recent matplotlib
        warnings.simplefilter("ignore", DeprecationWarning)
        axes = _pair(az, ds, side, text, n)
    axes = np.atleast_2d(axes)
    keys = list(draws)
    for i in range(k):
        lo, hi = np.quantile(draws[keys[i]], [0.025, 0.975])
        # with two parameters ArviZ draws a joint plot: the second marginal stands on its side
        side_on = k == 2 and i == 1
        diag = axes[i, i]
        (diag.axhspan if side_on else diag.axvspan)(lo, hi, color="C0", alpha=0.12, lw=0)
        for v in (lo, hi):
            (diag.axhline if side_on else diag.axvline)(v, color="C0", ls="--", lw=0.8)
        if side_on:
            diag.set_xticks([])
            diag.set_xlabel("")
        else:
            diag.set_yticks([])
            diag.set_ylabel("")
    for i in range(k):
        for j in range(k):
            axis = axes[i, j]
            if axis is None or not axis.get_visible() or (k == 2 and i == j == 1):
                continue
            axis.xaxis.set_major_locator(MaxNLocator(4))
            if i != j:
                axis.yaxis.set_major_locator(MaxNLocator(4))
            if i == k - 1:
                axis.set_xlabel(labels[keys[j]], fontsize=text)
                axis.tick_params(axis="x", labelrotation=40)
            if j == 0 and i > 0:
                axis.set_ylabel(labels[keys[i]], fontsize=text)
    fig = axes[0, 0].figure
    fig.set_size_inches(side, side)
    caption = ("Posterior of the sampled parameters, in display units: pairs of draws (one dot per draw) and each "
               "parameter's marginal density on the diagonal, with the median (red) and the 95 % interval "
               "(dashed lines, shaded). A thin slanted cloud means the data fix a combination of the two "
               "parameters better than either alone.")
    if k == 2:  # ArviZ's joint-plot grid does not suit tight_layout: leave room for the labels
        fig.subplots_adjust(left=0.2, bottom=0.2, right=0.97, top=0.97)
    return png(fig, dpi=CORNER_DPI, caption=caption, tight=k != 2)


def _pair(az, ds, side: float, text: float, n: int):
    k = len(ds.data_vars)
    # ArviZ draws at most plot.max_subplots (40) panels and silently drops parameters beyond: a 9-parameter
    # waveform fit (81 panels) lost its last row and column, and the report failed
    with az.rc_context(rc={"plot.max_subplots": max(40, k * k)}):
        return _pair_plot(az, ds, side, text, n)


def _pair_plot(az, ds, side: float, text: float, n: int):
    return az.plot_pair(ds, marginals=True, kind="scatter", point_estimate="median", figsize=(side, side),
                        textsize=text, scatter_kwargs={"alpha": 0.15 if n > 2000 else 0.3, "s": 3},
                        point_estimate_marker_kwargs={"color": "C3", "s": 30},
                        point_estimate_kwargs={"color": "C3", "lw": 1.0})


def _traces(res, names: list[str]) -> CaptionedPNG:
    """Trace plots: every walker's draws after burn-in, one compact panel per parameter."""
    plt = pyplot()
    draws, labels = _display_draws(res, names)
    k = len(draws)
    cols = min(3, k)
    rows = -(-k // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(9.0, 1.9 * rows + 0.5), squeeze=False, layout="constrained")
    burn = int(res.attrs.get("burn", 0) or 0)
    for axis, (key, values) in zip(axes.ravel(), draws.items()):
        stride = max(1, values.shape[1] // 600)  # at most ~600 points per walker: the same picture, drawn fast
        steps = burn + np.arange(values.shape[1])
        axis.plot(steps[::stride], values[:, ::stride].T, lw=0.4, alpha=0.35, color="C0")
        med = np.median(values)
        axis.axhline(med, color="C3", lw=0.9)
        axis.set_title(labels[key].replace("\n", " "), fontsize=LEGEND_PT)
        axis.tick_params(labelsize=8)
        axis.set_xlabel("step", fontsize=8)
    for extra in axes.ravel()[k:]:
        extra.set_visible(False)
    caption = ("Trace plots: each walker's position at every step kept after burn-in (thin lines), with the posterior "
               "median (red). Mixed walkers overlap as a band of constant width with no trend; a slow drift or "
               "walkers that stay apart mean the run is too short.")
    return png(fig, caption=caption)
