"""Timegrapher programs' logs: TimeGrapher-Net's measurement log and peterhudson/timegrapher's CSVs.

**TimeGrapher-Net** (Jae-hong-5/TimeGrapher-Net, ``src/TimeGrapher.App/Services/
MeasurementResultLogger.cs``, versions 351a6faf and 532aea5b; no licence, so no file of it is
shipped): an optional first line ``lift_angle_deg,52.000000`` (351a6faf; the later version writes
no such line), then the header ``session_id,source_id,history_version,latest_time_s,bph,
active_position,rate_valid,rate_s_per_day,amplitude_valid,amplitude_deg,beat_error_valid,
beat_error_ms,diff_tic_tac_valid,...,missed_beat_detections,sync_loss_count`` (26 columns) and
one row per displayed update (``WriteEntry``): flags ``true``/``false``, numbers ``F6`` in the
invariant culture, an empty field where a value is not valid, the watch position as its enum
name.  ``latest_time_s`` is the time of the latest beat of the update, so rows fall on beats.
The last row may be cut mid-field (the app stopped while writing): dropped with a note.
Several sessions (``session_id``) in one log: ``[recording] run`` picks one (default: refused,
listing them).  The rows become display readings as for the app logs
(:func:`~escfit.analysis.recordings.tg_applog.applog_recording`).

**peterhudson/timegrapher** (``crates/timegrapher-cli/src/main.rs`` 005014c9, ``output.rs``
1e2ab54b, ``docs``; GPL): ``analyze --beats`` ``index,time_s,quality,residual_us`` (one row per
beat; ``long`` writes ``index,time_s,true_time_s,quality``); ``analyze --windows``
``kind,start_s,end_s,rate_s_per_day,beat_error_ms[,beat_error_unlock_ms],amplitude_even_deg,
amplitude_odd_deg`` (``rate`` rows over 10 s, ``amplitude`` rows over 2 s); ``long``'s
``slices.csv`` ``start_s,end_s,rate_s_per_day,beat_error_ms,amplitude_deg`` (the run-down log:
one row per slice of about 1/400 of the run) and ``amplitude.csv``
``start_s,end_s,true_start_s,even_deg,odd_deg``; ``--json`` / ``summary.json``: a summary
(median amplitude, overall rate), read but not fittable.  The CSVs do not record the lift angle
(the program's ``--lift``, 52 deg by default): ``[recording] lift_angle`` gives it, else the
file is refused.  Window readings are the mean of the even and odd amplitudes; the beats are a
grid that follows the logged rate (:func:`rate_grid`), so such a record is fitted on its
amplitudes alone.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.tabletext import decode_lenient, numbered_lines, parse_number, split_fields
from .recording_spec import RecordingSpec
from .tg_applog import applog_recording
from .timegrapher import TimegrapherRecording

__all__ = ["read_timegrapher_net", "read_tgcli", "sniff_tg_logs", "rate_grid", "TGNET_HEADER"]

TGNET_HEADER = ("session_id,source_id,history_version,latest_time_s,bph,active_position,rate_valid,rate_s_per_day,"
                "amplitude_valid,amplitude_deg,beat_error_valid,beat_error_ms,diff_tic_tac_valid,diff_tic_tac_ms,"
                "diff_period_valid,diff_period_ms,avg_period_valid,avg_period_ms,rate_count,rate_mean_s_per_day,"
                "rate_sigma_s_per_day,amplitude_count,amplitude_mean_deg,amplitude_sigma_deg,missed_beat_detections,"
                "sync_loss_count").split(",")
_TGCLI = {"index,time_s,quality,residual_us": "tgcli-beats", "index,time_s,true_time_s,quality": "tgcli-beats",
          "start_s,end_s,rate_s_per_day,beat_error_ms,amplitude_deg": "tgcli-slices",
          "start_s,end_s,true_start_s,even_deg,odd_deg": "tgcli-amplitude"}


def sniff_tg_logs(text: str) -> str | None:
    """The format of a timegrapher program's log (``timegrapher-net``, ``tgcli-*``), or None."""
    head = text.lstrip("\ufeff")[:3000]
    if head.startswith("{") and '"schema"' in head and "timegrapher." in head:
        return "tgcli-json"
    lines = [s.strip() for _, s in numbered_lines(head) if s.strip()][:2]
    for line in lines:
        if line.startswith("session_id,source_id,history_version,latest_time_s"):
            return "timegrapher-net"
        if line in _TGCLI:
            return _TGCLI[line]
        if line.startswith("kind,start_s,end_s,rate_s_per_day,beat_error_ms"):
            return "tgcli-windows"
    return None


