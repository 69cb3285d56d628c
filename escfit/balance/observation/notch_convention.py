"""Which notch reading convention the readings follow: counted marks or the nearest mark.

Read with the other convention than the scene's, every notch interval is half a notch off.  A
fit absorbs most of such a shift into C, R and X (which are then biased), so the check looks
where it cannot: the positions of the best-fit amplitudes inside their intervals, and the
release readings when the release angle is fixed (see :func:`notch_reading_report`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["notch_reading_report", "POSITION_Z", "ANCHOR_ODDS"]

POSITION_Z = 4.0  # |mean position - 1/2| / standard error above which notch positions are flagged
ANCHOR_ODDS = 100.0  # odds for the other notch reading convention at the anchors above which it is flagged
EDGE = 0.1  # a position within this fraction of a notch from an interval edge counts as "at an edge"
MIN_READINGS = 8
_OTHER = {"counted": ("nearest", 0.5, "the mark nearest the turning point"),
          "nearest": ("counted", -0.5, "marks passed from the rest position")}


def _log_reading_probability(position: np.ndarray, jitter: float) -> np.ndarray:
    """log P(reading | expected amplitude) for an amplitude at ``position`` of its interval (in
    notches from the lower edge) and a normal reading jitter of ``jitter`` notches."""
    from scipy import special

    a, b = -position / jitter, (1.0 - position) / jitter
    upper = a > 0  # mirrored interval in the upper tail, for accuracy
    lo, hi = np.where(upper, -b, a), np.where(upper, -a, b)
    lhi, llo = special.log_ndtr(hi), special.log_ndtr(lo)
    with np.errstate(divide="ignore"):
        return lhi + np.log1p(-np.exp(llo - lhi))


def notch_reading_report(position: np.ndarray, *, reading: str, jitter: float, anchor: np.ndarray | None = None,
                         curve: np.ndarray | None = None) -> tuple[dict, list[str]]:
    """Check whether notch readings follow the other reading convention.

    Under the right convention the best-fit amplitudes spread over their readings' notch
    intervals (position uniform on [0, 1) blurred by the jitter, mean 1/2).  Read with the
    other convention every interval is half a notch off.  A fit often absorbs most of that
    shift into its parameters (which are then biased), but not where the amplitude is known
    without the fit: readings of the release angle when it is fixed (``anchor``).  Two tests:

    - **positions**: the mean position differs from 1/2 by more than ``POSITION_Z`` standard
      errors ``sqrt((1/12 + jitter**2) / n)``, towards the edge the other convention predicts;
    - **anchors**: the odds of the anchor readings under the other convention against this
      one exceed ``ANCHOR_ODDS`` (by the likelihood ratio's property, a false alarm rate of at
      most ``1/ANCHOR_ODDS`` when this convention is right).

    Parameters
    ----------
    position
        Position of each expected amplitude inside its reading's interval under the fit's
        convention, in notches from the interval's lower edge (0 lower edge, 1 upper edge;
        outside [0, 1) when outside), as :meth:`NotchObservation.interval_position` gives.
    reading
        The fit's convention, ``"counted"`` or ``"nearest"``.
    jitter
        Reading jitter (``observation.sigma``) in notches, > 0.
    anchor
        Readings whose amplitude the fit does not adjust (boolean mask), or ``None``.
    curve
        Curve label of each reading: positions are tested per curve, anchors together.

    Returns
    -------
    (dict, list of str)
        Figures (``notch_position_mean``, ``notch_position_z``, ``notch_edge_share`` per curve,
        ``notch_anchor_log_odds``) and warnings naming ``notch_reading``.
    """
    f = np.asarray(position, float)
    if reading not in _OTHER:
        raise ValueError(f"reading must be 'counted' or 'nearest', got {reading!r}")
    other, shift, other_words = _OTHER[reading]
    s = float(jitter) if np.isfinite(jitter) and jitter > 0 else 1e-3
    labels = np.zeros(f.size, dtype=object) if curve is None else np.asarray(curve, dtype=object)
    several = len(set(labels.tolist())) > 1
    advice = (f"set [observation] notch_reading = \"{other}\" if the marks were read as {other_words}; fitted under "
              f"the wrong convention every amplitude is off by half a notch and the damping parameters are biased "
              f"without the fit looking worse")
    figures: dict = {}
    warnings: list[str] = []
    for label in dict.fromkeys(labels.tolist()):
        ff = f[(labels == label) & np.isfinite(f)]
        if ff.size < MIN_READINGS:
            continue
        mean = float(np.mean(ff))
        z = (mean - 0.5) / math.sqrt((1.0 / 12.0 + s * s) / ff.size)
        edge = float(np.mean((ff < EDGE) | (ff > 1.0 - EDGE)))
        prefix = f"{label}: " if several else ""
        figures.update({prefix + "notch_position_mean": mean, prefix + "notch_position_z": z,
                        prefix + "notch_edge_share": edge})
        if abs(z) < POSITION_Z:
            continue
        side = "lower" if z < 0 else "upper"
        text = (f"{prefix}the best-fit amplitudes sit piled towards the {side} edge of their notch intervals (mean "
                f"position {mean:.2f} of a notch, {abs(z):.1f} standard errors from the middle; {100 * edge:.0f} % within "
                f"{EDGE:g} notch of an edge)")
        if (z < 0) == (shift > 0):  # the edge the other convention predicts
            warnings.append(f"{text}: the readings probably follow the other convention, notch_reading = \"{other}\", "
                            f"not \"{reading}\"; {advice}")
        else:
            warnings.append(f"{text}: the notch angle or the scale's zero (observation.offset) may be wrong")
    if anchor is not None:
        fa = f[np.asarray(anchor, bool) & np.isfinite(f)]
        if fa.size:
            log_odds = float(np.sum(_log_reading_probability(fa + shift, s) - _log_reading_probability(fa, s)))
            figures["notch_anchor_log_odds"] = log_odds
            if log_odds > math.log(ANCHOR_ODDS):
                odds = f"{math.exp(log_odds):.3g}" if log_odds < 700 else "more than 1e300"
                warnings.append(f"the reading{'s' if fa.size > 1 else ''} of the release angle, which the fit does not "
                                f"adjust, favour notch_reading = \"{other}\" over \"{reading}\" by {odds} to 1; {advice}")
    return figures, warnings
