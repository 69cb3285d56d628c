"""A hairspring whose stiffness changes at given balance angles.

The restoring torque is continuous and piecewise linear in theta: on piece ``i`` its
slope per inertia is ``omega0[i]**2``.  ``angles`` (ascending, rad) separate the pieces, so
``omega0`` has one more entry than ``angles``; the piece containing theta = 0 sets the
reference frequency used for the rate.  Monday's long program allowed four such values.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.scene import check_keys
from ...core.units import BARE_ANGLE_LIMIT, to_canonical
from .base import OMEGA0_RANGE, ReadContext, squared, toml_number

__all__ = ["Hairspring", "MAX_PIECES"]

#: Most pieces a restoring torque may have (the record's capacity).
MAX_PIECES = 8


@dataclass(frozen=True)
class Hairspring:
    """Piecewise-linear hairspring; parameters ``hairspring.omega0[i]`` (rad/s, i from 1)."""

    angles: tuple[float, ...]
    key = "hairspring"
    coordinates = frozenset({"angle"})
    needs = frozenset({"linear"})
    SLOTS = ()  # it fills the oscillator's restoring-torque pieces (escfit.balance.kernel_records.OSCILLATOR_SLOTS)

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Hairspring", list[Param]]:
        where = f"{ctx.where} [effects.hairspring]"
        check_keys(table, {"angles", "omega0"}, where, {"angles", "omega0"})
        if ctx.switching == "phase":
            raise SceneError("a hairspring with angle-dependent stiffness needs switching = 'angle'", where)
        angles, omegas = table["angles"], table["omega0"]
        if not isinstance(angles, list) or not isinstance(omegas, list) or len(omegas) != len(angles) + 1 or not angles:
            raise SceneError("'angles' must be a non-empty list and 'omega0' a list one entry longer", where)
        ang = tuple(to_canonical(a, "angle", f"{where}.angles[{i}]", bare_limit=BARE_ANGLE_LIMIT)
                    for i, a in enumerate(angles, 1))
        if len(omegas) > MAX_PIECES:
            raise SceneError(f"{len(omegas)} hairspring pieces; at most {MAX_PIECES} are supported", where)
        if any(b <= a for a, b in zip(ang, ang[1:])):
            raise SceneError(f"'angles' must increase strictly, got {angles!r}", f"{where}.angles")
        params = [
            read_param(w, name=f"hairspring.omega0[{i}]", kind="angular_frequency", lower=OMEGA0_RANGE[0], upper=OMEGA0_RANGE[1],
                       meaning=f"natural frequency of hairspring piece {i} (rad/s)", where=f"{where}.omega0[{i}]")
            for i, w in enumerate(omegas, 1)
        ]
        return cls(ang), params

    @staticmethod
    def random(rng, s) -> str:
        """A piecewise-linear spring of three pieces, the central one of frequency ``s.w0``."""
        b1, b2 = s.a0 * rng.uniform(-1.2, -0.1), s.a0 * rng.uniform(0.1, 1.2)
        w = [s.w0 * rng.uniform(0.7, 1.4), s.w0, s.w0 * rng.uniform(0.7, 1.4)]
        return (f"[effects.hairspring]\nangles = [{toml_number(b1)}, {toml_number(b2)}]\n"
                f"omega0 = [{', '.join(map(toml_number, w))}]\n")

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: three pieces, the central one of ``w0``
        (it gives the oscillator's omega0, so ``oscillator`` names the release only)."""
        return {"oscillator": f"theta0 = {a0!r}\n",
                "hairspring": f"angles = [{-0.5 * a0!r}, {0.4 * a0!r}]\nomega0 = [{1.2 * w0!r}, {w0!r}, {0.8 * w0!r}]\n"}

    def prepare(self, k: np.ndarray) -> None:
        n = len(self.angles) + 1
        k["n_pieces"] = n
        k["sp_bp"][:, :n - 1] = self.angles

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        n = len(self.angles) + 1
        bp = np.asarray(self.angles, float)
        w2 = k["sp_w2"]
        for i in range(n):
            w2[:, i] = squared(values[f"hairspring.omega0[{i + 1}]"])
        # offsets that make the restoring torque continuous and zero at theta = 0
        off = k["sp_off"]
        off[:, :n] = 0.0
        zero_piece = int(np.searchsorted(bp, 0.0, side="right"))
        for i in range(zero_piece + 1, n):  # pieces above zero
            b = bp[i - 1]
            off[:, i] = (w2[:, i - 1] * b + off[:, i - 1]) - w2[:, i] * b
        for i in range(zero_piece - 1, -1, -1):  # pieces below zero
            b = bp[i]
            off[:, i] = (w2[:, i + 1] * b + off[:, i + 1]) - w2[:, i] * b
        k["omega0"] = values[f"hairspring.omega0[{zero_piece + 1}]"]