def _lift(spec: RecordingSpec | None, found: tuple[str, str] | None, where: str, program: str) -> float:
    """Lift angle, deg: the file's, else ``[recording] lift_angle``, else refused."""
    if spec is not None and spec.lift_angle is not None:
        return math.degrees(spec.lift_angle)
    if found is not None:
        v = parse_number(found[0])
        if v is None or not 10.0 <= v <= 90.0:
            raise DataError(f"lift angle {found[0]!r} is not a number of degrees in 10-90", found[1])
        return v
    raise DataError(f"the file does not say the lift angle set in {program} (its amplitudes scale with it); set "
                    "[recording] lift_angle (e.g. \"52 deg\")", where)


def _flag(text: str, at: str) -> bool:
    low = text.strip().lower()
    if low not in ("true", "false"):
        raise DataError(f"expected true or false, got {text!r}", at)
    return low == "true"


def read_timegrapher_net(path: str | Path, spec: RecordingSpec | None = None) -> TimegrapherRecording:
    """Read a TimeGrapher-Net measurement log (see the module docstring)."""
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    text = decode_lenient(raw, where, notes)
    lines = [(n, s) for n, s in numbered_lines(text) if s.strip()]
    lift_at = None
    if lines and lines[0][1].lower().startswith("lift_angle_deg"):
        lift_at = (split_fields(lines[0][1], ",")[1:2] or [""])[0], f"{where}:{lines[0][0]}"
        lines = lines[1:]
    if not lines or split_fields(lines[0][1], ",")[:4] != TGNET_HEADER[:4]:
        raise DataError("no TimeGrapher-Net header (session_id,source_id,history_version,latest_time_s,...)", where)
    h_line, header = lines[0][0], split_fields(lines[0][1], ",")
    col = {name: header.index(name) for name in TGNET_HEADER if name in header}
    missing = [c for c in ("latest_time_s", "bph", "amplitude_valid", "amplitude_deg") if c not in col]
    if missing:
        raise DataError(f"the header lacks {missing}", f"{where}:{h_line}")
    lift = _lift(spec, lift_at, where, "TimeGrapher-Net")
    body = lines[1:]
    sessions: dict[str, list] = {}
    for j, (n, s) in enumerate(body):
        fields = split_fields(s, ",")
        at = f"{where}:{n}"
        try:
            if len(fields) != len(header):
                raise DataError(f"row has {len(fields)} of {len(header)} fields", at)
            row = {"clock": False, "time": _num(fields, col, "latest_time_s", at),
                   "bph": _num(fields, col, "bph", at),
                   "valid": _flag(fields[col["amplitude_valid"]], f"{at} [amplitude_valid]"),
                   "amplitude": _num(fields, col, "amplitude_deg", at)}
            for key, valid, value in (("rate", "rate_valid", "rate_s_per_day"),
                                      ("beat_error", "beat_error_valid", "beat_error_ms")):
                if value in col:
                    ok = _flag(fields[col[valid]], f"{at} [{valid}]") if valid in col else True
                    row[key] = _num(fields, col, value, at) if ok else math.nan
        except DataError:
            if j < len(body) - 1 or text.endswith(("\n", "\r")) and len(fields) == len(header):
                raise
            notes.append(f"dropped the truncated last row (line {n})")
            break
        if math.isnan(row["time"]):
            raise DataError("every row needs its latest_time_s", f"{at} [latest_time_s]")
        sessions.setdefault(fields[col.get("session_id", 0)], []).append(((n, fields), row))
    if not sessions:
        raise DataError("no rows under the header", where)
    names = list(sessions)
    if len(names) > 1 and (spec is None or spec.run is None):
        raise DataError(f"{len(names)} sessions in the log (session_id {', '.join(names)}); set [recording] run "
                        "(1-based, in that order)", where)
    pick = names[(spec.run or 1) - 1] if spec is not None and spec.run is not None and spec.run <= len(names) else None
    if pick is None:
        if spec is not None and spec.run is not None:
            raise DataError(f"[recording] run = {spec.run}, but the log has {len(names)} session(s)", where)
        pick = names[0]
    chosen = sessions[pick]
    meta = {"program": "TimeGrapher-Net", "session_id": pick, "rows_truncated": "1" if any(
        "truncated" in x for x in notes) else "0", "delimiter": ","}
    if "active_position" in col:
        meta["position"] = chosen[-1][0][1][col["active_position"]]
    cols = {"time": (col["latest_time_s"], 1.0), "amplitude": (col["amplitude_deg"], 1.0), "bph": (col["bph"], 1.0)}
    cols.update({k: (col[v], 1.0) for k, v in (("rate", "rate_s_per_day"), ("beat_error", "beat_error_ms")) if v in col})
    given = {"lift_angle": (f"{lift:g}", lift_at[1] if lift_at else f"{where} [recording].lift_angle")}
    header_named = list(header)
    return applog_recording(where, raw, h_line - 1, header_named, cols, given, meta, [r for r, _ in chosen],
                            [p for _, p in chosen], notes, False)


