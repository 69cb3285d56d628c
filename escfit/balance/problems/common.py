"""What every balance fit problem offers the inference layer beyond its likelihood.

:class:`BalanceProblem` fills in the parts of :class:`~escfit.likelihood.problem.Problem`
that are the same for unit curves, passage times, timegrapher readings and sampled
waveforms: units and meanings from the scene's parameters, the readings' coordinates,
provenance, Monday's derived ``K`` and the structural checks of
:mod:`escfit.balance.problems.checks`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ...likelihood.problem import ProblemBase
from .checks import end_of_motion, monday_k, phase_mode_warning

__all__ = ["BalanceProblem", "NOISE_PARAMS"]

# noise parameters of the balance observation models: least squares profiles or holds them
NOISE_PARAMS = ("observation.sigma", "observation.nu", "observation.sigma_t", "observation.rho")


class BalanceProblem(ProblemBase):
    """Mixin for balance fit problems (which set ``scene``, ``data``, ``params``, ``curves``,
    ``observation``, ``solver`` and ``solver_options``)."""

    family = "balance"

    @property
    def reading_units(self) -> str:
        """``"notches"`` for notch counts, else ``"rad"`` (recordings of times set their own)."""
        return "notches" if getattr(self.data, "kind", "") == "notches" else "rad"

    @property
    def noise_names(self) -> tuple[str, ...]:
        return tuple(n for n in NOISE_PARAMS if n in self.names)

    @property
    def observed(self) -> np.ndarray:
        """Every reading of every curve, concatenated in curve order."""
        return np.concatenate([c.y for c in self.curves])

    @property
    def n_data(self) -> int:
        return int(sum(c.y.size for c in self.curves))

    @property
    def units(self) -> dict[str, str]:
        out = {p.name: p.unit for p in self.params}
        out["K"] = ""
        return out

    @property
    def meanings(self) -> dict[str, str]:
        out = {p.name: p.meaning for p in self.params}
        out["K"] = "Monday's combined K (derived)"
        return out

    #: whether the readings come in branches (a unit curve's per-load curves) that the residual checks
    #: read one at a time
    readings_in_branches = False

    @property
    def misfit_options(self) -> dict[str, bool]:
        """How the generic residual checks read this problem's residuals."""
        ar1 = getattr(self.observation, "noise", "") == "ar1"
        return {"standardised": getattr(self.data, "kind", "") == "notches" or ar1,
                "branches": self.readings_in_branches, "innovations": ar1}

    def obs_coords(self) -> dict[str, Any]:
        swing = np.concatenate([c.swing for c in self.curves])
        curve = np.concatenate([[c.label] * c.swing.size for c in self.curves])
        load = np.concatenate([[c.load] * c.swing.size for c in self.curves])
        coords = {"obs": np.arange(swing.size), "swing": ("obs", swing), "curve": ("obs", curve.astype(str)),
                  "load": ("obs", load)}
        times = [getattr(c, "time", None) for c in self.curves]
        if all(t is not None for t in times):
            coords["time"] = ("obs", np.concatenate(times), {"units": "s"})
        return coords

    def provenance(self) -> dict[str, Any]:
        out = {"scene": self.scene.text, "scene_file": self.scene.where, "switching": self.scene.switching,
               "data_file": self.data.source, "data_sha256": self.data.sha256, "data_kind": self.data.kind,
               "solver": self.solver, "solver_options": self.solver_options}
        meta = getattr(self.data, "meta", None) or {}
        if "offset_rad" in meta:  # turning points read about an estimated centre: the fit's offset corrects it
            out.update(centre_removed_rad=float(meta["offset_rad"]),
                       centre_rate_removed_rad_per_s=float(meta.get("offset_rate_rad_per_s", 0.0)))
        window = getattr(self, "record_window", None)
        if window is not None:  # the record's first and last sample, the first and last instant fitted
            out.update(zip(("record_first_s", "record_last_s", "fit_first_s", "fit_last_s"), map(float, window)))
        keys = getattr(self.data, "window", None)  # the [recording] keys that set the window, if any
        set_by = [k for k in ("start", "release", "stop") if getattr(keys, k, None) is not None]
        if set_by:
            out.update(window_keys=", ".join(set_by))
        modes = getattr(self, "other_modes", ())
        if modes:  # the strongest weak oscillation beside the swing, which the fit leaves in the residuals
            period, share = max(modes, key=lambda m: m[1])
            out.update(second_mode_period_s=float(period), second_mode_share=float(share))
        if getattr(self.data, "kind", "") == "notches":  # how the counts read: the report draws their intervals
            out.update(notch_deg=math.degrees(float(self.data.notch)),
                       notch_reading=getattr(getattr(self, "observation", None), "reading", "counted"))
        return out

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        """Monday's combined K when his phase convention leaves only K determined."""
        if not phase_mode_warning(self):
            return {}
        return {"K": monday_k(self, values)}

    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        warnings = phase_mode_warning(self) + end_of_motion(self, best)
        rho = best.get("observation.rho", 0.0)
        if rho >= 0.95:
            warnings.append(f"the residuals are nearly a smooth curve (noise correlation rho = {rho:.2f} between "
                            "neighbouring samples): that is structure the model misses rather than reading noise; "
                            "the intervals describe the best fit of an incomplete model")
        return {}, warnings

    def consistency(self, values: Mapping[str, float]) -> list:
        """omega0 against the record's measured period, for sampled records (see
        :mod:`escfit.balance.problems.period`)."""
        from .period import period_consistency

        return period_consistency(self, values)

    def holding(self, name: str, value: float):
        """A copy of this problem with a parameter it holds (``held``) at ``value``: the fixed
        values the forward model reads and the parameter's record; this problem is unchanged."""
        import copy

        from ...core.errors import FitError

        if name not in self.held:
            raise FitError(f"{name} is not a parameter this problem holds")
        new = copy.copy(self)
        new._base = {**self._base, name: float(value)}
        new.params = self.params.with_values({name: value})
        for cache in ("_merged_fixed", "_merge_keys", "_layout_cache", "_readings_cache"):
            new.__dict__.pop(cache, None)
        return new

    def held_effects(self, values: Mapping[str, float]) -> list[tuple[str, float, dict[str, float]]]:
        """For each held parameter: its standard error and the derivative of every fitted
        parameter along the family of equally good fits (see :mod:`escfit.balance.problems.period`)."""
        from .period import held_omega0_effects

        return held_omega0_effects(self, values)

    def checks_of_posterior(self, chain: np.ndarray) -> list[str]:
        warnings = phase_mode_warning(self)
        if "observation.rho" in self.names:
            rho = float(np.median(chain[:, :, self.names.index("observation.rho")]))
            if rho >= 0.95:
                warnings.append(f"the posterior noise correlation is rho = {rho:.3f}: the residuals are nearly a "
                                "smooth curve, structure the model misses rather than reading noise")
        return warnings
