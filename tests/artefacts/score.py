"""Scoring a run of the record analysis and fit against an artefact's truth.

Shared by ``benchmarks/artefact_suite.py`` (subprocesses, any code under test) and
``tests/test_artefacts.py`` (in process): the same outcomes and tolerances.

Outcomes: ``RIGHT`` (exit 0, estimates within tolerance, window right), ``WRONG-WINDOW``
(estimates right, window not the true free one), ``WRONG-SILENT`` (exit 0, an estimate outside
its tolerance), ``REFUSED-WITH-REASON`` / ``REFUSED-OTHER`` (exit 2, the message matches / does
not match the truth's reason), ``NOT-DETERMINED`` / ``NOT-DETERMINED-OTHER`` (exit 3, the message
matches / does not match the truth's reason, where it names one), ``ERROR`` (anything else).

Tolerances: omega0 within 0.5 %; C and R each within the larger of 3 standard errors and the
class's floor (``Truth.rel_tol``, 15 % by default).  A free decay's omega0 is fixed by its zero
crossings to a few ppm, so 0.5 % only catches a wrong window, unit or model (a pendulum read in
degrees when written in radians is off by A**2/16, 0.8 % at 20 deg).  C and R are strongly
anticorrelated over 30-100 periods (r ~ -0.99): 3 standard errors is the statistical allowance
when the fit's errors are honest, and the 15 % floor allows for a noise model that understates
them, while a wrong window, quantity or an unmodelled push (tens of per cent, or factors) fails.

Window: the fit's release instant (``observation.t_release``, else the reference turning point of
its notes) no earlier than a quarter period before a true window's start, the last fitted sample
at most half a period after that window's end, and the fitted span at least half the window: a
window starting inside the free decay is right (it only wastes data), one reaching into the
hand, the hold, the drive or another decay is wrong.

Units: where the record is a length (the fit's ``coulomb.R`` in m/s**2 or mm/s**2, the pendulum
tracked as the bob's position ``x = L sin(theta)``), the true R is compared as ``L R`` in that
unit, with ``L = g/omega0**2``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .make import G

__all__ = ["read_result", "window_right", "estimates_right", "classify", "ACCEPTS", "PUSH_NOTE"]

PUSH_NOTE = re.compile(r"not a free decay|swing grows", re.I)
REF_NOTE = re.compile(r"reference one at t = ([-+0-9.eE]+) s")
ACCEPTS = {"RIGHT": "fit", "REFUSED-WITH-REASON": "refuse", "NOT-DETERMINED": "not determined"}


def read_result(path: str | Path) -> dict:
    """Estimates (value, standard error) of omega0, C and R, the fitted span (s), the release
    instant the fit used (s, or None) and the notes and warnings of a fit file."""
    from escfit.results import load_fit

    res = load_fit(path)
    rows = res.summary()

    def est(name):
        if name not in rows:
            return 0.0, 0.0  # the scene left the effect out: the fit says it is zero
        row = rows[name]
        return float(row["estimate"]), float(row.get("stderr", row.get("sd", 0.0)) or 0.0)

    t = res.group("observed_data")["time"].values
    out = {"omega0": est("oscillator.omega0"), "C": est("viscous.C"), "R": est("coulomb.R"),
           "R_unit": rows.get("coulomb.R", {}).get("unit", ""),
           "t_first": float(np.min(t)), "t_last": float(np.max(t)), "notes": list(res.notes),
           "warnings": list(res.warnings), "ref": None, "undetermined": list(res.undetermined)}
    if "observation.t_release" in rows:
        out["ref"] = float(rows["observation.t_release"]["estimate"])
    else:
        for note in res.notes:
            m = REF_NOTE.search(note)
            if m:
                out["ref"] = float(m.group(1))
    return out


def window_right(truth, ref: float | None, t_first: float, t_last: float) -> bool:
    """Whether the fitted span is one of the truth's free windows (see the module docstring)."""
    period = truth.period
    start = ref if ref is not None else t_first
    for a, b in truth.all_windows():
        if a - 0.25 * period <= start and t_last <= b + 0.5 * period and t_last - start >= 0.5 * (b - a):
            return True
    return False


def estimates_right(truth, r: dict) -> tuple[bool, dict]:
    """Whether omega0, C and R are within tolerance, and their relative errors (C and R are not
    judged when the fit marks both not determined and the truth accepts that)."""
    w, _ = r["omega0"]
    errs = {"omega0": (w - truth.omega0) / truth.omega0}
    ok = abs(errs["omega0"]) <= 0.005
    length = {"m": 1.0, "cm": 100.0, "mm": 1000.0}.get(r.get("R_unit", "").split("/")[0].strip(), 0.0)
    r_true = truth.R * length * G / truth.omega0**2 if length else truth.R  # L R in the record's length unit
    unsplit = "not determined" in truth.accept and {"viscous.C", "coulomb.R"} <= set(r.get("undetermined", []))
    for key, true in (("C", truth.C), ("R", r_true)):
        if unsplit:  # the fit says C and R are not separately determined, which this truth accepts
            continue
        v, se = r[key]
        errs[key] = (v - true) / true
        ok &= abs(v - true) <= max(3.0 * se, truth.rel_tol * true)
    return bool(ok), errs


def classify(truth, code: int, text: str, r: dict | None) -> str:
    """The outcome of a run: exit code, printed text and the read result (None without one)."""
    if code == 0 and r is not None:
        if not estimates_right(truth, r)[0]:
            return "WRONG-SILENT"
        return "RIGHT" if window_right(truth, r["ref"], r["t_first"], r["t_last"]) else "WRONG-WINDOW"
    if code == 2:
        return "REFUSED-WITH-REASON" if truth.reason and re.search(truth.reason, text, re.I) else "REFUSED-OTHER"
    if code == 3:  # with the reason the truth expects, where it names one
        return "NOT-DETERMINED" if not truth.reason or re.search(truth.reason, text, re.I) else "NOT-DETERMINED-OTHER"
    return "ERROR"
