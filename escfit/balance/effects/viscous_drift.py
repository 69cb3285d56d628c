"""Damping drift (Monday's Fig. 18): C grows a little every cycle as the motion decays.

After each full cycle the envelope ``exp(-int C dt / 2)`` is compared with descending
``thresholds``; the band it falls in selects the fractional growth ``rates[band]`` applied to
C (``rates`` has one more entry than ``thresholds``: the last applies below the smallest
threshold).  Monday's curve: thresholds 0.15, 0.03, 0.005 with rates 3 %, 1.5 %, 0.5 %, 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from ...core.errors import SceneError
from ...core.params import Param
from ...core.scene import check_keys
from .base import ReadContext, SystemBuilder

__all__ = ["ViscousDrift"]


@dataclass(frozen=True)
class ViscousDrift:
    """Structure-only effect: envelope thresholds and per-cycle growth rates of C."""

    thresholds: tuple[float, ...]
    rates: tuple[float, ...]
    key = "viscous_drift"

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
        if any(r <= -1 for r in rates):
            raise SceneError(f"rates must exceed -1 (fractional change per cycle), got {rates!r}", f"{where}.rates")
        return cls(tuple(map(float, th)), tuple(map(float, rates))), []

    def apply(self, values: Mapping[str, float], sys: SystemBuilder) -> None:
        sys.drift_thresholds = list(self.thresholds)
        sys.drift_rates = list(self.rates)
