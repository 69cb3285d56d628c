"""Quadratic air drag: a torque growing with the square of the angular velocity.

Per inertia the torque is ``-D |theta'| theta'`` with ``D >= 0`` in 1/rad: the drag of a body
moving through air at a Reynolds number high enough for the pressure drag to dominate (a
pendulum bob or a balance's arms at large amplitude), as opposed to the viscous ``-C theta'`` of
a slow, laminar flow.  At small damping it takes ``4 D A**2 / 3`` (rad) off a half swing of
amplitude ``A`` -- the energy lost, ``D * integral |theta'|**3 dt = (4/3) D omega0**2 A**3``, over
the energy's slope ``omega0**2 A`` -- so the decrement grows with the square of the amplitude,
where Coulomb friction's is constant and viscous damping's proportional to ``A``: the
signature that tells the three apart in a free decay.  The torque has no closed form with the
exact solver's pieces, so a scene that names it is solved by the integrating solvers (dop853
by default).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.kernels import kernel
from ...core.params import Param, read_param
from ...core.scene import check_keys
from .base import SIZE_MAX, Loss, ReadContext, Slot, toml_number

__all__ = ["Drag", "torque"]


@dataclass(frozen=True)
class Drag:
    """Quadratic air drag; parameter ``drag.D`` (1/rad, >= 0)."""

    key = "drag"
    needs = frozenset({"smooth"})
    coordinates = frozenset({"angle", "linear"})
    SLOTS = (Slot("drag", 0.0, "D", "1/rad", "quadratic air drag per inertia: torque -D |theta'| theta'", lower=0.0),)
    LOSS = Loss("drag.D", "D", "quadratic air drag", "drag", "proportional to A^2", "#2ca02c", ("1/rad", "1/m"),
                ("4 D A^2/3, proportional to A^2",) * 2
                + ("D (4A^2/3 + 4k3 A^4/5)/(1 + k3 A^2)", "D (4A^2/3 + 4k3 A^4/5)/(1 + k3 A^2) at small A"),
                plain=("air drag", "air drag"))

    @staticmethod
    def decrement(value, swing):
        """``D int theta'**2 dtheta / (dE/dA)`` (rad per half swing): ``4 D A**2 / 3`` on a linear spring."""
        return value * swing.speed2 / swing.gain

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Drag", list[Param]]:
        where = f"{ctx.where} [effects.drag]"
        check_keys(table, {"D"}, where, {"D"})
        if ctx.switching == "phase":
            raise SceneError("air drag needs switching = 'angle' (phase switching assumes the fixed half period of a "
                             "linear oscillator)", where)
        if ctx.coordinate == "linear":  # a mass moving through air: the drag force per mass is -D |x'| x'
            p = read_param(table["D"], name="drag.D", kind="inverse_length", lower=0.0, upper=SIZE_MAX["1/m"],
                           meaning="quadratic air drag per mass D (1/m): force -D |x'| x' per mass",
                           where=f"{where}.D")
            return cls(), [p]
        p = read_param(table["D"], name="drag.D", kind="dimensionless", lower=0.0, upper=SIZE_MAX["1/rad"], unit="1/rad",
                       meaning="quadratic air drag per inertia D (1/rad): torque -D |theta'| theta'",
                       where=f"{where}.D")
        return cls(), [p]

    @staticmethod
    def random(rng, s) -> str:
        """Quadratic drag taking up to about 13 % of the amplitude off a half swing (``4 D A / 3``)."""
        return f"[effects.drag]\nD = {toml_number(rng.uniform(0.0, 0.1) / s.a0)}\n"

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: about 3 % of the amplitude lost per half swing."""
        return {"drag": f"D = {0.02 / a0!r}\n"}

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        k["drag"] = values["drag.D"]


@kernel(inline="always")
def torque(x, v, k):
    """Swing-frame acceleration of the drag (rad/s^2), and its derivatives by x and by v.

    ``-D |theta'| theta'`` is odd in the velocity, so in the swing frame (``v = s*theta'``) it
    reads ``-D |v| v`` whichever way the balance swings.
    """
    d = k.drag
    return -d * abs(v) * v, 0.0, -2.0 * d * abs(v)
