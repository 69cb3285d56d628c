"""What a table's columns are when the names do not say: uncertainties of others, and the clock.

Plotting and fitting programs write tables as ``x, y, dx, dy`` (or ``X, Y, X', Y'``, or
``Time, Amplitude, Time uncertainty, Amplitude uncertainty``): a column for each quantity and one
for its uncertainty.  Two pieces of evidence decide, never a name alone:

- **Companions.**  A column is the uncertainty of another when its name qualifies the other's
  (``dx``, ``δx``, ``x'``, ``x err``, ``sigma x``, ``Amplitude uncertainty``) or is a word
  of uncertainty on its own (``error``, ``uncertainty``, ``std``), *and* it is never negative (an
  uncertainty is a size; a derivative ``dx`` of a swing changes sign every half period).  A
  companion is never a candidate for the time or the signal.
- **The clock.**  When no name says which column is the time, the one column that rises at every
  row (a stamp repeated by rounding aside), and only one, is the clock: a signal that swings cannot, an uncertainty that is constant
  does not.

:func:`companions` and :func:`rising_clock` return what they found; the reader puts it in a note.
"""

from __future__ import annotations

import re
from typing import Mapping, Sequence

import numpy as np

__all__ = ["companions", "rising_clock", "base_name"]

_UNCERTAINTY_WORDS = ("uncertainty", "uncertainties", "unc", "uncert", "error", "errors", "err", "sigma", "σ", "std",
                      "stdev", "stddev", "delta", "δ", "δ", "fehler", "unsicherheit")
_PREFIXES = ("d", "δ", "δ", "u", "s", "e", "σ", "delta", "sigma", "err", "error", "unc")


def base_name(name: str) -> str:
    """A column name without its unit (``Time (s)`` -> ``time``, ``phi / deg`` -> ``phi``), lower case."""
    return re.sub(r"\s*([(\[].*|/.*)$", "", name.strip()).strip().lower()


def _tokens(base: str) -> list[str]:
    return [t for t in re.split(r"[\s_\-.:]+", base) if t]


def _qualifies(base: str, other: str) -> bool:
    """Whether ``base`` names the uncertainty of a column called ``other`` (both :func:`base_name`)."""
    if not other or base == other:
        return False
    if base in (other + "'", other + "′", other + "_err", other + "err"):
        return True
    for p in _PREFIXES:
        rest = base[len(p):].lstrip(" _") if base.startswith(p) else None
        if rest == other:
            return True
    words = _tokens(base)
    others = _tokens(other)
    extra = [w for w in words if w not in others]
    return bool(others) and all(w in words for w in others) and bool(extra) and \
        all(w in _UNCERTAINTY_WORDS for w in extra)


def companions(names: Sequence[str], values: Mapping[int, np.ndarray]) -> dict[int, int | None]:
    """Columns that are uncertainties: index -> the index of the column they qualify (None: no one).

    Parameters
    ----------
    names : sequence of str
        The header's names.
    values : mapping of int to ndarray
        Numeric columns by index (columns that are not numbers are left out).

    Returns
    -------
    dict of int to (int or None)
        Each companion column (never negative, named as an uncertainty) and what it qualifies.
    """
    bases = [base_name(n) for n in names]
    out: dict[int, int | None] = {}
    for i, base in enumerate(bases):
        v = values.get(i)
        if v is None or not base:
            continue
        finite = v[np.isfinite(v)]
        if finite.size == 0 or np.any(finite < 0.0):
            continue
        of = [j for j, other in enumerate(bases) if j != i and _qualifies(base, other)]
        if of:
            out[i] = of[0]
        elif any(w in _UNCERTAINTY_WORDS for w in _tokens(base)):
            out[i] = None
    return out


def rising_clock(values: Mapping[int, np.ndarray], *, min_rows: int = 20) -> int | None:
    """The one column that rises at every row (its finite values; stamps repeated by rounding, as
    when a clock is written to three digits, are allowed: it never falls and rises at one row in
    ten at least, or rounds an even clock, :func:`~escfit.analysis.rounded_stamps.rounded_clock`),
    or None when none or several do."""
    from .rounded_stamps import rounded_clock

    rising = []
    for i, v in values.items():
        finite = v[np.isfinite(v)]
        steps = np.diff(finite)
        if finite.size >= min_rows and np.all(steps >= 0.0) and \
                (np.mean(steps > 0.0) >= 0.1 or rounded_clock(finite) is not None):
            rising.append(i)
    return rising[0] if len(rising) == 1 else None
