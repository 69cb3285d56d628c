"""What a timegrapher reports, computed from the exact motion.

Beats
-----
A beat is heard as the balance passes its rest position; beat ``k`` of the model is the
zero crossing of half swing ``k``, read on the recording's clock as ``t0 + t_zero + noise``
(``observation.sigma_t``, s; ``observation.t0``, s).  Any constant acoustic latency is
absorbed in ``t0``.

Amplitude
---------
The instrument times the sound pulse of each beat: from the unlocking to the drop, i.e. the
passage through the lift ``[-L/2, +L/2]`` of the *true* lift angle ``L``
(``observation.lift_angle``, rad, a nuisance parameter with a prior around the lift angle set
on the instrument).  From the pulse duration ``t`` and the period ``T`` measured over the same
window (twice the mean beat interval) it forms ``A/L_set = 0.5 / sin(pi t / T)``, the harmonic
formula, averages it over the beats of the window, multiplies by the lift angle *set* on the
instrument ``L_set`` and displays the result (rounded to the display resolution).  The
expected reading is that number; the reading is it plus Gaussian noise ``observation.sigma``
(rad), then rounded:

- a rounded reading ``r`` has probability ``Phi((r + q/2 - mu)/s) - Phi((r - q/2 - mu)/s)``
  (``q`` the resolution);
- outside ``[lo, hi]`` (135-360 deg) the instrument shows nothing: a blank reading has
  probability ``1 - (Phi((hi - mu)/s) - Phi((lo - mu)/s))``; where rejected readings are
  simply left out (tg's dump) the readings present are a selection and each density is
  divided by ``Phi((hi - mu)/s) - Phi((lo - mu)/s)``.

A lift edge the balance does not reach is clamped to the turning point (see
:meth:`escfit.balance.solution.DenseSolution.crossings`), so ``t -> T/2`` and the reading tends continuously to
``L_set/2``.  The harmonic formula makes the reading ``L_set/L`` times an amplitude that is
itself only approximately the true one; that error is part of the model, not of the noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
from scipy import special

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.scene import check_keys
from ...core.units import BARE_ANGLE_LIMIT
from .notches import log_interval_mass

__all__ = ["TimegrapherObservation", "beat_events", "window_readings"]


def beat_events(dense, n_swings: int, lift: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-crossing time and sound-pulse duration of half swings ``1 .. n_swings``.

    Parameters
    ----------
    dense
        The run's dense solution (:class:`escfit.balance.solution.DenseSolution`).
    n_swings
        Half swings wanted (``nan`` for those the run did not reach).
    lift
        True lift angle, rad; the pulse lasts from ``x = -lift/2`` to ``x = +lift/2``.

    Returns
    -------
    t_zero, pulse : ndarray
        Seconds since release, and seconds.
    """
    m = np.arange(1, n_swings + 1, dtype=np.int64)
    t = dense.crossings(np.concatenate([m, m, m]), np.repeat([0.0, -0.5 * lift, 0.5 * lift], n_swings))
    tz, lo, hi = t[:n_swings], t[n_swings:2 * n_swings], t[2 * n_swings:]
    return tz, hi - lo


