"""The nuisance parameters escfit adds to a sampled record's fit, held within what the record shows.

The centre of oscillation and its drift are kinematic facts of the record, measured from the
turning points' midpoints (:mod:`escfit.analysis.recordings.centre`) with their standard
errors.  Left free over wide ranges, a centre offset and a drift trade off with the decay
itself (a large-amplitude pendulum's losses are not exactly viscous or Coulomb, and a drift
can take up the difference: the damping doubles and the Coulomb friction vanishes).  So both
get a normal prior at the measured value with the measured standard error, within eight of
them: the fit may refine them as far as the record allows, no further.  A scene that gives
``[observation] offset`` or ``offset_rate`` itself keeps its own.
"""

from __future__ import annotations

import math

__all__ = ["centre_priors", "MIN_STDERR"]

MIN_STDERR = 1e-9  # rad or rad/s: an exact record's centre is still given a little room
SPAN = 8.0  # bounds at this many standard errors from the measured value


def _normal(value: float, sd: float) -> dict:
    sd = max(float(sd), MIN_STDERR) if math.isfinite(sd) else None
    if sd is None:
        return {"value": value, "vary": True, "min": value - 1.0, "max": value + 1.0}
    return {"value": value, "vary": True, "min": value - SPAN * sd, "max": value + SPAN * sd,
            "prior": f"normal({value!r}, {sd!r})"}


def centre_priors(tp, *, sign: float = 1.0, removed: bool = False) -> dict:
    """``[observation]`` entries for ``offset`` and ``offset_rate`` from the turning-point analysis.

    Parameters
    ----------
    tp
        The record's :class:`~escfit.analysis.recordings.turning_points.TurningPoints`.
    sign
        ``+1``: the observation's offset is the centre on the sensor's scale; ``-1``: it is
        minus that (the waveform convention, a reading being ``theta - offset``).
    removed
        The centre and its kept drift are already taken out of the readings (turning-point
        amplitudes): the parameters are corrections, centred on 0 (and on the measured drift
        less the kept one).

    Returns
    -------
    dict
        ``{"offset": {...}, "offset_rate": {...}}`` parameter tables with normal priors.
    """
    offset = 0.0 if removed else sign * float(tp.offset)
    kept = float(getattr(tp, "offset_rate", 0.0))
    measured = float(getattr(tp, "offset_rate_measured", kept))
    rate = sign * (measured - kept if removed else measured)
    rate_sd = float(getattr(tp, "offset_rate_stderr", math.nan))
    return {"offset": _normal(offset, float(getattr(tp, "offset_stderr", math.nan))),
            "offset_rate": _normal(rate, rate_sd)}
