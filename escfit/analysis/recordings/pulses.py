"""Photo-cell pulse trains of a notched balance (Monday's recorder chart).

The balance carries ``N`` equal notches (default 60, i.e. 6 deg) and a photo-cell gives a
pulse each time a tooth edge passes it.  The tooth at the rest position (``theta = 0``) is
short and gives a distinct ``zero`` pulse; all others give ``notch`` pulses.  The cell cannot
tell the direction of motion, but the sequence can: between two passages of the rest
position the balance runs out to a turning point and back, so the notch pulses between two
consecutive zero pulses come in a mirrored pair of runs, ``n`` out and ``n`` back, where
``n = floor(A / notch)`` is the notch count of that turning point.

CSV format
----------
Columns ``time_s`` (or ``time_<unit>`` in any time unit pint knows) and ``kind`` (``notch`` or
``zero``), one row per pulse in time order.  Metadata lines: ``# notches: 60`` (notches per
turn; or ``# notch_deg: 6``), optional ``# release_s: 0.0`` (the release instant on the
chart's clock).  The chart must start before the release; pulses after the last zero pulse
(an unfinished excursion) are not used.  Amplitudes must stay below one turn, and the timing
noise well below the pulse spacing at the rest position (``notch / (omega0 * A)``), or zero
pulses swap places with their neighbours and the pairs no longer match.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.units import registry
from ...core.csvtable import read_table
from .sniff import canonical_header, did_you_mean, refuse_unless_csv, release_from_meta
from .unit_curve import UnitCurve

__all__ = ["PulseTrain", "PulseAssignment", "read_pulses", "write_pulses", "assign_pulses", "pulses_to_unit_curve"]

KINDS = ("notch", "zero")


@dataclass
class PulseTrain:
    """Pulses of a notched balance passing a photo-cell.

    Attributes
    ----------
    time : ndarray
        Pulse times on the chart's clock, s (non-decreasing).
    zero : ndarray of bool
        Whether each pulse came from the short tooth at the rest position.
    notches : int
        Notches per turn; the notch angle is ``2*pi/notches`` rad.
    release_s : float
        Release instant on the chart's clock, s (``nan`` when the file does not say).
    lines : ndarray of int
        File line of each pulse (0 for synthetic trains), for messages.
    source, sha256, meta
        File name, content hash and ``# key: value`` metadata.
    """

    time: np.ndarray
    zero: np.ndarray
    notches: int = 60
    release_s: float = math.nan
    lines: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    source: str = ""
    sha256: str = ""
    meta: dict = field(default_factory=dict)
    kind = "pulses"

    @property
    def notch(self) -> float:
        """Notch angle, rad."""
        return 2.0 * math.pi / self.notches

    def where(self, i: int) -> str:
        """``file:line`` of pulse ``i`` for messages."""
        line = int(self.lines[i]) if self.lines.size > i else 0
        return f"{self.source}:{line}" if line else f"{self.source} [pulse {i}]"


@dataclass
class PulseAssignment:
    """Which half swing and which notch each used pulse belongs to.

    Attributes
    ----------
    index : ndarray of int
        Row of each used pulse in the train.
    swing : ndarray of int
        Half swing of each pulse (1 = the half swing that starts at the release).
    tooth : ndarray of int
        Notch position in the swing frame of that half swing: the pulse is the crossing of
        ``x = tooth * notch`` (``x = s*theta``, running from ``-A`` to ``+A``); 0 is the zero
        tooth.
    counts : ndarray of int
        Notch count of each turning point: ``counts[0]`` the release, ``counts[k]`` the end of
        half swing ``k``.
    turn_time : ndarray
        Estimated time of each of those turning points, s (midway between the two crossings
        of the outermost notch; ``nan`` for the release unless the file gives it).
    """

    index: np.ndarray
    swing: np.ndarray
    tooth: np.ndarray
    counts: np.ndarray
    turn_time: np.ndarray


def _notches_from_meta(meta: dict, where: str, notches: int | None) -> int:
    if notches is not None:
        n = notches
    elif "notches" in meta:
        try:
            n = float(meta["notches"])
        except ValueError:
            raise DataError(f"notches must be a whole number, got {meta['notches']!r}", f"{where} [notches]") from None
    elif "notch_deg" in meta:
        try:
            d = float(meta["notch_deg"])
        except ValueError:
            raise DataError(f"notch_deg must be a number, got {meta['notch_deg']!r}", f"{where} [notch_deg]") from None
        if not d > 0:
            raise DataError(f"notch_deg must be positive, got {meta['notch_deg']!r}", f"{where} [notch_deg]")
        n = 360.0 / d
        if abs(n - round(n)) > 1e-9:
            raise DataError(f"notch_deg {meta['notch_deg']!r} does not divide a turn into whole notches",
                            f"{where} [notch_deg]")
    else:
        n = 60
    if n != int(n) or not 4 <= n <= 100000:
        raise DataError(f"notches per turn must be a whole number from 4 to 100000, got {n!r}", f"{where} [notches]")
    return int(n)


def read_pulses(path: str | Path, *, notches: int | None = None) -> PulseTrain:
    """Read a pulse-train CSV (see the module docstring).

    Parameters
    ----------
    path
        The file.
    notches
        Notches per turn, overriding the file's metadata (default 60).

    Raises
    ------
    DataError
        JSON, binary or empty files, missing or unknown columns, unknown time units, text or
        non-finite times, times that decrease, unknown pulse kinds, bad notch metadata.
    """
    refuse_unless_csv(path, "a pulse train")
    t = canonical_header(read_table(path))
    where = t.path
    tcols = [c for c in t.header if c.startswith("time_")]
    if len(tcols) != 1 or "kind" not in t.header:
        raise DataError(f"need columns time_s (or time_<unit>) and kind, header has {t.header}"
                        f"{did_you_mean(t.header)}", where)
    unknown = [c for c in t.header if c not in (tcols[0], "kind")]
    if unknown:
        raise DataError(f"unknown column(s) {unknown}{did_you_mean(unknown)}; a pulse train has time_s, kind",
                        where)
    unit = tcols[0][len("time_"):]
    try:
        factor = float(registry().Quantity(1.0, unit).to("s").magnitude)
    except Exception:
        raise DataError(f"unknown time unit {unit!r} in column {tcols[0]!r}", where) from None
    time = np.array(t.floats(tcols[0])) * factor
    back = np.flatnonzero(np.diff(time) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise DataError(f"pulse times must not decrease: {t.rows[i - 1][t.header.index(tcols[0])]} then "
                        f"{t.rows[i][t.header.index(tcols[0])]}", f"{where}:{t.lines[i]} [{tcols[0]}]")
    kinds = t.column("kind")
    for line, k in zip(t.lines, kinds):
        if k.lower() not in KINDS:
            raise DataError(f"pulse kind must be 'notch' or 'zero', got {k!r}", f"{where}:{line} [kind]")
    zero = np.array([k.lower() == "zero" for k in kinds])
    n = _notches_from_meta(t.meta, where, notches)
    release = release_from_meta(t.meta, where)
    return PulseTrain(time, zero, n, release, np.array(t.lines, dtype=np.int64), where, t.sha256, dict(t.meta))


def write_pulses(path: str | Path, train: PulseTrain, *, comments: list[str] | None = None) -> None:
    """Write ``train`` in the CSV format :func:`read_pulses` reads (times to 1 ns); its
    metadata (provenance of synthetic trains) goes into ``# key: value`` lines."""
    lines = [f"# {c}" for c in (comments or [])]
    lines += [f"# {k}: {v}" for k, v in train.meta.items() if " " not in k and k not in ("notches", "notch_deg",
                                                                                         "release_s")]
    lines.append(f"# notches: {train.notches}")
    if math.isfinite(train.release_s):
        lines.append(f"# release_s: {train.release_s!r}")
    lines.append("time_s,kind")
    lines += [f"{t:.9f},{'zero' if z else 'notch'}" for t, z in zip(train.time, train.zero)]
    Path(path).write_text("\n".join(lines) + "\n")


