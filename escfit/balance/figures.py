"""Report figures of balance fits, drawn from a saved results file (amplitudes, notches, waveforms, times).

Each function takes a saved fit (anything with ``group(name)`` and ``attrs``, e.g.
:class:`escfit.results.FitResult`) and returns captioned PNG bytes; the report builder calls
:func:`figures` through the balance family's registry entry.  Angles are drawn in degrees,
times of beats as residuals in milliseconds; one colour per curve (load) in every panel.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ..core.display import RAD_TO_DEG, curve_label, load_unit
from ..core.figures import LEGEND_PT, fit_figure, png, pyplot

__all__ = ["figures"]


def figures(res) -> dict[str, bytes]:
    """The data-versus-model figure(s) of a balance fit, by the kind of its readings."""
    if "expected" not in res.arrays("least_squares"):
        return {}
    plt = pyplot()
    kind = res.attrs.get("data_kind", "amplitude")
    if kind == "timeseries":
        out = {"data and fit": _waveform_figure(res, plt)}
        envelope = _envelope_figure(res, plt)
        if envelope is not None:
            out["amplitude per swing"] = envelope
        return out
    if kind in ("amplitude", "notches"):
        return {"data and fit": _amplitude_figure(res, plt)}
    if kind == "timegrapher":
        out = {}
        curves = res.arrays("observed_data")["curve"].values.astype(str)
        if "amplitude" in curves:
            out["data and fit"] = _timegrapher_amplitudes(res, plt)
        if (curves != "amplitude").any():
            out["beat times"] = _residual_figure(res, plt, only=[c for c in dict.fromkeys(curves) if c != "amplitude"])
        return out
    return {"data and fit": _residual_figure(res, plt)}


def _band(res, n: int):
    """The 95 % posterior band of the expected readings, or None without a posterior."""
    pp = res.arrays("posterior_predictive")
    if pp is None:
        return None
    e = pp["expected"].values.reshape(-1, n)
    e = e[np.all(np.isfinite(e), axis=1)]
    if not e.size:
        return None
    return np.quantile(e, [0.025, 0.975], axis=0)


def _names(res, curves) -> dict[str, str]:
    loads_in = load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}"))
    return {c: curve_label(c, loads_in) for c in dict.fromkeys(curves)}


def _amplitude_figure(res, plt) -> bytes:
    """Amplitude (or notch) readings per half swing against the model, in degrees."""
    obs = res.arrays("observed_data")
    model = res.arrays("least_squares")["expected"].values.astype(float)
    y = obs["reading"].values.astype(float)
    curves = obs["curve"].values.astype(str)
    band = _band(res, y.size)
    k = RAD_TO_DEG
    if res.attrs.get("data_kind") == "notches":
        notch, reading = _notch_from_results(res)
        lower = 0.0 if reading == "counted" else -0.5  # where a count's interval starts, in notches
        shown, yerr = (y + lower + 0.5) * notch * k, 0.5 * notch * k
        words = ("between n and n+1 notches" if reading == "counted"
                 else "within half a notch of n notches (read at the nearest mark)")
        caption = (f"Notch readings: a count n says the amplitude lay {words} of "
                   f"{notch * k:.3g} deg (the notch interval); the marker sits at its middle and the error bar "
                   "spans it. Lines join the model's amplitude at the recorded half swings (least-squares best "
                   "fit); between them the model is not drawn")
        key, err = "notch readings", f"notch interval, {notch * k:.3g} deg"
    else:
        shown, yerr = y * k, None
        caption = ("Amplitude readings against the model's amplitude at the least-squares best fit (lines join the "
                   "recorded half swings)")
        key, err = "amplitude readings", ""
    several = len(set(curves)) > 1
    caption += ("; shaded: 95 % band of the model over the posterior draws" if band is not None else "") + \
        ". Lower panel: reading minus best fit" + (
            ", each curve's points moved a little sideways so they do not hide each other"
            + (" and its band drawn as two lines" if band is not None else "")
            + ". One colour per curve (load) in both panels." if several else ".")
    fig = fit_figure(plt, x=obs["swing"].values, y=shown, model=model * k, curves=curves,
                     band=None if band is None else (band[0] * k, band[1] * k), yerr=yerr,
                     names=_names(res, curves), xlabel="half swing (count from release)",
                     ylabel="amplitude (deg)", reading_key=key, error_key=err)
    return png(fig, caption=caption)


def _timegrapher_amplitudes(res, plt) -> bytes:
    """The timegrapher's amplitude readings (already in degrees) against the model."""
    obs = res.arrays("observed_data")
    m = obs["curve"].values.astype(str) == "amplitude"
    y = obs["reading"].values.astype(float)
    model = res.arrays("least_squares")["expected"].values.astype(float)
    band = _band(res, y.size)
    lift = _lift_angle_deg(res)
    fig = fit_figure(plt, x=obs["swing"].values[m], y=y[m], model=model[m], curves=obs["curve"].values[m],
                     band=None if band is None else (band[0][m], band[1][m]), names={"amplitude": "amplitude"},
                     xlabel="half swing (count from release)", ylabel="amplitude shown by the timegrapher (deg)",
                     reading_key="timegrapher amplitude readings", figsize=(9.0, 5.2))
    caption = ("Amplitudes the timegrapher displayed, computed by the instrument from the beat's duration and its "
               "lift-angle setting" + (f" ({lift})" if lift else "") + "; line: the model's displayed amplitude at "
               "the least-squares best fit" + ("; shaded: 95 % posterior band" if band is not None else "")
               + ". Lower panel: reading minus best fit.")
    return png(fig, caption=caption)


