"""Coulomb (pivot / sliding) friction, and static friction at rest.

While the balance moves, friction is a torque of constant size opposing the motion: per
inertia ``-R * sgn(theta')`` with ``R >= 0`` in rad/s^2.  It takes ``2*R/omega0**2`` (rad) off
every half swing of a linear spring, whatever the amplitude.

At a turning point the balance is at rest, and static friction holds it there as long as the
other torques do not exceed ``R_static`` (rad/s^2, ``>= R``; default ``R``): for a bare
hairspring, while ``omega0**2 * |theta| <= R_static``.  A static friction above the sliding
one stops the motion earlier, at the first turning point where that holds, and the run ends
with status ``stopped``.  Every solver applies the rule at the start of each half swing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.params import Param
from ...core.scene import check_keys
from .base import SIZE_MAX, Loss, ReadContext, Slot, read_either, toml_number

__all__ = ["Coulomb"]


@dataclass(frozen=True)
class Coulomb:
    """Coulomb friction; parameters ``coulomb.R`` and, if named, ``coulomb.R_static`` (rad/s^2, >= 0).

    Attributes
    ----------
    static
        Whether the scene names a static friction ``R_static`` (``static_torque``) apart from ``R``.
    """

    static: bool = False
    key = "coulomb"
    coordinates = frozenset({"angle", "linear"})
    LOSS = Loss("coulomb.R", "R", "Coulomb (dry) friction", "Coulomb", "constant", "#d62728", ("rad/s^2", "m/s^2"),
                ("2R/omega0^2, constant", "2R/omega0^2 at small A")
                + ("2R/(omega0^2 (1 + k3 A^2)) on the stiffening spring",) * 2, phase_constant=True,
                plain=("friction in the pivot", "sliding friction"))
    SLOTS = (
        Slot("r", 0.0, "R", "rad/s**2", "Coulomb (sliding) friction torque per inertia", lower=0.0),
        Slot("r_static", 0.0, "R_static", "rad/s**2",
             "static friction torque per inertia: holds the balance at rest at a turning point", lower=0.0),
    )

    @property
    def needs(self) -> frozenset[str]:
        return frozenset({"linear", "stop_rule"} if self.static else {"linear"})

    @staticmethod
    def decrement(value, swing):
        """``R int dtheta / (dE/dA) = 2 R A / (dE/dA)`` (rad per half swing): ``2R/omega0**2`` on a linear spring."""
        return value * swing.path / swing.gain

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Coulomb", list[Param]]:
        where = f"{ctx.where} [effects.coulomb]"
        check_keys(table, {"R", "torque", "R_static", "static_torque"}, where)
        if ctx.coordinate == "linear":
            return cls._read_linear(table, ctx, where)
        sliding = {k: table[k] for k in ("R", "torque") if k in table}
        p = read_either(sliding, ctx, where, name="coulomb.R", unit="1/s**2",
                        meaning="Coulomb friction torque per inertia R (rad/s^2), opposes the motion",
                        direct=("R", "angular_acceleration"), physical=("torque", "torque"))
        static = {k: table[k] for k in ("R_static", "static_torque") if k in table}
        if not static:
            return cls(), [p]
        if ctx.switching == "phase":
            from ...core.errors import SceneError

            raise SceneError("static friction needs switching = 'angle' (phase switching has no turning points at "
                             "rest)", f"{where}.R_static")
        q = read_either(static, ctx, where, name="coulomb.R_static", unit="1/s**2",
                        meaning="static friction torque per inertia (rad/s^2, >= R): holds the balance at rest",
                        direct=("R_static", "angular_acceleration"), physical=("static_torque", "torque"))
        if q.value < p.value:
            from ...core.errors import SceneError

            raise SceneError(f"static friction R_static = {q.value:g} rad/s^2 is below the sliding friction "
                             f"R = {p.value:g} rad/s^2; it must be at least R", f"{where}.R_static")
        return cls(static=True), [p, q]

    @staticmethod
    def random(rng, s) -> str:
        """Sliding friction R; in a third of the scenes static friction R_static up to 3 R above it."""
        r = s.unit * 10.0 ** rng.uniform(-4, math.log10(0.3))
        static = f"R_static = {toml_number(r * rng.uniform(1.0, 3.0))}\n" if rng.uniform() < 1.0 / 3.0 else ""
        return f"[effects.coulomb]\nR = {toml_number(r)}\n{static}"

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: sliding friction 4.7 % of the spring's
        acceleration at the release ``a0`` (rad), static friction 18.8 %.

        A half swing loses ``0.094 a0``; static friction holds the balance at the first turn
        within ``0.188 a0``, the ninth (``0.154 a0``): a static rule half as strong would let it
        swing once more, so the example tells them apart."""
        unit = w0 * w0 * a0
        return {"coulomb": f"R = {0.047 * unit!r}\nR_static = {0.188 * unit!r}\n"}

    @classmethod
    def _read_linear(cls, table: Mapping, ctx: ReadContext, where: str) -> tuple["Coulomb", list[Param]]:
        """A linear oscillator's dry friction: a force per mass, ``R`` (and ``R_static``) in m/s^2."""
        from ...core.errors import SceneError
        from ...core.params import read_param

        for key in ("torque", "static_torque"):
            if key in table:
                raise SceneError(f"a linear oscillator takes its dry friction as a force per mass, R (m/s^2); "
                                 f"'{key}' is a balance's torque", f"{where}.{key}")
        if "R" not in table:
            raise SceneError("give 'R' (m/s^2): the friction force per mass", where)
        meaning = "Coulomb (dry) friction force per mass R (m/s^2), opposes the motion"
        p = read_param(table["R"], name="coulomb.R", kind="acceleration", lower=0.0, upper=SIZE_MAX["m/s**2"], meaning=meaning,
                       where=f"{where}.R")
        if "R_static" not in table:
            return cls(), [p]
        q = read_param(table["R_static"], name="coulomb.R_static", kind="acceleration", lower=0.0,
                       upper=SIZE_MAX["m/s**2"],
                       meaning="static friction force per mass (m/s^2, >= R): holds the mass at rest",
                       where=f"{where}.R_static")
        if q.value < p.value:
            raise SceneError(f"static friction R_static = {q.value:g} m/s^2 is below the sliding friction "
                             f"R = {p.value:g} m/s^2; it must be at least R", f"{where}.R_static")
        return cls(static=True), [p, q]

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        k["r"] = values["coulomb.R"]
        k["r_static"] = values["coulomb.R_static"] if self.static else values["coulomb.R"]

    def refusals(self, k: np.ndarray) -> list[tuple[np.ndarray, str]]:
        """A static friction below the sliding one is refused (vectorised over the records)."""
        if not self.static:
            return []
        return [(k["r_static"] < k["r"], "R_static must be >= R, got R_static={r_static!r}, R={r!r}")]
