"""A spring that stiffens at large angles: a cubic term in the restoring torque.

Per inertia the restoring acceleration becomes ``omega0**2 * (theta + k3 * theta**3)`` (for a
piecewise hairspring or a pendulum, the cubic term ``omega0**2 * k3 * theta**3`` is added to
theirs), with ``k3 >= 0`` in 1/rad^2: at ``theta = 1 rad`` the spring pulls ``1 + k3`` times as
hard as its linear part.  This is the Duffing oscillator; it describes a hairspring or a leaf
spring whose stiffness grows with the deflection (large-angle bending, a spring stud's
constraint), and -- with a pendulum's gravity, whose ``sin(theta)`` softens as ``theta -
theta**3/6`` -- a leaf-spring suspension that partly cancels that softening (``k3 = 1/6``
cancels it to third order).

An undamped swing of amplitude ``A`` lasts half of ``4 K(m) / (omega0 sqrt(1 + k3 A**2))``
with ``m = k3 A**2 / (2 (1 + k3 A**2))`` and ``K`` the complete elliptic integral of the first
kind: the period shortens as the amplitude grows, which is what makes ``k3`` identifiable from
a free decay.  The torque has no closed form with the exact solver's pieces, so a scene that
names it is solved by the integrating solvers (dop853 by default).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.kernels import kernel
from ...core.params import Param, read_param
from ...core.scene import check_keys
from .base import SIZE_MAX, ReadContext, Slot, toml_number

__all__ = ["Stiffening", "torque"]


@dataclass(frozen=True)
class Stiffening:
    """Cubic stiffening of the restoring torque; parameter ``stiffening.k3`` (1/rad^2, >= 0)."""

    key = "stiffening"
    coordinates = frozenset({"angle"})
    needs = frozenset({"smooth"})
    SLOTS = (Slot("k3_w2", 0.0, "omega0**2 * k3", "1/(s**2*rad**2)",
                  "cubic stiffness per inertia: restoring acceleration omega0**2*k3*theta**3", lower=0.0),)

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["Stiffening", list[Param]]:
        where = f"{ctx.where} [effects.stiffening]"
        check_keys(table, {"k3"}, where, {"k3"})
        if ctx.switching == "phase":
            raise SceneError("a stiffening spring needs switching = 'angle' (phase switching assumes the fixed half "
                             "period of a linear spring)", where)
        p = read_param(table["k3"], name="stiffening.k3", kind="dimensionless", lower=0.0, upper=SIZE_MAX["1/rad**2"],
                       unit="1/rad**2",
                       meaning="cubic stiffening (1/rad^2): restoring torque omega0**2*(theta + k3*theta**3)",
                       where=f"{where}.k3")
        return cls(), [p]

    @staticmethod
    def random(rng, s) -> str:
        """A cubic stiffening up to doubling the spring's pull at the release angle."""
        return f"[effects.stiffening]\nk3 = {toml_number(rng.uniform(0.0, 1.0) / (s.a0 * s.a0))}\n"

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite: the spring 30 % stiffer at the release."""
        return {"stiffening": f"k3 = {0.3 / (a0 * a0)!r}\n"}

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        k["k3_w2"] = k["omega0"] ** 2 * values["stiffening.k3"]


@kernel(inline="always")
def torque(x, v, k):
    """Swing-frame acceleration of the cubic term (rad/s^2), and its derivatives by x and by v.

    An odd function of the angle: in the swing frame ``x = s*theta`` it is
    ``-omega0**2 * k3 * x**3`` whichever way the balance swings.
    """
    c3 = k.k3_w2
    return -c3 * x * x * x, -3.0 * c3 * x * x, 0.0
