"""MATLAB recordings (``.mat``) read into a TimeSeries.

MATLAB v4/v5/v7 files are read with ``scipy.io.loadmat(squeeze_me=True,
struct_as_record=False)``; v7.3 files (HDF5) with h5py, their numeric arrays, structs and
cell arrays mapped to the same shapes.

Selectors
---------
``[recording] angle_column`` and ``time_column`` name variables:

``name``
    A numeric vector, or a Simulink "structure with time" (fields ``time`` and
    ``signals.values``): its values are the signal and its ``time`` is the default clock.
``name.field.sub``
    A field of a struct (``Theta1.time``).
``name[k]``
    Signal ``k`` (1-based) of a 2-D array: counted along the shorter axis, so row ``k`` of a
    (signals x samples) array and column ``k`` of a (samples x signals) one.
a cell array
    Each piece is selected alike (``Y_id[1]``: row 1 of every piece) and the pieces are
    joined in order.
a list of selectors
    Joined in order: ``angle_column = ["Y_id[1]", "Y_vad[1]"]`` with
    ``time_column = ["Time_id", "Time_vad"]``.  The joined times must increase.

Without ``angle_column`` the angle is the only signal (Simulink struct, or numeric vector
of at least 20 samples), or among several the only one that varies (with a note).  Without
``time_column`` or ``sample_rate`` the clock is the Simulink struct's ``time``, a scalar
``dt``/``Ts`` variable, or a vector named ``t``/``time``/``tout`` of the angle's length.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ...core.errors import DataError
from .matvars import load_mat_variables
from .rawsteps import MIN_SAMPLES, build_series
from .recording_spec import COUNT_WORDS, RecordingSpec, rad_per_unit
from .series import TimeSeries

__all__ = ["read_mat_series"]

_SELECTOR = re.compile(r"\s*([A-Za-z]\w*(?:\.[A-Za-z]\w*)*)\s*(?:\[\s*(\d+)\s*\])?\s*")
_DT_NAMES = ("dt", "Ts", "dt_s", "ts")
_TIME_NAMES = ("t", "time", "Time", "tout", "t_s")


class _Variables(dict):
    """The variables read, and the class of every variable of the file (read or not)."""

    kinds: dict[str, str] = {}


def _is_struct(x: Any) -> bool:
    return hasattr(x, "_fieldnames")


def _is_simulink(x: Any) -> bool:
    return _is_struct(x) and "time" in x._fieldnames and _is_struct(getattr(x, "signals", None)) and \
        hasattr(x.signals, "values")


def _summary(x: Any) -> str:
    if _is_simulink(x):
        return "Simulink structure with time"
    if _is_struct(x):
        return f"struct with fields {', '.join(x._fieldnames)}"
    if isinstance(x, np.ndarray) and x.dtype == object:
        return f"cell array of {x.size}"
    if isinstance(x, np.ndarray):
        return f"{'x'.join(map(str, x.shape))} {x.dtype}"
    return type(x).__name__


def _listing(doc: dict[str, Any]) -> str:
    kinds = getattr(doc, "kinds", {})
    return "; ".join(f"{k} ({_summary(doc[k]) if k in doc else kinds[k]})" for k in {**dict.fromkeys(kinds), **doc})


def _component(arr: Any, k: int | None, where: str) -> np.ndarray:
    arr = np.asarray(arr)
    if arr.dtype.kind not in "iufb":
        raise DataError(f"not numeric ({_summary(arr)})", where)
    if k is None:
        if arr.ndim != 1:
            raise DataError(f"a {_summary(arr)} array; select one signal with [k] (1-based)", where)
        return arr.astype(float)
    if arr.ndim != 2:
        raise DataError(f"[{k}] selects a signal of a 2-D array, this is {_summary(arr)}", where)
    axis = 0 if arr.shape[0] <= arr.shape[1] else 1
    if not 1 <= k <= arr.shape[axis]:
        raise DataError(f"[{k}] is out of range: the array has {arr.shape[axis]} signals", where)
    return np.take(arr, k - 1, axis=axis).astype(float)


def _resolve(doc: dict[str, Any], selector: str, path: str, *, clock: bool) -> list[tuple[np.ndarray, Any]]:
    """The pieces ``(values, struct time or None)`` a selector names (``clock``: want times)."""
    where = f"{path} [{selector}]"
    m = _SELECTOR.fullmatch(selector)
    if not m:
        raise DataError("a selector is name, name.field or name[k] (k counts from 1)", where)
    parts, k = m.group(1).split("."), None if m.group(2) is None else int(m.group(2))
    if parts[0] not in doc:
        raise DataError(f"no variable {parts[0]!r}; the file has: {_listing(doc)}", where)
    obj = doc[parts[0]]
    for name in parts[1:]:
        if not _is_struct(obj) or name not in obj._fieldnames:
            raise DataError(f"no field {name!r} ({_summary(obj)})", where)
        obj = getattr(obj, name)
    if _is_simulink(obj):
        values = _component(obj.time if clock else obj.signals.values, k, where)
        if np.size(obj.time) != values.size:
            raise DataError(f"time has {np.size(obj.time)} samples but signals.values {values.size}", where)
        return [(values, np.asarray(obj.time, float))]
    if isinstance(obj, np.ndarray) and obj.dtype == object:
        return [(_component(p, k, f"{path} [{selector} piece {i + 1}]"), None) for i, p in enumerate(obj.ravel())]
    if not isinstance(obj, np.ndarray) or obj.ndim == 0:
        raise DataError(f"not a signal: {_summary(obj)} {obj!r}"[:200], where)
    return [(_component(obj, k, where), None)]


def _join(doc: dict[str, Any], selectors: tuple[str, ...], path: str, *, clock: bool = False):
    """Joined values, joined struct times (or None) and a locator of each sample."""
    pieces, labels = [], []
    for sel in selectors:
        got = _resolve(doc, sel, path, clock=clock)
        pieces += got
        labels += [f"{sel} piece {i + 1}" if len(got) > 1 else sel for i in range(len(got))]
    values = np.concatenate([p[0] for p in pieces])
    times = None if any(p[1] is None for p in pieces) else np.concatenate([p[1] for p in pieces])
    bounds = np.cumsum([0] + [p[0].size for p in pieces])

    def locate(i: int) -> str:
        j = int(np.searchsorted(bounds, i, side="right")) - 1
        return f"{path} [{labels[j]}, sample {i - bounds[j] + 1}]"

    return values, times, locate, len(pieces)


def _selectors(col: str | int | tuple, key: str, path: str) -> tuple[str, ...]:
    if isinstance(col, int):
        raise DataError(f"[recording] {key} = {col}: a .mat file names variables, not column positions", path)
    return col if isinstance(col, tuple) else (col,)


def _auto_angle(doc: dict[str, Any], path: str, notes: list[str]) -> str:
    cands = {k: v for k, v in doc.items() if k not in _TIME_NAMES and (
        (_is_simulink(v) and np.asarray(v.signals.values).ndim == 1) or
        (isinstance(v, np.ndarray) and v.dtype.kind in "iuf" and v.ndim == 1 and v.size >= MIN_SAMPLES))}
    signal = {k: (v.signals.values if _is_simulink(v) else v) for k, v in cands.items()}
    varying = [k for k, v in signal.items() if np.ptp(np.asarray(v, dtype=float)) > 0]
    if len(cands) == 1:
        return next(iter(cands))
    if len(varying) == 1 and cands:
        notes.append(f"angle: {varying[0]!r}, the only varying signal of {', '.join(cands)}")
        return varying[0]
    what = f"several variables could be the angle: {', '.join(cands)}" if cands else \
        f"no variable looks like an angle signal; the file has: {_listing(doc)}"
    raise DataError(f"{what}; set [recording] angle_column (e.g. angle_column = "
                    f"{next(iter(cands), 'name')!r}, or name[k] for signal k of a 2-D array)", path)


def _auto_clock(doc: dict[str, Any], n: int, path: str, notes: list[str]) -> tuple[np.ndarray, str]:
    for name in _DT_NAMES:
        v = doc.get(name)
        if isinstance(v, (float, int)) and not isinstance(v, bool) and v > 0:
            notes.append(f"clock: the scalar {name} = {v!r} s")
            return np.arange(n) * float(v), f"row number * {name} ({v!r} s)"
    for name in _TIME_NAMES:
        v = doc.get(name)
        if isinstance(v, np.ndarray) and v.ndim == 1 and v.size == n and v.dtype.kind in "iuf":
            notes.append(f"clock: the variable {name!r}")
            return v.astype(float), name
    raise DataError(f"no clock for the angle: set [recording] time_column (a variable) or sample_rate; the file has: "
                    f"{_listing(doc)}", path)


def _read_needed(path: str | Path, spec: RecordingSpec) -> tuple[_Variables, str]:
    """The variables the spec's selectors name (and the clock's candidates), or without an angle
    selector the numeric arrays and structs: never the whole file."""
    roots: set[str] | None = None
    if spec.angle_column is not None:
        named = [*_selectors(spec.angle_column, "angle_column", str(path))]
        if spec.time_column is not None:
            named += _selectors(spec.time_column, "time_column", str(path))
        elif spec.sample_rate is None:
            named += [*_DT_NAMES, *_TIME_NAMES]
        roots = {m.group(1).split(".")[0] for s in named if (m := _SELECTOR.fullmatch(s))}
    values, kinds, fmt = load_mat_variables(path, roots)
    if roots is not None and not roots & set(kinds) >= roots - {*_DT_NAMES, *_TIME_NAMES}:
        try:  # a name that is not there: the refusal lists what is, as read
            values = {**load_mat_variables(path, None)[0], **values}
        except DataError:
            pass
    doc = _Variables(values)
    doc.kinds = kinds
    return doc, fmt


def read_mat_series(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a MATLAB recording (see the module docstring for the selectors).

    Parameters
    ----------
    path
        The .mat file.
    spec
        Reading options; ``time_column``/``angle_column`` are selectors (or lists of them).
        The angle is ``raw * scale`` in ``angle_unit`` (default rad, with a note).

    Raises
    ------
    DataError
        Unreadable files, unknown variables or fields (the variables are listed), ambiguous
        angles, missing clocks, lengths that differ, times that do not increase.
    """
    spec = spec or RecordingSpec()
    where = str(path)
    raw = Path(path).read_bytes()
    doc, fmt = _read_needed(path, spec)
    notes: list[str] = []
    if not doc.kinds:
        raise DataError("the file holds no variables", where)
    angle_sel = _selectors(spec.angle_column, "angle_column", where) if spec.angle_column is not None else \
        (_auto_angle(doc, where, notes),)
    theta_raw, struct_time, locate, n_pieces = _join(doc, angle_sel, where)
    reader = {"source_format": fmt, "angle_column": ", ".join(angle_sel)}
    if n_pieces > len(angle_sel):
        notes.append(f"angle joined from {n_pieces} pieces of {', '.join(angle_sel)} in order")
    if spec.sample_rate is not None:
        time = np.arange(theta_raw.size) / spec.sample_rate
        reader["time_column"] = f"row number / {spec.sample_rate:g} Hz"
    elif spec.time_column is not None:
        time_sel = _selectors(spec.time_column, "time_column", where)
        time, _, time_locate, _ = _join(doc, time_sel, where, clock=True)
        reader["time_column"] = ", ".join(time_sel)
        if time.size != theta_raw.size:
            raise DataError(f"the time ({reader['time_column']}) has {time.size} samples but the angle "
                            f"({reader['angle_column']}) has {theta_raw.size}", where)
        locate = time_locate
    elif struct_time is not None:
        time = struct_time
        reader["time_column"] = ", ".join(f"{s.split('[')[0]}.time" for s in angle_sel)
    else:
        time, reader["time_column"] = _auto_clock(doc, theta_raw.size, where, notes)
    unit = spec.angle_unit
    if unit is None:
        unit = "rad"
        notes.append("no angle unit in the options, rad assumed")
        reader["angle_unit_assumed"] = "rad"
    scale = 1.0 if spec.scale is None else spec.scale
    theta = theta_raw * (scale * rad_per_unit(unit, spec.counts_per_turn, f"{where} [recording].angle_unit"))
    reader["angle_unit"] = unit + (f" ({spec.counts_per_turn:g} per turn)" if unit.lower() in COUNT_WORDS else "")
    if scale != 1.0:
        reader["scale"] = f"{scale:g}"
    loc: Callable[[int], str] = locate
    return build_series(time, theta, spec, source=where, sha256=hashlib.sha256(raw).hexdigest(), meta=reader,
                        notes=notes, where_of_row=loc, label=reader.get("angle_column", ""),
                        unit_from="option" if spec.angle_unit is not None else "assumed")
