"""Numbers in words for the plain sentences of a fit (see :mod:`escfit.report.plain`).

A median and its 95 % interval as "1.2 % (between 1.1 and 1.3 %, 95 %)", a share as "about two
thirds", and the friction coefficients of any family in a sentence.  Families write their own
sentences with these (:meth:`escfit.core.family.Family.plain`).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

__all__ = ["sig", "quantiles", "interval_words", "share_words", "fraction_words", "join_words",
           "coefficient_sentences"]


def sig(x: float, digits: int = 2) -> str:
    """``x`` to ``digits`` significant figures, without an exponent for everyday sizes."""
    if not math.isfinite(x):
        return "∞" if x > 0 else ("−∞" if x < 0 else "nan")
    if x == 0:
        return "0"
    decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
    if abs(x) >= 1e6 or abs(x) < 1e-4:
        return f"{x:.{digits - 1}e}"
    return f"{round(x, decimals):.{decimals}f}"


def quantiles(values) -> tuple[float, float, float]:
    """``(median, 2.5 %, 97.5 %)`` of the finite values (nans when there are none)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not v.size:
        return math.nan, math.nan, math.nan
    lo, med, hi = np.quantile(v, [0.025, 0.5, 0.975])
    return float(med), float(lo), float(hi)


def interval_words(values, unit: str = "", digits: int = 2) -> str:
    """``"1.2 % (between 1.1 and 1.3 %, 95 %)"``: the median and 95 % interval of ``values``."""
    med, lo, hi = quantiles(values)
    u = f" {unit}" if unit else ""
    if not math.isfinite(med):
        return "not determined"
    while digits < 4 and len({sig(lo, digits), sig(med, digits), sig(hi, digits)}) < 3 and lo < med < hi:
        digits += 1  # a narrow interval: enough figures to tell its ends from the median
    return f"{sig(med, digits)}{u} (between {sig(lo, digits)} and {sig(hi, digits)}{u}, 95 %)"


def share_words(share) -> str:
    """``"about two thirds (64 %, between 50 and 80 %)"`` for a share (0-1) of a whole."""
    med, lo, hi = quantiles(100 * np.asarray(share, float))
    digits = 2
    while digits < 3 and sig(lo, digits) == sig(hi, digits) and lo < hi:
        digits += 1  # a narrow interval: "between 85 and 85 %" says nothing
    if sig(lo, digits) == sig(hi, digits):
        return f"{fraction_words(med / 100)} ({sig(med, digits)} %)"
    return f"{fraction_words(med / 100)} ({sig(med, digits)} %, between {sig(lo, digits)} and {sig(hi, digits)} %)"


def fraction_words(x: float) -> str:
    """A fraction (0-1) as people say it: "about a third", "nearly all"."""
    # each word covers the values nearest it: 86 % is "most", not "about three quarters"
    for value, words in ((0.995, "all"), (0.9, "nearly all"), (0.8, "most"), (0.7, "about three quarters"),
                         (0.6, "about two thirds"), (0.4, "about half"), (0.29, "about a third"),
                         (0.2, "about a quarter"), (0.05, "a small part"), (0.0, "hardly any")):
        if x >= value:
            return words
    return "none"


def join_words(parts: list[str]) -> str:
    """``"a, b and c"``."""
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def coefficient_sentences(draws: Mapping[str, Any]) -> list[str]:
    """Friction coefficients (parameters named ``*.mu*`` that vary over the draws) in words."""
    out = []
    for name, values in draws.items():
        values = np.asarray(values, float)
        if name.split(".")[-1].startswith("mu") and np.ptp(values) > 0:
            where = name.split(".")[0]
            out.append(f"The friction coefficient μ ({where}) is {interval_words(values)}: the sliding surfaces "
                       f"resist with {sig(quantiles(values)[0] * 100)} % of the force pressing them together.")
    return out