def window_readings(t_zero: np.ndarray, pulse: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Window-averaged amplitude fraction ``A/L_set`` a timegrapher would compute.

    Parameters
    ----------
    t_zero
        Beat times on the recording's clock, s (increasing; ``nan`` ignored at the end).
    pulse
        Sound-pulse duration of each beat, s.
    start, end
        Averaging window of each reading, s.

    Returns
    -------
    ndarray
        ``mean(0.5 / sin(pi * pulse / T))`` over the beats inside each window, with ``T``
        twice the mean beat interval there; ``nan`` when a window holds fewer than 2 beats.
    """
    ok = np.isfinite(t_zero)
    tz, pl = t_zero[ok], pulse[ok]
    i0 = np.searchsorted(tz, start, side="left")
    i1 = np.searchsorted(tz, end, side="right")
    out = np.full(start.size, np.nan)
    for k, (a, b) in enumerate(zip(i0, i1)):
        n = b - a
        if n < 2:
            continue
        period = 2.0 * (tz[b - 1] - tz[a]) / (n - 1)
        arg = np.clip(math.pi * pl[a:b] / period, 1e-12, 0.5 * math.pi)
        out[k] = float(np.mean(0.5 / np.sin(arg)))
    return out


@dataclass(frozen=True)
class TimegrapherObservation:
    """Beat times and window-averaged, rounded, range-limited amplitude readings.

    Attributes
    ----------
    params
        ``observation.sigma`` (rad), ``observation.lift_angle`` (rad), ``observation.sigma_t``
        (s) and ``observation.t0`` (s).
    use_beats
        Whether beat times enter the likelihood (``beats = false`` in the scene drops them).
    """

    params: tuple[Param, ...]
    use_beats: bool = True
    kind = "timegrapher"
    KEYS = {"model", "sigma", "lift_angle", "sigma_t", "t0", "beats"}

    @classmethod
    def from_table(cls, table: Mapping | None, where: str, *, lift_set: float,
                   release_s: float = 0.0) -> "TimegrapherObservation":
        """Read an ``[observation]`` table with ``model = "timegrapher"`` (or defaults).

        Parameters
        ----------
        lift_set
            Lift angle set on the instrument, rad: the default of the true lift angle, whose
            default prior is ``normal(lift_set, 2 deg)`` within +-15 deg.
        release_s
            Default release instant on the recording's clock, s.
        """
        table = dict(table or {})
        model = table.get("model", "timegrapher")
        if model != "timegrapher":
            raise SceneError(f"a timegrapher recording needs model = \"timegrapher\" in [observation], got {model!r}",
                             f"{where}.model")
        check_keys(table, cls.KEYS | {"model"}, where)
        beats = table.get("beats", True)
        if not isinstance(beats, bool):
            raise SceneError(f"beats must be true or false, got {beats!r}", f"{where}.beats")
        sigma = read_param(table.get("sigma", {"value": math.radians(1.0), "vary": True, "min": 1e-5, "max": 1.0,
                                               "prior": "loguniform(1e-5, 1)"}),
                           name="observation.sigma", kind="angle", lower=0.0, lower_open=True, bare_limit=BARE_ANGLE_LIMIT,
                           meaning="noise of an amplitude reading before rounding (rad)", where=f"{where}.sigma")
        d = math.radians(15.0)
        lift = read_param(table.get("lift_angle", {"value": lift_set, "vary": True, "min": lift_set - d,
                                                   "max": lift_set + d,
                                                   "prior": f"normal({lift_set!r}, {math.radians(2.0)!r})"}),
                          name="observation.lift_angle", kind="angle", lower=0.0, lower_open=True, bare_limit=BARE_ANGLE_LIMIT,
                          meaning="true lift angle of the escapement (rad); the instrument assumes the set one",
                          where=f"{where}.lift_angle")
        sigma_t = read_param(table.get("sigma_t", 1e-4), name="observation.sigma_t", kind="time", lower=0.0,
                             lower_open=True, meaning="timing noise of a beat (s)", where=f"{where}.sigma_t")
        t0 = read_param(table.get("t0", release_s), name="observation.t0", kind="time",
                        meaning="release instant on the recording's clock (s)", where=f"{where}.t0")
        return cls((sigma, lift, sigma_t, t0), beats)

    # -- amplitude readings ------------------------------------------------------------------
    @staticmethod
    def amp_loglike_pointwise(mu_deg: np.ndarray, y_deg: np.ndarray, sigma_deg: float, resolution: float,
                              amp_range: tuple[float, float], rejected_shown: bool) -> np.ndarray:
        """Log-probability of each amplitude reading (``nan`` = shown as rejected).

        Parameters
        ----------
        mu_deg
            Expected readings, deg (``nan``: the model gives the window no reading, which
            makes any reading impossible).
        y_deg
            Readings, deg.
        sigma_deg
            Reading noise, deg.
        resolution
            Display resolution, deg (0 = not rounded).
        amp_range
            ``(lo, hi)`` accepted by the instrument, deg.
        rejected_shown
            Whether rejected readings appear as ``nan`` (else readings are truncated).
        """
        lo, hi = amp_range
        zlo, zhi = (lo - mu_deg) / sigma_deg, (hi - mu_deg) / sigma_deg
        shown = np.isfinite(y_deg)
        out = np.full(y_deg.size, -np.inf)
        with np.errstate(invalid="ignore", divide="ignore"):
            if resolution > 0:
                a = (y_deg - 0.5 * resolution - mu_deg) / sigma_deg
                b = (y_deg + 0.5 * resolution - mu_deg) / sigma_deg
                ll = log_interval_mass(a, b)
            else:
                z = (y_deg - mu_deg) / sigma_deg
                ll = -0.5 * z * z - math.log(sigma_deg) - 0.5 * math.log(2 * math.pi)
            if not rejected_shown:
                ll = ll - log_interval_mass(zlo, zhi)
            out[shown] = ll[shown]
            rej = ~shown
            if rej.any():
                out[rej] = np.logaddexp(special.log_ndtr(zlo[rej]), special.log_ndtr(-zhi[rej]))
        out[~np.isfinite(mu_deg)] = -np.inf
        return np.where(np.isnan(out), -np.inf, out)

    @staticmethod
    def amp_residuals(mu_deg: np.ndarray, y_deg: np.ndarray, sigma_deg: float, resolution: float,
                      amp_range: tuple[float, float]) -> np.ndarray:
        """Standardised residuals for least squares: shown readings against the expectation
        (rounding as uniform noise); a rejected reading by how far the expectation lies inside
        the accepted range."""
        lo, hi = amp_range
        spread = math.sqrt(sigma_deg**2 + resolution**2 / 12.0)
        r = (y_deg - mu_deg) / spread
        inside = np.minimum(mu_deg - lo, hi - mu_deg)
        rej = np.where(inside > 0, inside / sigma_deg, 0.0)
        return np.where(np.isfinite(y_deg), r, rej)

    @staticmethod
    def amp_sample(mu_deg: np.ndarray, sigma_deg: float, resolution: float, amp_range: tuple[float, float],
                   rng: np.random.Generator) -> np.ndarray:
        """Synthetic displayed readings, deg (``nan`` where the instrument rejects them)."""
        y = mu_deg + sigma_deg * rng.standard_normal(mu_deg.size)
        if resolution > 0:
            y = resolution * np.round(y / resolution)
        lo, hi = amp_range
        return np.where((y >= lo) & (y <= hi), y, np.nan)

    # -- beats -------------------------------------------------------------------------------
    @staticmethod
    def beat_loglike_pointwise(t_model: np.ndarray, y: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        sigma = values["observation.sigma_t"]
        z = (y - values["observation.t0"] - t_model) / sigma
        return -0.5 * z * z - math.log(sigma) - 0.5 * math.log(2 * math.pi)
