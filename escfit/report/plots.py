"""The report's figures: the family's data-versus-model figures, a generic one for families
without their own, the corner plot (:mod:`escfit.report.corner`) and the sampler's trace plots.

Every figure is :class:`escfit.core.figures.CaptionedPNG` (PNG bytes with a caption); draws
are converted to display units (deg, rad/s^2 ...) before plotting.
"""

from __future__ import annotations

import json

import numpy as np

from ..core.display import load_unit, to_display
from ..core.names import plain_name
from ..core.figures import LEGEND_PT, CaptionedPNG, fit_figure, png, pyplot, wrap_text

__all__ = ["report_figures", "CORNER_DPI"]

CORNER_DPI = 100


def report_figures(res) -> tuple[dict[str, CaptionedPNG], dict[str, CaptionedPNG]]:
    """``(figures, diagnostics)``: data-versus-model and corner plot; the sampler's trace plots."""
    from ..inference.registry import family

    plt = pyplot()
    figs: dict[str, CaptionedPNG] = {}
    draw = getattr(family(res.attrs.get("model", "balance")), "figures", None)
    if draw is not None:
        figs.update({title: image if isinstance(image, CaptionedPNG) else CaptionedPNG(image)
                     for title, image in draw(res).items()})
    lsq = res.arrays("least_squares")
    if "data and fit" not in figs and lsq is not None and "expected" in lsq:
        figs["data and fit"] = _generic_figure(res, plt)
    diagnostics: dict[str, CaptionedPNG] = {}
    post = res.arrays("posterior")
    names = _sampled(res)
    if post is not None and names:
        draws, labels = _display_draws(res, names)  # once, for both figures
        if len(names) > 1:
            figs["corner plot"] = _corner(draws, labels)
        diagnostics["trace plots"] = _traces(draws, labels, int(res.attrs.get("burn", 0) or 0))
    return figs, diagnostics


def _sampled(res) -> list[str]:
    post = res.arrays("posterior")
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
    obs = res.arrays("observed_data")
    model = res.arrays("least_squares")["expected"].values.astype(float)
    pp = res.arrays("posterior_predictive")
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
    post = res.arrays("posterior")
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


def _corner(draws: dict[str, np.ndarray], labels: dict[str, str]) -> CaptionedPNG:
    """Corner plot (:mod:`escfit.report.corner`) of draws in display units (:func:`_display_draws`):
    pairs of draws, marginal histograms, medians and 95 % intervals."""
    from .corner import corner_figure, thin

    fig = corner_figure(draws, labels, dpi=CORNER_DPI)
    first = next(iter(draws.values()))
    n, shown = first.size, thin(first).size  # the dots of every panel: the same draws of every parameter
    dots = (f"one dot per draw ({n} draws)" if shown == n else
            f"one dot per draw for {shown} draws evenly spread over the {n} kept")
    caption = ("Posterior of the sampled parameters, in display units: pairs of draws (" + dots + ") and a "
               "histogram of each parameter's draws on the diagonal, with the median (red) and the 95 % interval "
               "(dashed lines, shaded). A thin slanted cloud means the data fix a combination of the two "
               "parameters better than either alone.")
    return png(fig, dpi=CORNER_DPI, caption=caption, tight=False)


def _traces(draws: dict[str, np.ndarray], labels: dict[str, str], burn: int = 0) -> CaptionedPNG:
    """Trace plots of draws in display units (:func:`_display_draws`): every walker's draws after the
    ``burn`` steps of burn-in, one compact panel per parameter, three panels a row.

    The margins are fixed in inches and the titles wrapped to a panel's width (no layout engine:
    constrained layout measured every tick label and cost as much as the drawing).
    """
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.ticker import ScalarFormatter

    k = len(draws)
    cols = min(3, k)
    rows = -(-k // cols)
    width, left, right, gap, bottom, tick_pt = 9.0, 0.62, 0.15, 0.62, 0.5, 8
    panel_w, panel_h = (width - left - right - gap * (cols - 1)) / cols, 1.3
    titles = {key: wrap_text(labels[key].replace("\n", " "), panel_w, LEGEND_PT) for key in draws}
    title_h = max(t.count("\n") + 1 for t in titles.values()) * LEGEND_PT * 1.25 / 72 + 0.08
    row_h = panel_h + title_h + bottom  # a panel, its title above and its step axis below
    height = rows * row_h + 0.05
    fig = Figure(figsize=(width, height))
    n_steps = next(iter(draws.values())).shape[1]
    # at most ~300 points per walker, about one per pixel column of a panel: the same band, drawn in half the time
    stride = max(1, n_steps // 300)
    steps = (burn + np.arange(n_steps))[::stride]
    for n, (key, values) in enumerate(draws.items()):
        r, c = divmod(n, cols)
        axis = fig.add_axes(((left + c * (panel_w + gap)) / width, (height - (r + 1) * row_h + bottom) / height,
                             panel_w / width, panel_h / height))
        kept = values[:, ::stride]
        # one collection of every walker's line: one artist to lay out and draw instead of one per walker;
        # each line is still drawn on its own, so overlapping walkers darken as they did
        segments = np.stack([np.broadcast_to(steps, kept.shape), kept], axis=-1)
        axis.add_collection(LineCollection(segments, lw=0.4, alpha=0.35, color="C0"))
        axis.autoscale_view()
        axis.axhline(np.median(values), color="C3", lw=0.9)
        axis.set_title(titles[key], fontsize=LEGEND_PT)
        axis.yaxis.set_major_formatter(ScalarFormatter(useOffset=False))  # no offset text under the title
        axis.tick_params(labelsize=tick_pt)
        axis.set_xlabel("step", fontsize=tick_pt)
    every = "every step" if stride == 1 else f"one step in {stride}"
    caption = (f"Each walker's position at {every} after burn-in (thin lines), with the posterior "
               "median (red). Mixed walkers overlap as a band of constant width with no trend; a slow drift or "
               "walkers that stay apart mean the run is too short.")
    return png(fig, caption=caption, tight=False)
