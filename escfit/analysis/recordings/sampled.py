"""A sampled record as the turning-point analysis holds it, and the local fits that place a turn.

:class:`SampledRecord` carries the samples, their smoothing and what the first steps of
:func:`~escfit.analysis.recordings.turning_points.reduce_series` learnt about them (period,
noise, quantisation, the rest band and the extremum search's hysteresis), and places a turning
point from the raw samples around it: a kinked polynomial (the curvature jumps where Coulomb
friction reverses), a plain parabola when that fails, or, for a record of fewer than
``ARC_SAMPLES_PER_PERIOD`` samples a period, an arc of the record's oscillation (a damped
sinusoid of the record's period with its third harmonic).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from .extrema import kinked_vertex
from .series import show_value

__all__ = ["SampledRecord", "MIN_SAMPLES_PER_PERIOD", "ARC_SAMPLES_PER_PERIOD"]

MIN_SAMPLES_PER_PERIOD = 16  # the local fits need some 5 samples each side of a turn
# below this many samples a period a turn is placed by an arc of the record's oscillation, not a
# polynomial: over the 9-25 samples of a turn a polynomial of degree 4 misses the vertex by 0.1-1 %
# of the amplitude, by more or less as the samples fall (a slow false trend of the decay); at 60
# samples a period it is within 1e-5, and closer than the arc on a pendulum swinging past 60 deg
ARC_SAMPLES_PER_PERIOD = 50


@dataclass
class SampledRecord:
    """The samples and what the first steps learnt about them."""

    t: np.ndarray
    x: np.ndarray
    xs: np.ndarray  # smoothed
    period: float
    dt: float
    band: float  # half width of the rest band, rad
    step: float  # hysteresis of the extremum search, rad
    window: float
    degree: int
    where: str
    notes: list
    shared: bool  # noise or quantisation dominate: only the curvature kinked at a turn
    sigma: float = 0.0  # reading noise, rad
    quantum: float = 0.0  # sensor step, rad
    quantity: str = "angle"  # what the samples are (the units of the notes)
    warnings: list = field(default_factory=list)  # what the user must know (a large part left out)
    steps: list = field(default_factory=list)  # offset steps found: (first sample moved, s; jump; note)
    find_steps: bool = True  # look for offset steps (not in a record they were already taken out of)
    cut_end: float = float("nan")  # the free decay chosen ends here, s: a push after it (nan: none)
    other_modes: tuple = ()  # weak oscillations besides the swing: (period s, share of its power)
    moving_at_start: bool = False  # the samples start in motion (cut where a drive was switched off): no hold, no turn there

    def show(self, value: float, digits: int = 3, *, signed: bool = False) -> str:
        """A value of the record's quantity for a note (angles in degrees)."""
        return show_value(value, self.quantity, digits, signed=signed)

    def head(self, n: int) -> "SampledRecord":
        """The first ``n`` samples, with the same findings (the notes, warnings and steps are shared)."""
        return replace(self, t=self.t[:n], x=self.x[:n], xs=self.xs[:n])

    def half_width(self) -> float:
        """Half width of a local vertex fit, s: ``window`` periods, at least 4.5 samples."""
        return min(max(self.window * self.period, 4.5 * self.dt), 0.3 * self.period)

    def refine(self, first: int, last: int, *, is_max: bool | None = None, flat: str = "",
               degree: int | None = None) -> tuple[float, float] | None:
        """Time (s) and value (rad) of the vertex spanning samples ``first..last``.

        ``None`` when the fit window does not fit in the record.  A failed fit of an extremum
        (``is_max`` given) falls back to the smoothed extremum with a note, because the
        numbering depends on keeping it; a failed fit of a release or stop gives ``None``.
        ``degree`` overrides the record's polynomial degree.
        """
        t, x = self.t, self.x
        if self.period / self.dt < ARC_SAMPLES_PER_PERIOD and is_max is not None:
            got = self._arc(first, last, is_max)
            if got is not None:
                return got
        tc = 0.5 * (t[first] + t[last])
        half = max(self.half_width(), 0.5 * (t[last] - t[first]) + 3 * self.dt)
        got = None
        for _ in range(4):  # recentre on a vertex found off-centre
            if min(tc - t[0], t[-1] - tc) < 0.4 * half:
                return None
            lo, hi = np.searchsorted(t, [tc - half, tc + half], side="right")
            fit = kinked_vertex((t[lo:hi] - tc) / half, x[lo:hi], degree or self.degree, flat=flat,
                                shared=self.shared)
            if fit is None:
                break
            tc += fit[0] * half
            if abs(fit[0]) < 0.3:
                got = (tc, fit[1])
                break
        else:
            if fit is not None and abs(fit[0]) < 0.7:
                got = (tc, fit[1])
        if is_max is None:
            return got
        if got is not None and self._plausible(first, last, is_max, *got):
            return got
        # noise can make the kinked fit prefer a corner away from the turn: a plain parabola then
        para = self._parabola(first, last, is_max)
        if para is not None:
            return para
        span = self.xs[first:last + 1]
        i = first + int(np.argmax(span) if is_max else np.argmin(span))
        self._note_fallback(float(t[i]))
        return float(t[i]), float(self.xs[i])

    def _note_fallback(self, at: float) -> None:
        """One note for every turning point whose local fit failed: how many, and the first."""
        for k, note in enumerate(self.notes):
            found = re.match(r"the local fit failed at (\d+) turning point\(s\), the first near (t = \S+ s)", note)
            if found:
                self.notes[k] = (f"the local fit failed at {int(found.group(1)) + 1} turning point(s), the first near "
                                 f"{found.group(2)}; the smoothed extremum is used there")
                return
        self.notes.append(f"the local fit failed at 1 turning point(s), the first near t = {at:.4g} s; the smoothed "
                          "extremum is used there")

    def _arc(self, first: int, last: int, is_max: bool) -> tuple[float, float] | None:
        """Vertex of an oscillation of the record's period through the samples within a third
        of a period of the smoothed extremum.

        The arc is linear in its coefficients: ``c + (p + p' t) cos(w t) + (q + q' t) sin(w t)
        + p3 cos(3 w t) + q3 sin(3 w t)``, a sinusoid whose amplitude changes linearly across
        the turn (damping) with its third harmonic (a pendulum's swing is flatter at the top than
        a sinusoid: at 45 deg the harmonic is a third of a percent of it).  The harmonic needs 9
        samples and the changing amplitude 11; fewer, and the plain sinusoid is fitted.  The
        vertex is where the arc's slope is zero, from the fundamental's phase by Newton's steps.
        On noise-free pendulum records (15-80 deg, 20-40 samples a period) this places the
        amplitude within 1e-4 of the exact turning point, where a polynomial over the few
        samples of a turn misses by 0.1-1 %, depending on where the samples fall (the rows
        below :data:`ARC_SAMPLES_PER_PERIOD`).
        """
        t, x = self.t, self.x
        centre = 0.5 * (t[first] + t[last])
        if min(centre - t[0], t[-1] - centre) < 0.4 * self.period / 3.0:
            return None  # the arc would reach past the record's edge: the caller places such a turn
        sel = np.abs(t - centre) <= self.period / 3.0
        arc = self.fit_arc(sel, centre)
        if arc is None:
            return None
        t0 = arc.vertex(is_max)
        got = (centre + t0, arc.at(t0)[0])
        p, q, w = arc.p, arc.q, arc.w
        # the vertex lies beyond the nearest sample by at most what the arc rises over one interval
        amp = math.hypot(p, q)
        sign = 1.0 if is_max else -1.0
        beyond = sign * (got[1] - (np.max(x[sel]) if is_max else np.min(x[sel])))
        near = abs(t0) <= 0.15 * self.period + 0.5 * (t[last] - t[first])
        ok = near and math.isfinite(got[1]) and -self.step <= beyond <= amp * (1.0 - math.cos(w * self.dt)) + self.step
        return got if ok else None

    def fit_arc(self, sel: np.ndarray, centre: float) -> "_Arc | None":
        """The arc of :meth:`_arc` through the samples ``sel``, its time counted from ``centre``
        (s); None with fewer than 5 samples."""
        n = int(np.count_nonzero(sel))
        if n < 5:
            return None
        w = 2.0 * math.pi / self.period
        ts = self.t[sel] - centre
        cols = [np.ones_like(ts), np.cos(w * ts), np.sin(w * ts)]
        if n >= 9:
            cols += [np.cos(3.0 * w * ts), np.sin(3.0 * w * ts)]
        if n >= 11:
            cols += [ts * np.cos(w * ts), ts * np.sin(w * ts)]
        coef = np.zeros(7)
        coef[:len(cols)] = np.linalg.lstsq(np.stack(cols, axis=1), self.x[sel], rcond=None)[0]
        return _Arc(w, *coef)

    def _plausible(self, first: int, last: int, is_max: bool, tc: float, value: float) -> bool:
        """Whether a vertex lies near the smoothed extremum, in time and in value."""
        t = self.t
        centre = 0.5 * (t[first] + t[last])
        span = self.xs[first:last + 1]
        ext = float(np.max(span) if is_max else np.min(span))
        near = abs(tc - centre) <= 0.15 * self.period + 0.5 * (t[last] - t[first])
        return near and abs(value - ext) <= self.step

    def _parabola(self, first: int, last: int, is_max: bool) -> tuple[float, float] | None:
        """Vertex of a parabola through the samples within an eighth of a period of the smoothed extremum."""
        t, x = self.t, self.x
        centre = 0.5 * (t[first] + t[last])
        half = max(0.125 * self.period + 0.5 * (t[last] - t[first]), 3.5 * self.dt)
        sel = np.abs(t - centre) <= half
        if np.count_nonzero(sel & (t < centre)) < 3 or np.count_nonzero(sel & (t > centre)) < 3:
            return None
        c2, c1, c0 = np.polyfit(t[sel] - centre, x[sel], 2)
        if (c2 >= 0) if is_max else (c2 <= 0):
            return None
        s = -c1 / (2.0 * c2)
        if abs(s) > half:
            return None
        got = (centre + s, c0 - c1 * c1 / (4.0 * c2))
        return got if self._plausible(first, last, is_max, *got) else None


