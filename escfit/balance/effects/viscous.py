"""Viscous damping: a torque ``-c * theta'`` (per inertia ``-C * theta'``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.params import Param
from ...core.scene import check_keys
from .base import Loss, ReadContext, Slot, read_either, toml_number

__all__ = ["Viscous", "near_critical_damping"]


def near_critical_damping(rng, w0: float) -> float:
    """C within 1e-12 to 1e-3 (relative, either side) of critical damping ``2 w0`` (1/s)."""
    d = 10.0 ** rng.uniform(-12, -3) * rng.choice([-1.0, 1.0])
    return 2.0 * w0 * (1.0 + d)


@dataclass(frozen=True)
class Viscous:
    """Linear viscous damping; parameter ``viscous.C`` = c/I in 1/s (>= 0).

    The decrement per half swing at small damping is about ``pi*C*A/(2*omega0)`` (rad): it
    grows in proportion to the amplitude ``A``.
    """

    key = "viscous"
    needs = frozenset({"linear"})
    coordinates = frozenset({"angle", "linear"})
    SLOTS = (Slot("c", 0.0, "C", "1/s", "viscous damping per inertia C = c/I", lower=0.0),)
    LOSS = Loss("viscous.C", "C", "viscous damping", "viscous", "proportional to A", "#1f77b4", ("1/s", "1/s"),
                ("about pi C A/(2 omega0), proportional to A",) * 2
                + ("C int|theta'|dtheta/(dE/dA), about pi C A/(2 omega0) at small A",) * 2)

    @staticmethod
    def decrement(value, swing):
        """``C int |theta'| dtheta / (dE/dA)`` (rad per half swing); on a linear spring the exact
        ``2 tanh(pi C/(4 omega1)) A`` (:meth:`escfit.balance.decrement.Swing.viscous`)."""
        return swing.viscous(value)

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Viscous", list[Param]]:
        where = f"{ctx.where} [effects.viscous]"
        check_keys(table, {"C", "c"}, where)
        p = read_either(table, ctx, where, name="viscous.C", unit="1/s",
                        meaning="viscous damping per inertia C = c/I (1/s)",
                        direct=("C", "rate_per_s"), physical=("c", "damping"))
        return cls(), [p]

    @staticmethod
    def random(rng, s) -> str:
        """Damping up to 6 w0; a quarter of the scenes within 1e-12 to 1e-3 of critical damping
        2 w0 (either side), where solvers have disagreed on whether the balance creeps to rest or
        turns once more."""
        kind = rng.uniform()
        if kind < 0.25:
            c = near_critical_damping(rng, s.w0)
        elif kind < 0.85:
            c = s.w0 * rng.uniform(0.0, 0.3)
        else:
            c = s.w0 * rng.uniform(0.3, 6.0)
        return f"[effects.viscous]\nC = {toml_number(c)}\n"

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: damping ratio 0.015 at ``w0`` (rad/s)."""
        return {"viscous": f"C = {0.03 * w0!r}\n"}

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        k["c"] = values["viscous.C"]
