"""Timegrapher recordings: tg's JSON dump and a per-beat CSV.

A timegrapher listens to the escapement.  Each *beat* (tic or toc) is one passage of the
balance through its rest position; the *amplitude* is not heard but computed from the lift
angle ``L`` set on the instrument and the measured duration ``t`` of the escapement's sound
pulse (unlock to drop) within the oscillation period ``T``, assuming harmonic motion::

    A = L / (2 sin(pi t / T))

tg (Marcello Mamino's open-source timegrapher, ``src/algo.c`` ``compute_amplitude``) stores
this as the fraction ``A / L = 0.5 / sin(pi t / T)``, averaged over the processing buffer
(2, 4, 8 or 16 s of audio), and shows nothing when ``A`` falls outside 135-360 deg
(``src/computer.c``).

JSON dump (tg)
--------------
Field names follow the reader shipped with tg (``tgdata.py`` in the xyzzy42/tg fork)::

    {"sample_rate": 48000, "bph": 18000,
     "beats": {"times": [<sample index>, ...], "tictoc": [true, false, ...]},
     "amplitude": {"liftangle": 52.0, "times": [<sample index>, ...], "values": [<A/L>, ...]}}

``beats.times`` and ``amplitude.times`` are sample indices of the audio stream (the clock of
the recording; ``amplitude.times`` are the centres of the averaging windows), ``liftangle`` is
in degrees.  tg does not record the averaging window or the instant the balance was released;
escfit reads them from an optional ``"escfit"`` object (``window_s``, default 2 s, tg's shortest
buffer; ``release_sample``) that its recorder writes.  Readings tg rejected are simply absent.

Per-beat CSV
------------
One row per beat: ``time_s`` (the beat on the recording's clock), ``rate_s_per_day``,
``amplitude_deg`` (the displayed amplitude, whole degrees, averaged over the ``window_s``
seconds ending at the beat; empty or ``---`` when the instrument rejected it) and
``beat_error_ms``.  Metadata lines: ``# lift_angle_deg: 52``, ``# bph: 18000``,
``# window_s: 2``, optional ``# release_s: 0.0``, ``# amplitude_resolution_deg: 1``.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.textfile import refuse_binary
from ...core.csvtable import read_table
from .sniff import canonical_header, did_you_mean, file_kind, refuse_unless_csv

__all__ = ["TimegrapherRecording", "read_tg_json", "read_timegrapher_csv", "write_tg_json", "write_timegrapher_csv",
           "beat_swings", "CSV_COLUMNS", "TG_RANGE_DEG", "TG_WINDOW_S"]

#: Half swings a timegrapher record may span from the release: 40 hours at 36,000 beats per hour.
#: The model is solved up to the last beat, so the count bounds the work and the memory.
MAX_HALF_SWINGS = 1_440_000
TG_RANGE_DEG = (135.0, 360.0)  # tg shows no amplitude outside this range (src/computer.c)
TG_WINDOW_S = 2.0  # tg's shortest processing buffer, 2**FIRST_STEP s (src/tg.h)
CSV_COLUMNS = ("time_s", "rate_s_per_day", "amplitude_deg", "beat_error_ms")
_BLANK = ("", "---", "-")


class _OutOfRange(Exception):
    """A JSON number a float cannot hold (its text, shortened, is the message)."""


def _finite_number(text: str) -> int | float:
    """A JSON number as int (up to 15 digits) or float; 1e400 or a 5000-digit integer is refused."""
    if len(text) > 40:
        raise _OutOfRange(text[:20] + "...")
    if text.lstrip("-").isdigit() and len(text.lstrip("-")) <= 15:
        return int(text)
    value = float(text)
    if not math.isfinite(value):
        raise _OutOfRange(text)
    return value


@dataclass
class TimegrapherRecording:
    """Beats and amplitude readings of a timegrapher.

    Attributes
    ----------
    beat_time : ndarray
        Time of each beat on the recording's clock, s (increasing).
    tictoc : ndarray of bool
        Whether each beat is a tic (True) or a toc; two equal in a row mean a missed beat.
    amp_time : ndarray
        Time of each amplitude reading, s: the centre (JSON) or end (CSV) of its window.
    amp_deg : ndarray
        Displayed amplitude, deg; ``nan`` where the instrument showed nothing (CSV only).
    lift_angle : float
        Lift angle set on the instrument, rad.
    bph : int
        Nominal beats per hour set on the instrument.
    window : float
        Averaging window of an amplitude reading, s.
    window_align : str
        ``"centre"`` (the reading's time is the window's centre) or ``"end"``.
    resolution_deg : float
        Display resolution of the amplitude, deg (0 = unrounded).
    amp_range_deg : tuple
        Range outside which the instrument rejects an amplitude, deg.
    rejected_shown : bool
        Whether rejected readings appear (as ``nan``); otherwise they are absent and the
        readings present are a selection (truncated at ``amp_range_deg``).
    release_s : float
        Release instant on the recording's clock, s (``nan`` when unknown).
    rate, beat_error : ndarray or None
        Rate (s/day) and beat error (ms) of each CSV row.
    sample_rate : float
        Audio sample rate, Hz (``nan`` for CSV).
    format : str
        ``"tg-json"``, ``"csv"`` or ``"tg-applog"`` (see :mod:`escfit.analysis.recordings.tg_applog`).
    """

    beat_time: np.ndarray
    tictoc: np.ndarray
    amp_time: np.ndarray
    amp_deg: np.ndarray
    lift_angle: float
    bph: int
    window: float = TG_WINDOW_S
    window_align: str = "centre"
    resolution_deg: float = 0.0
    amp_range_deg: tuple[float, float] = TG_RANGE_DEG
    rejected_shown: bool = False
    release_s: float = math.nan
    rate: np.ndarray | None = None
    beat_error: np.ndarray | None = None
    sample_rate: float = math.nan
    format: str = "tg-json"
    source: str = ""
    sha256: str = ""
    meta: dict = field(default_factory=dict)
    kind = "timegrapher"

    @property
    def amp_window(self) -> tuple[np.ndarray, np.ndarray]:
        """Start and end of each reading's averaging window, s."""
        if self.window_align == "centre":
            return self.amp_time - 0.5 * self.window, self.amp_time + 0.5 * self.window
        return self.amp_time - self.window, self.amp_time.copy()