def _num(fields: list[str], col: dict, name: str, at: str) -> float:
    text = fields[col[name]]
    if not text.strip():
        return math.nan
    v = parse_number(text)
    if v is None or math.isinf(v):
        raise DataError(f"expected a number, got {text!r}", f"{at} [{name}]")
    return v


def rate_grid(t0: float, t1: float, bph: float, times: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """Beat times from ``t0`` to ``t1`` (s) that follow a logged rate (s/day) at ``times``.

    The beat interval is ``(3600/bph) / (1 + rate/86400)`` (a watch gaining ``rate`` beats
    faster), the rate taken from the nearest logged value (the nominal beat where none is given).
    """
    nominal = 3600.0 / bph
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 >= t0):
        raise DataError(f"no beat grid from {t0} to {t1} s")
    n = int((t1 - t0) / nominal * 1.01) + 3
    if n > 3_000_000:
        raise DataError(f"{n} beats between {t0:g} and {t1:g} s: beyond the 40 hours a timegrapher record may span")
    grid = np.arange(n) * nominal + t0
    if times.size:
        order = np.argsort(times)
        r = np.interp(grid, times[order], np.nan_to_num(rate[order], nan=0.0))
        grid = t0 + np.concatenate([[0.0], np.cumsum(nominal / (1.0 + r[:-1] / 86400.0))])
    return grid[grid <= t1 + nominal]


def _table(path: Path, where: str) -> tuple[bytes, list[str], list[tuple[int, list[str]]], list[str]]:
    raw = path.read_bytes()
    notes: list[str] = []
    lines = [(n, s) for n, s in numbered_lines(decode_lenient(raw, where, notes)) if s.strip()]
    at = next((i for i, (_, s) in enumerate(lines) if s.strip().startswith(("index,", "kind,", "start_s,"))), None)
    if at is None:
        raise DataError("no header line (index,time_s,... / kind,start_s,... / start_s,end_s,...)", where)
    if at > 0:
        raise DataError(f"line {lines[0][0]} comes before the header (line {lines[at][0]}): delete it", where)
    header = split_fields(lines[0][1], ",")
    rows = [(n, split_fields(s, ",")) for n, s in lines[1:]]
    if rows and len(rows[-1][1]) < len(header):
        notes.append(f"dropped the truncated last row (line {rows[-1][0]})")
        rows = rows[:-1]
    for n, r in rows:
        if len(r) != len(header):
            raise DataError(f"expected {len(header)} fields ({','.join(header)}), found {len(r)}", f"{where}:{n}")
    return raw, header, rows, notes


