"""What a table's rows are: samples of a swing in time, or its turning points.

A table of turning points (each row the time and the signed extreme angle of one swing) and a
swing sampled in time are both two columns of times and angles.  The physics tells them apart:

- **turning points** come one per half swing, on alternate sides of the centre: the rows'
  values alternate in sign about a centre, their times step by a steady half period (a row the
  reader missed is a step of two half periods, the side unchanged), and their magnitudes are the
  swing's amplitude, which changes slowly from row to row and never grows in a free decay.  A
  table of one side's turning points (the peaks, a period apart) or of magnitudes read each side
  has one sign and the same steady steps and smooth magnitudes;
- **samples** alternate in sign row by row only when the sampling is close to two samples a
  period.  A sine of phase step ``pi (1 + e)`` per row is ``(-1)**k A sin(phi + pi e k)``: it
  fails to alternate on a share ``|e|`` of the steps (at each zero of its beat) and its
  magnitudes beat between 0 and the amplitude every ``1/|e|`` rows: they dip towards zero and
  rise again, where a turning-point table's change smoothly.  Rows of one sign that are
  samples (a swing about a far-off zero) oscillate about a decay curve instead of falling along
  it.

The exact two samples a period of a sine is a turning-point table of amplitude ``A |cos phi|``:
no table can tell them apart (aliasing), and a sampling within a few per cent of it, over fewer
rows than one beat, looks like a smooth decay.  Such a record is read as turning points; the
times then say what the swing's half period is.

:func:`judge_rows` measures the evidence and returns a :class:`RowKind` with the verdict
``"turning points"``, ``"samples"`` or ``"ambiguous"``.

Thresholds
----------
:data:`ALTERNATION` (0.9): the share of steps that cross the centre as their half-swing count
says that turning points show (a misread row or two aside); a sampled sine alternates this often
only within 10 % of two samples a period, where its magnitudes beat.
:data:`STEP_SPREAD` (0.1): the robust spread of the steps, per step (a turning time read off a
video frame grid of 1/30 s at a 0.75 s half period spreads 4 %).
:data:`SCATTER` (0.1): the robust scatter of the magnitudes about a free decay fitted to them
(``a exp(-g t) + b``: viscous and dry friction), per their median, 10 %: reading noise; a
beat's magnitudes scatter over the whole range.
:data:`DIP` (0.5): a row below half the decay curve is a dip (a beat passing zero); a
turning-point table has at most :data:`MAX_DIPS` (2 %) of them (a misread row).  Rows where the
curve is within three scatters of zero (the end of the motion) are not judged.
:data:`RISE` (0.15): the decay curve rising this much (relative) is no free decay.
:data:`FALL` (0.05): rows of one sign are turning points only when their decay curve falls at
least this much (relative) and three times their scatter over the table: a free decay's
amplitudes, not a swing's samples about a far-off zero.
Clearly samples: alternation under :data:`SAMPLED_ALTERNATION` (0.7) for rows of both signs, or
magnitudes scattering over 3 times :data:`SCATTER`, dipping on over 10 % of the rows or rising
twice :data:`RISE`.
:data:`ZIGZAG` (4): how many standard errors the alternate rows' difference from the decay
curve must reach for a table of one sign to be magnitudes read each side about a zero off the
centre (one per half swing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["RowKind", "judge_rows", "row_steps", "ALTERNATION", "STEP_SPREAD", "SCATTER", "DIP", "RISE", "ZIGZAG",
           "SAMPLED_ALTERNATION", "MIN_ROWS", "FALL"]

ALTERNATION = 0.9
SAMPLED_ALTERNATION = 0.7
STEP_SPREAD = 0.1
SCATTER = 0.1
DIP = 0.5
RISE = 0.15
FALL = 0.05
ZIGZAG = 4.0
MIN_ROWS = 4
MAX_DIPS = 0.02  # a turning-point table may hold a misread row or two


@dataclass(frozen=True)
class RowKind:
    """The evidence on what a table's rows are.

    Attributes
    ----------
    verdict : str
        ``"turning points"``, ``"samples"`` or ``"ambiguous"``.
    rows : int
        Rows judged.
    one_sided : bool
        All values of one sign (about zero) and not alternating about any centre: one side's
        turning points, or magnitudes.
    alternation : float
        Share (0-1) of the steps between rows that cross the centre as their half-swing count
        says (after one half swing to the other side, after two to the same side).
    step : float
        The step between rows, s: a half period for rows on alternate sides, one row's step for
        a table of one sign (a half period or a period: see :attr:`per_half_swing`).
    step_spread : float
        RMS spread of the steps (each divided by its whole number of steps) within 35 % of the
        usual step, per step; at least the share of steps farther off.
    missing : int
        Steps of two or more (rows not in the table).
    centre : float
        The centre the values alternate about (0 for a table of one sign), in the values' unit.
    scatter : float
        Robust scatter of the magnitudes about a free decay fitted to them, per their median.
    dips : float
        Share of the rows below :data:`DIP` of the decay curve (where it stands clear of the noise).
    rise : float
        Largest rise of the decay curve along the table (relative; 0 for a decay).
    zigzag : float
        For a table of one sign: the alternate rows' difference from the decay curve, in
        standard errors (magnitudes read each side about a zero off the centre show one).
    reasons : tuple of str
        Why the verdict is not ``"turning points"``.
    """

    verdict: str
    rows: int
    one_sided: bool = False
    alternation: float = math.nan
    step: float = math.nan
    step_spread: float = math.nan
    missing: int = 0
    centre: float = 0.0
    scatter: float = math.nan
    dips: float = math.nan
    rise: float = math.nan
    zigzag: float = math.nan
    reasons: tuple = ()

    @property
    def per_half_swing(self) -> bool | None:
        """Whether each row is a half swing: True for rows on alternate sides or a zig-zag of one
        sign, None for a table of one sign without one (the peaks a period apart, or magnitudes
        each side about a centred zero: the rows cannot say which)."""
        if not self.one_sided:
            return True
        return True if abs(self.zigzag) >= ZIGZAG else None

    def evidence(self) -> str:
        """The measured evidence in words."""
        side = ("all of one sign" if self.one_sided else
                f"signs alternating about the centre {self.centre:+.4g} on {100 * self.alternation:.0f} % of the steps")
        gaps = f", {self.missing} missing row(s)" if self.missing else ""
        zig = f", alternate rows {self.zigzag:+.1f} standard errors off the curve" if self.one_sided else ""
        return (f"{self.rows} rows {side}; steps {self.step:.4g} s with a spread of {100 * self.step_spread:.1f} %"
                f"{gaps}; magnitudes {100 * self.scatter:.1f} % about a free decay, {100 * self.dips:.0f} % of rows "
                f"dipping below half of it, rising {100 * self.rise:.0f} % at most{zig}")


def _steps(t: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Whole steps between rows (1 for neighbours, 2 for one row missing ...), the step and its spread."""
    d = np.diff(t)
    h = float(np.median(d))
    if not h > 0:
        return np.ones(d.size, dtype=np.int64), h, math.inf
    whole = np.maximum(np.rint(d / h), 1).astype(np.int64)
    rel = d / whole / h - 1.0
    if np.any(d < 0.5 * h):  # rows closer than half the usual step: not one per turning point
        rel = d / h - 1.0
    near = np.abs(rel) <= 0.35
    # the RMS of the steps near the usual one (times on a frame grid make most steps equal, so a
    # median deviation would say 0), and at least the share of steps far from it
    spread = float(np.sqrt(np.mean(rel[near] ** 2))) if near.any() else math.inf
    spread = max(spread, float(np.mean(~near)))
    return whole, h, spread


