"""Timegrapher app logs: one row per display update, a settings block, flags, a cut last row.

Phone and PC timegrapher apps export what they displayed, not the beats they heard::

    Lift angle,52
    BPH,18000
    Time,Rate (s/d),Amplitude (deg),Beat error (ms),Valid
    21:47:04.349,+357.0,227,+0.3,true
    21:47:04.748,+144.2,203,-0.3,false
    21:47:05.148,+112.6,19                     <- the app was stopped mid-write

- Before the header: settings ``name,value`` (``name: value``, ``name = value``, ``;``, tab,
  ``# name: value``) and titles.  Read: lift angle (deg; the app's amplitudes come from it), BPH
  (or ``<f> Hz``), averaging (``<n> beats`` or ``<s> s`` per reading; default the beats since
  the previous update), release (when the balance was let go, on the time column's clock:
  escfit's addition, needed to fit a decay).  All are kept in ``meta`` (snake_case names).
- Header: the first line naming a time column and a rate or beat error column (an app shows
  both); case-insensitive, units in brackets or as a suffix (``Rate [s/d]``,
  ``beat_error_ms``); delimiter ``,``, ``;`` or tab (then decimal commas are read).  Unknown
  columns are ignored (``meta["notes"]``).  Time in s or ms, or clock time ``hh:mm:ss.sss``
  (a date may precede it), as seconds from the first row, passing midnight.
- Flags (``Valid``, ``OK``, ``Status`` ...): true/false, 1/0, yes/no, ok, blank (= invalid).
  Invalid rows and rows without an amplitude are dropped and counted in ``meta``; so is a cut
  last row.  A short row anywhere else is refused, naming its line.

The fit: kept rows lie a whole number of beats apart (checked); ``beat_time`` is a *grid* (rows
at their logged times, beats between interpolated, one beyond the outer windows) counting half
swings, not heard beats: fit with ``beats = false`` in ``[observation]``.  Each kept row is one
amplitude reading of the ``m`` beats up to it (``meta["beats_per_reading"]``): ``amp_time``
their centre, the window ``m - 1/2`` beats wide, so consecutive windows do not overlap and each
reading counts once, with noise ``observation.sigma``; readings are as displayed
(``resolution_deg`` from the decimals), not selected by amplitude (``amp_range_deg = (0, inf)``).
``rate`` (s/day) and ``beat_error`` (ms, signed as written: which side of the beat is late) are
per reading, unused by the fit.  ``meta["steady_state"]`` holds :func:`is_steady_state`'s
verdict; a steady record also gets ``meta["steady_state_warning"]`` (:data:`STEADY_STATE_WARNING`).
"""

from __future__ import annotations

import csv
import datetime as _dt
import hashlib
import math
import re
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from .sniff import file_kind
from .timegrapher import CSV_COLUMNS, TimegrapherRecording

__all__ = ["read_tg_applog", "applog_recording", "sniff_tg_applog", "is_steady_state", "amplitude_drift", "FORMAT", "STEADY_STATE_WARNING"]

FORMAT = "tg-applog"
STEADY_STATE_WARNING = ("a steady-state record fixes only the balance of C, R and X; a free decay (let down the "
                        "mainspring / stop the watch and record the decay) or runs at several mainspring torques "
                        "separate them")
_CLOCK = None  # unit factor of a clock-time column
_COLUMNS = {  # role: (names, {unit: factor to s, s/day, deg, ms, bph})
    "time": (("time", "t", "timestamp", "clock", "elapsed", "elapsed time"),
             {"": 1.0, "s": 1.0, "sec": 1.0, "seconds": 1.0, "ms": 1e-3, "clock": _CLOCK, "hh:mm:ss": _CLOCK}),
    "rate": (("rate", "daily rate"), {"": 1.0, "s/d": 1.0, "s/day": 1.0, "sec/day": 1.0, "s per day": 1.0, "spd": 1.0}),
    "amplitude": (("amplitude", "amp", "ampl"), {"": 1.0, "deg": 1.0, "°": 1.0, "degrees": 1.0}),
    "beat_error": (("beat error", "beaterror", "be", "beat err"), {"": 1.0, "ms": 1.0, "us": 1e-3, "µs": 1e-3}),
    "bph": (("bph", "beat rate", "beats per hour", "vph"), {"": 1.0, "bph": 1.0}),
    "valid": (("valid", "validity", "ok", "status", "locked", "good", "flag", "quality"), {"": 1.0}),
}
_SETTINGS = {"lift_angle": ("lift angle", "lift", "liftangle", "la"), "bph": _COLUMNS["bph"][0],
             "averaging": ("averaging", "average", "window", "averaging time", "integration"),
             "release": ("release", "released", "released at", "release time")}
