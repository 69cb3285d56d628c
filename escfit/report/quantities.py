"""Quantities people quote, derived from a saved fit by its model family.

Each family says which quantities it derives and how (:meth:`escfit.core.family.Family.derived`;
the balance wheel's and pendulum's: :mod:`escfit.balance.derived`).  Here each is computed at
every posterior draw (a least-squares fit: at draws of the normal approximation of its
parameters, clipped to their bounds), and shown as the median and 95 % interval of those
values, in the units people read.  Held parameters enter at their values.
"""

from __future__ import annotations

import numpy as np

from ..core.display import format_row
from ..core.errors import SceneError
from ..core.family import get_family
from .params import held_values

__all__ = ["derived_rows", "parameter_draws"]

N_DRAWS = 4000
MIN_INSIDE = 50  # below one draw in this many inside the bounds, the draws are clipped instead


def parameter_draws(res, rng: np.random.Generator | None = None) -> dict[str, np.ndarray]:
    """Draws of every parameter (canonical units): the posterior's, else the least-squares normal
    approximation restricted to the bounds (:func:`_bounded_normal`); held parameters as constants."""
    post, lsq = res.arrays("posterior"), res.arrays("least_squares")
    out: dict[str, np.ndarray] = {}
    if post is not None:
        for name in res.parameter_names:
            if name in post:
                out[name] = np.asarray(post[name].values, float).ravel()
    elif lsq is not None:
        rng = rng or np.random.default_rng(0)
        names = list(map(str, lsq["parameter"].values))
        value = lsq["value"].values.astype(float)
        se = np.nan_to_num(lsq["stderr"].values.astype(float), nan=0.0)
        corr = np.nan_to_num(lsq["correlation"].values.astype(float), nan=0.0)
        np.fill_diagonal(corr, 1.0)
        cov = corr * np.outer(se, se)
        lo = lsq["min"].values.astype(float) if "min" in lsq else np.full(len(names), -np.inf)
        hi = lsq["max"].values.astype(float) if "max" in lsq else np.full(len(names), np.inf)
        draws = _bounded_normal(rng, value, cov, lo, hi)
        out = {n: draws[:, i] for i, n in enumerate(names)}
    size = max((v.size for v in out.values()), default=1)
    for name, value in held_values(res).items():
        out.setdefault(name, np.full(size, value))
    return out


def _bounded_normal(rng: np.random.Generator, value: np.ndarray, cov: np.ndarray, lo: np.ndarray,
                    hi: np.ndarray) -> np.ndarray:
    """:data:`N_DRAWS` draws of the normal ``N(value, cov)`` that lie inside the bounds.

    Draws outside are left out, not clipped: clipping each parameter on its own breaks their
    correlation (two losses that trade along a ridge, one of them on its bound 0, would both be
    pushed up, and the loss they share with them), while leaving draws out keeps every draw on
    the ridge.  Where fewer than one draw in :data:`MIN_INSIDE` lies inside (a normal
    approximation far out of its bounds), the draws are clipped as a last resort.
    """
    kept, first, drawn = [], None, 0
    block = 2 * N_DRAWS
    while drawn < N_DRAWS * MIN_INSIDE:
        size = min(block, N_DRAWS * MIN_INSIDE - drawn)
        draws = value + rng.multivariate_normal(np.zeros(value.size), cov, size=size, method="eigh",
                                                check_valid="ignore")
        first = draws if first is None else first
        kept.append(draws[np.all((draws >= lo) & (draws <= hi), axis=1)])
        drawn += size
        if sum(map(len, kept)) >= N_DRAWS:
            return np.concatenate(kept)[:N_DRAWS]
        block *= 4  # few inside: draw more at once
    return np.clip(first[:N_DRAWS], lo, hi)


def derived_rows(res) -> tuple[list[str], list[list[str]], str]:
    """Header, rows and a closing sentence of the derived-quantities table (empty when the fit's
    family derives nothing, or is not registered here).

    Rows: ``[quantity, unit, median, 95 % interval, formula]``.
    """
    try:
        family = get_family(str(res.attrs.get("model", "balance")))
    except SceneError:
        return [], [], ""
    quantities, note = family.derived(parameter_draws(res), res.attrs)
    rows = [row for row in map(_row, quantities) if row is not None]
    if not rows:
        return [], [], ""
    how = ("posterior draws" if res.arrays("posterior") is not None
           else "the least-squares estimate's normal approximation")
    note = f"{note} Medians and 95 % intervals over {how}; held parameters at their values.".lstrip()
    return ["quantity", "unit", "median", "95% interval", "formula"], rows, note


def _row(quantity) -> list[str] | None:
    """A table row of ``(label, unit, values, formula)``: median and 95 % interval of the values
    (NaN dropped); None when no finite median."""
    label, unit, values, formula = quantity
    v = np.asarray(values, float).ravel()
    v = v[~np.isnan(v)]
    if not v.size:
        return None
    lo, med, hi = np.quantile(v, [0.025, 0.5, 0.975])
    finite = np.isfinite([lo, med, hi])
    if not finite[1]:
        return None
    text, ends = format_row(med, (lo, hi), (hi - lo) if finite.all() else None)
    ends = [e if f else "∞" for e, f in zip(ends, finite[[0, 2]])]
    return [label, unit, text, f"[{ends[0]}, {ends[1]}]", formula]