def row_steps(time: np.ndarray) -> np.ndarray:
    """Whole steps between successive rows (1 for neighbours, 2 where one row is missing ...),
    counted in the median step; ``time`` in s, sorted."""
    return _steps(np.asarray(time, float))[0]


def _alternation(v: np.ndarray, whole: np.ndarray) -> tuple[float, float]:
    """The centre the values alternate about and the share of steps that go to the side the step
    count says (the other side after an odd number of half swings, the same after an even one).

    Counted step by step, so that one misread row costs one or two steps, not every row after it."""
    pairs = whole == 1
    mids = 0.5 * (v[1:] + v[:-1])
    centre = float(np.median(mids[pairs] if pairs.any() else mids))
    side = np.sign(v - centre)
    flips = side[1:] != side[:-1]
    share = float(np.mean(flips == (whole % 2 == 1)))
    return centre, share


def _decay_fit(t: np.ndarray, m: np.ndarray, parity: np.ndarray | None) -> tuple[np.ndarray, float, float]:
    """The free decay through the magnitudes: ``a exp(-g t) + b`` (viscous and dry friction; ``g``
    scanned, negative for a growth; a straight line for pure dry friction), plus ``z (-1)**n``
    (a zig-zag of magnitudes read each side about a zero off the centre) when ``parity`` is given.

    Returns the curve (without the zig-zag), the robust scatter about it (per the median
    magnitude) and the zig-zag in standard errors."""
    x = (t - t[0]) / max(float(t[-1] - t[0]), 1e-300)
    extra = [] if parity is None else [parity]
    bases = [np.column_stack([np.ones_like(x), x] + extra)]
    bases += [np.column_stack([np.ones_like(x), np.exp(-g * x)] + extra) for g in _RATES if g != 0.0]
    best = None
    for design in bases:
        coef, *_ = np.linalg.lstsq(design, m, rcond=None)
        res = m - design @ coef
        cost = float(np.sum(res ** 2))
        if best is None or cost < best[0]:
            best = (cost, design, coef, res)
    _, design, coef, res = best
    curve = design[:, :2] @ coef[:2]
    scale = float(np.median(m))
    scatter = 1.4826 * float(np.median(np.abs(res - np.median(res)))) / scale if scale > 0 else math.inf
    zigzag = math.nan
    if parity is not None:
        dof = max(m.size - design.shape[1], 1)
        cov = float(np.sum(res ** 2)) / dof * np.linalg.pinv(design.T @ design)
        se = math.sqrt(max(cov[-1, -1], 0.0))
        zigzag = float(coef[-1] / se) if se > 0 else (0.0 if coef[-1] == 0 else math.copysign(math.inf, coef[-1]))
    return curve, scatter, zigzag


