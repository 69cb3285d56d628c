"""The records the balance kernels take: coefficients, run options and per-half-swing results.

Every compiled kernel receives one coefficient record ``k`` (a row of a numpy structured array,
read in numba as ``k.c``, ``k.w_lo[:k.n_windows]`` ...) with every number of one parameter set,
besides its run options and its output arrays; the batch path passes an array of the same
records.  The record's fields are the oscillator's (:data:`OSCILLATOR_SLOTS`) followed by the
:class:`~escfit.balance.effects.base.Slot` declarations of every registered effect, in registry
order, so an effect's numbers reach every solver without being listed anywhere else.  A field
an effect leaves alone keeps its default, which makes the effect absent (zero drag, no banking
pins ...).

Every field is 8 bytes wide and the record is packed, so a record array views as a table of
float64 for the finiteness checks of :mod:`escfit.balance.system` (one numpy operation however
many fields there are).  Passing a structured array to a compiled function costs less than the
positional arrays it replaces (``benchmarks/kernels.py``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .effects import EFFECTS
from .effects.base import Slot
from .effects.hairspring import MAX_PIECES

__all__ = ["COEFFICIENTS", "SLOTS", "RUN", "HALF_SWING", "MAX_PIECES", "ROWS_FULL", "blank", "run_options",
           "half_swings", "columns", "with_rows"]

#: What a kernel returns as its status when the dense solution's rows ran out of room: the front
#: end runs it again with more (:func:`with_rows`).  Not a :class:`~escfit.core.status.Status`:
#: no caller sees it.  Kernels never return arrays, whose conversion to Python objects could turn
#: a signal arriving then (Ctrl-C, SIGTERM) into a ``SystemError``.
ROWS_FULL = -1

#: The oscillator's own fields: release, reference frequency and the restoring torque.
OSCILLATOR_SLOTS = (
    Slot("theta0", math.nan, "theta0", "rad", "release angle"),
    Slot("v0", 0.0, "v0", "rad/s", "angular velocity at the release (0: released at rest)"),
    Slot("omega0", 1.0, "omega0", "rad/s", "reference natural frequency (the rate's)"),
    Slot("pendulum", 0, "pendulum", "", "1: restoring acceleration omega0**2 * sin(theta) (gravity)", dtype="i8"),
    Slot("smooth", 0, "smooth torques", "", "1: an effect adds a smooth torque (escfit.balance.acceleration)", dtype="i8"),
    Slot("n_pieces", 1, "pieces", "", "pieces of the restoring torque", dtype="i8"),
    Slot("sp_bp", 0.0, "hairspring angles", "rad", "angles between the restoring torque's pieces (ascending)",
         size=MAX_PIECES - 1, count="n_pieces", extra=-1),
    Slot("sp_w2", 1.0, "hairspring stiffness", "1/s**2", "stiffness per inertia of each piece", size=MAX_PIECES,
         count="n_pieces"),
    Slot("sp_off", 0.0, "hairspring offsets", "rad/s**2",
         "offsets of each piece: restoring acceleration w2[i]*theta + off[i], continuous, zero at 0",
         size=MAX_PIECES, count="n_pieces"),
)


def _all_slots() -> tuple[Slot, ...]:
    slots = list(OSCILLATOR_SLOTS)
    seen = {s.name for s in slots}
    for key, cls in EFFECTS.items():
        for slot in getattr(cls, "SLOTS", ()):
            if slot.name in seen:
                raise RuntimeError(f"effect {key!r} declares record field {slot.name!r} twice")
            seen.add(slot.name)
            slots.append(slot)
    return tuple(slots)


SLOTS: tuple[Slot, ...] = _all_slots()

#: The coefficient record (packed; every field 8 bytes).
COEFFICIENTS = np.dtype([(s.name, s.dtype, (s.size,)) if s.size else (s.name, s.dtype) for s in SLOTS])


def _prototype() -> np.ndarray:
    proto = np.zeros(1, COEFFICIENTS)
    for s in SLOTS:
        proto[s.name] = s.default
    return proto


#: the defaults as the record's raw 8-byte words (copying those is a memcpy; copying a structured
#: array with subarray fields goes field by field and took 9 us)
_PROTOTYPE = _prototype().view(np.float64)


def blank(n: int) -> np.ndarray:
    """``n`` coefficient records holding every slot's default."""
    k = np.empty(n, COEFFICIENTS)
    k.view(np.float64).reshape(n, _PROTOTYPE.size)[:] = _PROTOTYPE
    return k


