"""The user's window on a record: ``[recording] start``, ``stop`` and ``release`` on the record's clock.

A leaf module (it imports neither a reader nor the analysis): the readers resolve the keys
against the clock of the file they read (:func:`resolve_window`, called once, by
:func:`~escfit.analysis.recordings.rawsteps.build_series`, for every format that yields a
sampled series) and the analysis takes the result as an explicit argument
(:class:`RecordWindow`, see :func:`~escfit.analysis.recordings.turning_points.reduce_series`).

The clock rule
--------------
A time the user gives is read on the record's own clock **measured from its first sample**:
``start = "13 s"`` is 13 s after the first sample, whatever the file's clock reads there
(0 s, 5 s, or 1.407e9 s of an epoch clock).  Two ways to name the file's own clock instead:

- ``"abs 1407000013 s"`` (the prefix ``abs``): always the file's clock reading;
- a bare value that cannot be a time after the first sample (it exceeds the record's span)
  but lies within the file's clock range, first to last sample, is taken as such a reading
  (``start = 1407000013.0`` on an epoch clock).  When a value fits both (a clock that does not
  start at 0 and a value inside both ranges), the time after the first sample wins and a note
  says so, naming the ``abs`` form.

A value that lies beyond the record on both readings is refused in one line naming the key,
the value and the record's span.  The analysis and its notes count time from the first sample
too (:func:`~escfit.analysis.recordings.turning_points.reduce_series` works on that clock), so a
time read off a note can be written back as a key unchanged.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...core.errors import DataError

__all__ = ["Instant", "RecordWindow", "parse_instant", "resolve_window", "window_of", "WINDOW_KEYS", "ABS_PREFIX"]

WINDOW_KEYS = ("start", "stop", "release")
ABS_PREFIX = "abs"
_ABS = re.compile(rf"\s*{ABS_PREFIX}\b\s*", re.IGNORECASE)


@dataclass(frozen=True)
class Instant:
    """A time the user gave for a window key.

    Attributes
    ----------
    seconds : float
        The value, s.
    absolute : bool
        ``True``: a reading of the file's own clock (written ``"abs <time>"``); ``False``: a
        bare value, read by the clock rule of the module docstring.
    text : str
        The value as given (for messages).
    """

    seconds: float
    absolute: bool = False
    text: str = field(default="", compare=False)

    def __float__(self) -> float:
        return float(self.seconds)

    def shown(self) -> str:
        return self.text or f"{self.seconds:g} s"


def parse_instant(value: Any, where: str, quantity) -> Instant:
    """A window key's value: a number (s), ``"13 s"``, ``"2 min"`` or ``"abs 1407000013 s"``.

    ``quantity(text, where)`` converts a number with a unit to seconds (the spec's parser).
    """
    if isinstance(value, Instant):
        return value
    text = value if isinstance(value, str) else repr(value)
    absolute = False
    if isinstance(value, str):
        m = _ABS.match(value)
        if m:
            absolute, value = True, value[m.end():]
    return Instant(float(quantity(value, where)), absolute, text.strip())


@dataclass(frozen=True)
class RecordWindow:
    """The window the user set, resolved on a series' clock (s); ``None``: not set.

    Attributes
    ----------
    origin : float
        The file's first sample on this clock (the zero of the keys and of the notes).
    start, stop : float or None
        The kept stretch (the samples outside it are already gone).
    release : float or None
        Where the model is released: the free decay starts there.
    notes : tuple of str
        How the keys were read (the clock rule's choices).
    end : float or None
        The file's last sample on this clock (the samples after ``stop`` are gone; None: not known).
    """

    origin: float = 0.0
    start: float | None = None
    stop: float | None = None
    release: float | None = None
    notes: tuple = ()
    end: float | None = None

    @property
    def given(self) -> bool:
        """Whether the user fixed where the free decay starts (``start`` or ``release``)."""
        return self.start is not None or self.release is not None

    def shifted(self, dt: float) -> RecordWindow:
        """The same window on a clock ``dt`` seconds later (every instant plus ``dt``)."""
        move = lambda v: None if v is None else v + dt  # noqa: E731
        return replace(self, origin=self.origin + dt, start=move(self.start), stop=move(self.stop),
                       release=move(self.release), end=move(self.end))

    def after_first(self, t: float) -> float:
        """``t`` as a time after the first sample, s."""
        return t - self.origin


def _on_clock(key: str, value: Instant, first: float, lo: float, hi: float, where: str, notes: list) -> float:
    """``value`` on the file's clock (see the module docstring's rule), or a one-line refusal.

    ``first`` is the first sample's time, ``lo``/``hi`` the smallest and largest time, s.
    """
    span = hi - first
    slack = 1e-9 * max(1.0, abs(lo), abs(hi))
    v = value.seconds
    inside = lo - slack <= v <= hi + slack
    if value.absolute:
        if inside:
            return v
    elif -slack <= v <= span + slack:
        if first != 0.0 and inside:
            notes.append(f"[recording] {key} = {value.shown()} read as {v:g} s after the first sample ({first + v:.10g} "
                         f"s on the file's clock); write \"{ABS_PREFIX} {v:g} s\" for the file's own clock")
        return first + v
    elif inside:
        return v
    clock = "" if first == 0.0 else f"; the file's clock reads {lo:.10g} to {hi:.10g} s"
    raise DataError(f"[recording] {key} = {value.shown()} lies beyond the record, which spans 0 to {span:.6g} s after "
                    f"its first sample{clock}", f"{where} [recording].{key}")


def resolve_window(spec, time: np.ndarray, where: str) -> tuple[RecordWindow, list[str]]:
    """The spec's ``start``, ``stop`` and ``release`` on the file's clock ``time`` (s, as read).

    The first sample is ``time[0]`` (the first row); the clock's range is the smallest to the
    largest time.  Returns the window and the notes the clock rule asks for.

    Raises
    ------
    DataError
        A value beyond the record; ``release`` outside ``start..stop``; ``stop`` not after ``start``.
    """
    time = np.asarray(time, float)
    notes: list[str] = []
    if not time.size:
        return RecordWindow(), notes
    first, lo, hi = float(time[0]), float(np.min(time)), float(np.max(time))
    last = float(time[-1])
    got = {}
    for key in WINDOW_KEYS:
        value = getattr(spec, key, None)
        if value is not None:
            got[key] = _on_clock(key, value, first, lo, hi, where, notes)
    start, stop, release = got.get("start"), got.get("stop"), got.get("release")
    if start is not None and stop is not None and not start < stop:
        raise DataError(f"[recording] start = {spec.start.shown()} must come before stop = {spec.stop.shown()}",
                        f"{where} [recording].stop")
    if release is not None and ((start is not None and release < start) or (stop is not None and release > stop)):
        raise DataError(f"[recording] release = {spec.release.shown()} lies outside the window start..stop",
                        f"{where} [recording].release")
    return RecordWindow(first, start, stop, release, tuple(notes), last), notes


def window_of(series) -> RecordWindow:
    """The series' window (its first sample the origin when the reader set none)."""
    window = getattr(series, "window", None)
    if window is not None:
        return window
    t = np.asarray(series.time, float)
    return RecordWindow(origin=float(t[0]) if t.size else 0.0, end=float(t[-1]) if t.size else None)
