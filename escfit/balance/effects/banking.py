"""Banking: the balance strikes the banking pins when |theta| reaches the banking angle.

The impact reverses the velocity and scales it by the coefficient of restitution ``e``
(0: the balance stops dead against the pin and restarts from rest; 1: elastic).  The half
swing ends at the impact, its amplitude is the banking angle and it is flagged ``banked``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.scene import check_keys
from ...core.units import BARE_ANGLE_LIMIT, to_canonical
from .base import ReadContext, Slot, toml_number

__all__ = ["Banking"]


@dataclass(frozen=True)
class Banking:
    """Banking pins at ``angle`` (rad, > 0); parameter ``banking.e`` in [0, 1]."""

    angle: float
    key = "banking"
    coordinates = frozenset({"angle"})
    needs = frozenset({"impacts"})
    SLOTS = (
        Slot("bank", math.inf, "banking angle", "rad", "banking angle (inf: no pins)", finite=False),
        Slot("restitution", 0.0, "e", "", "coefficient of restitution at the banking pins", lower=0.0),
    )

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Banking", list[Param]]:
        where = f"{ctx.where} [effects.banking]"
        check_keys(table, {"angle", "restitution"}, where, {"angle"})
        if ctx.switching == "phase":
            raise SceneError("banking needs switching = 'angle' (phase switching has no turning points)", where)
        angle = to_canonical(table["angle"], "angle", f"{where}.angle", bare_limit=BARE_ANGLE_LIMIT)
        if not angle > 0:
            raise SceneError(f"banking angle must be positive, got {table['angle']!r}", f"{where}.angle")
        e = read_param(table.get("restitution", 0.0), name="banking.e", kind="dimensionless", lower=0.0, upper=1.0,
                       meaning="coefficient of restitution at the banking pins", where=f"{where}.restitution")
        return cls(angle), [e]

    @staticmethod
    def random(rng, s) -> str:
        """Pins at 1 to 1.4 times the release amplitude, restitution 0 (dead), 0.3, 0.7 or 1 (elastic)."""
        angle = s.a0 * rng.uniform(1.0, 1.4)
        return (f"[effects.banking]\nangle = {toml_number(angle)}\n"
                f"restitution = {toml_number(rng.choice([0.0, 0.3, 0.7, 1.0]))}\n")

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: an impulse that drives the balance onto
        pins 1.1 ``a0`` out (rad), restitution 0.5, and viscous damping."""
        window = f'[[effects.escapement]]\nkind = "impulse"\nfrom = {-0.1 * a0!r}\nto = {0.1 * a0!r}\nX = {2.0 * w0 * w0 * a0!r}\n'
        return {"viscous": f"C = {0.02 * w0!r}\n", "escapement": window,
                "banking": f"angle = {1.1 * a0!r}\nrestitution = 0.5\n"}

    def prepare(self, k: np.ndarray) -> None:
        k["bank"] = self.angle

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        k["restitution"] = values["banking.e"]