def _pulse_name(train: PulseTrain, i: int) -> str:
    return f"line {int(train.lines[i])}" if train.lines.size > i and train.lines[i] else f"pulse {i}"


def assign_pulses(train: PulseTrain) -> PulseAssignment:
    """Reconstruct half swings and notch positions from the pulse sequence.

    Zero pulse ``k`` (1-based) is the passage of the rest position in half swing ``k``.  The
    notch pulses before the first zero pulse belong to half swing 1 (from the release, teeth
    ``-n0 .. -1``).  The ``2n`` notch pulses between zero pulses ``k`` and ``k+1`` are ``n`` out
    (half swing ``k``, teeth ``1 .. n``) and ``n`` back (half swing ``k+1``, teeth ``-n .. -1``).

    Raises
    ------
    DataError
        No zero pulse, an odd number of notch pulses between two zero pulses (a missing or
        extra pulse), or an excursion of a full turn or more.
    """
    z = np.flatnonzero(train.zero)
    if z.size == 0:
        raise DataError("no zero pulse: the balance never passed the rest position (or the short tooth was not seen)",
                        train.source)
    idx, swing, tooth = [], [], []
    n0 = int(z[0])
    idx += list(range(n0))
    swing += [1] * n0
    tooth += list(range(-n0, 0))
    counts = [n0]
    turn_time = [train.release_s]
    for k in range(z.size - 1):
        a, b = int(z[k]), int(z[k + 1])
        c = b - a - 1
        if c % 2:
            raise DataError(f"{c} notch pulses between the zero pulses of {_pulse_name(train, a)} and "
                            f"{_pulse_name(train, b)}: out and back must pair up (a pulse is missing, extra or out of "
                            "order)", train.where(b))
        n = c // 2
        if n >= train.notches:
            raise DataError(f"{n} notches out from the rest position: the balance turned a full turn or more, which "
                            "the zero tooth cannot resolve", train.where(b))
        idx.append(a)
        swing.append(k + 1)
        tooth.append(0)
        idx += list(range(a + 1, b))
        swing += [k + 1] * n + [k + 2] * n
        tooth += list(range(1, n + 1)) + list(range(-n, 0))
        counts.append(n)
        if n:
            turn_time.append(0.5 * (train.time[a + n] + train.time[a + n + 1]))
        else:
            turn_time.append(0.5 * (train.time[a] + train.time[b]))
    last = int(z[-1])
    idx.append(last)
    swing.append(z.size)
    tooth.append(0)
    return PulseAssignment(np.array(idx, dtype=np.int64), np.array(swing, dtype=np.int64),
                           np.array(tooth, dtype=np.int64), np.array(counts, dtype=np.int64), np.array(turn_time))


def pulses_to_unit_curve(train: PulseTrain, *, include_release: bool = True) -> UnitCurve:
    """Notch counts of every turning point, as a unit curve (``kind = "notches"``).

    Parameters
    ----------
    train
        The pulse train.
    include_release
        Also give the release count (notch pulses before the first zero pulse) as swing 0.

    Returns
    -------
    UnitCurve
        Swing ``k`` holds ``floor(A_k / notch)`` and the estimated time of the turning point.
    """
    a = assign_pulses(train)
    k = np.arange(a.counts.size, dtype=np.int64)
    counts = a.counts.astype(float)
    times = a.turn_time
    if not include_release:
        k, counts, times = k[1:], counts[1:], times[1:]
    meta = dict(train.meta)
    meta["derived_from"] = "pulse train (notch pulses between zero pulses)"
    return UnitCurve(k, counts, "notches", train.notch, unit=np.full(k.size, "", dtype=str), time=times,
                     source=train.source, sha256=train.sha256, meta=meta)
