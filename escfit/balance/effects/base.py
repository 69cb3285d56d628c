"""What every balance effect shares: the reading context, record slots and solver needs.

An effect is a small frozen dataclass holding structure only (window angles, which
swings); its numeric parameters are declared as :class:`escfit.core.params.Param` when the
scene is read.  Each effect module says, in one place, everything the solvers need of it:

``key``
    Its table name in the scene, ``[effects.<key>]``.
``SLOTS``
    The fields it owns in the coefficient record (:mod:`escfit.balance.kernel_records`), with their
    defaults (the value that makes the effect absent), units, meanings and lower bounds; the
    record every kernel receives is assembled from the slots of every registered effect, so a
    new effect's numbers reach every solver, the batch path included, without being listed
    anywhere else.
``needs``
    What it asks of a solver (a subset of :data:`NEEDS`); a solver that does not handle one of
    them is refused before any work, naming the solvers that do.
``read(table, ctx)``
    Reads its table into the effect and its parameters.
``prepare(k)`` (optional)
    Writes the slots fixed by the scene's structure (window edges, break angles), once per
    scene: the scene keeps the prepared record and copies it for every parameter set.
``fill(values, k)``
    Writes its slots that depend on parameter values into the record array ``k``; ``values``
    holds numbers or arrays of one entry per parameter set, so the same code fills one set or a
    batch.
``torque(x, v, k)`` (smooth effects only)
    A compiled function: its angular acceleration (rad/s^2) in the swing frame and the partial
    derivatives of that by the angle and by the angular velocity, which
    :mod:`escfit.balance.acceleration` adds up for every integrating solver.
``refusals(k)`` (optional)
    Relations between its parameters a parameter set must satisfy (vectorised).
``coordinates``
    The coordinates it acts on: ``"angle"`` (a balance or a pendulum) and, for the losses a
    mass on a spring has too, ``"linear"``; a linear oscillator's scene refuses the others.
``LOSS`` and ``decrement(value, swing)`` (dissipative effects only)
    What it takes off each half swing, in words, symbol and colour (:class:`Loss`), and its
    part of the decrement per half swing at the swing's amplitudes, from the work its torque
    does along the undamped swing (:class:`escfit.balance.decrement.Swing`):
    :func:`escfit.balance.decrement.law_parts`, the decrement figure and its legend take every
    effect that has them, and nothing else.
``random(rng, scale)``
    A random instance for the solver comparison (:mod:`escfit.balance.synthetic.random_scenes`):
    its TOML tables drawn with ``rng`` on the scene's scales (``scale.w0`` rad/s, ``scale.a0``
    rad, ``scale.unit = w0**2 a0`` rad/s^2), covering the range where solvers could disagree.
``example(w0, a0)``
    A typical instance, as the TOML tables of a balance scene of natural frequency ``w0``
    (rad/s) released at ``a0`` (rad): ``{table key: table body}``, with any other effect it
    needs to show (an escapement for the banking pins to be reached) and, under the key
    ``"oscillator"``, the oscillator's lines when it sets them itself.  The conformance suite
    (``tests/test_conformance.py``) runs every effect's example through every solver that
    claims it: an effect with no example fails there.

Values are passed in, never stored, so effects are cheap to send to worker processes and a fit
never mutates them.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError

__all__ = ["ReadContext", "Slot", "Loss", "NEEDS", "per_inertia", "read_either", "OMEGA0_RANGE", "squared",
           "toml_number"]

#: omega0 (rad/s) the solvers handle: a period between about 6 nanoseconds and 200 years.
#: Outside, the solvers' arithmetic (omega0**2, half periods) would overflow or divide by zero.
OMEGA0_RANGE = (1e-9, 1e9)
# Largest effect size a scene may give, by the unit of the read value: far past any oscillator
# (a rate 1000 times the fastest omega0, an acceleration 1000 rad times its square; a drag or
# stiffening that doubles the force at a micro-radian), yet small enough that the solvers'
# products stay finite; a typo of exponents (1e200) is refused, not simulated to nonsense.
SIZE_MAX = {"1/s": 1e12, "1/s**2": 1e21, "m/s**2": 1e21, "1/rad": 1e6, "1/rad**2": 1e12, "1/m": 1e6}

#: What an effect may ask of a solver.
NEEDS = {
    "linear": "torques constant or linear in theta and theta' between switch points (closed form exists)",
    "windows": "torques switched on and off at angles of the swing (escapement windows)",
    "smooth": "a smooth torque nonlinear in theta or theta' (no closed form: integrated numerically)",
    "stop_rule": "static friction holding the balance at rest at a turning point",
    "impacts": "impacts on the banking pins",
    "drift": "coefficients changed between cycles (damping drift)",
    "phase_switching": "Monday's phase convention (torques switched at phases of each half cycle)",
}


def toml_number(x) -> str:
    """``x`` as a TOML number that reads back as the same float."""
    return repr(float(x))


def squared(x):
    """``x**2`` as Python's float power computes it, for a number or an array of one per set.

    numpy's ``x**2`` multiplies, which differs from C's ``pow`` in the last bit for some x; a
    parameter set must give the same record whether it is built alone or in a batch.
    """
    if not isinstance(x, np.ndarray):
        return float(x) ** 2
    return np.array([v ** 2 for v in np.asarray(x, float).ravel().tolist()]).reshape(x.shape)


@dataclass(frozen=True)
class Slot:
    """One field of the coefficient record.

    Attributes
    ----------
    name
        Field name in the record (what kernels read as ``k.<name>``).
    default
        Value when the effect is absent (or when it leaves the field alone).
    label
        Short name in messages (``"C"``, ``"R"``).
    unit, meaning
        Unit of the stored value and what it is.
    lower
        Values below it are refused before any work (``None``: no bound).
    size
        0 for a number; else the capacity of an array field, of which ``count`` entries are used.
    count, extra
        An array field uses its first ``k.<count> + extra`` entries.
    dtype
        ``"f8"`` (default) or ``"i8"``; every field is 8 bytes wide, so a record array views as
        a float table for the finiteness check.
    finite
        Whether the value must be finite (the banking angle may be infinite: no pins).
    """

    name: str
    default: float
    label: str
    unit: str
    meaning: str
    lower: float | None = None
    size: int = 0
    count: str | None = None
    extra: int = 0
    dtype: str = "f8"
    finite: bool = True


@dataclass(frozen=True)
class Loss:
    """What a dissipative effect takes off each half swing, as the decrement figure shows it.

    Attributes
    ----------
    parameter
        Its coefficient's parameter name (``"viscous.C"``).
    symbol
        The coefficient's symbol in formulas, and its keyword in
        :func:`~escfit.balance.decrement.law_parts` (``"C"``).
    name
        What it is (``"viscous damping"``).
    short
        Its name before the coefficient's value in a legend (``"viscous"``).
    shape
        How its part of the decrement depends on the amplitude ``A`` (``"proportional to A"``).
    colour
        Its colour in figures.
    units
        The coefficient's unit for an angle (per inertia) and for a displacement (per mass).
    forms
        Its part's formula in a legend on a linear spring and on a pendulum, then on each with
        a stiffening spring (``[effects.stiffening]``).
    phase_constant
        Whether its part is a constant that Monday's phase convention cannot tell from the
        escapement's (Coulomb friction: the two are drawn as one constant there).
    plain
        Its name in plain sentences for an angle and for a displacement (``("friction in the
        pivot", "sliding friction")``); empty: :attr:`name`.
    """

    parameter: str
    symbol: str
    name: str
    short: str
    shape: str
    colour: str
    units: tuple[str, str]
    forms: tuple[str, str, str, str]
    phase_constant: bool = False
    plain: tuple[str, str] = ("", "")

    def words(self, *, linear: bool = False) -> str:
        """Its plain name with its symbol, ``"friction in the pivot (R)"``."""
        return f"{self.plain[linear] or self.name} ({self.symbol})"

    def legend(self, *, stiff: bool, pendulum: bool) -> str:
        """The part's formula for a legend."""
        return self.forms[2 * stiff + pendulum]

    def value_text(self, value: float, *, linear: bool) -> str:
        """``short, symbol = value unit`` for a legend."""
        return f"{self.short}, {self.symbol} = {value:.3g} {self.units[1] if linear else self.units[0]}"


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
    coordinate
        ``"angle"`` (a balance or pendulum, rad) or ``"linear"`` (a mass on a spring, m): the
        units of the per-inertia (per-mass) parameters follow it.
    """

    where: str
    inertia: float | None
    switching: str
    coordinate: str = "angle"


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
                          where=f"{where}.{dkey}", unit=unit, upper=SIZE_MAX.get(unit, math.inf))
    return read_param(table[pkey], name=name, kind=pkind, lower=0.0, meaning=meaning, upper=SIZE_MAX.get(unit, math.inf),
                      where=f"{where}.{pkey}", convert=per_inertia(ctx, pkey, f"{where}.{pkey}"), unit=unit)