_RATES = np.linspace(-3.0, 8.0, 45)  # decay rates scanned, per table span (e-folds)


def judge_rows(time: np.ndarray, values: np.ndarray) -> RowKind:
    """Judge whether rows of (time, value) are turning points or samples (see the module docstring).

    Parameters
    ----------
    time : ndarray
        Row times, s (sorted here; rows with a non-finite time or value are left out).
    values : ndarray
        The rows' values (an angle or a displacement, any unit: only signs and ratios are used).

    Returns
    -------
    RowKind
    """
    t = np.asarray(time, float)
    v = np.asarray(values, float)
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    if t.size < MIN_ROWS or not np.ptp(t) > 0:
        return RowKind("ambiguous", int(t.size), reasons=(f"only {t.size} rows with distinct times",))
    whole, step, spread = _steps(t)
    count = np.concatenate([[0], np.cumsum(whole)])
    centre, share = _alternation(v, whole)
    one_sided = bool((np.all(v > 0) or np.all(v < 0)) and share < ALTERNATION)
    if one_sided:
        centre = 0.0
    m = np.abs(v - centre)
    parity = np.where(count % 2 == 0, 1.0, -1.0) if one_sided else None
    curve, scatter, zigzag = _decay_fit(t, m, parity)
    top = float(np.max(np.abs(curve))) if curve.size else 0.0
    floor = max(3.0 * scatter * float(np.median(m)), 1e-12 * top)  # magnitudes at the noise's level are not judged
    judged = curve > floor
    dips = float(np.mean(m[judged] < DIP * curve[judged])) if judged.any() else 0.0
    level = np.maximum(curve, floor)
    rise = float(np.max(level / np.minimum.accumulate(level)) - 1.0)
    reasons = []
    if not one_sided and share < ALTERNATION:
        reasons.append(f"the signs alternate about the centre on only {100 * share:.0f} % of the steps")
    if spread > STEP_SPREAD:
        reasons.append(f"the steps between rows spread {100 * spread:.0f} %")
    if scatter > SCATTER:
        reasons.append(f"the magnitudes scatter {100 * scatter:.0f} % about a free decay")
    if dips > MAX_DIPS:
        reasons.append(f"{100 * dips:.0f} % of the magnitudes dip below half the decay curve")
    if rise > RISE:
        reasons.append(f"the magnitudes rise {100 * rise:.0f} %")
    fall = float(1.0 - level[-1] / level[0])
    if one_sided and (fall < FALL or fall < 3.0 * scatter):
        reasons.append(f"the values, all of one sign, fall {100 * fall:.0f} % over the table: no decay of amplitudes")
    if not reasons:
        verdict = "turning points"
    elif ((not one_sided and share < SAMPLED_ALTERNATION) or scatter > 3 * SCATTER or dips > 0.1
          or rise > 2 * RISE or spread > 2.5 * STEP_SPREAD or (one_sided and fall < FALL)):
        verdict = "samples"
    else:
        verdict = "ambiguous"
    return RowKind(verdict, int(t.size), one_sided, share, step, spread, int(np.sum(whole > 1)), centre, scatter,
                   dips, rise, zigzag, tuple(reasons))
