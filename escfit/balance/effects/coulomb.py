"""Coulomb (pivot / sliding) friction: a torque of constant size opposing the motion.

Per inertia it is ``-R * sgn(theta')`` with ``R >= 0`` in rad/s^2.  At rest, friction holds
the balance as long as the other torques do not exceed ``R`` (for a bare hairspring:
``omega0**2 * |theta| <= R``), which ends a run with status ``stopped``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from ...core.params import Param
from ...core.scene import check_keys
from .base import ReadContext, SystemBuilder, read_either

__all__ = ["Coulomb"]


@dataclass(frozen=True)
class Coulomb:
    """Coulomb friction; parameter ``coulomb.R`` = torque/I in rad/s^2 (>= 0)."""

    key = "coulomb"

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Coulomb", list[Param]]:
        where = f"{ctx.where} [effects.coulomb]"
        check_keys(table, {"R", "torque"}, where)
        p = read_either(table, ctx, where, name="coulomb.R", unit="1/s**2",
                        meaning="Coulomb friction torque per inertia R (rad/s^2), opposes the motion",
                        direct=("R", "angular_acceleration"), physical=("torque", "torque"))
        return cls(), [p]

    def apply(self, values: Mapping[str, float], sys: SystemBuilder) -> None:
        sys.r = values["coulomb.R"]
