"""The parameter table: plain names, display units, digits set by the intervals, held values listed.

Every row is shown in display units (:mod:`escfit.core.display`) with the same last digit for
the estimate and its interval ends: the second significant digit of the 95 % interval's width
(:func:`~escfit.core.display.format_row`).  In a report (``plain=True``) each row starts with
the parameter's plain name and symbol (:func:`escfit.core.names.plain_name`) and ends with its
code name, and the parameters the fit held (fixed by the scene, or tied to a free one) follow
as rows marked *held* with their values.

Sign convention: the scale's zero offset is shown as the **centre of the swing on the sensor's
scale**, ``centre = removed - offset`` (``removed``: the centre a turning-point analysis took
off the readings before the fit, 0 for a waveform fit) and its drift as
``removed_rate - offset_rate``, the convention of the record's notes and of the figures.
"""

from __future__ import annotations

import json
import math
from typing import Any

from ..core.display import format_row, load_unit, to_display
from ..core.names import plain_name

__all__ = ["parameter_table", "held_table", "estimate_kind", "held_values", "centre_row", "CENTRE_BASE"]

_BOUND_FLAG = {"min": "at lower bound", "max": "at upper bound"}
CENTRE_BASE = {"observation.offset": "centre_removed_rad", "observation.offset_rate": "centre_rate_removed_rad_per_s"}


def estimate_kind(row: dict[str, Any]) -> str:
    """``"median"`` (posterior row) or ``"best fit"`` (least-squares row) of a summary row.

    Rows written before ``estimate_kind`` existed tell by their keys: posterior rows carry
    ``mean``, least-squares rows ``stderr``.
    """
    if row.get("estimate_kind"):
        return str(row["estimate_kind"])
    return "median" if "mean" in row else "best fit"


def _estimate(row: dict[str, Any]) -> float | None:
    for key in ("estimate", "median", "best_fit"):
        if row.get(key) is not None:
            return row[key]
    return None


def _attrs(res) -> dict:
    return dict(getattr(res, "attrs", {}) or {})


def held_values(res) -> dict[str, float]:
    """Parameters the fit held, at their values (canonical units): stored with the fit, else
    (older files) read from the scene kept with it."""
    a = _attrs(res)
    if a.get("held"):
        return {k: float(v) for k, v in json.loads(a["held"]).items()}
    text = a.get("scene", "")
    if not text:
        return {}
    try:
        from ..core.scene import load_scene

        scene = load_scene(a.get("scene_file") or "scene.toml", text=text)
        params = getattr(scene, "params", None)
        items = params.params.items() if hasattr(params, "params") else {}
    except Exception:  # noqa: BLE001 - an old or foreign scene: list nothing rather than fail the report
        return {}
    free = set(getattr(res, "parameter_names", []) or [])
    return {n: float(p.value) for n, p in items
            if not p.vary and n not in free and math.isfinite(float(p.value))}


def centre_row(name: str, r: dict, a: dict) -> dict:
    """A zero-offset row turned into the centre of the swing on the sensor's scale (see the module docstring)."""
    base = float(a.get(CENTRE_BASE[name], 0.0) or 0.0)
    out = dict(r)
    for key in ("estimate", "median", "best_fit"):
        if out.get(key) is not None:
            out[key] = base - out[key]
    for lo, hi in (("lo68", "hi68"), ("lo95", "hi95")):
        if r.get(lo) is not None and r.get(hi) is not None:
            out[lo], out[hi] = base - r[hi], base - r[lo]
    out["at_bound"] = {"min": "max", "max": "min"}.get(r.get("at_bound"))
    return out