def read_tgcli(path: str | Path, spec: RecordingSpec | None = None) -> TimegrapherRecording:
    """Read one of peterhudson/timegrapher's files (see the module docstring); the beat rate comes
    from ``[recording] bph`` (the beats file: from its median interval)."""
    p, where = Path(path), str(path)
    bph = spec.bph if spec is not None else None
    head = p.read_bytes()[:3000].decode("utf-8", "replace")
    kind = sniff_tg_logs(head)
    if kind == "tgcli-json":
        return _refuse_summary(p, where)
    if kind is None or kind == "timegrapher-net":
        raise DataError("not a peterhudson/timegrapher CSV (beats, windows, slices or amplitude)", where)
    raw, header, rows, notes = _table(p, where)
    c = {name: i for i, name in enumerate(header)}
    need = {"tgcli-beats": ("index", "time_s"), "tgcli-windows": ("kind", "start_s", "end_s", "rate_s_per_day",
                                                                  "amplitude_even_deg", "amplitude_odd_deg"),
            "tgcli-slices": ("start_s", "end_s", "rate_s_per_day", "amplitude_deg"),
            "tgcli-amplitude": ("start_s", "end_s", "even_deg", "odd_deg")}[kind]
    missing = [n for n in need if n not in c]
    if missing:
        raise DataError(f"the header lacks {missing}", f"{where}:1")

    def column(name: str, subset=None) -> np.ndarray:
        out = []
        for n, r in (rows if subset is None else subset):
            v = parse_number(r[c[name]]) if r[c[name]].strip() else math.nan
            if v is None or math.isinf(v):
                raise DataError(f"expected a number, got {r[c[name]]!r}", f"{where}:{n} [{name}]")
            out.append(v)
        return np.array(out, dtype=float)

    if kind == "tgcli-beats":
        t, index = column("time_s"), column("index")
        if not (np.isfinite(t).all() and np.isfinite(index).all()) or t.size < 2:
            raise DataError("every beat needs its index and time_s (and there must be two beats)", where)
        index = index.astype(np.int64)
        if np.any(np.diff(t) <= 0):
            i = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
            raise DataError(f"beat times must increase: {t[i - 1]} then {t[i]}", f"{where}:{rows[i][0]} [time_s]")
        rate_bph = bph or _standard_bph(3600.0 / float(np.median(np.diff(t))))
        meta = {"program": "peterhudson/timegrapher", "file": "beats", "notes": "; ".join(
            notes + ["beats only: no amplitude readings to fit"])}
        return TimegrapherRecording(t, index % 2 == 0, np.zeros(0), np.zeros(0), math.radians(52.0),
                                    int(round(rate_bph)), 2.0, "centre", 0.0, (0.0, math.inf), False, math.nan, None,
                                    None, math.nan, "tgcli-beats", where, hashlib.sha256(raw).hexdigest(), meta)
    if kind == "tgcli-windows":
        amp_rows = [(n, r) for n, r in rows if r[c["kind"]] == "amplitude"]
        rate_rows = [(n, r) for n, r in rows if r[c["kind"]] == "rate"]
        start, end = column("start_s", amp_rows), column("end_s", amp_rows)
        amp = _sides(column("amplitude_even_deg", amp_rows), column("amplitude_odd_deg", amp_rows))
        rt = (column("start_s", rate_rows) + column("end_s", rate_rows)) / 2
        rate = column("rate_s_per_day", rate_rows)
    else:
        start, end = column("start_s"), column("end_s")
        if kind == "tgcli-slices":
            amp, rate, rt = column("amplitude_deg"), column("rate_s_per_day"), (start + end) / 2
        else:
            amp = _sides(column("even_deg"), column("odd_deg"))
            rate, rt = np.zeros(0), np.zeros(0)
    return _windowed(raw, where, kind, start, end, amp, rt, rate, spec, bph, notes)