HEAD_BYTES = 1 << 20  # a header is looked for in the first MiB and 200 lines
MAX_HEADER_FIELDS = 64  # a line of more fields is data, not an app log's header
_TRUE = {"true", "1", "yes", "y", "ok", "valid", "good", "locked", "t"}
_FALSE = {"false", "0", "no", "n", "invalid", "bad", "nok", "not ok", "error", "err", "f", "lost", "", "-", "---"}


def _name_unit(raw: str) -> tuple[str, str]:
    s = raw.strip().strip("\"'").lower().replace("_", " ")
    m = re.fullmatch(r"(.*?)\s*[(\[]\s*([^)\]]*?)\s*[)\]]", s)
    s, unit = (m.group(1), m.group(2)) if m else (s, "")
    return re.sub(r"\s+", " ", s).strip(), unit


def _role(raw: str) -> tuple[str | None, str]:
    """The column a header field names (``None``: unknown) and its unit."""
    name, unit = _name_unit(raw)
    for role, (names, units) in _COLUMNS.items():
        for alias in names:
            if name == alias:
                return role, unit
            if not unit and name.startswith(alias + " ") and name[len(alias) + 1:] in units:
                return role, name[len(alias) + 1:]
    return None, ""


def _split(line: str, delim: str) -> list[str]:
    return [f.strip() for f in next(csv.reader([line], delimiter=delim))]


def _find_header(lines: list[str], limit: int | None = None) -> tuple[int, str, list[str]] | None:
    """Index, delimiter and fields of the header line."""
    for i, line in enumerate(lines[:limit]):
        s = line.strip().lstrip("\ufeff")
        delim = max(("\t", ";", ","), key=s.count)
        if s and not s.startswith("#") and 0 < s.count(delim) <= MAX_HEADER_FIELDS:
            roles = {_role(f)[0] for f in _split(s, delim)}
            if "time" in roles and roles & {"rate", "beat_error"}:
                return i, delim, _split(s, delim)
    return None


def _head_lines(path: str | Path, count: int) -> list[str]:
    """The first ``count`` lines of a text file (as ``splitlines`` of the whole text gives them),
    read in growing pieces from 64 kB up to :data:`HEAD_BYTES`: a long record is not read whole
    to look at its start, nor a file of few, very long lines (no app log's header is so far in)."""
    data = b""
    size = 1 << 16
    with open(path, "rb") as f:
        while True:
            chunk = f.read(size)
            size *= 2
            data += chunk
            lines = data.decode("utf-8", errors="replace").replace("\r\n", "\n").replace("\r", "\n").splitlines()
            if not chunk or len(lines) > count or len(data) >= HEAD_BYTES:
                return lines[:count]


def sniff_tg_applog(path: str | Path) -> bool:
    """Whether a file looks like an app log: such a header within its first 200 lines (escfit's
    own per-beat CSV header does not count)."""
    if file_kind(path) != "text":
        return False
    found = _find_header(_head_lines(path, 200), 200)
    return found is not None and not {f.strip().lower() for f in found[2]} <= set(CSV_COLUMNS)


def _number(text: str, comma: bool, where: str, what: str) -> float:
    s = re.sub(r"(?i)\s*(°|deg|degrees|bph|s)$", "", text.strip())
    if s.lower() in ("", "-", "--", "---", "n/a", "na"):
        return math.nan
    try:
        v = float(s.replace(",", ".") if comma else s)
    except ValueError:
        raise DataError(f"expected {what}, got {text!r}", where) from None
    if not math.isfinite(v):
        raise DataError(f"{text!r} is not a finite number; expected {what}", where)
    return v


def _clock(text: str, comma: bool, where: str) -> float:
    """Seconds of a clock time (since midnight, or since 1970 when a date precedes it)."""
    s = text.strip().replace(",", ".") if comma else text.strip()
    try:
        if re.match(r"\d{4}[-/]\d\d[-/]\d\d", s):
            stamp = _dt.datetime.fromisoformat(s.replace("/", "-")).replace(tzinfo=None)
            return (stamp - _dt.datetime(1970, 1, 1)).total_seconds()
        parts = [float(p) for p in s.split(":")]
        if len(parts) not in (2, 3) or min(parts) < 0 or max(parts[1:]) >= 60:
            raise ValueError
        return sum(p * 60.0**k for k, p in enumerate(reversed(parts)))
    except ValueError:
        raise DataError(f"expected a clock time hh:mm:ss.sss, got {text!r}", where) from None


