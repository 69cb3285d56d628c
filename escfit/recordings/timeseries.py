"""Free-decay time series: the balance angle sampled in time, reduced to turning points.

CSV format
----------
Columns ``time_s`` and one angle column ``theta_rad``, ``theta_deg`` or ``theta_<unit>`` (any
angle unit pint knows), sampled at increasing times.  The series must start at the release
(the balance at rest at ``theta0``) unless a ``# release_s: <t>`` metadata line gives the
release instant; it may carry noise, quantisation (an encoder's steps) and a zero offset.

Turning points
--------------
:func:`turning_points` finds them in three steps, each chosen to survive noise and
quantisation:

1. the period ``P`` from the zero crossings of the smoothed, offset-free series;
2. candidate extrema of a Savitzky-Golay smoothing (window ``P/10``), merged so that maxima
   and minima alternate at least ``P/4`` apart;
3. at each candidate, a least-squares fit to the raw samples within ``+-window*P`` (default
   ``P/8``) of two quartics in ``s = t - t_c`` without linear term, one each side of the
   turning time ``t_c``, sharing the vertex value: the velocity vanishes at the turn but the
   curvature jumps there, because Coulomb friction reverses (a smooth polynomial across
   the turn misplaces it by about a millisecond).  ``t_c`` comes from a bounded scalar search,
   the rest from linear least squares.  Near a turning point the escapement does not act, so
   each side is a smooth damped oscillation; the fit averages the noise of some ``P/4`` of
   samples.

The zero offset is estimated from consecutive extrema ``e1, e2, e3`` as
``((e1 + e3)/2 + e2)/2`` (exact for a linear decay, second order otherwise), medianed over the
record, and subtracted before the amplitudes are formed; a remaining offset can be fitted
with the amplitude observation's ``observation.offset``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError
from ..units import ureg
from .csvtable import read_table
from .timegrapher import refuse_unless_csv
from .unit_curve import UnitCurve

__all__ = ["TimeSeries", "TurningPoints", "read_timeseries", "write_timeseries", "turning_points",
           "timeseries_to_unit_curve"]


@dataclass
class TimeSeries:
    """A sampled balance angle.

    Attributes
    ----------
    time : ndarray
        Sample times, s (strictly increasing).
    theta : ndarray
        Balance angle, rad, in the scene's frame (the scene releases at ``+theta0``; a
        sensor's zero offset is still in it).
    release_s : float
        Release instant, s (``nan``: the first sample).
    source, sha256, meta
        File name, content hash and ``# key: value`` metadata.
    """

    time: np.ndarray
    theta: np.ndarray
    release_s: float = math.nan
    source: str = ""
    sha256: str = ""
    meta: dict = field(default_factory=dict)
    kind = "timeseries"


@dataclass
class TurningPoints:
    """Turning points found in a series.

    Attributes
    ----------
    swing : ndarray of int
        Half swing each one ends (1 = the first after the release).
    time, theta : ndarray
        Time (s) and signed angle (rad, before removing the offset) of each.
    period : float
        Estimated period, s.
    offset : float
        Estimated zero offset, rad.
    """

    swing: np.ndarray
    time: np.ndarray
    theta: np.ndarray
    period: float
    offset: float


def read_timeseries(path: str | Path) -> TimeSeries:
    """Read a time-series CSV (see the module docstring).

    Raises
    ------
    DataError
        JSON, binary or empty files, missing or ambiguous columns, unknown or non-angle
        units, text or non-finite numbers, times that do not increase.
    """
    refuse_unless_csv(path, "a time series")
    t = read_table(path)
    where = t.path
    angle = [c for c in t.header if c.startswith("theta_")]
    if "time_s" not in t.header or len(angle) != 1:
        raise DataError(f"need columns time_s and one angle column theta_rad or theta_deg, header has {t.header}",
                        where)
    unknown = [c for c in t.header if c not in ("time_s", angle[0])]
    if unknown:
        raise DataError(f"unknown column(s) {unknown}; a time series has time_s and theta_rad|theta_deg", where)
    unit = angle[0][len("theta_"):]
    try:
        q = ureg.Quantity(1.0, unit)
    except Exception:
        raise DataError(f"unknown angle unit {unit!r} in column {angle[0]!r}", where) from None
    if not q.dimensionless:
        raise DataError(f"column {angle[0]!r}: {unit!r} is not an angle unit", where)
    factor = float(q.to("rad").magnitude)
    time = np.array(t.floats("time_s"))
    bad = np.flatnonzero(np.diff(time) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise DataError(f"times must increase: {t.rows[i - 1][t.header.index('time_s')]} then "
                        f"{t.rows[i][t.header.index('time_s')]}", f"{where}:{t.lines[i]} [time_s]")
    theta = np.array(t.floats(angle[0])) * factor
    release = math.nan
    if "release_s" in t.meta:
        try:
            release = float(t.meta["release_s"])
        except ValueError:
            raise DataError(f"release_s must be a number, got {t.meta['release_s']!r}",
                            f"{where} [release_s]") from None
    if time.size < 20:
        raise DataError(f"only {time.size} samples; a decay needs many samples per period", where)
    return TimeSeries(time, theta, release, where, t.sha256, dict(t.meta))


def write_timeseries(path: str | Path, series: TimeSeries, *, unit: str = "rad", decimals: int = 6,
                     comments: list[str] | None = None) -> None:
    """Write ``series`` in the CSV format :func:`read_timeseries` reads.

    Parameters
    ----------
    unit
        ``"rad"`` or ``"deg"`` for the angle column.
    decimals
        Decimals of the angle (times are written to 1 us).
    comments
        Comment lines; the series' metadata follows as ``# key: value`` lines.
    """
    if unit not in ("rad", "deg"):
        raise DataError(f"unit must be 'rad' or 'deg', got {unit!r}", str(path))
    values = series.theta if unit == "rad" else np.degrees(series.theta)
    lines = [f"# {c}" for c in (comments or [])]
    lines += [f"# {k}: {v}" for k, v in series.meta.items() if " " not in k and k != "release_s"]
    if math.isfinite(series.release_s):
        lines.append(f"# release_s: {series.release_s!r}")
    lines.append(f"time_s,theta_{unit}")
    lines += [f"{t:.6f},{v:.{decimals}f}" for t, v in zip(series.time, values)]
    Path(path).write_text("\n".join(lines) + "\n")


def _period(t: np.ndarray, x: np.ndarray) -> float:
    xc = x - np.median(x)
    up = np.flatnonzero((xc[:-1] < 0) & (xc[1:] >= 0))
    if up.size < 2:
        raise DataError("fewer than two upward zero crossings: not an oscillation (or far too short)", "")
    tc = t[up] - xc[up] * (t[up + 1] - t[up]) / (xc[up + 1] - xc[up])
    return float(np.median(np.diff(tc)))


def _kinked_vertex(u: np.ndarray, x: np.ndarray, degree: int = 4) -> tuple[float, float] | None:
    """Vertex ``(u_c, x_c)`` of a turning point from samples at scaled times ``u`` in [-1, 1].

    Each side is a polynomial of ``degree`` (default: quartic) in ``s = u - u_c`` without a
    linear term (the velocity is zero at the turn), sharing the vertex value; the curvatures
    may differ because Coulomb friction reverses there.  Linear least squares for a given
    ``u_c``, a bounded scalar search over it.
    """
    from scipy.optimize import minimize_scalar

    def solve(uc: float):
        s = u - uc
        left = s < 0
        cols = [np.ones_like(s)]
        for p in range(2, degree + 1):
            sp = s**p
            cols += [np.where(left, sp, 0.0), np.where(left, 0.0, sp)]
        a = np.stack(cols, axis=1)
        coef, *_ = np.linalg.lstsq(a, x, rcond=None)
        r = a @ coef - x
        return float(r @ r), float(coef[0])

    if min(np.sum(u < -0.3), np.sum(u > 0.3)) < 4:
        return None
    res = minimize_scalar(lambda uc: solve(uc)[0], bounds=(-0.5, 0.5), method="bounded",
                          options={"xatol": 1e-7})
    if not res.success or abs(res.x) > 0.49:
        return None
    return float(res.x), solve(float(res.x))[1]


def turning_points(series: TimeSeries, *, window: float = 0.125, degree: int = 4) -> TurningPoints:
    """Locate the turning points of a sampled decay (see the module docstring).

    Parameters
    ----------
    series
        The samples.
    window
        Half width of the local fits, in periods.
    degree
        Degree of the polynomial each side of a turning point (2 to 6).

    Raises
    ------
    DataError
        No oscillation, fewer than 8 samples per fit window, or no turning point found.
    """
    from scipy.signal import savgol_filter

    if not 2 <= degree <= 6:
        raise DataError(f"degree must be 2 to 6, got {degree!r}", series.source)
    t, x = series.time, series.theta
    dt = float(np.median(np.diff(t)))
    try:
        period = _period(t, x)
    except DataError as exc:
        raise DataError(exc.message, series.source) from None
    per_window = window * period / dt
    if per_window < 4:
        raise DataError(f"{2 * per_window:.1f} samples per fit window ({window:g} period each side); sample faster "
                        "than 16 per period", series.source)
    n_smooth = max(5, int(round(0.1 * period / dt)) | 1)
    smooth = savgol_filter(x, n_smooth, 2, mode="interp")
    d = np.diff(smooth)
    cand = np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0) + 1
    # alternate maxima and minima at least a quarter period apart: a noise wiggle near an
    # extremum gives max-min-max in quick succession, of which the more extreme max survives
    keep: list[int] = []
    kinds: list[bool] = []
    for i in cand:
        is_max = bool(d[i - 1] > 0)
        if keep:
            j = keep[-1]
            if is_max == kinds[-1]:
                if (smooth[i] > smooth[j]) == is_max:
                    keep[-1] = i
                continue
            if t[i] - t[j] < 0.25 * period:
                continue
        keep.append(i)
        kinds.append(is_max)
    half = window * period
    times, values = [], []
    for i in keep:
        lo, hi = np.searchsorted(t, [t[i] - half, t[i] + half])
        if t[i] - half < t[0] or t[i] + half > t[-1] or hi - lo < 8:
            continue  # a one-sided window would bias the vertex
        fit = _kinked_vertex((t[lo:hi] - t[i]) / half, x[lo:hi], degree)
        if fit is None:
            continue
        times.append(t[i] + fit[0] * half)
        values.append(fit[1])
    if len(values) < 1:
        raise DataError("no turning point found (is the series long enough?)", series.source)
    times_a, values_a = np.array(times), np.array(values)
    release = series.release_s if math.isfinite(series.release_s) else t[0]
    swing = np.rint((times_a - release) / (0.5 * period)).astype(np.int64)
    after = swing >= 1  # the release itself (balance held, then let go) is not a turning point of the motion
    times_a, values_a, swing = times_a[after], values_a[after], swing[after]
    if not swing.size:
        raise DataError("no turning point after the release", series.source)
    if np.any(np.diff(swing) <= 0):
        raise DataError("turning points do not fall one per half period after the release; is the series a free "
                        "decay starting at the release (or does release_s say when)?", series.source)
    if values_a.size >= 3:
        e = values_a
        offset = float(np.median(0.5 * (0.5 * (e[:-2] + e[2:]) + e[1:-1])))
    elif values_a.size == 2:
        offset = float(0.5 * (values_a[0] + values_a[1]))
    else:
        offset = 0.0
    return TurningPoints(swing, times_a, values_a, period, offset)


def timeseries_to_unit_curve(series: TimeSeries, *, window: float = 0.125, degree: int = 4, remove_offset: bool = True,
                             release_theta: float | None = None, tolerance: float = 0.05) -> UnitCurve:
    """Amplitudes of the turning points of a decay, as a unit curve.

    Parameters
    ----------
    series
        The samples.
    window, degree
        Half width of the local fits in periods, and their degree (see :func:`turning_points`).
    remove_offset
        Subtract the estimated zero offset before taking ``|theta|``.
    release_theta
        The scene's release angle (rad); when given, a series that does not start there
        (within ``tolerance`` relative) is refused as belonging to another scene.
    tolerance
        Relative tolerance of that check.

    Returns
    -------
    UnitCurve
        ``kind = "amplitude"`` readings (rad) per half swing with their times; the offset and
        period estimates are in ``meta``.

    Raises
    ------
    DataError
        When the series does not match ``release_theta`` or has no turning points.
    """
    tp = turning_points(series, window=window, degree=degree)
    off = tp.offset if remove_offset else 0.0
    if release_theta is not None:
        start = series.theta[0] - off if not math.isfinite(series.release_s) else \
            float(np.interp(series.release_s, series.time, series.theta)) - off
        if abs(start - release_theta) > tolerance * abs(release_theta) + 1e-9:
            raise DataError(f"the series starts at {start:.4g} rad but the scene releases the balance at "
                            f"{release_theta:.4g} rad (theta0)", series.source)
    meta = dict(series.meta)
    meta.update(derived_from="time series (local quartic fits at the turning points)", period_s=repr(tp.period),
                offset_rad=repr(tp.offset), offset_removed=str(bool(remove_offset)))
    amp = np.abs(tp.theta - off)
    return UnitCurve(tp.swing, amp, "amplitude", unit=np.full(amp.size, "", dtype=str), time=tp.time,
                     source=series.source, sha256=series.sha256, meta=meta)