def _sides(even: np.ndarray, odd: np.ndarray) -> np.ndarray:
    """The mean of the two pallets' amplitudes, or the one given (nan when neither is)."""
    both = np.isfinite(even) & np.isfinite(odd)
    return np.where(both, 0.5 * (even + odd), np.where(np.isfinite(even), even, odd))


def _windowed(raw, where, kind, start, end, amp, rt, rate, spec, bph, notes) -> TimegrapherRecording:
    lift = _lift(spec, None, where, "peterhudson/timegrapher")
    if not amp.size or not np.isfinite(amp).any():
        raise DataError("no amplitude readings in the file", where)
    if bph is None:
        raise DataError("the file does not say the beat rate: set [recording] bph (the watch's beats per hour, "
                        "e.g. 28800)", where)
    bad = np.flatnonzero(~(np.isfinite(start) & np.isfinite(end) & (end > start)))
    if bad.size:
        raise DataError(f"window {int(bad[0]) + 1} has no valid start_s < end_s", where)
    if np.any(np.diff(start) < 0):
        raise DataError("the windows are not in time order", where)
    ok = np.isfinite(amp)
    if (~ok).any():
        notes.append(f"{int((~ok).sum())} window(s) without an amplitude (the program's null: outside 100-380 deg) "
                     "left out")
    start, end, amp = start[ok], end[ok], amp[ok]
    grid = rate_grid(float(start.min()), float(end.max()), bph, rt, rate)
    notes.append("beats: a grid that follows the logged rate, not heard beats: amplitudes fitted alone")
    meta = {"program": "peterhudson/timegrapher", "file": kind, "lift_angle_deg": f"{lift:g}",
            "notes": "; ".join(notes)}
    return TimegrapherRecording(grid, np.arange(grid.size) % 2 == 0, (start + end) / 2, amp, math.radians(lift),
                                int(round(bph)), float(np.median(end - start)), "centre", 0.1, (0.0, math.inf), False,
                                math.nan, None, None, math.nan, "tg-applog", where, hashlib.sha256(raw).hexdigest(),
                                meta)


#: the beat rates peterhudson/timegrapher guesses from (its --bph help)
STANDARD_BPH = (12000, 14400, 17280, 18000, 19800, 21600, 25200, 28800, 36000, 43200, 72000)


def _standard_bph(measured: float) -> float:
    """The standard beat rate within 1 % of a measured one (a watch's rate error is far smaller), else itself."""
    near = min(STANDARD_BPH, key=lambda b: abs(b - measured))
    return float(near) if abs(near / measured - 1.0) < 0.01 else measured


def _refuse_summary(p: Path, where: str) -> TimegrapherRecording:
    try:
        doc = json.loads(p.read_text(encoding="utf-8-sig"))
    except (ValueError, RecursionError, UnicodeDecodeError) as exc:
        raise DataError(f"invalid JSON ({str(exc)[:60]})", where) from None
    amp = doc.get("amplitude_deg") if isinstance(doc, dict) else None
    dur = doc.get("duration_s") if isinstance(doc, dict) else None
    raise DataError(f"a timegrapher summary ({doc.get('schema', '?') if isinstance(doc, dict) else '?'}: median "
                    f"amplitude {amp} deg over {dur} s), not readings over time; export the windows (--windows CSV) "
                    "or, for a long run, slices.csv, and read that", where)
