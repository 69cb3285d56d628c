"""Where a drive that kept the swing steady was switched off: the change from a steady swing to a decay.

A free oscillator loses at every half swing, and loses no less at a larger amplitude than at a
smaller one: Coulomb friction takes the same amount at every amplitude, viscous damping an
amount in proportion to it, air drag in proportion to its square.  So when the first stretch
of a record keeps its peak-to-peak swing ``p_k`` (nearly) steady while the swings just after
it, smaller, lose steadily, the first stretch cannot have been free: something (a motor, a
hand) made up its losses, and the free decay starts where that stopped.

The change is found as a split of ``p``: for each candidate half swing ``m``, ``p`` over the
first half swings (until :data:`MIN_AFTER` after the swing has fallen to :data:`SPAN_FALL` of its start) is
fitted by least squares with a straight line before ``m`` and a parabola from ``m`` on (a
decay's losses shrink as it fades: the parabola follows that curvature; the half swing in
which the drive stops lies between the two and joins the one it fits better).  The ``m``
whose split fits best is the change; it is a drive switched off when

- the slope before it (the loss per half swing of the early stretch) is under
  :data:`LOSS_SHARE` of the slope just after it (the free loss measured there, at a smaller
  amplitude, where a free decay would lose less, not more), and
- that difference of slopes stands :data:`Z_DRIVE` standard errors out of the scatter of the
  swings about the fit (reading noise, a drive's own unsteadiness and the decay's departure
  from a parabola alike), and
- the record goes on for at least :data:`MIN_FREE` half swings after the change: a release
  starts a free decay of several periods, while a swing that a hand or a brake stops at the end
  of a long, slowly losing free decay collapses within a few (the same two slopes, but the free
  decay is the stretch before the change, and taking it for a drive would fit the hand).

A fixed tolerance on how steady the early swing must be (a share of the record's median swing)
fails exactly where a drive is followed by a long decay: the median swing is then the decay's,
small against the drive's, and a drive's slight unsteadiness exceeds that tolerance.  The
comparison here is against the record's own scatter and the loss measured after the change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DriveOff", "drive_off", "not_a_wobble", "Z_DRIVE", "LOSS_SHARE", "SPAN_FALL"]

Z_DRIVE = 5.0  # evidence the change needs, in standard errors of the difference of slopes
LOSS_SHARE = 0.5  # an early stretch losing under this share of the free loss after it was driven
SPAN_FALL = 0.4  # the fit spans the half swings until the swing has fallen to this share of its start
MAD = 1.4826  # median absolute deviation -> standard deviation of a normal sample
MIN_BEFORE = 2  # half swings before the change at least (a slope; one or two: segments.driven_start)
MIN_AFTER = 5  # half swings after the change at least (a parabola and its scatter)
MIN_FREE = 10  # half swings of the record after the change at least: the free decay a release starts
WOBBLE_WINDOW = 12  # half swings, at most, of the stretches whose changes of loss a drive's must stand out of
COARSE = 200  # candidate splits tried one by one; a longer record is searched on a grid first


@dataclass(frozen=True)
class DriveOff:
    """A drive switched off, found among the first half swings.

    Attributes
    ----------
    half_swing : int
        ``m``: the first free half swing (from turning point ``m`` to ``m + 1``); the free decay
        is taken from turning point ``m`` (a drive stopped within half swing ``m - 1`` or ``m``).
    loss_before, loss_after : float
        Loss of the peak-to-peak swing per half swing before the change and just after it (the
        record's unit, rad for an angle).
    score : float
        Difference of those losses over its standard error.
    """

    half_swing: int
    loss_before: float
    loss_after: float
    score: float


def _split_fit(p: np.ndarray, m: int, bend: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """Residual sum of squares, coefficients and unscaled covariance of the fit split before ``m``.

    ``p[:m]`` by a line, ``p[m:]`` by a parabola (``bend``) or a line, each with its own level;
    the slopes are taken at the last half swing before the split and at the first after it
    (coefficients 1 and 3).
    """
    k = np.arange(p.size, dtype=float)
    before = k < m
    u, w = np.where(before, k - (m - 1), 0.0), np.where(before, 0.0, k - m)
    columns = [before.astype(float), u, (~before).astype(float), w] + ([w * w] if bend else [])
    design = np.stack(columns, axis=1)
    coef, *_ = np.linalg.lstsq(design, p, rcond=None)
    r = p - design @ coef
    return float(r @ r), coef, np.linalg.pinv(design.T @ design)


def _best_split(p: np.ndarray, candidates: range) -> int:
    """The candidate split whose fit (:func:`_split_fit`) leaves the least residual.

    Every candidate is tried up to :data:`COARSE` of them; a longer record (thousands of half
    swings before its swing has fallen, each fit over all of them) is searched on a grid of about
    that many, then around its three best points at every candidate: linear in the record's
    length instead of quadratic, and the same split wherever the residual falls towards one
    change, as a drive's does.
    """
    step = max(1, -(-len(candidates) // COARSE))
    sse = {m: _split_fit(p, m)[0] for m in candidates[::step]}
    if step > 1:
        for m0 in sorted(sse, key=sse.get)[:3]:
            for m in range(max(candidates.start, m0 - step + 1), min(candidates.stop, m0 + step)):
                if m not in sse:
                    sse[m] = _split_fit(p, m)[0]
    return min(sse, key=lambda m: (sse[m], m))


def drive_off(values: np.ndarray) -> DriveOff | None:
    """The drive switched off at the start of ``values`` (alternating turning points), or ``None``.

    See the module docstring.  ``None`` also when too few half swings follow the change.
    """
    v = np.asarray(values, float)
    p = np.abs(np.diff(v))
    if p.size < MIN_BEFORE + MIN_AFTER or not np.all(np.isfinite(p)):
        return None
    start = float(np.median(p[:3]))
    fallen = np.flatnonzero(p < SPAN_FALL * start)
    # the change comes before the swing has fallen, and a fast decay needs a few half swings after it
    n = min(int(fallen[0]) + MIN_AFTER, p.size) if fallen.size else p.size
    p = p[:n]
    candidates = range(MIN_BEFORE, n - MIN_AFTER + 1)
    if not candidates:
        return None
    m = _best_split(p, candidates)
    # the evidence from straight lines either side: a line through a decay's curving losses
    # gives the loss after the change as less than it is at its start (never more, as a
    # parabola's end slope may on noisy swings)
    q = p[:min(n, m + max(m, MIN_AFTER))]  # after the change as many half swings as before it
    sse, coef, cov = _split_fit(q, m, bend=False)
    dof = q.size - 4
    if dof < 1:
        return None
    # the scatter about the best split understates the noise (the split was chosen to fit it):
    # no less than the swings' own, from their second differences (a turning point's noise s
    # gives p a noise of sqrt(2) s and p's second differences one of 2 s)
    d2 = np.diff(q, 2)
    s_p = MAD * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(2.0)
    s2 = max(sse / dof, s_p * s_p)
    b1, b2 = float(coef[1]), float(coef[3])  # slopes before and just after the change (per half swing)
    var = s2 * float(cov[1, 1] + cov[3, 3] - 2.0 * cov[1, 3])
    score = (b1 - b2) / math.sqrt(var) if var > 0 else math.inf
    # a free decay follows a drive's switch-off for several periods; a swing that collapses within
    # a few half swings after a long, slowly losing stretch was stopped (a hand, a brake) at the
    # end of a free decay, which that stretch is
    free = v.size - 1 - m
    if b2 < 0 and -b1 < LOSS_SHARE * -b2 and score > Z_DRIVE and free >= MIN_FREE \
            and not_a_wobble(np.abs(np.diff(v)), m, b1 - b2):
        return DriveOff(m, -b1, -b2, score)
    return None


def not_a_wobble(p: np.ndarray, m: int, change: float) -> bool:
    """Whether the change of loss at ``m`` stands out of the changes between consecutive
    stretches of the same length along the rest of the record (a slow wobble of the swing makes
    its loss rise and fall all along; a drive switched off changes it once): relative to the
    swing, over :func:`escfit.analysis.segments.stands_out`.  True when the record is too short
    to say.

    The stretches are :data:`MIN_AFTER` to :data:`WOBBLE_WINDOW` half swings long; after a long
    prefix (a wobble's slow half cycle can keep the swing for tens of half swings) the change at
    ``m`` is measured again over that length, so that the record after it holds enough of them.
    """
    from .segments import stands_out

    length = max(MIN_AFTER, min(m, WOBBLE_WINDOW))
    k = np.arange(length, dtype=float)

    def change_at(j: int) -> float:
        a, b = p[j - length:j], p[j:j + length]
        return (np.polyfit(k, a, 1)[0] - np.polyfit(k, b, 1)[0]) / float(np.mean(np.r_[a, b]))

    if length < m and m + length <= p.size:
        early = change_at(m)
    else:
        early = change / float(np.mean(p[:m + length]))
    later = [change_at(j) for j in range(m + 2 * length, p.size - length + 1, length)]
    return stands_out(early, np.array(later), least=3) is not False
