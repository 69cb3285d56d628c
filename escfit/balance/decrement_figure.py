"""The decrement figure of a balance or pendulum decay, drawn from a saved fit.

For fits whose readings give turning-point amplitudes (unit curves of amplitudes or notch counts,
turning points of a recording) or whose samples show them (waveform fits), the figure draws the
measured decrement per half swing against the amplitude, the fitted model's decrements at the
same half swings, and each damping law's part at the best fit (see
:mod:`escfit.balance.decrement` for the formulas).  Everything comes from the results file:
the readings (``observed_data``), the model's expected readings and the best-fit values
(``least_squares``) and the scene text stored with them; the recording is never read again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.display import RAD_TO_DEG, curve_label, load_unit
from .decrement import LAWS, Decrements, Window, binned, from_readings, from_turns, law_parts, losses

__all__ = ["DecrementPanel", "decrement_panels", "decrement_figure"]

#: effects whose part the decomposition knows (others leave the parts out, said in the caption)
KNOWN_EFFECTS = {*losses(), "escapement", "stiffening"}
MAX_PANELS = 4
WINDOW_PERIODS = 0.2  # samples within +-this many periods of a turning point locate it


@dataclass
class DecrementPanel:
    """One curve's decrements (rad).  ``parts`` maps law keys to ``(amplitude grid, decrement)``;
    ``coefficients`` holds the best-fit ``omega0``, ``C``, ``R``, ``D`` used for them."""

    label: str
    measured: Decrements
    model: Decrements
    parts: dict = field(default_factory=dict)
    coefficients: dict = field(default_factory=dict)


def decrement_panels(res) -> tuple[list[DecrementPanel], list[str]]:
    """The decrements of every curve of a saved balance fit, and notes for the caption.

    Returns ``([], [why])`` for fits whose readings give no amplitudes (passage times,
    timegrapher readings) or too few of them.
    """
    lsq = res.arrays("least_squares")
    obs = res.arrays("observed_data")
    kind = res.attrs.get("data_kind", "amplitude")
    if lsq is None or obs is None or "expected" not in lsq:
        return [], ["no readings and model stored"]
    best = dict(zip(map(str, lsq["parameter"].values), map(float, lsq["value"].values)))
    expected = lsq["expected"].values.astype(float)
    y = obs["reading"].values.astype(float)
    curves = obs["curve"].values.astype(str)
    if kind in ("amplitude", "notches"):
        half = None
        if kind == "notches":
            notch, reading = _notch(res)
            lower = 0.0 if reading == "counted" else -0.5
            y, half = (y + lower + 0.5) * notch, 0.5 * notch
        pieces = {}
        for c in dict.fromkeys(curves):
            m = curves == c
            s = obs["swing"].values[m]
            pieces[c] = (from_readings(s, y[m], None if half is None else np.full(m.sum(), half)),
                         from_readings(s, expected[m]))
    elif kind == "timeseries" and obs["reading"].attrs.get("units") == "rad/s":
        return [], ["a record of the angular velocity shows no amplitudes per half swing (the fit reads the rate)"]
    elif kind == "timeseries" and "time" in obs:
        t = obs["time"].values.astype(float)
        rate = best.get("observation.offset_rate", 0.0)
        pieces = {"waveform": (_decrements_of_samples(t, y, expected, rate),
                               _decrements_of_samples(t, expected, expected, rate))}
    else:
        return [], [f"{kind} readings give no amplitudes"]
    scene, per_curve, notes = _curve_values(res, best, obs)
    panels = []
    for label, (measured, model) in list(pieces.items())[:MAX_PANELS]:
        if measured.decrement.size < 2:
            continue
        panel = DecrementPanel(label, measured, model)
        vals = per_curve.get(label) if per_curve else None
        if scene is not None and vals is not None:
            _add_parts(panel, scene, vals, measured, model)
        panels.append(panel)
    if len(pieces) > MAX_PANELS:
        notes.append(f"the first {MAX_PANELS} of {len(pieces)} curves are drawn")
    if not panels:
        return [], ["fewer than three turning points: no decrement to draw"]
    return panels, notes


def _notch(res) -> tuple[float, str]:
    from .figures import _notch_from_results

    return _notch_from_results(res)


def _decrements_of_samples(t: np.ndarray, y: np.ndarray, model: np.ndarray, rate: float) -> Decrements:
    """Decrements of sampled angles ``y`` at the turning points the model shows.

    The fitted model (``least_squares`` expected samples) says where the half swings turn; each
    turning angle is the vertex of a local polynomial fit to the samples within
    :data:`WINDOW_PERIODS` periods of it (kinked at the vertex, where Coulomb friction reverses).
    A drifting centre (``offset_rate``, rad/s) is removed before the spans are taken.
    """
    from ..analysis.recordings.extrema import kinked_vertex

    turns = _model_turns(model)
    if turns.size < 3:
        return Decrements(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, np.int64))
    period = 2.0 * float(np.median(np.diff(t[turns])))
    half = WINDOW_PERIODS * period
    values, times = [], []
    for k in turns:
        m = np.abs(t - t[k]) <= half
        if t[k] - half < t[0] or t[k] + half > t[-1]:
            continue  # a turn at the record's edge has samples on one side only
        found = kinked_vertex((t[m] - t[k]) / half, y[m])
        if found is None:
            continue
        values.append(found[1])
        times.append(t[k] + found[0] * half)
    theta = np.asarray(values) + rate * np.asarray(times)  # the centre moves by rate*t: remove it
    return from_turns(theta)


def _model_turns(model: np.ndarray) -> np.ndarray:
    """Indices of the samples where the (noise-free) model changes direction."""
    slope = np.sign(np.diff(model))
    moving = np.flatnonzero(slope != 0)
    if moving.size < 2:
        return np.zeros(0, np.int64)
    s = slope[moving]
    change = np.flatnonzero(s[1:] != s[:-1])
    return moving[change + 1]  # the first sample of the new direction's step: the extreme sample


def _curve_values(res, best: dict, obs) -> tuple[object, dict, list[str]]:
    """The scene and every curve's parameter values at the best fit (loads applied), or
    ``(None, {}, [why])`` when the parts cannot be drawn."""
    from ..core.errors import EscfitError
    from ..core.scene import load_scene

    try:
        scene = load_scene(res.attrs.get("scene_file") or "fit.toml", text=res.attrs.get("scene", ""))
    except EscfitError as exc:
        return None, {}, [f"the stored scene cannot be read ({exc}): no parts drawn"]
    others = sorted({e.key for e in scene.effects} - KNOWN_EFFECTS)
    if others:
        return None, {}, [f"the parts cover Coulomb friction, viscous damping, drag, an escapement and a stiffening "
                          f"spring; this scene also "
                          f"has {', '.join(others)}, so none is drawn"]
    known = {k: v for k, v in best.items() if k in scene.params}
    vals = dict(scene.params.with_values(known).values())
    vals.update({k: v for k, v in best.items() if k not in vals})
    curves = obs["curve"].values.astype(str)
    table = (scene.extra.get("fit") or {}).get("loads")
    if table is None:
        return scene, {c: vals for c in dict.fromkeys(curves)} | {"waveform": vals}, []
    rule = _load_rule(res, scene, table, obs)
    if rule is None:
        return scene, {}, ["the load rule of the fit cannot be rebuilt from the results: no parts drawn"]
    loads = obs["load"].values.astype(float)
    return scene, {c: rule.apply(vals, float(loads[curves == c][0])) for c in dict.fromkeys(curves)}, []


def _load_rule(res, scene, table, obs):
    """The fit's :class:`~escfit.balance.problems.loads.LoadRule`, rebuilt from the stored loads."""
    import json
    from types import SimpleNamespace

    from ..core.errors import EscfitError
    from ..core.params import ParamSet
    from .problems.loads import LoadRule

    loads = np.unique(obs["load"].values.astype(float))
    data = SimpleNamespace(load=loads, load_unit=load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}")))
    try:
        return LoadRule.read(table, scene, data, [SimpleNamespace(load=ld) for ld in loads],
                             ParamSet(dict(scene.params.params)))
    except (EscfitError, OSError, ValueError):
        return None