#: Run options of a kernel call (each solver reads the ones it takes).
RUN = np.dtype([
    ("n_swings", "i8"),      # half swings wanted
    ("max_segments", "i8"),  # segment budget (located events, exact pieces)
    ("max_steps", "i8"),     # integration-step budget
    ("t_end", "f8"),         # the run may end at the first half swing ending at or after this time (s)
    ("dense", "i8"),         # 1: keep the rows of the dense solution
    ("rtol", "f8"),          # adaptive solvers: relative tolerance
    ("atol_x", "f8"),        # absolute tolerance of theta (rad)
    ("atol_v", "f8"),        # absolute tolerance of omega (rad/s)
    ("h", "f8"),             # fixed-step solvers: the step (s)
    ("mode", "i8"),          # a solver's variant (rk4: 1 steps over the switches)
])


@functools.lru_cache(maxsize=512)
def run_options(n_swings: int, *, max_segments: int = 0, max_steps: int = 0, t_end: float = math.inf,
                dense: bool = False, rtol: float = 0.0, atol_x: float = 0.0, atol_v: float = 0.0,
                h: float = 0.0, mode: int = 0) -> np.ndarray:
    """One :data:`RUN` record (an array of one, which numba receives fastest).

    The same options give the same array (kernels only read it): do not write to it.
    """
    run = np.zeros(1, RUN)
    run[0] = (n_swings, max_segments, max_steps, t_end, int(dense), rtol, atol_x, atol_v, h, mode)
    return run


#: What a kernel writes at the end of each half swing.
HALF_SWING = np.dtype([
    ("amplitude", "f8"),    # |theta| at the turning point or banking impact ending it (rad)
    ("theta_turn", "f8"),   # signed theta there (rad)
    ("half_period", "f8"),  # its duration (s)
    ("time", "f8"),         # time at its end since the release (s)
    ("banked", "i8"),       # 1: it ended on the banking pins
])


def columns(out: np.ndarray, n: int) -> tuple:
    """Copies of the first ``n`` half swings' amplitude, theta_turn, half_period, time and banked
    (bool) columns: the arrays a :class:`~escfit.balance.trajectory.Trajectory` holds."""
    done = out[:n]
    return (done["amplitude"].copy(), done["theta_turn"].copy(), done["half_period"].copy(), done["time"].copy(),
            done["banked"].astype(bool))


def half_swings(*shape: int, nan: bool = False) -> np.ndarray:
    """Output array of :data:`HALF_SWING` records: uninitialised, or NaN (and not banked) with ``nan``."""
    out = np.empty(shape, HALF_SWING)
    if nan:
        for name in ("amplitude", "theta_turn", "half_period", "time"):
            out[name] = math.nan
        out["banked"] = 0
    return out


def with_rows(call, rows: int, width: int, dense: bool) -> tuple:
    """``call(rows_array)`` with room for ``rows`` rows of ``width`` columns, run again with four
    times the room until it fits; returns the kernel's result and the rows array.

    Without ``dense`` the kernel gets an empty array and runs once.
    """
    if not dense:
        buf = np.empty((0, width))
        return call(buf), buf
    while True:
        buf = np.empty((int(rows), width))
        res = call(buf)
        if res[1] != ROWS_FULL:
            return res, buf
        rows *= 4
