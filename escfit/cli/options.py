"""Option types of the command line that refuse what click's own types let through.

click's ``float`` and ``FloatRange`` accept ``nan`` (every comparison with it is false, so
no bound stops it) and ``inf``: ``--noise nan`` would write a recording of NaN, and
``--checkpoint-every nan`` would never save.  :class:`FiniteFloat` takes only finite numbers,
within optional bounds, and names the option and the value when it refuses one.
"""

from __future__ import annotations

import math

import click

from ..core.limits import STEPS_MAX, WALKERS_MAX

__all__ = ["FiniteFloat", "StepsType", "MethodType", "WALKERS_MAX", "STEPS_MAX"]


class FiniteFloat(click.ParamType):
    """A finite number, optionally within ``[low, high]`` (``low_open``/``high_open`` exclude the end).

    Parameters
    ----------
    low, high
        Bounds (``None``: none on that side).
    unit
        Named after the value in the refusal, e.g. ``"deg"``.
    """

    name = "number"

    def __init__(self, low: float | None = None, high: float | None = None, *, low_open: bool = False,
                 high_open: bool = False, unit: str = "") -> None:
        self.low, self.high, self.low_open, self.high_open, self.unit = low, high, low_open, high_open, unit

    def _range(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        if self.low is not None and self.high is not None:
            return (f"in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"
                    f"{unit}")
        if self.low is not None:
            return f"{'>' if self.low_open else '>='} {self.low:g}{unit}"
        if self.high is not None:
            return f"{'<' if self.high_open else '<='} {self.high:g}{unit}"
        return "finite"

    def convert(self, value, param, ctx):
        try:
            x = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(x):
            self.fail(f"{value!r} is not a finite number (the value must be {self._range()})", param, ctx)
        below = self.low is not None and (x <= self.low if self.low_open else x < self.low)
        above = self.high is not None and (x >= self.high if self.high_open else x > self.high)
        if below or above:
            self.fail(f"{value!r} is not {self._range()}", param, ctx)
        return x


class StepsType(click.ParamType):
    """``--steps``: a whole number of steps (at least 10, at most :data:`STEPS_MAX`) or ``auto``
    (sample until converged)."""

    name = "N|auto"

    def convert(self, value, param, ctx):
        if value == "auto":
            return value
        if isinstance(value, int) and not isinstance(value, bool):
            n = value
        else:
            try:
                n = int(str(value))
            except ValueError:
                n = None
        if n is None or not 10 <= n <= STEPS_MAX:
            self.fail(f"{value!r} is neither 'auto' nor a whole number of steps in [10, {STEPS_MAX}]", param, ctx)
        return n


class MethodType(click.ParamType):
    """``--method``: ``leastsq``, ``emcee`` or ``lmfit:NAME`` for any lmfit minimiser escfit runs
    (checked against :data:`escfit.inference.lmfit_path.LMFIT_METHODS` without importing lmfit)."""

    name = "leastsq|emcee|lmfit:NAME"

    def convert(self, value, param, ctx):
        from ..core.errors import FitError
        from ..inference.lmfit_path import check_method

        try:
            check_method(str(value))
        except FitError as exc:
            self.fail(str(exc), param, ctx)
        return str(value)
