"""What every balance effect shares: the reading context and the system builder.

An effect is a small frozen dataclass holding structure only (window angles, which
swings); its numeric parameters are declared as :class:`escfit.core.params.Param` when the
scene is read and their values are passed to :meth:`apply` at compile time, so effects are
cheap to send to worker processes and a fit never mutates them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ...core.errors import SceneError

__all__ = ["ReadContext", "SystemBuilder", "per_inertia"]

#: omega0 (rad/s) the solvers handle: a period between about 6 nanoseconds and 200 years.
#: Outside, the solvers' arithmetic (omega0**2, half periods) would overflow or divide by zero.
OMEGA0_RANGE = (1e-9, 1e9)


@dataclass(frozen=True)
class ReadContext:
    """Facts an effect may need while reading its table.

    Attributes
    ----------
    where
        Scene file name for messages.
    inertia
        Moment of inertia (kg*m^2) when the oscillator gives one, else ``None``; needed
        to convert physical torques and damping coefficients to per-inertia form.
    switching
        ``"angle"`` or ``"phase"``.
    """

    where: str
    inertia: float | None
    switching: str


def per_inertia(ctx: ReadContext, key: str, where: str):
    """Return the map torque -> torque/I, refusing when no inertia was given."""
    if ctx.inertia is None:
        raise SceneError(
            f"'{key}' is a physical torque/coefficient and needs [oscillator] inertia to convert it "
            "to per-inertia form",
            where,
        )
    inertia = ctx.inertia
    return lambda v: v / inertia


@dataclass
class SystemBuilder:
    """Numeric description of one parameter set, assembled by the effects in turn.

    All values are per unit inertia: ``c`` (1/s), ``r`` (rad/s^2), window magnitudes
    (rad/s^2, positive drives the motion, negative opposes it), stiffness pieces
    (1/s^2).  ``restoring`` is ``"spring"`` (restoring acceleration ``omega0**2 * theta``,
    or the hairspring's pieces) or ``"pendulum"`` (``omega0**2 * sin(theta)``, gravity
    with ``omega0 = sqrt(g/L)``; no hairspring pieces).
    """

    theta0: float = 0.0
    omega0: float = 1.0
    restoring: str = "spring"
    c: float = 0.0
    r: float = 0.0
    spring_breaks: list[float] = field(default_factory=list)
    spring_w2: list[float] = field(default_factory=list)
    w_lo: list[float] = field(default_factory=list)
    w_hi: list[float] = field(default_factory=list)
    w_x: list[float] = field(default_factory=list)
    w_dir: list[int] = field(default_factory=list)
    bank: float = math.inf
    restitution: float = 0.0
    drift_thresholds: list[float] = field(default_factory=list)
    drift_rates: list[float] = field(default_factory=lambda: [0.0])

    def spring_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Breakpoints, stiffness pieces and offsets of a continuous restoring torque.

        The restoring acceleration is ``w2[i]*theta + off[i]`` on piece ``i``; offsets
        are chosen so the torque is continuous and zero at theta = 0.
        """
        if not self.spring_w2:
            return np.zeros(0), np.array([self.omega0**2]), np.zeros(1)
        bp = np.asarray(self.spring_breaks, float)
        w2 = np.asarray(self.spring_w2, float)
        off = np.zeros_like(w2)
        zero_piece = int(np.searchsorted(bp, 0.0, side="right"))
        for i in range(zero_piece + 1, len(w2)):  # pieces above zero
            b = bp[i - 1]
            off[i] = (w2[i - 1] * b + off[i - 1]) - w2[i] * b
        for i in range(zero_piece - 1, -1, -1):  # pieces below zero
            b = bp[i]
            off[i] = (w2[i + 1] * b + off[i + 1]) - w2[i] * b
        return bp, w2, off


def table_of(doc: Mapping, key: str, where: str) -> Mapping:
    value = doc.get(key, {})
    if not isinstance(value, Mapping):
        raise SceneError(f"[{key}] must be a table", where)
    return value


def read_either(
    table: Mapping,
    ctx: ReadContext,
    where: str,
    *,
    name: str,
    meaning: str,
    direct: tuple[str, str],
    physical: tuple[str, str],
    unit: str,
):
    """Read a per-inertia parameter given either directly or as a physical quantity.

    Parameters
    ----------
    direct, physical
        ``(key, kind)`` pairs, e.g. ``("R", "angular_acceleration")`` and
        ``("torque", "torque")``; exactly one of the two keys must be present.  The
        physical one is divided by the oscillator's inertia.
    unit
        The per-inertia unit of the result.
    """
    from ...core.params import read_param

    (dkey, dkind), (pkey, pkind) = direct, physical
    if (dkey in table) == (pkey in table):
        raise SceneError(f"give exactly one of '{dkey}' ({unit}) or '{pkey}' (physical, needs inertia)", where)
    if dkey in table:
        return read_param(table[dkey], name=name, kind=dkind, lower=0.0, meaning=meaning,
                          where=f"{where}.{dkey}", unit=unit)
    return read_param(table[pkey], name=name, kind=pkind, lower=0.0, meaning=meaning,
                      where=f"{where}.{pkey}", convert=per_inertia(ctx, pkey, f"{where}.{pkey}"), unit=unit)