def _settings(lines: list[str], delim: str, where: str) -> tuple[dict, dict[str, tuple[str, str]]]:
    """``meta`` from the lines before the header, and the settings read, ``{key: (value,
    "file:line")}`` (a unit in the name is appended to the value)."""
    meta, given = {"delimiter": {"\t": "tab"}.get(delim, delim), "rows_truncated": "0"}, {}
    for n, line in enumerate(lines, start=1):
        s = line.strip().lstrip("\ufeff")
        comment, s = s.startswith("#"), s.lstrip("#").strip()
        cuts = [i for i in (s.find(c) for c in (delim, ",", ";", "\t", ":", "=")) if i > 0]
        if not cuts:
            if s and not comment:
                meta.setdefault("title", s)
            continue
        name, unit = _name_unit(s[:min(cuts)])
        meta[name.replace(" ", "_")] = value = s[min(cuts) + 1:].strip().strip("\"'")
        given.update({key: (f"{value} {unit}".strip(), f"{where}:{n}") for key, names in _SETTINGS.items()
                      if name in names})
    return meta, given


def _parse_row(fields: list[str], cols: dict, header: list[str], comma: bool, at: str) -> dict:
    out = {}
    for role, (i, factor) in cols.items():
        here, text = f"{at} [{header[i]}]", fields[i]
        if role == "valid":
            if text.strip("\"' ").lower() not in _TRUE | _FALSE:
                raise DataError(f"expected a validity flag (true/false, 1/0, yes/no, ok or blank), got {text!r}", here)
            out[role] = text.strip("\"' ").lower() in _TRUE
        elif role == "time":
            out["clock"] = factor is _CLOCK or ":" in text
            out[role] = _clock(text, comma, here) if out["clock"] else factor * _number(text, comma, here, "a time")
            if math.isnan(out[role]):
                raise DataError("every row needs its time", here)
        else:
            out[role] = factor * _number(text, comma, here, f"a number (the {role.replace('_', ' ')})")
    return out


def _table(path: str | Path):
    """Raw bytes, header line index, header, columns, settings, meta, rows, parsed rows, notes and
    whether decimal commas are read."""
    where, raw = str(path), Path(path).read_bytes()
    lines = (text := raw.decode("utf-8", errors="replace")).splitlines()
    found = _find_header(lines)
    if found is None:
        raise DataError("no table header naming a time column and a rate or beat error column (e.g. "
                        "'Time,Rate (s/d),Amplitude (deg),Beat error (ms)')", where)
    h, delim, header = found
    while header and not header[-1]:
        header.pop()
    nh, notes, cols = len(header), [], {}
    meta, given = _settings(lines[:h], delim, where)
    for i, f in enumerate(header):
        role, unit = _role(f)
        if role is not None and (unit not in _COLUMNS[role][1] or role in cols):
            raise DataError(f"a second {role} column" if role in cols else f"unknown unit {unit!r} of the "
                            f"{role} column; use one of {sorted(u for u in _COLUMNS[role][1] if u)}",
                            f"{where}:{h + 1} [{f}]")
        notes += [f"ignored column {f!r}"] if role is None else []
        cols.update({role: (i, _COLUMNS[role][1][unit])} if role else {})
    body = [(n, s) for n, s in enumerate(lines[h + 1:], start=h + 2) if s.strip() and not s.lstrip().startswith("#")]
    rows, parsed = [], []
    for j, (n, s) in enumerate(body):
        fields = _split(s, delim)
        while len(fields) > nh and not fields[-1]:
            fields.pop()
        try:
            if len(fields) != nh:
                raise DataError(f"row has {len(fields)} of {nh} fields ({', '.join(header)}): cut short; only the last "
                                "row of a log may be (an app stopped mid-write); complete or delete it" if
                                len(fields) < nh else f"row has {len(fields)} fields, the header {nh}; a decimal "
                                f"comma in a '{delim}'-delimited file? use ';' as the delimiter", f"{where}:{n}")
            parsed.append(_parse_row(fields, cols, header, delim != ",", f"{where}:{n}"))
            rows.append((n, fields))
        except DataError:  # only the last row may be cut: short, or unreadable with no line end
            if j < len(body) - 1 or len(fields) > nh or (text.endswith(("\n", "\r")) and len(fields) == nh):
                raise
            notes.append(f"dropped the truncated last row (line {n})")
            meta["rows_truncated"] = "1"
    if len(parsed) < 2:
        raise DataError(f"need at least 2 rows under the header (line {h + 1}), found {len(parsed)}", where)
    return raw, h, header, cols, given, meta, rows, parsed, notes, delim != ","