def _lift_angle_deg(res) -> str:
    lsq = res.arrays("least_squares")
    names = [str(n) for n in lsq["parameter"].values]
    if "observation.lift_angle" in names:
        value = float(lsq["value"].values[names.index("observation.lift_angle")])
        return f"fitted true lift angle {value * RAD_TO_DEG:.4g} deg"
    return ""


#: what a waveform's readings are, by their unit: factor to the drawn unit, its label, the words
READ_AS = {"rad": (RAD_TO_DEG, "deg", "angle", "theta(t)"),
           "rad/s": (1.0, "rad/s", "angular velocity", "theta'(t), the rate of the angle,"),
           "m": (1.0, "m", "displacement", "x(t)")}


def _waveform_figure(res, plt) -> bytes:
    """Every sample against time with the model's theta(t) (or theta'(t), x(t)), and the residuals below."""
    obs = res.arrays("observed_data")
    lsq_exp = res.arrays("least_squares")["expected"].values
    t = obs["time"].values
    k, unit, what, model_words = READ_AS.get(obs["reading"].attrs.get("units", "rad"), READ_AS["rad"])
    y = obs["reading"].values.astype(float)
    band = _band(res, y.size)
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, layout="constrained",
                                  gridspec_kw={"height_ratios": [3, 1.3]})
    ms = 3 if y.size < 500 else 1.5
    ax.plot(t, k * y, "o", ms=ms, color="C0", mfc="none", label=f"recorded {what} (every sample fitted)")
    ax.plot(t, k * lsq_exp, "-", lw=0.9, color="C3", label="model, best fit")
    if band is not None:
        axr.fill_between(t, k * (band[0] - lsq_exp), k * (band[1] - lsq_exp), alpha=0.3, color="C3",
                         label="95 % posterior band of the model")
    axr.plot(t, k * (y - lsq_exp), "o", ms=ms, color="C0", mfc="none", label="recording - best fit")
    axr.axhline(0, color="k", lw=0.6)
    ax.set_ylabel(f"recorded {what}, sensor's scale ({unit})")
    axr.set_ylabel(f"reading - best fit ({unit})")
    axr.set_xlabel("time on the recording's clock (s)")
    for a in (ax, axr):
        a.tick_params(labelsize=LEGEND_PT)
        a.grid(alpha=0.25)
    ax.legend(fontsize=LEGEND_PT, loc="upper right")
    if band is not None:
        axr.legend(fontsize=LEGEND_PT, loc="upper right")
    zero = "the rate's zero (the sensor's bias)" if unit == "rad/s" else "the centre"
    caption = (f"The recorded {what} of every sample (blue circles) and the model's reading at the least-squares best "
               f"fit (red line: {model_words} placed on the sensor's scale by the fitted {zero}), in {unit}; "
               f"{zero} and its drift are in the parameter table. Lower panel: "
               "recording minus model; a pattern that repeats each swing points at a missing effect, a slow trend at "
               "a drift of the sensor's zero.")
    return png(fig, caption=caption)


