"""Viscous damping: a torque ``-c * theta'`` (per inertia ``-C * theta'``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.params import Param
from ...core.scene import check_keys
from .base import ReadContext, Slot, read_either

__all__ = ["Viscous"]


@dataclass(frozen=True)
class Viscous:
    """Linear viscous damping; parameter ``viscous.C`` = c/I in 1/s (>= 0).

    The decrement per half swing at small damping is about ``pi*C*A/(2*omega0)`` (rad): it
    grows in proportion to the amplitude ``A``.
    """

    key = "viscous"
    needs = frozenset({"linear"})
    SLOTS = (Slot("c", 0.0, "C", "1/s", "viscous damping per inertia C = c/I", lower=0.0),)

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Viscous", list[Param]]:
        where = f"{ctx.where} [effects.viscous]"
        check_keys(table, {"C", "c"}, where)
        p = read_either(table, ctx, where, name="viscous.C", unit="1/s",
                        meaning="viscous damping per inertia C = c/I (1/s)",
                        direct=("C", "rate_per_s"), physical=("c", "damping"))
        return cls(), [p]

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: damping ratio 0.015 at ``w0`` (rad/s)."""
        return {"viscous": f"C = {0.03 * w0!r}\n"}

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        k["c"] = values["viscous.C"]