def parameter_table(res, plain: bool = False) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the parameter table, in display units.

    Parameters
    ----------
    res
        A saved fit (:class:`escfit.results.FitResult`).
    plain
        Reports: plain names with symbols first, held parameters listed, the code name last.
        The command line (``False``) keeps the code names.

    Returns
    -------
    tuple
        ``(head, rows)``, all strings.  The estimate column is headed ``"median"`` for a
        posterior, ``"best fit"`` for least squares (``"estimate"`` if the rows mix both, each
        row then saying which in the note column), ``"value (NOT determined)"`` when the fit
        determines nothing (:attr:`escfit.results.FitResult.verdict`); a parameter the fit does
        not determine says so in the note column.  R-hat and ESS columns appear for
        posteriors only; a ``note`` column when a row needs one: an estimate on a bound of
        the scene's range, which reading noise a posterior ``observation.sigma`` is, a held
        value.
    """
    a = _attrs(res)
    summary = res.summary()
    meanings = json.loads(a.get("meanings", "{}") or "{}")
    loads_in = load_unit(meanings)
    kinds = {estimate_kind(r) for r in summary.values()}
    column = kinds.pop() if len(kinds) == 1 else "estimate"
    verdict = getattr(res, "verdict", "")
    undetermined = set(getattr(res, "undetermined", []) or [])
    if verdict == "not determined":
        column = "value (NOT determined)"
    posterior = any(estimate_kind(r) == "median" for r in summary.values())
    rows, notes, codes = [], [], []
    for name, r in summary.items():
        if name in CENTRE_BASE:  # the centre of the swing, as the notes and figures give it
            r = centre_row(name, r, a)
        value, unit = to_display(_estimate(r), r.get("unit"), name)
        ends = [to_display(r.get(k), r.get("unit"), name)[0] for k in ("lo68", "hi68", "lo95", "hi95")]
        bound = {"min": ends[2], "max": ends[3]}.get(r.get("at_bound"))
        if bound is not None and value is not None and abs(value - bound) <= 1e-9 * max(abs(ends[3] - ends[2]), 1e-300):
            value = bound  # on the bound to rounding (5.8e-17 against 0): show the bound
        width = ends[3] - ends[2] if None not in (ends[2], ends[3]) else None
        shown, (l68, h68, l95, h95) = format_row(value, ends, width)
        label = _label(name, meanings, loads_in, plain, a)
        row = [label, unit, shown, f"[{l68}, {h68}]", f"[{l95}, {h95}]"]
        if posterior:
            row += [f"{r['rhat']:.3f}" if r.get("rhat") is not None and math.isfinite(r["rhat"]) else "-",
                    _count(r.get("ess_bulk"))]
        note = []
        if column == "estimate":
            note.append(estimate_kind(r))
        if name in undetermined and verdict != "not determined":
            note.append("not determined")
        if r.get("at_bound") in _BOUND_FLAG:  # a posterior row: the least-squares start was there, not the median
            note.append(_BOUND_FLAG[r["at_bound"]] if estimate_kind(r) == "best fit"
                        else f"least squares {_BOUND_FLAG[r['at_bound']]}")
        if name == "observation.sigma" and estimate_kind(r) == "median":
            note.append("reading noise, posterior")
        if r.get("rhat") is not None and r["rhat"] > 1.01:
            note.append("not converged (R-hat above 1.01)")
        rows.append(row)
        notes.append(note)
        codes.append(name)
    head = ["parameter", "unit", column, "68% interval", "95% interval"]
    if posterior:
        head += ["R-hat", "ESS (bulk)"]
    if any(notes):
        head.append("note")
        rows = [row + ["; ".join(note)] for row, note in zip(rows, notes)]
    if plain:
        head.append("name in the files")
        rows = [row + [code] for row, code in zip(rows, codes)]
    return head, rows


def held_table(res) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the parameters the fit held (fixed by the scene, or tied to a free one), in
    display units: ``[parameter, unit, value, name in the files]``."""
    a = _attrs(res)
    meanings = json.loads(a.get("meanings", "{}") or "{}")
    units = json.loads(a.get("units", "{}") or "{}")
    loads_in = load_unit(meanings)
    free = set(res.summary())
    reference = _load_reference(a)
    rows = []
    for name, value in held_values(res).items():
        if name in free:
            continue
        shown, unit = to_display(value, units.get(name, ""), name)
        if name in CENTRE_BASE:
            shown = float(a.get(CENTRE_BASE[name], 0.0) or 0.0) * (180 / math.pi) - shown
        label = _label(name, meanings, loads_in, True, a)
        if reference and name.startswith("escapement[") and name.endswith(".X"):
            label += f" at the reference load {reference}, in proportion to the load"
        rows.append([label, unit, format_row(shown)[0], name])
    return ["parameter", "unit", "held at", "name in the files"], rows


def _load_reference(a: dict) -> str:
    """The ``[fit.loads] reference`` of a joint fit of several loads (escapement torques are given there)."""
    import tomllib

    try:
        loads = tomllib.loads(a.get("scene", "") or "").get("fit", {}).get("loads", {})
    except tomllib.TOMLDecodeError:
        return ""
    return str(loads.get("reference", "")) if isinstance(loads, dict) else ""


def _label(name: str, meanings: dict, loads_in: str, plain: bool, a: dict | None = None) -> str:
    if not plain:
        from ..core.display import display_name

        if name in CENTRE_BASE:
            rate = "angular velocity" in meanings.get("observation.offset", "")
            return {"observation.offset": f"{'rate zero (bias)' if rate else 'centre'} [observation.offset]",
                    "observation.offset_rate": f"{'bias' if rate else 'centre'} drift [observation.offset_rate]"}[name]
        return display_name(name, loads_in)
    return plain_name(name, meanings.get(name, ""), loads_in) + _reference(name, a or {})


def _reference(name: str, a: dict) -> str:
    """Where a friction rig's mu is given: `` at 2.2 gf and 6.5 ft/s`` (the scene's load_ref, speed_ref)."""
    if name != "friction.mu":
        return ""
    import tomllib

    try:
        fr = tomllib.loads(a.get("scene", "") or "").get("friction", {})
    except tomllib.TOMLDecodeError:
        return ""
    where = [str(fr[k]) for k in ("load_ref", "speed_ref") if k in fr]
    return f" at {' and '.join(where)}" if where else ""


def _count(value) -> str:
    """An effective sample size: a whole number of draws (``-`` when undefined)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return "-"
    return f"{v:.0f}" if math.isfinite(v) else "-"