def _envelope_figure(res, plt):
    """Amplitude of every half swing of a sampled waveform, recording and model, in degrees.

    The half swings are cut where the model changes sign; in each, the largest distance of the
    samples and of the model from the sensor's zero is the amplitude (alternate half swings
    differ by twice the centre's offset).
    """
    obs = res.arrays("observed_data")
    model = res.arrays("least_squares")["expected"].values.astype(float)
    y = obs["reading"].values.astype(float)
    t = obs["time"].values.astype(float)
    k, unit, what, _ = READ_AS.get(obs["reading"].attrs.get("units", "rad"), READ_AS["rad"])
    cuts = np.flatnonzero(np.signbit(model[1:]) != np.signbit(model[:-1])) + 1
    if cuts.size < 3:
        return None
    pieces = [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b - a >= 3]
    times = np.array([t[np.argmax(np.abs(model[a:b])) + a] for a, b in pieces])
    amp_y = k * np.array([np.max(np.abs(y[a:b])) for a, b in pieces])
    amp_m = k * np.array([np.max(np.abs(model[a:b])) for a, b in pieces])
    peak = "peak angular velocity" if unit == "rad/s" else "amplitude"
    fig = fit_figure(plt, x=times, y=amp_y, model=amp_m, curves=np.full(times.size, "amplitude"),
                     xlabel="time on the recording's clock (s)", ylabel=f"{peak} of the half swing ({unit})",
                     reading_key=f"largest recorded {what} in the half swing", figsize=(9.0, 5.0))
    caption = (f"{peak[0].upper() + peak[1:]} of every half swing: the largest recorded {what} (circles) and the "
               f"model's (line, least-squares best fit), in {unit} from the sensor's zero, so alternate half swings "
               "differ by twice the zero's offset. The decay's shape tells the "
               "damping: exponential for viscous drag, a straight line for dry (Coulomb) friction. Samples are "
               "discrete and noisy: a recorded peak may fall short of the true turning point (between samples) or "
               "pass it (the largest of several noisy samples), so the lower panel may sit off zero.")
    return png(fig, caption=caption)


def _residual_figure(res, plt, only=None) -> bytes:
    """Readings that are times or instrument values: residuals per reading series.

    Passage times and beat times grow through the run, so the informative picture is the data
    minus the least-squares prediction, with the posterior band of the prediction around it.
    Times are shown in milliseconds.
    """
    obs = res.arrays("observed_data")
    lsq_exp = res.arrays("least_squares")["expected"].values
    y = obs["reading"].values.astype(float)
    swing, curves = obs["swing"].values, obs["curve"].values.astype(str)
    units = obs["reading"].attrs.get("units", "")
    band = _band(res, y.size)
    labels = only or list(dict.fromkeys(curves))
    colours = {lab: f"C{k % 10}" for k, lab in enumerate(dict.fromkeys(curves))}
    fig, axes = plt.subplots(len(labels), 1, figsize=(9, 2.6 * len(labels) + 0.9), squeeze=False, layout="constrained")
    timed = units.strip() == "s" or "s (" in units or units.endswith("s (beats)")
    for ax, label in zip(axes[:, 0], labels):
        m = curves == label
        scale, unit = (1e3, "ms") if (timed and label != "amplitude") else (1.0, units)
        if band is not None:
            ax.fill_between(swing[m], scale * (band[0][m] - lsq_exp[m]), scale * (band[1][m] - lsq_exp[m]), alpha=0.3,
                            step="mid", color=colours[label], label="95 % posterior band of the prediction")
        ax.plot(swing[m], scale * (y[m] - lsq_exp[m]), "o", ms=3.5, mfc="white", color=colours[label],
                label=f"{label}: reading - best fit")
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylabel(f"{label} - best fit ({unit})", fontsize=LEGEND_PT)
        ax.tick_params(labelsize=LEGEND_PT)
        ax.grid(alpha=0.25)
        ax.legend(fontsize=LEGEND_PT, loc="upper right")
    axes[-1, 0].set_xlabel("half swing (count from release)")
    caption = ("Times and instrument readings grow through the run, so each series is drawn as the reading minus "
               "the model's prediction at the least-squares best fit" + (" with the 95 % posterior band of the "
               "prediction" if band is not None else "") + "; times in milliseconds. A drift means a missing "
               "effect or a wrong rate; scatter of a fraction of a millisecond is the instrument's resolution.")
    return png(fig, caption=caption)


def _notch_from_results(res) -> tuple[float, str]:
    """Notch angle (rad) and reading convention of a notch fit: stored with the fit, else (older
    files) the scene's ``[observation]`` table, else 6 deg counted."""
    a = res.attrs
    if "notch_deg" in a:
        return math.radians(float(a["notch_deg"])), str(a.get("notch_reading", "counted"))
    import tomllib

    obs = tomllib.loads(a.get("scene", "")).get("observation", {})
    nd = obs.get("notch_deg", 6.0)
    try:
        value = float(nd) if not isinstance(nd, str) else float(nd.split()[0])
    except (TypeError, ValueError):
        value = 6.0
    return math.radians(value), str(obs.get("notch_reading", "counted"))
