"""The corner plot of a posterior, drawn with matplotlib alone.

One column and one row per sampled parameter: below the diagonal, pairs of draws as dots (an
evenly thinned subset, at most :data:`MAX_DOTS` per panel); on the diagonal, a histogram of every
draw of the parameter with its median and 95 % interval; above the diagonal, nothing.  Every
panel of a column shares the column's parameter range, every panel of a row the row's, so a
parameter's ticks are read once, on the outer edge.

The margins are fixed in inches (no layout engine and no ``tight_layout`` pass: both measure
every tick label of every panel, which cost more than drawing the dots), and the axis labels
are wrapped to the width of a panel, so long names such as "Coulomb friction R at 330.66 g"
do not run into the next panel's.
"""

from __future__ import annotations

import numpy as np

from ..core.figures import wrap_text

__all__ = ["corner_figure", "thin", "MAX_DOTS", "MAX_INCHES"]

MAX_DOTS = 4000  # dots per panel: 100,000 draws make the same cloud and took seconds to draw
MAX_INCHES = 9.6  # the figure's side stays within ~1000 px at 100 dpi, whatever the parameter count
BINS = 40
# margins in inches: the tick labels (rotated below, level on the left) and, added to them, the lines
# of the axis labels
TICKS_X, TICKS_Y, RIGHT, TOP = 0.5, 0.5, 0.12, 0.12
GAP = 0.08  # space between panels, as a fraction of a panel


def thin(values: np.ndarray, most: int = MAX_DOTS) -> np.ndarray:
    """Every ``ceil(n / most)``-th draw of each chain (``values`` is (chain, draw)), flattened.

    Whole chains are kept, so a stuck chain still shows up in the cloud.
    """
    values = np.atleast_2d(values)
    stride = max(1, -(-values.size // most))
    return values[:, ::stride].ravel()


def _finite(values: np.ndarray) -> np.ndarray:
    """The finite draws (a sampler that records a failed step as inf must not take the axis with it);
    a single 0 when none is, so that the axes still get a range."""
    finite = values[np.isfinite(values)]
    return finite if finite.size else np.zeros(1)


def _limits(values: np.ndarray) -> tuple[float, float]:
    lo, hi = float(np.min(values)), float(np.max(values))
    pad = 0.04 * (hi - lo) if hi > lo else max(abs(lo) * 1e-3, 1e-12)
    return lo - pad, hi + pad


def corner_figure(draws: dict[str, np.ndarray], labels: dict[str, str], *, dpi: int = 100):
    """The corner plot of ``draws`` as a matplotlib figure (not yet saved).

    Parameters
    ----------
    draws
        Posterior draws, (chain, draw) arrays in display units, keyed by the name shown.
    labels
        Axis label of each key (name, a line end, then the unit in parentheses).
    dpi
        Resolution the figure will be saved at (fixes the size of the dots in pixels).

    Returns
    -------
    matplotlib.figure.Figure
        ``k (k + 1) / 2`` axes for ``k`` parameters, row by row: in row ``i``, the pairs of
        parameter ``i`` (y) with parameters ``0 .. i - 1`` (x), then the histogram of
        parameter ``i``; ``ax.get_subplotspec()`` gives each one's row and column.
    """
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    keys = list(draws)
    k = len(keys)
    side = min(MAX_INCHES, 1.9 * k + 1.2)
    text = 8.5 if k <= 4 else 7.5
    panel = (side - 1.0 - RIGHT) / (k + GAP * (k - 1))  # a first guess of the margins sets the wrap width
    wrapped = {key: wrap_text(labels[key], panel, text) for key in keys}
    line = text * 1.3 / 72  # inches per line of label text
    lines_x = max(wrapped[key].count("\n") + 1 for key in keys)
    lines_y = max((wrapped[key].count("\n") + 1 for key in keys[1:]), default=1)
    bottom, left = TICKS_X + lines_x * line, TICKS_Y + lines_y * line
    fig = Figure(figsize=(side, side), dpi=dpi)
    grid = fig.add_gridspec(k, k, left=left / side, bottom=bottom / side, right=1 - RIGHT / side,
                            top=1 - TOP / side, wspace=GAP, hspace=GAP)
    ticks = 4 if panel >= 1.2 else 3  # rotated tick labels of narrow panels would touch
    flat = {key: _finite(np.asarray(v, dtype=float).ravel()) for key, v in draws.items()}
    dots = {key: thin(np.asarray(v, dtype=float)) for key, v in draws.items()}  # a non-finite dot is not drawn
    limits = {key: _limits(v) for key, v in flat.items()}
    median = {key: float(np.median(v)) for key, v in flat.items()}
    alpha = 0.15 if dots[keys[0]].size > 2000 else 0.3
    for i, ky in enumerate(keys):
        for j, kx in enumerate(keys[: i + 1]):
            ax = fig.add_subplot(grid[i, j])
            ax.set_xlim(*limits[kx])
            if i == j:
                _marginal(ax, flat[kx], limits[kx], median[kx])
            else:
                ax.plot(dots[kx], dots[ky], ls="none", marker="o", ms=1.6, mew=0, color="C0", alpha=alpha)
                ax.set_ylim(*limits[ky])
                ax.axvline(median[kx], color="C3", lw=1.0)
                ax.axhline(median[ky], color="C3", lw=1.0)
                ax.plot([median[kx]], [median[ky]], "s", color="C3", ms=5 if k <= 4 else 3.5)
                ax.yaxis.set_major_locator(MaxNLocator(ticks))
            ax.xaxis.set_major_locator(MaxNLocator(ticks))
            for axis in (ax.xaxis, ax.yaxis):
                form = ScalarFormatter(useOffset=False)  # an offset printed inside the grid would be read
                axis.set_major_formatter(form)          # as belonging to one panel
            ax.tick_params(labelsize=text - 0.5, length=3, labelbottom=i == k - 1, labelleft=j == 0 and i > 0)
            if i == k - 1:
                ax.set_xlabel(wrapped[kx], fontsize=text)
                ax.tick_params(axis="x", labelrotation=40)
            if j == 0 and i > 0:
                ax.set_ylabel(wrapped[ky], fontsize=text)
    return fig


def _marginal(ax, values: np.ndarray, limits: tuple[float, float], median: float) -> None:
    """Histogram of every draw (a density outline), the median in red and the 95 % interval shaded."""
    counts, edges = np.histogram(values, bins=BINS, range=limits)
    ax.stairs(counts, edges, color="C0", lw=1.2)
    lo, hi = np.quantile(values, [0.025, 0.975])
    ax.axvspan(lo, hi, color="C0", alpha=0.12, lw=0)
    for v in (lo, hi):
        ax.axvline(v, color="C0", ls="--", lw=0.8)
    ax.axvline(median, color="C3", lw=1.2)
    ax.set_ylim(0, counts.max() * 1.08 if counts.max() > 0 else 1)
    ax.set_yticks([])