# -- readers -------------------------------------------------------------------------------
def _json_error_line(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def read_tg_json(path: str | Path) -> TimegrapherRecording:
    """Read tg's JSON dump (see the module docstring).

    Raises
    ------
    DataError
        Not JSON or truncated (naming line and column), ``NaN``/``Infinity`` literals,
        missing keys, values of the wrong type, non-positive sample rate, bph or lift angle,
        negative amplitudes, beat or reading times that do not increase, arrays of unequal
        length.
    """
    p = Path(path)
    where = str(path)
    kind = file_kind(p)
    if kind == "binary":
        refuse_binary(p.read_bytes()[:512], where, "a JSON timegrapher dump")
    if kind == "empty":
        raise DataError("empty file (no JSON object)", where)
    raw = p.read_bytes()
    text = raw.decode("utf-8").lstrip("\ufeff")
    if kind != "json":
        raise DataError("not a JSON file (a CSV table? read per-beat timegrapher CSVs with read_timegrapher_csv)",
                        f"{where}:1")
    bad_const = re.search(r"(?<![\w\"])(NaN|-?Infinity)(?![\w\"])", text)
    if bad_const:
        raise DataError(f"{bad_const.group(1)} is not a number JSON allows",
                        f"{where}:{_json_error_line(text, bad_const.start())}")
    try:
        doc = json.loads(text, parse_float=_finite_number, parse_int=_finite_number)
    except json.JSONDecodeError as exc:
        hint = " (the file is truncated)" if exc.pos >= len(text.rstrip()) else ""
        raise DataError(f"invalid JSON: {exc.msg} at column {exc.colno}{hint}", f"{where}:{exc.lineno}") from None
    except _OutOfRange as exc:
        raise DataError(f"number {exc} is out of range", where) from None
    except RecursionError:
        raise DataError("JSON nested too deeply to be a timegrapher dump", where) from None
    if not isinstance(doc, dict):
        raise DataError(f"expected a JSON object at the top, got {type(doc).__name__}", where)

    def get(obj, dotted: str):
        cur = obj
        for part in dotted.split("."):
            if not isinstance(cur, dict) or part not in cur:
                raise DataError(f"missing key {dotted!r}", where)
            cur = cur[part]
        return cur

    def number(dotted: str, *, positive: bool = True) -> float:
        v = get(doc, dotted)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise DataError(f"expected a number, got {v!r}", f"{where} [{dotted}]")
        if positive and not v > 0:
            raise DataError(f"value {v!r} must be positive", f"{where} [{dotted}]")
        return float(v)

    def numbers(dotted: str, *, integer: bool = False, nonneg: bool = True, increasing: bool = False) -> np.ndarray:
        v = get(doc, dotted)
        if not isinstance(v, list):
            raise DataError(f"expected a list of numbers, got {type(v).__name__}", f"{where} [{dotted}]")
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or (integer and not isinstance(x, int)):
                raise DataError(f"expected {'a whole number' if integer else 'a number'}, got {x!r}",
                                f"{where} [{dotted}[{i}]]")
            if nonneg and x < 0:
                raise DataError(f"value {x!r} must not be negative", f"{where} [{dotted}[{i}]]")
        arr = np.array(v, dtype=float)
        if increasing:
            bad = np.flatnonzero(np.diff(arr) <= 0)
            if bad.size:
                i = int(bad[0]) + 1
                raise DataError(f"times must increase: {v[i - 1]!r} then {v[i]!r}", f"{where} [{dotted}[{i}]]")
        return arr

    sr = number("sample_rate")
    bph = number("bph")
    if bph != int(bph):
        raise DataError(f"bph must be a whole number, got {bph!r}", f"{where} [bph]")
    beats = numbers("beats.times", integer=True, increasing=True)
    tictoc = get(doc, "beats.tictoc")
    if not isinstance(tictoc, list) or not all(isinstance(x, (bool, int)) for x in tictoc):
        raise DataError("expected a list of true/false", f"{where} [beats.tictoc]")
    if len(tictoc) != beats.size:
        raise DataError(f"{len(tictoc)} tictoc flags for {beats.size} beats", f"{where} [beats.tictoc]")
    if "amplitude" in doc and doc["amplitude"] is None:  # tg's dump_to_json writes null without an amplitude
        la, amp_t, values = math.nan, np.zeros(0), np.zeros(0)
    else:
        la = number("amplitude.liftangle")
        if not 10.0 <= la <= 90.0:
            raise DataError(f"lift angle {la!r} deg lies outside tg's 10-90 deg", f"{where} [amplitude.liftangle]")
        amp_t = numbers("amplitude.times", increasing=True)
        values = numbers("amplitude.values")
    if values.size != amp_t.size:
        raise DataError(f"{values.size} amplitude values for {amp_t.size} times", f"{where} [amplitude.values]")
    zero = np.flatnonzero(values == 0)
    if zero.size:
        raise DataError("amplitude fraction 0 (tg's 'not available') must be left out, not stored",
                        f"{where} [amplitude.values[{int(zero[0])}]]")
    if beats.size < 2:
        raise DataError(f"need at least 2 beats, got {beats.size}", f"{where} [beats.times]")
    span = beats[-1] - beats[0]
    outside = np.flatnonzero((amp_t < beats[0] - span) | (amp_t > beats[-1] + span))
    if outside.size:  # a reading is an average over the beats around it: it cannot lie far beyond them
        i = int(outside[0])
        raise DataError(f"amplitude reading at sample {amp_t[i]:.17g} lies far outside the beats (samples "
                        f"{beats[0]:.17g} to {beats[-1]:.17g})", f"{where} [amplitude.times[{i}]]")
    extra = doc.get("escfit", {})
    if not isinstance(extra, dict):
        raise DataError("expected an object", f"{where} [escfit]")
    window = TG_WINDOW_S
    release = math.nan
    if "window_s" in extra:
        window = number("escfit.window_s")
    if "release_sample" in extra:
        release = number("escfit.release_sample", positive=False) / sr
    meta = {k: str(v) for k, v in extra.items()}
    if "tg-timer-version" in doc:
        meta["tg-timer-version"] = str(doc["tg-timer-version"])
    return TimegrapherRecording(beats / sr, np.array(tictoc, dtype=bool), amp_t / sr, values * la, math.radians(la),
                                int(bph), window, "centre", 0.0, TG_RANGE_DEG, False, release, None, None, sr,
                                "tg-json", where, hashlib.sha256(raw).hexdigest(), meta)


def _meta_float(meta: dict, key: str, where: str, default: float | None = None, positive: bool = True) -> float:
    if key not in meta:
        if default is None:
            raise DataError(f"missing metadata line '# {key}: ...'", where)
        return default
    try:
        v = float(meta[key])
    except ValueError:
        raise DataError(f"metadata {key} must be a number, got {meta[key]!r}", f"{where} [{key}]") from None
    if not math.isfinite(v) or (positive and not v > 0):
        raise DataError(f"metadata {key} must be a {'positive ' if positive else ''}finite number, got {meta[key]!r}",
                        f"{where} [{key}]")
    return v


def read_timegrapher_csv(path: str | Path) -> TimegrapherRecording:
    """Read a per-beat timegrapher CSV (see the module docstring).

    Raises
    ------
    DataError
        JSON, binary or empty files, missing or unknown columns, missing metadata, text or
        non-finite numbers, negative amplitudes or beat errors, times that do not increase.
    """
    refuse_unless_csv(path, "timegrapher beats")
    t = canonical_header(read_table(path))
    where = t.path
    missing = [c for c in ("time_s", "amplitude_deg") if c not in t.header]
    if missing:
        raise DataError(f"missing column(s) {missing}{did_you_mean(t.header)}; a timegrapher CSV has "
                        f"{list(CSV_COLUMNS)}", where)
    unknown = [c for c in t.header if c not in CSV_COLUMNS]
    if unknown:
        raise DataError(f"unknown column(s) {unknown}{did_you_mean(unknown)}; known: {list(CSV_COLUMNS)}", where)
    time = np.array(t.floats("time_s"))
    bad = np.flatnonzero(np.diff(time) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        col = t.header.index("time_s")
        raise DataError(f"beat times must increase: {t.rows[i - 1][col]} then {t.rows[i][col]}",
                        f"{where}:{t.lines[i]} [time_s]")

    def optional(col: str, nonneg: bool) -> np.ndarray | None:
        if col not in t.header:
            return None
        out = np.full(len(t.rows), np.nan)
        for k, (line, text) in enumerate(zip(t.lines, t.column(col))):
            if text in _BLANK:
                continue
            try:
                v = float(text)
            except ValueError:
                raise DataError(f"expected a number (or empty / --- for no reading), got {text!r}",
                                f"{where}:{line} [{col}]") from None
            if not math.isfinite(v):
                raise DataError(f"value {text!r} is not a finite number", f"{where}:{line} [{col}]")
            if nonneg and v < 0:
                raise DataError(f"value {text!r} must not be negative", f"{where}:{line} [{col}]")
            out[k] = v
        return out

    amp = optional("amplitude_deg", True)
    rate = optional("rate_s_per_day", False)
    be = optional("beat_error_ms", True)
    la = _meta_float(t.meta, "lift_angle_deg", where)
    if not 10.0 <= la <= 90.0:
        raise DataError(f"lift angle {la!r} deg lies outside 10-90 deg", f"{where} [lift_angle_deg]")
    bph = _meta_float(t.meta, "bph", where)
    if bph != int(bph):
        raise DataError(f"bph must be a whole number, got {t.meta['bph']!r}", f"{where} [bph]")
    window = _meta_float(t.meta, "window_s", where, TG_WINDOW_S)
    resolution = _meta_float(t.meta, "amplitude_resolution_deg", where, 1.0, positive=False)
    release = _meta_float(t.meta, "release_s", where, math.nan, positive=False) if "release_s" in t.meta else math.nan
    lo, hi = TG_RANGE_DEG
    if "amplitude_range_deg" in t.meta:
        try:
            lo, hi = (float(x) for x in t.meta["amplitude_range_deg"].split(","))
        except ValueError:
            raise DataError(f"amplitude_range_deg must be 'low, high', got {t.meta['amplitude_range_deg']!r}",
                            f"{where} [amplitude_range_deg]") from None
        if not (0.0 <= lo < hi and math.isfinite(lo) and not math.isnan(hi)):
            raise DataError(f"amplitude_range_deg must be 'low, high' with 0 <= low < high, got "
                            f"{t.meta['amplitude_range_deg']!r}", f"{where} [amplitude_range_deg]")
    tictoc = np.arange(time.size) % 2 == 0
    return TimegrapherRecording(time, tictoc, time.copy(), amp, math.radians(la), int(bph), window, "end", resolution,
                                (lo, hi), True, release, rate, be, math.nan, "csv", where, t.sha256, dict(t.meta))


def beat_swings(rec: TimegrapherRecording) -> np.ndarray:
    """Half swing (1 = the one starting at the release) in which each beat was heard.

    The first beat's half swing follows from the release instant and the median beat
    interval; later ones from the intervals between beats, rounded to whole beats, so a
    missed beat (two tics in a row in tg's ``tictoc``) skips an index.

    Raises
    ------
    DataError
        No release instant, or a beat before it.
    """
    if not math.isfinite(rec.release_s):
        meta = getattr(rec, "meta", None) or {}
        if "amplitude_drift_deg" in meta:  # a timegrapher program's log: the watch was running when it began
            amp = np.asarray(rec.amp_deg, float)
            amp = amp[np.isfinite(amp)]
            shown = f"amplitude {np.median(amp):.0f} deg, " if amp.size else ""
            steady = f"; {meta['steady_state_warning']}" if meta.get("steady_state") == "true" else ""
            raise DataError(f"the log begins with the watch already running ({shown}drifting "
                            f"{meta['amplitude_drift_deg']} deg over the log) and no release: a fit starts its model at a release, so log the watch from a "
                            f"release (a free decay, or a run-down from a stop){steady}", rec.source)
        raise DataError("the recording does not say when the balance was released (release_s / escfit.release_sample);"
                        " the beats cannot be aligned with the scene's release", rec.source)
    t = rec.beat_time
    if t[0] <= rec.release_s:
        raise DataError(f"first beat at {t[0]:.6g} s is not after the release at {rec.release_s:.6g} s", rec.source)
    d = np.diff(t)
    typical = float(np.median(d[: min(d.size, 20)])) if d.size else 1.0
    out = np.empty(t.size, dtype=np.int64)
    first = (t[0] - rec.release_s) / typical + 0.5
    if not first <= MAX_HALF_SWINGS:
        raise DataError(f"the release at {rec.release_s:.6g} s lies {first:.3g} beats before the first beat: more than "
                        f"{MAX_HALF_SWINGS:,} half swings would have to be simulated; check release_s / release_sample",
                        rec.source)
    out[0] = max(1, int(round(first)))
    recent = [typical]  # the beat interval drifts with the amplitude: follow it over the last ten beats
    for i, di in enumerate(d):
        k = di / float(np.median(recent[-10:]))
        if not out[i] + k <= MAX_HALF_SWINGS:
            raise DataError(f"beat {i + 2} at {t[i + 1]:.6g} s lies beyond {MAX_HALF_SWINGS:,} half swings after the "
                            "release; check the beat times", rec.source)
        k = max(1, int(round(k)))
        out[i + 1] = out[i] + k
        recent.append(di / k)
    return out


# -- writers -------------------------------------------------------------------------------
def write_tg_json(path: str | Path, rec: TimegrapherRecording, *, extra: dict | None = None) -> None:
    """Write ``rec`` as a tg-style JSON dump (times as sample indices)."""
    sr = rec.sample_rate
    if not math.isfinite(sr):
        raise DataError("a tg JSON dump needs the audio sample rate", str(path))
    keep = np.isfinite(rec.amp_deg)
    la = math.degrees(rec.lift_angle)
    esc = {"window_s": rec.window}
    if math.isfinite(rec.release_s):
        esc["release_sample"] = int(round(rec.release_s * sr))
    esc.update({k: v for k, v in rec.meta.items() if k not in ("window_s", "release_sample", "tg-timer-version")})
    esc.update(extra or {})
    doc = {
        "sample_rate": int(sr) if sr == int(sr) else sr,
        "bph": int(rec.bph),
        "beats": {"times": [int(round(x * sr)) for x in rec.beat_time], "tictoc": [bool(x) for x in rec.tictoc]},
        "amplitude": {"liftangle": la, "times": [int(round(x * sr)) for x in rec.amp_time[keep]],
                      "values": [float(f"{v / la:.7g}") for v in rec.amp_deg[keep]]},
        "escfit": esc,
    }
    Path(path).write_text(json.dumps(doc, separators=(",", ":")) + "\n")


def write_timegrapher_csv(path: str | Path, rec: TimegrapherRecording, *, comments: list[str] | None = None) -> None:
    """Write ``rec`` as a per-beat CSV (one row per beat, readings at the beats); its
    metadata goes into ``# key: value`` lines."""
    if rec.amp_time.size != rec.beat_time.size:
        raise DataError("a per-beat CSV needs one amplitude reading per beat", str(path))
    reserved = {"lift_angle_deg", "bph", "window_s", "amplitude_resolution_deg", "release_s", "amplitude_range_deg"}
    lines = [f"# {c}" for c in (comments or [])]
    lines += [f"# {k}: {v}" for k, v in rec.meta.items() if " " not in k and k not in reserved]
    lines += [f"# lift_angle_deg: {math.degrees(rec.lift_angle):.10g}", f"# bph: {rec.bph}",
              f"# window_s: {rec.window:g}", f"# amplitude_resolution_deg: {rec.resolution_deg:g}"]
    if math.isfinite(rec.release_s):
        lines.append(f"# release_s: {rec.release_s!r}")
    lines.append(",".join(CSV_COLUMNS))

    def fmt(v: float, spec: str) -> str:
        return "" if not math.isfinite(v) else format(v, spec)

    rate = rec.rate if rec.rate is not None else np.full(rec.beat_time.size, np.nan)
    be = rec.beat_error if rec.beat_error is not None else np.full(rec.beat_time.size, np.nan)
    for t, r, a, b in zip(rec.beat_time, rate, rec.amp_deg, be):
        lines.append(f"{t:.6f},{fmt(r, '.1f')},{fmt(a, '.0f') if rec.resolution_deg >= 1 else fmt(a, '.3f')},"
                     f"{fmt(b, '.1f')}")
    Path(path).write_text("\n".join(lines) + "\n")