@dataclass(frozen=True)
class _Arc:
    """``c + (p + pd t) cos(w t) + (q + qd t) sin(w t) + p3 cos(3 w t) + q3 sin(3 w t)``."""

    w: float
    c: float
    p: float
    q: float
    p3: float
    q3: float
    pd: float
    qd: float

    def vertex(self, is_max: bool, guess: float | None = None) -> float:
        """Time (s from the centre) where the slope vanishes: Newton's steps from ``guess``
        (default: the fundamental's own maximum or minimum)."""
        u = guess if guess is not None else (
            math.atan2(self.q, self.p) / self.w if is_max else math.atan2(-self.q, -self.p) / self.w)
        for _ in range(8):
            _, slope, curvature = self.at(u)
            if curvature == 0.0 or not math.isfinite(curvature):
                break
            u -= slope / curvature
        return u

    def at(self, u: float) -> tuple[float, float, float]:
        """Value, slope and curvature at ``u`` (s from the arc's centre)."""
        w = self.w
        co, si, c3, s3 = math.cos(w * u), math.sin(w * u), math.cos(3 * w * u), math.sin(3 * w * u)
        a, b = self.p + self.pd * u, self.q + self.qd * u
        value = self.c + a * co + b * si + self.p3 * c3 + self.q3 * s3
        slope = w * (-a * si + b * co) + self.pd * co + self.qd * si + 3 * w * (-self.p3 * s3 + self.q3 * c3)
        curvature = (-w * w * (a * co + b * si) + 2 * w * (-self.pd * si + self.qd * co)
                     - 9 * w * w * (self.p3 * c3 + self.q3 * s3))
        return value, slope, curvature
