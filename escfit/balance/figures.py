"""Report figures of balance fits, drawn from a saved results file (amplitudes, notches, waveforms, times).

Each function takes a saved fit (anything with ``group(name)`` and ``attrs``, e.g.
:class:`escfit.results.FitResult`) and returns PNG bytes; the report builder calls
:func:`figures` through the balance family's registry entry.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.figures import png, pyplot

__all__ = ["figures"]


def figures(res) -> dict[str, bytes]:
    """The data-versus-model figure of a balance fit, by the kind of its readings."""
    if "expected" not in res.group("least_squares"):
        return {}
    plt = pyplot()
    kind = res.attrs.get("data_kind", "amplitude")
    if kind == "timeseries":
        return {"data and fit": _waveform_figure(res, plt)}
    draw = _data_figure if kind in ("amplitude", "notches") else _residual_figure
    return {"data and fit": draw(res, plt)}


def _data_figure(res, plt) -> bytes:
    obs = res.group("observed_data")
    lsq = res.group("least_squares")
    pp = res.group("posterior_predictive")
    kind = res.attrs.get("data_kind", "amplitude")
    y = obs["reading"].values.astype(float)
    swing = obs["swing"].values
    curves = obs["curve"].values
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    for label in dict.fromkeys(curves):
        m = curves == label
        if pp is not None:
            e = pp["expected"].values.reshape(-1, y.size)[:, m]
            e = e[np.all(np.isfinite(e), axis=1)]
            if e.size:
                lo, med, hi = np.quantile(e, [0.025, 0.5, 0.975], axis=0)
                ax.fill_between(swing[m], lo, hi, alpha=0.3, label=f"95% posterior band {label}")
                ax.plot(swing[m], med, "-", lw=1)
        ax.plot(swing[m], lsq["expected"].values[m], "--", lw=1, label=f"least squares {label}")
        yy = y[m] if kind == "amplitude" else None
        if yy is not None:
            ax.plot(swing[m], yy, "o", ms=4, label=f"data {label}")
            axr.plot(swing[m], yy - lsq["expected"].values[m], "o", ms=4)
    if kind == "notches":
        scene_notch = _notch_from_scene(res)
        for label in dict.fromkeys(curves):
            m = curves == label
            ax.errorbar(swing[m], (y[m] + 0.5) * scene_notch, yerr=0.5 * scene_notch, fmt="o", ms=4,
                        label=f"notch readings {label}")
            axr.plot(swing[m], (y[m] + 0.5) * scene_notch - lsq["expected"].values[m], "o", ms=4)
    ax.set_ylabel("amplitude reading (rad)")
    ax.legend(fontsize=7)
    axr.axhline(0, color="k", lw=0.5)
    axr.set_xlabel("half swing")
    axr.set_ylabel("residual (rad)")
    return png(fig)


def _waveform_figure(res, plt) -> bytes:
    """Every sample against time with the model's theta(t), and the residuals below (deg)."""
    obs = res.group("observed_data")
    lsq_exp = res.group("least_squares")["expected"].values
    pp = res.group("posterior_predictive")
    t = obs["time"].values
    k = 180.0 / np.pi
    y = obs["reading"].values.astype(float)
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    ms = 3 if y.size < 500 else 1.2
    ax.plot(t, k * y, "o", ms=ms, color="0.45", label="recording (every sample fitted)")
    ax.plot(t, k * lsq_exp, "-", lw=1, color="C3", label="model at the least-squares fit")
    if pp is not None:
        e = pp["expected"].values.reshape(-1, y.size)
        e = e[np.all(np.isfinite(e), axis=1)]
        if e.size:
            lo, hi = np.quantile(e - lsq_exp, [0.025, 0.975], axis=0)
            axr.fill_between(t, k * lo, k * hi, alpha=0.3, color="C3", label="95 % posterior band of the model")
    axr.plot(t, k * (y - lsq_exp), "o", ms=ms, color="C0", label="recording - model")
    axr.axhline(0, color="k", lw=0.5)
    ax.set_ylabel("angle reading (deg)")
    axr.set_ylabel("residual (deg)")
    axr.set_xlabel("time on the recording's clock (s)")
    ax.legend(fontsize=8, loc="upper right")
    axr.legend(fontsize=8, loc="upper right")
    return png(fig)


def _residual_figure(res, plt) -> bytes:
    """Recordings whose readings are times or instrument values: residuals per reading series.

    Passage times and beat times grow through the run, so the informative picture is the data
    minus the least-squares prediction, with the posterior band of the prediction around it.
    """
    obs = res.group("observed_data")
    lsq_exp = res.group("least_squares")["expected"].values
    pp = res.group("posterior_predictive")
    y = obs["reading"].values.astype(float)
    swing, curves = obs["swing"].values, obs["curve"].values
    units = obs["reading"].attrs.get("units", "")
    labels = list(dict.fromkeys(curves))
    fig, axes = plt.subplots(len(labels), 1, figsize=(8, 2.8 * len(labels) + 0.8), squeeze=False)
    for ax, label in zip(axes[:, 0], labels):
        m = curves == label
        if pp is not None:
            e = pp["expected"].values.reshape(-1, y.size)[:, m]
            e = e[np.all(np.isfinite(e), axis=1)]
            if e.size:
                lo, hi = np.quantile(e - lsq_exp[m], [0.025, 0.975], axis=0)
                ax.fill_between(swing[m], lo, hi, alpha=0.3, step="mid", label="95% posterior band of the prediction")
        ax.plot(swing[m], y[m] - lsq_exp[m], ".", ms=3, label="data")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"{label}: data - fit")
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel("half swing")
    fig.suptitle(f"residuals against the least-squares prediction (readings in {units})", fontsize=9)
    return png(fig)


def _notch_from_scene(res) -> float:
    import tomllib

    doc = tomllib.loads(res.attrs["scene"])
    nd = doc.get("observation", {}).get("notch_deg", 6.0)
    return math.radians(float(nd))


