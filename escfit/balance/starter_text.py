"""The text of a starter scene: a commented TOML file written from a :class:`~escfit.balance.starter.Survey`.

Every number in it comes from the record (see :mod:`escfit.balance.starter`); the comments say
where from and what to change.  :func:`starter_scene` returns the text and a few lines for the
terminal; the command ``escfit init`` (:mod:`escfit.cli.init`) writes it.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from .starter import Survey, decay_estimates, survey

__all__ = ["starter_scene", "toml_number"]

OMEGA0_SPAN = (0.8, 1.25)  # free omega0 within these factors of the measured period's value
BOUND_TEXT = "three times"  # in words: escfit.balance.starter.BOUND_FACTOR
_CONTROL = re.compile(r"[\x00-\x08\x0a-\x1f\x7f\x85\u2028\u2029]+")  # TOML comments may hold a tab, no other control


def toml_number(x: float, digits: int = 4) -> str:
    """A float for TOML with ``digits`` significant figures (always a float literal)."""
    text = f"{float(x):.{digits}g}"
    return text if any(c in text for c in ".en") else text + ".0"


def _outward(x: float, up: bool) -> float:
    """``x`` rounded outward to two significant figures (a bound that reads cleanly)."""
    if x == 0 or not math.isfinite(x):
        return x
    e = math.floor(math.log10(abs(x))) - 1
    f = 10.0 ** e
    return (math.ceil(x / f) if up else math.floor(x / f)) * f


def _param(value: float, lo: float, hi: float, digits: int = 4) -> str:
    lo, hi = _outward(lo, False), _outward(hi, True)
    return (f"{{ value = {toml_number(value, digits)}, vary = true, min = {toml_number(lo, 2)}, "
            f"max = {toml_number(hi, 2)} }}")


def _quote(text: str) -> str:
    return json.dumps(str(text), ensure_ascii=False)  # a TOML basic string is a JSON string


def starter_scene(path: str | Path, *, restoring: str = "spring", recording: dict | None = None,
                  fmt: str | None = None, notch_deg: float | None = None, restoring_said: str = "") -> tuple[str, list[str], Survey]:
    """A commented starter scene that fits the record at ``path``.

    Parameters
    ----------
    path
        The recording.
    restoring
        ``"pendulum"`` (gravity, ``omega0**2 sin(theta)``) or ``"spring"`` (linear).
    recording, fmt, notch_deg
        Reading options as for a fit (see :func:`escfit.balance.starter.read_with_help`).
    restoring_said
        How the restoring torque was chosen, for the comment (``"--pendulum"``, ``"asked"``...).

    Returns
    -------
    tuple
        ``(text, summary, survey)``: the TOML text, lines describing the record for the
        terminal, and the survey itself.
    """
    s = survey(path, restoring=restoring, recording=recording, fmt=fmt, notch_deg=notch_deg)
    if s.quantity == "displacement":  # a displacement is a linear oscillator's, whatever was asked
        restoring, restoring_said = "spring", "a displacement in m"
    name = Path(path).name
    lines = [f"# Starter scene written by `escfit init` from {name}.",
             "# Every value is a starting point for the fit, measured from the record: edit freely.",
             f"# The record: {s.format_words}; {s.columns_words}."]
    lines += [f"#   {line}" for line in _record_lines(s)]
    lines += ["model = \"balance\"", f"title = {_quote(f'{name}: free decay (starter scene)')}", ""]
    lines += _recording_table(s)
    if s.kind == "timegrapher":
        lines += _timegrapher_body(s)
    else:
        lines += _decay_body(s, restoring, restoring_said)
    text = "\n".join(_one_line(line) for line in lines).rstrip() + "\n"
    return text, _summary(s), s


def _one_line(text: str) -> str:
    """A line of the scene without line breaks or control characters (a file's own text in a comment)."""
    return _CONTROL.sub(" ", str(text))


def _record_lines(s: Survey) -> list[str]:
    c = s.counts
    deg, unit = np.degrees(s.amplitudes), "deg"
    out = []
    if s.kind == "waveform":
        zeros = " (zeros of the rate)" if s.quantity == "angular_velocity" else ""
        out.append(f"{c['samples']} samples over {c['duration']:.4g} s ({c['rate']:.4g} per s); {c['turning points']} "
                   f"turning points{zeros}; period {s.period:.5g} s (the record's periodogram and turning times)")
        if s.quantity == "displacement":
            out.append(f"amplitude about the centre {s.amplitudes[0]:.3g} m at the release, {s.amplitudes[-1]:.3g} m "
                       f"at the last turn; centre {c['centre']:+.4g} m on the sensor's scale")
        elif s.quantity == "angular_velocity":
            out.append(f"angle swept about the centre (from the rate's zeros) {deg[0]:.3g} deg at the release, "
                       f"{deg[-1]:.3g} deg at the last turn; the rate's zero (the sensor's bias) "
                       f"{c['rate zero']:+.3g} +- {c['rate zero se']:.2g} rad/s")
        else:
            out.append(f"amplitude about the centre {deg[0]:.3g} deg at the release, {deg[-1]:.3g} deg at the last "
                       f"turn; centre {math.degrees(c['centre']):+.3g} deg on the sensor's scale")
    elif s.kind in ("amplitude", "notches"):
        count = c.get("readings", s.amplitudes.size)
        out.append(f"{count} readings, one per half swing; amplitude {deg[0]:.3g} -> {deg[-1]:.3g} {unit}")
        if math.isfinite(s.period):
            out.append(f"period {s.period:.5g} s from the reading times")
    else:
        out.append(f"period {s.period:.6g} s from {c['period from']}; displayed amplitude {deg[0]:.3g} -> "
                   f"{deg[-1]:.3g} deg")
    return out + [str(n) for n in s.notes]


def _recording_table(s: Survey) -> list[str]:
    """The ``[recording]`` table: the options that read the file, and the window the analysis chose
    (active keys where it left part of the record out, commented ones to edit otherwise)."""
    active, commented = _window_keys(s)
    if not s.recording and not active:
        if not commented:
            return []
        return ["# [recording]    # the window the analysis chose: uncomment a key (and this line) to set it"] + \
            commented + [""]
    out = ["[recording]"]
    if s.recording:
        out.append("# how to read the file: detection alone could not decide all of this")
    for key, value in s.recording.items():
        why = s.why.get(key, "given on the command line")
        rendered = value if isinstance(value, (int, float)) and not isinstance(value, bool) else _quote(value)
        out.append(f"{key} = {rendered}    # {why}")
    if active or commented:
        out.append("# the free decay's window, in s after the record's first sample (\"abs <time>\": the file's clock)")
    return out + active + commented + [""]


def _seconds(t: float) -> str:
    return _quote(f"{t:.6g} s")


def _window_keys(s: Survey) -> tuple[list[str], list[str]]:
    """``start``/``release`` and ``stop`` lines for what the analysis found (keys the user gave are kept as given)."""
    w = s.window
    if not w:
        return [], []
    active: list[str] = []
    commented: list[str] = []
    ref, period = w["reference"], w["period"]
    user = any(k in s.recording for k in ("start", "release"))
    if not user:
        if w["held"] is not None:
            line = (f"release = {_seconds(ref)}    # the analysis found the oscillator held at "
                    f"{math.degrees(w['held']):.4g} deg until {ref:.6g} s: the model is released there")
            if w["left_out"]:
                active.append(line + "; the record before it was taken as not free (held, pushed or driven: the notes "
                              "at the top of the scene say which): set release (or start) earlier to keep it")
            else:
                commented.append("# " + line)
        elif w.get("drive_off") is not None and not (w["left_out"] and ref - 0.25 * period > w["drive_off"][0]):
            at, column = w["drive_off"]
            active.append(f"start = {_seconds(at)}    # the drive logged in column {column!r} was switched off here "
                          "(the warning at the top of the scene gives the evidence): the record before it was driven; "
                          "set start earlier to keep it")
            active.append(f"release = {_seconds(ref)}    # the first turning point after the switch-off: the model is "
                          "released at rest there")
        elif w["left_out"]:
            start = max(ref - 0.25 * period, w["first"])
            active.append(f"start = {_seconds(start)}    # the record before {ref:.6g} s (the reference turning point) "
                          "was taken as not a free decay (held, pushed or driven: the notes at the top of the scene say which): set start "
                          "earlier to keep it")
        else:
            commented.append(f"# start = {_seconds(w['first'])}    # the free decay starts at the record's first "
                             f"turning point ({ref:.6g} s): nothing before it was left out")
    if "stop" not in s.recording:
        if math.isfinite(w["stop"]) and w.get("pushed"):
            active.append(f"stop = {_seconds(w['stop'])}    # pushed again after this (the warning at the top of the "
                          f"scene gives the evidence); the record runs on to {w['last']:.6g} s: set start and stop "
                          "around another free stretch to fit that one")
        elif math.isfinite(w["stop"]) and w.get("sunk"):
            active.append(f"stop = {_seconds(w['stop'])}    # the swing sank into the record's noise there (the notes at "
                          f"the top of the scene give the floor); the record runs on to {w['last']:.6g} s in noise, "
                          "not motion: set stop later to keep more")
        elif math.isfinite(w["stop"]):
            commented.append(f"# stop = {_seconds(w['stop'])}    # motion stopped (or faded into the noise) at "
                             f"{w['stop']:.6g} s; the record runs on to {w['last']:.6g} s")
        else:
            last = math.floor(w["last"] * 1e3) / 1e3  # rounded inwards: a stop past the last sample is refused
            commented.append(f"# stop = {_seconds(last)}    # the record ends in motion (last turning point used "
                             f"at {w['last_turn']:.6g} s): set stop earlier to leave its end out")
    return active, commented


def _decay_body(s: Survey, restoring: str, said: str) -> list[str]:
    c = s.counts
    omega0 = c.get("omega0", math.nan)
    timed = math.isfinite(omega0)
    w = omega0 if timed else 2 * math.pi  # placeholder: 1 s period when the file has no times
    est = decay_estimates(s.amplitudes, w, s.times)
    out = ["[oscillator]"]
    linear = s.quantity == "displacement"
    if linear:
        out.append("coordinate = \"linear\"    # a mass on a spring, recorded by its displacement x (m): x0 in m, "
                   "R in m/s^2")
    elif restoring == "pendulum":
        out.append(f"restoring = \"pendulum\"    # a gravity pendulum ({said or '--pendulum'}): torque omega0^2 sin(theta)")
    else:
        out.append(f"# a linear restoring torque (a balance spring, a torsion wire; {said or '--spring'}); for a "
                   "gravity pendulum add: restoring = \"pendulum\"")
    if not timed:
        out += ["# The file has no times, so the period is not measured: omega0 = 6.283 rad/s (1 s) is a PLACEHOLDER.",
                "# C scales with omega0 and R with omega0^2: set your oscillator's omega0 before trusting them.",
                "omega0 = 6.283"]
    elif s.kind == "waveform":
        small = " (small-swing value: the pendulum's period grows with the amplitude)" if restoring == "pendulum" else ""
        out += [f"# natural frequency omega0 (rad/s) from the measured period {s.period:.5g} s{small};",
                "# free within -20 % / +25 %: the fit of every sample pins it",
                f"omega0 = {_param(omega0, OMEGA0_SPAN[0] * omega0, OMEGA0_SPAN[1] * omega0)}"]
    else:
        small = " (its small-swing value)" if restoring == "pendulum" and s.kind == "amplitude" else ""
        out += [f"# natural frequency omega0 (rad/s) from the measured period {s.period:.5g} s{small}, held: amplitudes",
                "# alone fix omega0 only weakly (through the damping per swing)",
                f"omega0 = {toml_number(omega0, 5)}"]
    if s.kind in ("amplitude", "notches") and "readings" not in s.recording:
        first = int(c.get("first swing", 0))
        what = "the release amplitude" if first == 0 else f"the first reading (half swing {first}), CHECK it"
        out += [f"theta0 = {toml_number(s.amplitudes[0], 5)}    # rad: {what}"]
    else:
        out += [f"# {'x0' if linear else 'theta0'} is left out: the model is released at rest at the record's "
                "reference turning point"]
    out += ["", "[effects.viscous]"]
    if not est["decays"]:
        out.append("# the record shows no clear decay: the bounds below are wide guesses")
    out += ["# viscous damping C = c/I (1/s): alone, the amplitude would decay as exp(-C t / 2); the upper bound is",
            f"# {BOUND_TEXT} the C that alone explains the decay seen",
            f"C = {_param(est['C'], 0.0, _outward(est['C_max'], True), 3)}",
            "", "[effects.coulomb]",
            "# dry (Coulomb) friction, force per mass R (m/s^2): alone, the amplitude would fall by" if linear else
            "# dry (Coulomb) friction, torque per inertia R (rad/s^2): alone, the amplitude would fall by",
            f"# 2 R / omega0^2 per half swing; the upper bound is {BOUND_TEXT} the R that alone explains the decay",
            f"R = {_param(est['R'], 0.0, _outward(est['R_max'], True), 3)}"]
    out += ["", "[observation]"] + _observation_lines(s)
    if c.get("loads") and len(c["loads"]) > 1:
        unit = c.get("load unit") or ""
        reference = f"{c['loads'][0]:g} {unit}".strip()
        out += ["", "[fit.loads]", "# several fixture loads in one file: one friction R per load, C shared",
                f"reference = {_quote(reference)}", "friction = \"free\""]
    return out



def _observation_lines(s: Survey) -> list[str]:
    if s.kind == "waveform":
        what = {"angular_velocity": "theta'(t), the rate,", "displacement": "x(t)"}.get(s.quantity, "theta(t)")
        zero = "the rate's zero (bias)" if s.quantity == "angular_velocity" else "the centre"
        out = [f"model = \"waveform\"    # every sample of {what} is fitted (the release instant and {zero} too)"]
        if s.noise_ar1:
            out.append(f"noise = \"ar1\"    # the samples' scatter is correlated from one to the next (lag-1 "
                       f"correlation {s.lag1:+.2f} above white noise's): a tracker or filter, or a small unmodelled effect")
        else:
            lag = f"{s.lag1:+.2f}" if math.isfinite(s.lag1) else "not measurable"
            out.append(f"# noise = \"ar1\"    # white noise assumed: the samples' lag-1 correlation is {lag} above "
                       "white noise's; use ar1 if the fit reports correlated neighbours")
        return out
    if s.kind == "notches":
        return ["model = \"notches\"", f"notch_deg = {toml_number(math.degrees(s.counts['notch']), 4)}"]
    out = ["model = \"amplitude\"    # one amplitude reading per half swing"]
    if s.recording.get("readings") == "amplitudes":
        span = _outward(0.25 * float(np.max(s.amplitudes)), True)
        out += ["# the scale's zero may sit off the centre: readings on alternate sides then differ by twice the offset",
                f"offset = {{ value = 0.0, vary = true, min = {toml_number(-span, 2)}, max = {toml_number(span, 2)} }}"]
    elif s.kind == "amplitude":
        out.append("# offset = { value = 0.0, vary = true, min = -0.05, max = 0.05 }    # rad: a scale zero off the centre")
    return out


def _timegrapher_body(s: Survey) -> list[str]:
    c = s.counts
    w = c["omega0"]
    lift = c["lift angle"]
    a0 = float(s.amplitudes[0]) if s.amplitudes.size else math.radians(270)
    a_end = float(s.amplitudes[-1]) if s.amplitudes.size else a0
    # losses from the decay of the displayed amplitude as if free (a lower limit: the impulse hides part of
    # them), then the impulse that balances them at the last amplitude shown: X*lift = pi*C*omega0*A^2/2 + 2*R*A
    times = s.times - s.times[0] if s.times is not None and s.times.size else None
    est = decay_estimates(s.amplitudes, w, times)
    c0, r0 = est["C"], est["R"]
    x0 = max((math.pi * c0 * w * a_end ** 2 / 2.0 + 2.0 * r0 * a_end) / lift, 1e-3 * w ** 2)
    return ["[oscillator]",
            f"# natural frequency (rad/s) from the measured period {s.period:.6g} s ({c['period from']}), held",
            f"omega0 = {toml_number(w, 6)}",
            f"theta0 = {toml_number(a0, 4)}    # rad: the first amplitude shown ({math.degrees(a0):.4g} deg); the "
            "release if the log starts at it",
            "", "[effects.viscous]",
            "# viscous damping C = c/I (1/s); start: the decay of the amplitudes shown, as if free",
            f"C = {_param(c0, 0.0, _outward(10 * est['C_max'], True), 3)}",
            "", "[effects.coulomb]", "# pivot friction, torque per inertia R (rad/s^2); start as C",
            f"R = {_param(r0, 0.0, _outward(10 * est['R_max'], True), 3)}",
            "", "[[effects.escapement]]",
            "# the impulse, spread over the lift angle about the centre (a starting geometry: replace it by your",
            "# escapement's windows, unlock and impulse, if you know them)",
            "kind = \"impulse\"", f"from = {toml_number(-lift / 2, 4)}", f"to = {toml_number(lift / 2, 4)}",
            "# X (rad/s^2): start from the energy balance at the last amplitude shown",
            f"X = {_param(x0, 0.0, 30 * x0, 3)}",
            "", "[observation]",
            "model = \"timegrapher\"    # amplitudes as the instrument computes them; beat times when the file has them",
            "# a log of a watch running steadily fixes only the balance of C, R and X: hold two of them, or record",
            "# the decay after the mainspring is let down"]


def _summary(s: Survey) -> list[str]:
    what = {"waveform": "every sample fitted (waveform)", "amplitude": "one amplitude per half swing",
            "notches": "notch counts per half swing", "timegrapher": "timegrapher readings"}[s.kind]
    out = [f"read {Path(s.path).name}: {s.format_words}; {s.columns_words}", *_record_lines(s)[:2],
           f"observation: {what}", *s.checks]
    if s.kind == "timegrapher":
        out.append("a timegrapher starter is only a starting geometry (an impulse over the lift angle, the first "
                   "amplitude shown as the release): give your escapement's windows and the release amplitude if you "
                   "know them, and read the fit's warnings")
    for key, value in s.recording.items():
        if key in s.why:
            out.append(f"[recording] {key} = {value!r}: {s.why[key]}")
    meta = getattr(s.data, "meta", None)
    if isinstance(meta, dict):  # what reading did to the record (the time base's repairs), as a fit prints it
        from ..analysis.recordings.rawsteps import notes_of, warnings_of

        out += [f"note: {n}" for n in notes_of(meta)] + [f"warning: {w}" for w in warnings_of(meta)]
    for line in _window_keys(s)[0]:  # the window the analysis chose where it left part of the record out
        key, _, why = line.partition("    # ")
        out.append(f"[recording] {key}: {why}")
    return [_one_line(line) for line in out]
