"""Escapement windows: constant torques acting over ranges of the swing.

Each window acts while the balance is inside ``[from, to)`` measured in the frame of the
current swing, ``x = s*theta`` with ``s`` the direction of motion, so every swing runs from
``x = -A`` to ``x = +A`` and a window at ``from = -0.63, to = -0.28`` is met shortly before
the balance passes zero, whichever way it swings.  ``kind = "unlock"`` opposes the motion
(the balance does work releasing the escape wheel), ``kind = "impulse"`` drives it.
``swings`` restricts a window to ``"positive"`` (theta increasing) or ``"negative"`` swings
for asymmetric escapements.

With ``switching = "phase"`` the limits are phase offsets (rad) from the zero crossing in
the middle of each half cycle, as in Monday's programs, and must lie within +-pi/2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.scene import check_keys
from ...core.units import BARE_ANGLE_LIMIT, to_canonical
from .base import ReadContext, Slot, read_either, toml_number

__all__ = ["Window", "Escapement", "MAX_WINDOWS"]

_SWINGS = {"both": 0, "positive": 1, "negative": -1}

#: Most windows a scene may name (the record's capacity).
MAX_WINDOWS = 12


@dataclass(frozen=True)
class Window:
    """One escapement window (structure only; its magnitude is ``escapement[i].X``)."""

    index: int  # 1-based, file order
    kind: str  # "unlock" | "impulse"
    lo: float  # rad, swing frame (or phase offset)
    hi: float
    swings: str  # "both" | "positive" | "negative"

    @property
    def name(self) -> str:
        return f"escapement[{self.index}].X"

    @property
    def sign(self) -> float:
        return 1.0 if self.kind == "impulse" else -1.0


@dataclass(frozen=True)
class Escapement:
    """The set of escapement windows of a scene."""

    windows: tuple[Window, ...]
    key = "escapement"
    coordinates = frozenset({"angle"})
    needs = frozenset({"windows"})
    SLOTS = (
        Slot("n_windows", 0, "windows", "", "number of escapement windows", dtype="i8"),
        Slot("w_lo", 0.0, "window starts", "rad", "window starts in the swing frame (or phase offsets)",
             size=MAX_WINDOWS, count="n_windows"),
        Slot("w_hi", 0.0, "window ends", "rad", "window ends in the swing frame (or phase offsets)",
             size=MAX_WINDOWS, count="n_windows"),
        Slot("w_x", 0.0, "escapement magnitudes", "rad/s**2",
             "signed window torques per inertia (> 0 drives the motion, < 0 opposes it)",
             size=MAX_WINDOWS, count="n_windows"),
        Slot("w_dir", 0, "window swings", "", "swings a window acts on: 0 both, +1 positive, -1 negative",
             size=MAX_WINDOWS, count="n_windows", dtype="i8"),
    )

    @staticmethod
    def random(rng, s) -> str:
        """A lever escapement's unlocking and impulse windows, both sides of the swing frame."""
        def window(lo: float, hi: float, kind: str, x: float) -> str:
            return (f'[[effects.escapement]]\nkind = "{kind}"\nfrom = {toml_number(lo)}\nto = {toml_number(hi)}\n'
                    f'X = {toml_number(x)}\nswings = "both"\n')

        lift = s.a0 * rng.uniform(0.05, 0.4)
        unlock = lift * rng.uniform(1.2, 2.0)
        out = window(-lift, lift, "impulse", s.unit * rng.uniform(0.2, 8.0))
        if rng.uniform() < 0.7:
            out += window(-unlock, -lift, "unlock", s.unit * rng.uniform(0.0, 0.5))
        return out

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: a lever escapement's unlocking and impulse
        windows about the centre, with viscous damping to balance the impulse."""
        unit = w0 * w0 * a0
        window = '[[effects.escapement]]\nkind = "{}"\nfrom = {!r}\nto = {!r}\nX = {!r}\nswings = "{}"\n'
        text = (window.format("unlock", -0.3 * a0, -0.1 * a0, 0.05 * unit, "both")
                + window.format("impulse", -0.1 * a0, 0.1 * a0, 0.6 * unit, "positive")
                + window.format("impulse", -0.1 * a0, 0.12 * a0, 0.5 * unit, "negative"))
        return {"viscous": f"C = {0.05 * w0!r}\n", "escapement": text}

    @classmethod
    def read(cls, tables: Sequence, ctx: ReadContext) -> tuple["Escapement", list[Param]]:
        if isinstance(tables, Mapping):
            tables = [tables]
        if len(tables) > MAX_WINDOWS:
            raise SceneError(f"{len(tables)} escapement windows; at most {MAX_WINDOWS} are supported",
                             f"{ctx.where} [effects.escapement]")
        windows: list[Window] = []
        raw_x: list[tuple[Window, Mapping, str]] = []
        for i, table in enumerate(tables, start=1):
            where = f"{ctx.where} [effects.escapement {i}]"
            check_keys(table, {"kind", "from", "to", "X", "torque", "eps", "swings"}, where, {"kind", "from", "to"})
            kind = table["kind"]
            if kind not in ("unlock", "impulse"):
                raise SceneError(f"kind must be 'unlock' or 'impulse', got {kind!r}", f"{where}.kind")
            lo = to_canonical(table["from"], "angle", f"{where}.from", bare_limit=BARE_ANGLE_LIMIT)
            hi = to_canonical(table["to"], "angle", f"{where}.to", bare_limit=BARE_ANGLE_LIMIT)
            if not lo < hi:
                raise SceneError(f"'from' ({table['from']!r}) must be below 'to' ({table['to']!r})", where)
            if ctx.switching == "phase" and (abs(lo) > math.pi / 2 + 1e-12 or abs(hi) > math.pi / 2 + 1e-12):
                raise SceneError(
                    f"with phase switching window limits are phase offsets within +-pi/2 of the zero "
                    f"crossing; got from={table['from']!r}, to={table['to']!r}",
                    where,
                )
            swings = table.get("swings", "both")
            if not isinstance(swings, str) or swings not in _SWINGS:
                raise SceneError(f"swings must be one of {sorted(_SWINGS)}, got {swings!r}", f"{where}.swings")
            w = Window(i, kind, lo, hi, swings)
            windows.append(w)
            raw_x.append((w, table, where))
        _refuse_overlaps(windows, ctx.where)
        params = [_magnitude(w, table, where, ctx, windows) for w, table, where in raw_x]
        return cls(tuple(windows)), params

    def prepare(self, k: np.ndarray) -> None:
        n = len(self.windows)
        k["n_windows"] = n
        k["w_lo"][:, :n] = [w.lo for w in self.windows]
        k["w_hi"][:, :n] = [w.hi for w in self.windows]
        k["w_dir"][:, :n] = [_SWINGS[w.swings] for w in self.windows]

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        n = len(self.windows)
        xs = [w.sign * values[w.name] for w in self.windows]
        w_x = k["w_x"]
        if not any(isinstance(x, np.ndarray) for x in xs):  # one parameter set (or the same values for all)
            w_x[:, :n] = xs
        else:
            for i, x in enumerate(xs):
                w_x[:, i] = x


def _magnitude(w: Window, table: Mapping, where: str, ctx: ReadContext, windows: list[Window]) -> Param:
    meaning = f"{w.kind} torque per inertia of window {w.index} (rad/s^2, {'drives' if w.sign > 0 else 'opposes'} the motion)"
    if "eps" in table:
        if w.kind != "unlock" or "X" in table or "torque" in table:
            raise SceneError("'eps' (unlock torque as a fraction of the impulse torque, S = eps*M) "
                             "goes alone on an unlock window", where)
        eps = read_param(table["eps"], name=f"escapement[{w.index}].eps", kind="dimensionless", lower=0.0,
                         meaning="unlock/impulse torque ratio", where=f"{where}.eps")
        partners = [o for o in windows if o.kind == "impulse" and (o.swings == w.swings or "both" in (o.swings, w.swings))]
        if len(partners) != 1:
            raise SceneError(f"'eps' needs exactly one impulse window on the same swings, found {len(partners)}", where)
        return Param(w.name, math.nan, "1/s**2", meaning, tie=(partners[0].name, eps.value))
    return read_either(table, ctx, where, name=w.name, meaning=meaning, unit="1/s**2",
                       direct=("X", "angular_acceleration"), physical=("torque", "torque"))


def _refuse_overlaps(windows: list[Window], where: str) -> None:
    for a in windows:
        for b in windows:
            if a.index >= b.index:
                continue
            shared = a.swings == b.swings or "both" in (a.swings, b.swings)
            if shared and max(a.lo, b.lo) < min(a.hi, b.hi):
                raise SceneError(
                    f"escapement windows {a.index} [{a.lo:g}, {a.hi:g}) and {b.index} [{b.lo:g}, {b.hi:g}) "
                    "overlap on the same swings",
                    where,
                )