def _add_parts(panel: DecrementPanel, scene, vals: dict, measured: Decrements, model: Decrements) -> None:
    omega0 = vals.get("oscillator.omega0", math.nan)
    if not math.isfinite(omega0):
        return
    esc = scene.effect("escapement")
    windows = tuple(Window(w.sign, vals[w.name], w.lo, w.hi, 1.0 if w.swings == "both" else 0.5)
                    for w in esc.windows) if esc is not None else ()
    symbols = {cls.LOSS.symbol: vals.get(cls.LOSS.parameter, 0.0) for cls in losses().values()}
    coeff = {"omega0": omega0, **symbols, "k3": vals.get("stiffening.k3", 0.0)}
    amps = np.concatenate([measured.amplitude, model.amplitude])
    top = 1.08 * float(np.max(amps))
    bottom = 0.85 * float(np.min(amps)) if windows else 0.0
    grid = np.linspace(max(bottom, 1e-3 * top), top, 200)
    parts = law_parts(grid, omega0=omega0, k3=coeff["k3"], windows=windows, restoring=scene.restoring,
                      switching=scene.switching, **symbols)
    if coeff["k3"]:  # how far the linear spring's forms would be off at the largest amplitude: said in the caption
        top_a = np.array([float(np.max(amps))])
        stiff = law_parts(top_a, omega0=omega0, k3=coeff["k3"], restoring=scene.restoring, **symbols)
        plain = law_parts(top_a, omega0=omega0, restoring=scene.restoring, **symbols)
        coeff["stiffening_effect"] = {key: float(stiff[key][0] / plain[key][0] - 1.0) for key in stiff
                                      if plain.get(key) is not None and plain[key][0]}
        coeff["stiffening_at"] = float(top_a[0])
    scale = float(np.max(np.abs(np.concatenate([measured.decrement, model.decrement]))))
    # a coefficient on its lower bound (R = 1e-17) leaves a part too small to see: said, not drawn
    absent = {key: "zero" for key, v in parts.items() if float(np.max(np.abs(v))) < 1e-6 * scale}
    panel.parts = {key: (grid, v) for key, v in parts.items() if key not in absent}
    panel.coefficients = coeff | {"restoring": scene.restoring, "switching": scene.switching,
                                  "windows": len(windows), "absent": absent,
                                  "linear": getattr(scene, "linear", False)}