def read_tg_applog(path: str | Path) -> TimegrapherRecording:
    """Read a timegrapher app's log (file shape and meaning: see the module docstring).

    Returns
    -------
    TimegrapherRecording
        ``format = "tg-applog"``; ``meta`` holds the settings, ``lift_angle_deg`` and
        ``lift_angle_source``, row counts, ``notes`` and the steady-state verdict.

    Raises
    ------
    DataError
        One line naming file, line, column and what to set.
    """
    where, kind = str(path), file_kind(path)
    if kind != "text":
        raise DataError(f"{kind} file, not a timegrapher app log", where)
    return applog_recording(where, *_table(path))


def applog_recording(where: str, raw: bytes, h: int, header: list[str], cols: dict, given: dict, meta: dict,
                     rows: list, parsed: list[dict], notes: list[str], comma: bool, *,
                     fmt: str = FORMAT) -> TimegrapherRecording:
    """A TimegrapherRecording from a display log's parsed rows (shared by the app-log readers).

    ``cols`` maps roles (time, rate, amplitude, beat_error, bph) to ``(field index, factor)``,
    ``parsed`` holds each row's values by role (and ``valid``, ``clock``), ``rows`` the
    ``(line, fields)`` pairs, ``given`` the settings ``{key: (value, where)}``.
    """
    ti, clock = cols["time"][0], parsed[0]["clock"]
    t = np.array([r["time"] for r in parsed])
    if clock:  # a time of day runs past midnight (a full date needs no help)
        t = t + 86400.0 * np.concatenate([[0], np.cumsum(np.diff(t) < -43200.0)])
    origin, t = t[0], t - t[0]
    if len(parsed) < 2:
        raise DataError(f"need at least 2 rows under the header (line {h + 1}), found {len(parsed)}", where)
    bad = np.flatnonzero((np.diff(t) <= 0) | np.array([r["clock"] != clock for r in parsed[1:]], dtype=bool))
    if bad.size:
        k = int(bad[0]) + 1
        raise DataError(f"time {rows[k][1][ti]!r} does not come after {rows[k - 1][1][ti]!r}; rows must be in time "
                        "order, all clock times or all seconds", f"{where}:{rows[k][0]} [{header[ti]}]")
    valid = np.array([r.get("valid", True) for r in parsed])
    amp = np.array([r.get("amplitude", math.nan) for r in parsed])
    no_amp = valid & np.isnan(amp) & ("amplitude" in cols)
    idx = np.flatnonzero(valid & ~no_amp)
    meta.update({"time_origin": rows[0][1][ti], "rows": str(len(rows)), "rows_invalid": str(int((~valid).sum())),
                 "rows_no_amplitude": str(int(no_amp.sum())), "rows_kept": str(idx.size)})
    notes += [f"dropped {c} {what}" for c, what in ((int((~valid).sum()), "row(s) flagged invalid"),
                                                    (int(no_amp.sum()), "valid row(s) without an amplitude")) if c]
    if idx.size < 2:
        raise DataError(f"{idx.size} usable row(s) once invalid ones are dropped; need at least 2", where)
    bph = _bph(given.get("bph"), {parsed[i]["bph"] for i in idx if "bph" in cols and not math.isnan(parsed[i]["bph"])},
               f"{where} [{header[cols['bph'][0]]}]" if "bph" in cols else where, h)
    lift = math.nan
    if "amplitude" in cols:  # the app computed the amplitudes from the lift angle set in it
        if "lift_angle" not in given:
            raise DataError("no lift angle: the amplitudes depend on the one set in the app; add a settings line "
                            f"'Lift angle,52' (that angle, deg) before the header at line {h + 1}", where)
        value, at = given["lift_angle"]
        lift = _number(value, comma, at, "a lift angle in deg")
        if not 10.0 <= lift <= 90.0:
            raise DataError(f"lift angle {lift:g} deg lies outside 10-90 deg", at)
        meta.update({"lift_angle_deg": f"{lift:g}", "lift_angle_source": at})
    release = math.nan
    if "release" in given:
        value, at = given["release"]
        dated = bool(re.match(r"\d{4}", value)) or not clock  # else a time of day, against the first row's
        release = (_clock(value, comma, at) if clock else _number(value, comma, at, "a time")) - origin
        release = release if dated else (release + 43200.0) % 86400.0 - 43200.0
        if not release < t[idx[0]]:
            raise DataError(f"release {value!r} does not come before the first kept row (line {rows[idx[0]][0]})", at)
    tk = t[idx]
    rates = np.array([parsed[i].get("rate", math.nan) for i in idx])
    k, per_update, period = _count_beats(tk, [rows[i][0] for i in idx], bph, where, header[ti], rates, notes)
    value, at = given.get("averaging", (f"{per_update} beats", where))  # beats a reading averages (at least 2)
    avg = re.fullmatch(r"([0-9.]+)\s*(beats?|s|sec|seconds)", value.lower())
    if not avg:
        raise DataError(f"averaging must say '<n> beats' or '<s> s', got {value!r}", at)
    m = max(2, round(float(avg.group(1)) / (1.0 if avg.group(2).startswith("beat") else period)))
    j = np.arange(k[0] - m, k[-1] + 2)  # the grid: the readings' beats and one more either side
    grid = np.interp(j, k, tk)
    grid[:m] = tk[0] + (j[:m] - k[0]) * (tk[1] - tk[0]) / (k[1] - k[0])
    grid[-1] = tk[-1] + (tk[-1] - tk[-2]) / (k[-1] - k[-2])
    csum = np.concatenate([[0.0], np.cumsum(grid)])
    amp_time = (csum[k - j[0] + 1] - csum[k - j[0] + 1 - m]) / m  # centre of the beats each reading averages
    heard = grid > release if math.isfinite(release) else np.ones(grid.size, bool)
    a = amp[idx] if "amplitude" in cols else np.zeros(0)
    per_row = {r: np.array([parsed[i][r] for i in idx]) if r in cols else None for r in ("rate", "beat_error")}
    decimals = [len(re.split(r"[.,]", rows[i][1][cols["amplitude"][0]] + ".")[1]) for i in idx] if a.size else [0]
    meta.update({"bph": str(int(bph)), "beats_per_update": str(per_update), "beats_per_reading": str(m),
                 "beat_times": "grid: kept rows at their logged times, the beats between interpolated; not heard "
                               "beats: fit with beats = false"})
    if a.size:
        drift, scatter = amplitude_drift(a, amp_time)
        steady = is_steady_state(a, amp_time, resolution_deg=10.0 ** -max(decimals))
        meta.update({"steady_state": str(steady).lower(), "amplitude_drift_deg": f"{drift:.3g}",
                     "amplitude_scatter_deg": f"{scatter:.3g}"})
        if steady:
            meta["steady_state_warning"] = STEADY_STATE_WARNING
            notes.append(STEADY_STATE_WARNING)
    meta["notes"] = "; ".join(notes)
    return TimegrapherRecording(grid[heard], (j % 2 == 0)[heard], amp_time if a.size else np.zeros(0), a,
                                math.radians(lift), int(bph), (m - 0.5) * period, "centre", 10.0 ** -max(decimals),
                                (0.0, math.inf), False, release, per_row["rate"], per_row["beat_error"], math.nan,
                                fmt, where, hashlib.sha256(raw).hexdigest(), meta)


