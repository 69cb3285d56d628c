"""A drive recorded beside the swing, and where it was switched off.

A driven-oscillator rig (a Pohl wheel, a torsion pendulum on a motor, a shaker) often logs its
drive in a column of its own beside the oscillator's.  The usual experiment runs the drive for a
while and then switches it off, and the decay after that is the free one.  The swing alone does not
always show the change: a drive away from resonance leaves beats in the swing, and these neither
hold the swing steady nor lift it the way a push does.  The drive's own column shows the change
plainly.  A switched-off drive reads one value, row after row, to the end of the record.

A column beside the signal is taken as a drive switched off at the instant of its last change
when all of the following hold:

- **A drive before.**  In the stretch before it goes flat it changes at almost every row
  (:data:`ACTIVE_SHARE`), at least :data:`MIN_CHANGES` times in all, and it oscillates.  A
  sinusoid explains at least :data:`DRIVE_EXPLAINED` of its variance, over the last
  :data:`SHAPE_ROWS` rows before the flat tail at most (:func:`~escfit.analysis.quantity.swing_shape`).
  A setting, a flag or a counter fails this test, and so does a sensor's noise.
- **Flat after.**  From its last change to the end it holds one value for at least
  :data:`MIN_FLAT_ROWS` rows and :data:`MIN_FLAT_SHARE` of the record.
- **Off, not stalled.**  That value is exactly 0: a drive's voltage, current or speed switched off.
  A logger that stalls repeats its last reading, and a sinusoid's last reading is 0 only by
  chance.  Noise rounded to a coarse step can stop on 0 too, which is why the column must also
  have oscillated.
- **The signal goes on.**  After that instant the signal still swings, by at least
  :data:`STILL_SWINGS` of its range before.  If the signal stopped too, the column is the same
  motion's, not its drive.

A column left empty after the switch-off, rather than reading 0, is not taken for a drive: a
table pads a shorter column the same way.  The free decay cannot start before the instant found.
The user's ``[recording] start`` or ``release`` overrides this choice.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

__all__ = ["SwitchOff", "switched_off", "drive_switched_off"]

ACTIVE_SHARE = 0.5  # share of rows, just before the flat tail, at which an active drive changes
MIN_CHANGES = 20  # changes of the column before its flat tail, at least
MIN_FLAT_ROWS = 20  # rows of the flat tail, at least
MIN_FLAT_SHARE = 0.1  # share of the record's rows in the flat tail, at least
DRIVE_EXPLAINED = 0.8  # share of the column's variance a sinusoid explains before it goes flat, at least
SHAPE_ROWS = 20000  # rows before the flat tail whose shape is measured, at most
STILL_SWINGS = 0.2  # the signal's range after the switch-off, as a share of its range before, at least


@dataclass(frozen=True)
class SwitchOff:
    """A drive column switched off: where, and the evidence.

    Attributes
    ----------
    column : str
        The drive's column, as the file names it.
    time : float
        Time of the first sample at which the column is flat, on the file's clock (s).
    value : float
        The value it holds from there to the end (in the file's units).
    flat_rows : int
        Rows from there to the end.
    frequency : float
        The drive's frequency before, Hz.
    explained : float
        Share of the column's variance a sinusoid of that frequency explains there (0-1).
    active_share : float
        Share of rows at which the column changed in the stretch just before (0-1).
    swing_kept : float
        The signal's range after the switch-off over its range before (dimensionless).
    """

    column: str
    time: float
    value: float
    flat_rows: int
    active_share: float
    swing_kept: float
    frequency: float = float("nan")
    explained: float = float("nan")

    def evidence(self, signal: str, origin: float) -> str:
        """The decision in one sentence, times counted from the file's first sample ``origin`` (s)."""
        return (f"column {self.column!r} oscillates at {self.frequency:.4g} Hz (a sinusoid explains "
                f"{100 * self.explained:.0f} % of it) until t = {self.time - origin:.4g} s and reads {self.value:g} "
                f"at every one of the {self.flat_rows} rows after, while {signal!r} goes on swinging "
                f"({100 * self.swing_kept:.0f} % of its range before): a drive switched off there")


def switched_off(time: np.ndarray, column: np.ndarray, signal: np.ndarray, *, name: str = "") -> SwitchOff | None:
    """The instant ``column`` was switched off as a drive beside ``signal`` (see the module docstring).

    Parameters
    ----------
    time : array
        The rows' times on the file's clock (s), in order.
    column, signal : array
        The candidate drive and the oscillator's signal at those rows (any units). Rows that are not
        finite in either one are ignored.
    name : str
        The column's name, for :attr:`SwitchOff.column`.

    Returns
    -------
    SwitchOff or None
        None when any of the tests fails.
    """
    ok = np.isfinite(time) & np.isfinite(column) & np.isfinite(signal)
    t, v, s = np.asarray(time, float)[ok], np.asarray(column, float)[ok], np.asarray(signal, float)[ok]
    n = v.size
    changes = np.flatnonzero(np.diff(v) != 0.0)
    if changes.size < MIN_CHANGES:
        return None
    first_flat = int(changes[-1]) + 1
    flat_rows = n - first_flat
    if flat_rows < max(MIN_FLAT_ROWS, MIN_FLAT_SHARE * n):
        return None
    recent = np.diff(v[:first_flat + 1])[-max(10, first_flat // 4):]
    active = float(np.mean(recent != 0.0))
    if active < ACTIVE_SHARE:
        return None
    level = float(v[first_flat])
    if level != 0.0:
        return None
    before, after = np.ptp(s[:first_flat]), np.ptp(s[first_flat:])
    kept = float(after / before) if before > 0.0 else 0.0
    if kept < STILL_SWINGS:
        return None
    from .quantity import swing_shape

    lo = max(0, first_flat - SHAPE_ROWS)
    shape = swing_shape(t[lo:first_flat], v[lo:first_flat])
    if not shape.explained >= DRIVE_EXPLAINED:
        return None
    return SwitchOff(name, float(t[first_flat]), level, flat_rows, active, kept, float(shape.frequency),
                     float(shape.explained))


def drive_switched_off(time: np.ndarray, columns: Mapping[str, np.ndarray], signal: np.ndarray) -> SwitchOff | None:
    """The latest switch-off among ``columns`` (name -> values at the rows of ``time``), or None.

    Where several columns switch off, the free decay starts after the last of them.
    """
    found = [f for f in (switched_off(time, v, signal, name=k) for k, v in columns.items()) if f is not None]
    return max(found, key=lambda f: f.time) if found else None