# -- drawing -----------------------------------------------------------------------------------
COLOURS = {**{key: cls.LOSS.colour for key, cls in losses().items()}, "escapement": "#9467bd",
           "constant": "#8c564b"}


def decrement_figure(res):
    """The decrement figure as captioned PNG bytes, or ``None`` when the fit shows no decay."""
    import json

    panels, notes = decrement_panels(res)
    if not panels:
        return None
    from ..core.figures import LEGEND_PT, png, pyplot

    plt = pyplot()
    n = len(panels)
    fig, axes = plt.subplots(1, n, figsize=(9.0, 5.6) if n == 1 else (4.4 * n, 5.4), squeeze=False,
                             layout="constrained", sharey=True)
    loads_in = load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}"))
    for ax, p in zip(axes[0], panels):
        handles = _draw_panel(ax, p, LEGEND_PT)
        if n == 1:
            ax.legend(*zip(*[(h, _label(key, p)) for key, h in handles]), fontsize=LEGEND_PT - 1, loc="best",
                      framealpha=0.9)
        else:
            ax.set_title(curve_label(p.label, loads_in), fontsize=LEGEND_PT + 1)
            ax.text(0.03, 0.97, "\n".join(_values_text(p)), transform=ax.transAxes, va="top", fontsize=LEGEND_PT - 1,
                    bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"})
    if n > 1:
        fig.legend(*zip(*[(h, _label(key, None)) for key, h in handles]), loc="outside lower center", ncols=2,
                   fontsize=LEGEND_PT - 1)
    axes[0, 0].set_ylabel(f"decrement per half swing, A(k) - A(k+1) ({_units(panels[0])[1]})")
    notes = notes + [f"{LAWS[key][0]} is {why} at the best fit, so it has no part"
                     for p in panels[:1] for key, why in p.coefficients.get("absent", {}).items()]
    return png(fig, caption=_caption(res, panels, notes))


def _draw_panel(ax, p: DecrementPanel, pt: float) -> list[tuple[str, object]]:
    """Draw one curve; returns ``(key, handle)`` pairs in legend order."""
    k, unit = _units(p)
    m = p.measured
    many = m.decrement.size > 30
    out = []
    if np.any(m.error > 0):
        h = ax.errorbar(m.amplitude * k, m.decrement * k, yerr=m.error * k, fmt="o", ms=5, mfc="white", color="0.25",
                        capsize=2, lw=0.8, zorder=3)
        out.append(("measured_interval", h))
    else:
        (h,) = ax.plot(m.amplitude * k, m.decrement * k, "o", ms=3 if many else 5, mfc="white",
                       color="0.6" if many else "0.25", lw=0, zorder=2)
        out.append(("measured", h))
    if many:
        a, d, se = binned(m.amplitude, m.decrement)
        out.append(("binned", ax.errorbar(a * k, d * k, yerr=se * k, fmt="s", ms=6, color="k", capsize=3, lw=1.2,
                                          zorder=4)))
    order = np.argsort(p.model.amplitude)
    (h,) = ax.plot(p.model.amplitude[order] * k, p.model.decrement[order] * k, "-", color="#ff7f0e", lw=2.2, zorder=5)
    out.append(("model", h))
    for key, (grid, dec) in p.parts.items():
        (h,) = ax.plot(grid * k, dec * k, "--", color=COLOURS[key], lw=1.6)
        out.append((key, h))
    if len(p.parts) > 1:
        grid = next(iter(p.parts.values()))[0]
        (h,) = ax.plot(grid * k, sum(dec for _, dec in p.parts.values()) * k, ":", color="k", lw=1.4)
        out.append(("sum", h))
    ax.axhline(0.0, color="k", lw=0.6)
    if not p.coefficients.get("windows"):
        ax.set_xlim(left=0.0)  # lines through the origin show the laws' shapes
    ax.set_xlabel(f"amplitude A ({unit})")
    ax.tick_params(labelsize=pt)
    ax.grid(alpha=0.25)
    return out


FIXED_LABELS = {"measured": "measured, from consecutive turning points",
                "measured_interval": "measured (error bar: from the notch intervals)",
                "binned": "measured, mean of each amplitude bin (+- standard error)",
                "model": "fitted model at the same half swings",
                "sum": "sum of the parts"}


def _label(key: str, p: DecrementPanel | None) -> str:
    """Legend text of an element; with ``p`` the part's best-fit value is in it."""
    if key in FIXED_LABELS:
        return FIXED_LABELS[key]
    c = p.coefficients if p is not None else {}
    pend = c.get("restoring") == "pendulum"
    value = _values_text(p, key)[0] + ": " if p is not None else ""
    # each loss's own form, on the stiffening spring where there is one (escfit.balance.decrement)
    shapes = {key: cls.LOSS.legend(stiff=bool(c.get("k3")), pendulum=pend) for key, cls in losses().items()}
    shapes.update({"escapement": "-(work per swing)/(omega0^2 A), a gain ~ 1/A",
                   "constant": "constant; the phase convention fixes only this sum"})
    return f"{value}{shapes[key]}" if p is not None else f"{LAWS[key][0]}: {shapes[key]}"


def _values_text(p: DecrementPanel, only: str | None = None) -> list[str]:
    """``name = value`` of each part's coefficient (display units), one line each."""
    c, (k, unit) = p.coefficients, _units(p)
    linear = c.get("linear", False)
    text = {key: cls.LOSS.value_text(c.get(cls.LOSS.symbol, 0.0), linear=linear) for key, cls in losses().items()}
    text["escapement"] = "escapement"
    if "constant" in p.parts:
        text["constant"] = f"Coulomb + escapement, {float(p.parts['constant'][1][-1]) * k:.3g} {unit}"
    keys = [only] if only else list(p.parts)
    return [text[key] for key in keys]


def _units(p: DecrementPanel) -> tuple[float, str]:
    """Factor and label of the amplitudes: degrees for an angle, metres for a linear oscillator."""
    return (1.0, "m") if p.coefficients.get("linear") else (RAD_TO_DEG, "deg")


def _stopped(p: DecrementPanel) -> bool:
    """Whether the model's last decrements fall well below the parts' sum (dry friction stopped it)."""
    if "coulomb" not in p.parts or not p.model.amplitude.size:
        return False
    grid = next(iter(p.parts.values()))[0]
    total = np.interp(p.model.amplitude, grid, sum(dec for _, dec in p.parts.values()))
    return bool(np.any(p.model.decrement < 0.9 * total))


def _caption(res, panels: list[DecrementPanel], notes: list[str]) -> str:
    if res.attrs.get("data_kind") == "timeseries":
        how = ("Loss of amplitude per half swing against the amplitude, from the turning points of the samples (each "
               "the vertex of a local polynomial fit around a turn the fitted model shows; the centre's fitted drift "
               "removed). The span between turning points k and k+1 is A(k) + A(k+1) wherever the centre lies, so "
               "half the difference of consecutive spans is (A(k) - A(k+2))/2, drawn at a quarter of their sum.")
    else:
        swings = [np.diff(res.arrays("observed_data")["swing"].values[res.arrays("observed_data")["curve"].values == c])
                  for c in dict.fromkeys(res.arrays("observed_data")["curve"].values)]
        consecutive = all(np.all(g == 1) for g in swings)
        how = ("Loss of amplitude per half swing against the amplitude, from the amplitude readings: "
               + ("three consecutive half swings k, k+1, k+2 give (A(k) - A(k+2))/2 at the amplitude "
                  "(A(k) + 2A(k+1) + A(k+2))/4" if consecutive else
                  "readings j - i half swings apart (j - i even) give (A(i) - A(j))/(j - i) at (A(i) + A(j))/2")
               + ", so a zero offset of the scale cancels.")
    c = next((p.coefficients for p in panels if p.coefficients), {})
    shape = "on a linear spring, the damping law shows in the shape" if c.get("k3") else "The damping law shows in the shape"
    text = [how, ("At small amplitude, " if c.get("k3") else "") + shape + ": dry (Coulomb) friction loses the same 2R/omega0^2 at every "
            "amplitude (a horizontal line), viscous damping a loss proportional to the amplitude, about "
            "pi C A/(2 omega0) (a line through the origin), quadratic air drag 4 D A^2/3 (a parabola)."]
    text.append("Orange: the fitted model's own decrements at the recorded half swings (least-squares best fit), "
                "measured the same way. Dashed: each law's part at the best-fit values, the viscous one exact on a "
                "linear spring at the half swing's mean amplitude, the others first order in the damping.")
    if c.get("restoring") == "pendulum":
        text.append("For a pendulum the parts are the energy lost over one undamped swing of amplitude A, which "
                    "reduce to the forms above at small amplitude (Coulomb's part then grows slowly with A).")
    if c.get("switching") == "phase":
        text.append("In Monday's phase convention the escapement's gain and Coulomb friction's loss are both "
                    "constant per half swing, so a decay fixes only their sum (drawn, exactly) and not R alone.")
    elif c.get("windows"):
        text.append("The escapement feeds energy in: its part is a gain, negative here, falling like 1/A; where it "
                    "balances the losses the amplitude settles. The decomposition is first order in the impulse.")
    if c.get("k3"):
        effect = c.get("stiffening_effect", {})
        words = ", ".join(f"{LAWS[key][0]}'s {abs(v) * 100:.0f} % {'smaller' if v < 0 else 'larger'}"
                          for key, v in effect.items() if abs(v) >= 0.005)
        text.append(f"The stiffening spring (k3 = {c['k3']:.3g} 1/rad^2) dissipates nothing and has no part of its "
                    "own: it stores more energy at the same amplitude and speeds up the swing, so it changes every "
                    "law's decrement, and the dashed parts include that (the energy lost over one undamped swing of "
                    "the stiffened spring, divided by dE/dA)."
                    + (f" At the largest amplitude, {c['stiffening_at'] * RAD_TO_DEG:.3g} deg, that makes {words} than "
                       "on a linear spring." if words else " At these amplitudes the change is below 0.5 %."))
    if any(_stopped(p) for p in panels):
        text.append("Dry friction stops the model at a turning point once the spring can no longer overcome it; "
                    "its decrements there fall below the parts' sum.")
    if c and not c.get("D"):
        text.append("Quadratic drag is not in this model, so it has no part.")
    text += [n[0].upper() + n[1:] + "." for n in notes]
    return " ".join(text)
