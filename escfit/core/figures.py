"""Figures as PNG bytes: matplotlib (an optional dependency) is imported only when one is drawn.

:func:`fit_figure` draws the data-versus-model picture every family uses: readings, the model at
the best fit, the 95 % posterior band of the model and the residuals, one colour per curve
(load, material, reading series) across every panel, and one shared legend (one entry per curve
plus a key to the line styles).  :class:`CaptionedPNG` carries a figure's caption with its bytes.
"""

from __future__ import annotations

import io
from typing import Sequence

import numpy as np

__all__ = ["unit_of", "pyplot", "png", "CaptionedPNG", "curve_colours", "fit_figure", "wrap_text", "LEGEND_PT"]

LEGEND_PT = 9.5  # legend and tick labels stay readable when the page shows the PNG at 1:1


class CaptionedPNG(bytes):
    """PNG bytes with the caption to print under the figure (``caption``, plain text).

    A ``bytes`` subclass, so a family's ``figures(result) -> dict[str, bytes]`` may return
    either plain bytes or captioned ones.
    """

    caption: str

    def __new__(cls, data: bytes, caption: str = ""):
        obj = super().__new__(cls, data)
        obj.caption = caption
        return obj


def pyplot():
    """matplotlib's pyplot on the file-only Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def png(fig, dpi: int = 100, caption: str = "", tight: bool = True) -> CaptionedPNG:
    """The figure as PNG bytes (laid out tightly unless it has a layout engine or ``tight`` is
    false), closing it.

    The PNG is ``figsize * dpi`` pixels: the layout never resizes the canvas.  The figure is drawn
    once (``savefig`` draws a figure with a layout engine twice: once to lay it out, once to
    print) and stored with a palette of 256 colours: the report's line art, anti-aliased edges and
    translucent dots look the same (on average a pixel's channels move by ~1.5 of 255; a few dozen
    edge pixels where curves of several colours cross, by up to ~40) and the file is three to
    five times smaller than in 24-bit colour.
    """
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    try:
        fig.set_dpi(dpi)
        if tight and fig.get_layout_engine() is None:
            fig.tight_layout()
        canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
        canvas.draw()  # a layout engine (constrained layout) runs inside this one draw
        rgba = np.asarray(canvas.buffer_rgba())
        opaque = bool(np.all(rgba[..., 3] == 255))  # a white page: the alpha channel holds nothing
        image = Image.fromarray(rgba[..., :3] if opaque else rgba)
        image = image.quantize(256, method=Image.Quantize.FASTOCTREE)  # the method that keeps an alpha channel
        buf = io.BytesIO()
        image.save(buf, format="png", dpi=(dpi, dpi))
    finally:
        plt.close(fig)
    return CaptionedPNG(buf.getvalue(), caption)


def wrap_text(text: str, width_in: float, points: float) -> str:
    """``text`` with line ends put between words so that no line is wider than ``width_in`` inches
    in matplotlib's default font at ``points`` (a word longer than the width keeps a line of its own).

    For figures laid out with fixed margins: a label wider than its panel would run into the next one.
    """
    from matplotlib.font_manager import FontProperties, findfont, get_font

    font = get_font(findfont(FontProperties()))
    font.set_size(points, 72)  # 72 dpi: widths come out in points

    def width(line: str) -> float:
        font.set_text(line, 0.0)
        return font.get_width_height()[0] / 64 / 72  # 26.6 fixed point, in inches

    out = []
    for paragraph in text.split("\n"):
        line = ""
        for word in paragraph.split(" "):
            trial = f"{line} {word}" if line else word
            if line and width(trial) > width_in:
                out.append(line)
                line = word
            else:
                line = trial
        out.append(line)
    return "\n".join(out)


def unit_of(label: str) -> str:
    """The ``" (unit)"`` ending of an axis label, or ``""``."""
    return f" ({label.rsplit('(', 1)[1]}" if label.rstrip().endswith(")") and "(" in label else ""


def curve_colours(labels: Sequence[str]) -> dict[str, str]:
    """One colour per curve, in order of first appearance (matplotlib's ten-colour cycle)."""
    return {label: f"C{k % 10}" for k, label in enumerate(dict.fromkeys(labels))}


def connect_only_line(x, curves) -> bool:
    """Whether the readings are too dense to move sideways (hundreds per curve): then no dodge."""
    curves = np.asarray(curves).astype(str)
    return max((int(np.sum(curves == c)) for c in np.unique(curves)), default=0) > 200


def fit_figure(plt, *, x, y, model, curves, xlabel: str, ylabel: str, band=None, yerr=None,
               names: dict[str, str] | None = None, reading_key: str = "readings",
               error_key: str = "reading interval", connect: bool = True, figsize=(9.0, 6.0)):
    """Readings, best-fit model, posterior band and residuals, one colour per curve.

    Parameters
    ----------
    x, y, model
        Plotting coordinate, readings and the model at the best fit, one value per reading, in
        the units the axes are labelled with (already converted for display).
    curves
        Curve label of every reading; each curve gets one colour in every panel.
    band
        ``(lo, hi)``: the 95 % posterior band of the model per reading, or ``None``.
    yerr
        Half-widths of the readings' intervals (e.g. half a notch), drawn as error bars.
    names
        Display name of each curve label (defaults to the label).
    reading_key, error_key
        Wording of the style key for the markers and the error bars.
    connect
        Draw the model as a line through the sorted x (else as crosses, for scattered x).

    Returns
    -------
    matplotlib.figure.Figure
        Main panel on top, residuals (reading - best fit) below, legend on the right.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    x, y, model = (np.asarray(v, dtype=float) for v in (x, y, model))
    curves = np.asarray(curves).astype(str)
    names = names or {}
    colours = curve_colours(list(curves))
    fig, (ax, axr) = plt.subplots(2, 1, figsize=figsize, sharex=True, layout="constrained",
                                  gridspec_kw={"height_ratios": [3, 1.2]})
    many = len(colours) > 1
    # several curves share the residual panel: each curve's points are moved sideways by a fraction of the
    # spacing of the readings and its band is drawn as two lines in its colour, so the curves stay apart
    spacing = float(np.min(np.diff(np.unique(x)))) if np.unique(x).size > 1 else 1.0
    dodge = {label: (k - (len(colours) - 1) / 2) * 0.18 * spacing / max(len(colours) - 1, 1) * min(len(colours) - 1, 2)
             for k, label in enumerate(colours)} if many and not connect_only_line(x, curves) else {}
    for label, colour in colours.items():
        m = curves == label
        order = np.argsort(x[m], kind="stable")
        xs = x[m][order]
        xr = xs + dodge.get(label, 0.0)
        if band is not None:
            lo, hi = (np.asarray(b, dtype=float)[m][order] for b in band)
            if xs.size > 1:
                ax.fill_between(xs, lo, hi, color=colour, alpha=0.22, lw=0, step=None if connect else "mid")
            else:  # one reading: the band is a bar
                ax.vlines(xs, lo, hi, color=colour, alpha=0.35, lw=8)
            if many:
                for edge in (lo, hi):
                    axr.plot(xr, edge - model[m][order], "-", color=colour, lw=1.0, alpha=0.85)
            else:
                axr.fill_between(xs, lo - model[m][order], hi - model[m][order], color=colour, alpha=0.22, lw=0)
        if connect:
            ax.plot(xs, model[m][order], "-", lw=1.4, color=colour)
        else:
            ax.plot(xs, model[m][order], "x", ms=7, color=colour)
        err = None if yerr is None else np.broadcast_to(np.asarray(yerr, dtype=float), y.shape)[m][order]
        ax.errorbar(xs, y[m][order], yerr=err, fmt="o", ms=4.5, mfc="white", mec=colour, ecolor=colour,
                    elinewidth=0.9, capsize=2 if err is not None else 0, color=colour)
        axr.errorbar(xr, (y[m] - model[m])[order], yerr=err, fmt="o", ms=4.5, mfc="white", mec=colour,
                     ecolor=colour, elinewidth=0.9, capsize=2 if err is not None else 0)
    axr.axhline(0, color="k", lw=0.6)
    span = max(np.ptp(np.r_[y, model]), 0.0)
    centre = float(np.mean(np.r_[y, model]))
    if span <= 1e-6 * max(abs(centre), 1e-300):  # a single reading, or a fit through every reading
        half = max(0.05 * abs(centre), 1e-12) if yerr is None else max(float(np.max(yerr)) * 2, 1e-12)
        ax.set_ylim(centre - half, centre + half)
        axr.set_ylim(-half, half)
    for a in (ax, axr):
        a.ticklabel_format(axis="y", useOffset=False)
    ax.set_ylabel(ylabel)
    axr.set_ylabel(f"reading - best fit{unit_of(ylabel)}")
    axr.set_xlabel(xlabel)
    for a in (ax, axr):
        a.tick_params(labelsize=LEGEND_PT)
        a.grid(alpha=0.25)
    handles = [Patch(color=c, label=names.get(lab, lab)) for lab, c in colours.items()] if many else []
    # one curve: the key is drawn in its colour; several: in grey, each curve's own colour said in the label
    ink = "0.45" if many else next(iter(colours.values()), "C0")
    each = " (each curve's colour)" if many else ""
    key = [Line2D([], [], ls="none", marker="o", mfc="white", mec=ink, color=ink,
                  label=reading_key + (f" (bars: {error_key})" if yerr is not None else "")),
           Line2D([], [], ls="-" if connect else "none", marker=None if connect else "x", color=ink,
                  label="model, best fit" + each)]
    if band is not None:
        key.append(Patch(color=ink, alpha=0.3, label="95 % posterior band" + each))
        if many:
            key.append(Line2D([], [], ls="-", color=ink, lw=1.0, label="its edges, in the residual panel"))
    entries = handles + key
    fig.legend(handles=entries, fontsize=LEGEND_PT, loc="outside upper center", frameon=False,
               ncol=min(len(entries), 3 if len(entries) > 4 else len(entries)))
    return fig
