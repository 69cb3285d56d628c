"""Damping drift (Monday's Fig. 18): C grows a little every cycle as the motion decays.

After each full cycle the envelope ``exp(-int C dt / 2)`` is compared with descending
``thresholds``; the band it falls in selects the fractional growth ``rates[band]`` applied to
C (``rates`` has one more entry than ``thresholds``: the last applies below the smallest
threshold).  Monday's curve: thresholds 0.15, 0.03, 0.005 with rates 3 %, 1.5 %, 0.5 %, 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.params import Param
from ...core.scene import check_keys
from .base import ReadContext, Slot, toml_number

__all__ = ["ViscousDrift", "MAX_BANDS"]

#: Most envelope thresholds a drift may have (the record's capacity).
MAX_BANDS = 8


@dataclass(frozen=True)
class ViscousDrift:
    """Structure-only effect: envelope thresholds and per-cycle growth rates of C."""

    thresholds: tuple[float, ...]
    rates: tuple[float, ...]
    key = "viscous_drift"
    coordinates = frozenset({"angle"})
    needs = frozenset({"drift"})
    SLOTS = (
        Slot("n_bands", 0, "drift thresholds", "", "number of envelope thresholds", dtype="i8"),
        Slot("drift_th", 0.0, "drift thresholds", "", "envelope thresholds, descending", size=MAX_BANDS,
             count="n_bands"),
        Slot("drift_rate", 0.0, "drift rates", "", "fractional growth of C per cycle in each band (one more than "
             "thresholds; all zero: no drift)", size=MAX_BANDS + 1, count="n_bands", extra=1),
    )

    @classmethod
    def read(cls, table: Mapping, ctx: ReadContext) -> tuple["ViscousDrift", list[Param]]:
        where = f"{ctx.where} [effects.viscous_drift]"
        check_keys(table, {"thresholds", "rates"}, where, {"thresholds", "rates"})
        th, rates = table["thresholds"], table["rates"]
        ok = isinstance(th, list) and isinstance(rates, list) and len(rates) == len(th) + 1
        if not ok or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in [*th, *rates]):
            raise SceneError("'thresholds' and 'rates' must be lists of numbers, rates one longer", where)
        if any(not 0 < t < 1 for t in th) or any(b >= a for a, b in zip(th, th[1:])):
            raise SceneError(f"thresholds must lie in (0, 1) and decrease, got {th!r}", f"{where}.thresholds")
        if len(th) > MAX_BANDS:
            raise SceneError(f"{len(th)} thresholds; at most {MAX_BANDS} are supported", f"{where}.thresholds")
        if any(r <= -1 for r in rates):
            raise SceneError(f"rates must exceed -1 (fractional change per cycle), got {rates!r}", f"{where}.rates")
        return cls(tuple(map(float, th)), tuple(map(float, rates))), []

    @staticmethod
    def random(rng, s) -> str:
        """Damping that grows by up to 5 % a cycle as the envelope decays."""
        r1, r2 = rng.uniform(0.0, 0.05), rng.uniform(0.0, 0.05)
        return (f"[effects.viscous_drift]\nthresholds = [0.5, 0.1]\n"
                f"rates = [{toml_number(r1)}, {toml_number(r2)}, 0.0]\n")

    @staticmethod
    def example(w0: float, a0: float) -> dict[str, str]:
        """A typical instance for the conformance suite, with the viscous damping it changes."""
        return {"viscous": f"C = {0.05 * w0!r}\n",
                "viscous_drift": "thresholds = [0.8, 0.5]\nrates = [0.05, 0.02, 0.0]\n"}

    def prepare(self, k: np.ndarray) -> None:
        n = len(self.thresholds)
        k["n_bands"] = n
        k["drift_th"][:, :n] = self.thresholds
        k["drift_rate"][:, :n + 1] = self.rates

    def fill(self, values: Mapping[str, float], k: np.ndarray) -> None:
        pass  # structure only
