"""The numeric system of one or many parameter sets: coefficient records plus what they need.

:meth:`escfit.balance.scene.BalanceScene.system` builds a :class:`System` from parameter values
(numbers, or arrays of one entry per set): the oscillator's slots, then each effect's
:meth:`fill`, into :func:`escfit.balance.kernel_records.blank` records.  A :class:`System` is what
every solver front end takes; its :attr:`needs` are checked against the solver's declared
capabilities before any work (:func:`escfit.balance.solvers.check`), and :meth:`refusals`
says, set by set, which parameter values no solver can run (non-finite numbers, values below a
slot's bound, relations an effect declares).  The single-set solvers and the batch path use the
same :meth:`refusals`, so they refuse alike.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..core.errors import SolverError
from ..core.kernels import kernel
from .kernel_records import COEFFICIENTS, SLOTS, blank

__all__ = ["System", "Structure"]


def _columns(filter_) -> tuple[np.ndarray, list]:
    """Columns of the float64 view of a record holding the used part of each slot passing ``filter_``."""
    cols, owners = [], []
    for slot in SLOTS:
        if slot.dtype != "f8" or not filter_(slot):
            continue
        start = COEFFICIENTS.fields[slot.name][1] // 8
        for j in range(max(slot.size, 1)):
            cols.append(start + j)
            owners.append((slot, j))
    return np.array(cols, np.int64), owners


_FINITE_COLS, _FINITE_OWNERS = _columns(lambda s: s.finite and s.name != "theta0")
_LOWER_COLS, _LOWER_OWNERS = _columns(lambda s: s.lower is not None)
_LOWER_VALUES = np.array([slot.lower for slot, _ in _LOWER_OWNERS], float)
_WIDTH = COEFFICIENTS.itemsize // 8
_THETA0_COL = COEFFICIENTS.fields["theta0"][1] // 8
# one row per checked column: (column, lower bound or -inf, whether the value must be finite)
_CHECKS = np.array(sorted({(float(c), -math.inf, 1.0) for c in _FINITE_COLS}
                          | {(float(c), lo, 0.0) for c, lo in zip(_LOWER_COLS, _LOWER_VALUES)}))
_C_COL = COEFFICIENTS.fields["c"][1] // 8
_OMEGA0_COL = COEFFICIENTS.fields["omega0"][1] // 8


@kernel
def _flag_values(table, checks, mode, bad):
    """Flag the rows of the records' float table that no solver can run; returns how many.

    ``checks`` rows are ``(column, lower bound, must be finite)`` (theta0 is always checked);
    ``mode`` adds 1: a pendulum's |theta0| < pi, 2: phase switching's C < 2 omega0.
    """
    n_bad = 0
    for i in range(table.shape[0]):
        theta0 = table[i, _THETA0_COL]
        flag = not math.isfinite(theta0) or (mode & 1 and not abs(theta0) < math.pi)
        if mode & 2 and not table[i, _C_COL] < 2.0 * table[i, _OMEGA0_COL]:
            flag = True
        for j in range(checks.shape[0]):
            v = table[i, int(checks[j, 0])]
            if v < checks[j, 1] or (checks[j, 2] != 0.0 and not math.isfinite(v)):
                flag = True
        bad[i] = flag
        n_bad += flag
    return n_bad


@dataclass(frozen=True, eq=False)
class Structure:
    """What a scene's effects fix for all its parameter sets, worked out once.

    Attributes
    ----------
    effects
        The scene's effect objects.
    restoring
        ``"spring"`` or ``"pendulum"``.
    switching
        ``"angle"`` or ``"phase"``.
    """

    effects: tuple = ()
    restoring: str = "spring"
    switching: str = "angle"

    @functools.cached_property
    def demands(self) -> tuple[tuple[str, str], ...]:
        """``(need, who)`` pairs: each need of :data:`escfit.balance.effects.base.NEEDS` and what asks for it."""
        out = [(need, f"[effects.{e.key}]") for e in self.effects for need in sorted(e.needs)]
        if self.restoring == "pendulum":
            out.append(("smooth", "[oscillator] restoring = 'pendulum'"))
        if self.switching == "phase":
            out.append(("phase_switching", "switching = 'phase'"))
        return tuple(out)

    @functools.cached_property
    def needs(self) -> frozenset[str]:
        """Everything a solver must handle."""
        return frozenset(need for need, _ in self.demands)

    @functools.cached_property
    def relations(self) -> tuple:
        """The effects that declare relations between their parameters (``refusals``)."""
        return tuple(e for e in self.effects if hasattr(e, "refusals"))

    @functools.cached_property
    def words(self) -> np.ndarray:
        """A record holding what the structure fixes, as its raw 8-byte words (read-only).

        The defaults, the restoring torque's kind, whether an effect adds a smooth torque (the
        integrators then add up :mod:`escfit.balance.acceleration`'s terms) and each effect's
        ``prepare``.  Parameter sets start from copies of it (a copy of the words is a memcpy; a
        structured copy goes field by field, ten times slower).
        """
        k = blank(1)
        k["pendulum"] = self.restoring == "pendulum"
        k["smooth"] = "smooth" in {need for e in self.effects for need in e.needs}
        for e in self.effects:
            getattr(e, "prepare", lambda _: None)(k)
        words = k.view(np.float64)
        words.flags.writeable = False
        return words

    def records(self, n: int) -> np.ndarray:
        """``n`` records prepared for this structure, to be filled with parameter values."""
        out = np.empty((n, self.words.size))
        out[:] = self.words  # n copies of the prepared words (np.tile's result, without its wrapping)
        return out.reshape(-1).view(COEFFICIENTS)


@dataclass(frozen=True)
class System:
    """Coefficient records of one scene's parameter sets, with the structure solvers check.

    Attributes
    ----------
    k : ndarray
        Records of :data:`escfit.balance.kernel_records.COEFFICIENTS`, shape ``(sets,)``.
    structure : Structure
        The scene's effects, restoring torque and switching law.
    """

    k: np.ndarray
    structure: Structure = Structure()

    @property
    def switching(self) -> str:
        return self.structure.switching

    @property
    def effects(self) -> tuple:
        return self.structure.effects

    @property
    def restoring(self) -> str:
        return self.structure.restoring

    def __len__(self) -> int:
        return self.k.shape[0]

    def __getitem__(self, i: int) -> "System":
        """Parameter set ``i`` alone."""
        i = range(len(self))[i]
        return System(self.k[i:i + 1], self.structure)

    @classmethod
    def stack(cls, systems: Sequence["System"]) -> "System":
        """The parameter sets of several systems as one (one switching law; effects pooled).

        Raises
        ------
        SolverError
            For no systems or mixed switching laws.
        """
        if not systems:
            raise SolverError("a batch needs at least one parameter set")
        structures = {id(s.structure): s.structure for s in systems}
        if len(structures) == 1:
            structure = systems[0].structure
        else:
            switching = {s.switching for s in systems}
            if len(switching) > 1:
                raise SolverError(f"a batch has one switching law, got {sorted(switching)}")
            effects = tuple({id(e): e for s in systems for e in s.effects}.values())
            restoring = "pendulum" if any(s.restoring == "pendulum" for s in systems) else "spring"
            structure = Structure(effects, restoring, systems[0].switching)
        return cls(np.concatenate([s.k for s in systems]), structure)

    # -- what the solvers are asked for -----------------------------------------------------------
    def demands(self) -> tuple[tuple[str, str], ...]:
        """``(need, who)`` pairs: each need of :data:`escfit.balance.effects.base.NEEDS` and what asks for it."""
        return self.structure.demands

    @property
    def needs(self) -> frozenset[str]:
        """Everything a solver must handle to run this system."""
        return self.structure.needs

    # -- one set's numbers -----------------------------------------------------------------------
    def field(self, name: str, i: int = 0) -> np.ndarray | float:
        """Slot ``name`` of set ``i``: a float, or the used entries of an array slot."""
        slot = next(s for s in SLOTS if s.name == name)
        value = self.k[name][i]
        if not slot.size:
            return value.item()
        n = int(self.k[slot.count][i]) + slot.extra if slot.count else slot.size
        return value[:n].copy()

    @property
    def theta0(self) -> float:
        """Release angle of set 0 (rad)."""
        return float(self.k["theta0"][0])

    @property
    def omega0(self) -> float:
        """Reference natural frequency of set 0 (rad/s)."""
        return float(self.k["omega0"][0])

    # -- refusals --------------------------------------------------------------------------------
    def refusals(self) -> list[str]:
        """Why each set would be refused before any work (``""`` when it is fine)."""
        k = self.k
        n = len(self)
        table = k.view(np.float64).reshape(n, _WIDTH)
        bad = np.empty(n, np.bool_)
        mode = (self.structure.restoring == "pendulum") + 2 * (self.structure.switching == "phase")
        n_bad = _flag_values(table, _CHECKS, mode, bad)
        checks = [check for e in self.structure.relations for check in e.refusals(k)]
        for flagged, _ in checks:
            bad |= flagged
        if not n_bad and not any(flagged.any() for flagged, _ in checks):  # the usual case: no message to build
            return [""] * n
        fine = ~bad
        reasons = [""] * n
        bad_finite = ~np.isfinite(table[:, _FINITE_COLS])
        with np.errstate(invalid="ignore"):
            bad_lower = table[:, _LOWER_COLS] < _LOWER_VALUES
        for i in np.flatnonzero(~fine):
            reasons[i] = self._reason(i, bad_finite[i], bad_lower[i], checks)
        return reasons

    def _reason(self, i: int, bad_finite: np.ndarray, bad_lower: np.ndarray, checks: list) -> str:
        k = self.k[i]
        if math.isnan(k["theta0"]):
            return ("theta0 is not given: the scene takes its release from a recording; give [oscillator] theta0 "
                    "to simulate it")
        if not math.isfinite(k["theta0"]):
            return f"parameter theta0 = {float(k['theta0'])!r} is not finite"
        for flag, (slot, _) in zip(bad_finite, _FINITE_OWNERS):
            if flag and self._used(slot, i):
                if slot.size:
                    return f"{slot.label} must be finite, got {list(map(float, self.field(slot.name, i)))!r}"
                return f"parameter {slot.label} = {float(k[slot.name])!r} is not finite"
        if self.restoring == "pendulum" and not abs(k["theta0"]) < math.pi:
            return f"a pendulum needs |theta0| < pi, got theta0 = {float(k['theta0'])!r} rad"
        for flag, (slot, j) in zip(bad_lower, _LOWER_OWNERS):
            if flag and self._used(slot, i):
                value = self.field(slot.name, i)
                shown = list(map(float, value)) if slot.size else float(value)
                return f"{slot.label} must be >= {slot.lower:g}, got {slot.label}={shown!r}"
        if self.switching == "phase" and not k["c"] < 2.0 * k["omega0"]:
            return (f"phase switching needs an underdamped balance, C < 2*omega0; got C={float(k['c']):g}, "
                    f"omega0={float(k['omega0']):g}")
        scalars = {s.name: float(k[s.name]) for s in SLOTS if not s.size and s.dtype == "f8"}
        for bad, template in checks:
            if bad[i]:
                return template.format(**scalars)
        return ""

    def _used(self, slot, i: int) -> bool:
        """Whether a flagged value lies in the used part of its slot (unused capacity is never refused)."""
        if not slot.size:
            return True
        value = self.field(slot.name, i)
        ok = np.isfinite(value) if slot.finite else np.ones(value.shape, bool)
        if slot.lower is not None:
            with np.errstate(invalid="ignore"):
                ok &= ~(value < slot.lower)
        return not ok.all()

    def check(self) -> None:
        """Raise :class:`~escfit.core.errors.SolverError` for the first set that would be refused."""
        for reason in self.refusals():
            if reason:
                raise SolverError(reason)
