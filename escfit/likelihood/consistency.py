"""What a recording measures directly about a parameter, for checking a fit against it.

Some recordings measure a parameter outright, independently of the likelihood's fit: a
sampled decay measures its period, hence omega0.  A problem may report, at any parameter
values, what the recording implies for such a parameter (:meth:`Problem.consistency`); the
inference layer compares it with the fit (:mod:`escfit.inference.reconcile`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Implied"]


@dataclass(frozen=True)
class Implied:
    """A parameter's fitted value against the value the recording implies for it.

    Attributes
    ----------
    name : str
        The parameter, e.g. ``"oscillator.omega0"``.
    fitted : float
        Its value in the fit.
    implied : float
        The value the recording implies, at the fit's other values (same unit).
    tolerance : float
        Largest ``|fitted - implied|`` the measurement's uncertainty explains.
    facts : str
        What was measured and what the fit gives, as a clause for messages.
    """

    name: str
    fitted: float
    implied: float
    tolerance: float
    facts: str

    @property
    def agrees(self) -> bool:
        return abs(self.fitted - self.implied) <= self.tolerance