def _bph(setting: tuple[str, str] | None, column: set, at: str, h: int) -> float:
    """Beats per hour: the setting (``18000``, ``18000 bph``, ``2.5 Hz``) agreeing with the column."""
    m = re.fullmatch(r"\s*([0-9.]+)\s*(bph|hz)?\s*", setting[0].lower()) if setting else None
    if setting and not m:
        raise DataError(f"expected beats per hour (e.g. 18000) or '<f> Hz', got {setting[0]!r}", setting[1])
    values = column | ({float(m.group(1)) * (7200.0 if m.group(2) == "hz" else 1.0)} if m else set())
    at = setting[1] if setting else at
    if len(values) != 1:
        raise DataError(f"the beat rate is not one number: {sorted(values)} (BPH setting, bph column)" if values else
                        f"no beat rate: add a settings line 'BPH,18000' (the beats per hour set in the app) before "
                        f"the header at line {h + 1}", at)
    bph = values.pop()
    if bph != round(bph) or not 3600 <= bph <= 172800:
        raise DataError(f"beat rate {bph:g} bph is not a whole number of beats per hour in 3600-172800", at)
    return bph


#: Rows further apart than this many beats are long-window readings (a run-down log): the beats
#: between them are counted from the logged rate, not checked to fall on whole beats.
LONG_WINDOW_BEATS = 20


def _count_beats(t: np.ndarray, lines: list[int], bph: float, where: str, col: str,
                 rate: np.ndarray | None = None, notes: list[str] | None = None):
    """Beat index of each kept row (the first 0), beats per update and the typical beat period.

    Rows a few beats apart fall on beats (checked).  Rows many beats apart (each a window of
    minutes, as in a run-down log) follow the logged rate: a watch gaining ``r`` s/day beats every
    ``(3600/bph) / (1 + r/86400)`` s, and the beats between rows are that interval's count.
    """
    d = np.diff(t)
    typical = float(np.median(d)) * bph / 3600.0
    if typical > LONG_WINDOW_BEATS:
        nominal = 3600.0 / bph
        r = np.nan_to_num(np.asarray(rate if rate is not None else np.zeros(t.size), dtype=float)[1:], nan=0.0)
        period = nominal / (1.0 + r / 86400.0)
        k = np.round(np.concatenate([[0.0], np.cumsum(d / period)])).astype(np.int64)
        if notes is not None:
            follows = "the logged rate" if rate is not None and np.isfinite(rate).any() else "the nominal beat"
            notes.append(f"rows are some {typical:.0f} beats apart (long windows): the beats between them are counted "
                         f"from {follows}, not required to fall on whole beats")
        return k, max(1, round(typical)), float(np.median(d)) / typical
    per_update = max(1, round(typical))
    if abs(typical / per_update - 1.0) > 0.1:
        raise DataError(f"rows are typically {np.median(d):.4g} s apart, {typical:.2f} beats at {bph:g} bph: not a "
                        "whole number; set BPH to the watch's beat rate (rows must fall on beats)", where)
    period = float(np.median(d)) / per_update
    k, recent = [0], [period]
    for i, di in enumerate(d):
        beat = float(np.median(recent[-10:]))  # the beat drifts with the amplitude: follow it
        n = round(di / beat)
        if n < 1 or abs(di / beat - n) > 0.3:
            raise DataError(f"row comes {di:.4g} s after the previous kept row, {di / beat:.2f} beats of "
                            f"{1e3 * beat:.4g} ms: rows must fall on beats; check the time and BPH",
                            f"{where}:{lines[i + 1]} [{col}]")
        k.append(k[-1] + n)
        recent.append(di / n)
    return np.array(k), per_update, period


def amplitude_drift(amplitude: np.ndarray, time: np.ndarray, *, blocks: int = 3) -> tuple[float, float]:
    """Drift (range of the means of ``blocks`` equal-duration blocks) and scatter (median of the
    blocks' standard deviations) of amplitude readings (deg) at ``time`` (s); ``nan`` when a block
    holds fewer than 3 readings.  See :func:`is_steady_state`."""
    a, t = np.asarray(amplitude, float), np.asarray(time, float)
    ok = np.isfinite(a) & np.isfinite(t)
    a, t = a[ok], t[ok]
    if a.size < 3 * blocks or not t.max() > t.min():
        return math.nan, math.nan
    b = np.minimum((blocks * (t - t.min()) / (t.max() - t.min())).astype(int), blocks - 1)
    groups = [a[b == i] for i in range(blocks)]
    if min(g.size for g in groups) < 3:
        return math.nan, math.nan
    means = [g.mean() for g in groups]
    return float(max(means) - min(means)), float(np.median([g.std(ddof=1) for g in groups]))


def is_steady_state(amplitude: np.ndarray, time: np.ndarray, *, resolution_deg: float = 0.0) -> bool:
    """Whether an amplitude record is at steady state: flat within its own scatter.

    Criterion: cut the record into three equal-duration blocks (start, middle, end); it is
    steady when the range of the block means (the drift) does not exceed the scatter of single
    readings (the median of the blocks' standard deviations, insensitive to a slow trend,
    combined in quadrature with the display rounding ``resolution_deg / sqrt(12)``).  A decay,
    even one that settles early, lifts the first block's mean by more than that; a record too
    short for 3 readings per block is not called steady.

    Parameters
    ----------
    amplitude
        Amplitude readings, deg.
    time
        Their times, s.
    resolution_deg
        Display resolution of the readings, deg.
    """
    drift, scatter = amplitude_drift(amplitude, time)
    return bool(math.isfinite(drift) and drift <= math.hypot(scatter, resolution_deg / math.sqrt(12.0)))
