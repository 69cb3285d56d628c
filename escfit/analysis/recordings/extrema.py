"""Signal-level tools for sampled oscillations: period, resolution, extrema, vertex fits.

These know nothing of swings, releases or files; :mod:`escfit.analysis.recordings.turning_points`
composes them into the analysis of a recorded decay.  Angles are in the series' unit (rad),
times in s.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["periodogram", "spectral_period", "extrema_period", "power_near", "smooth", "smoothing_window", "smoothing_share", "resolution", "alternating_extrema", "kinked_vertex", "vertex_at",
           "local_amplitude"]


# the longest zero-padded transform of a periodogram (32 MB of input, as much of spectrum): a
# record of more than 2^22 / 8 samples (half a million) is padded less, not at all beyond 2^22
# samples; its frequency grid, 1 / (samples * dt), is then finer than any working period needs
MAX_FFT = 1 << 22


def periodogram(t: np.ndarray, x: np.ndarray, oversample: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and power of ``x`` resampled on a uniform grid, its mean and linear trend
    removed, under a Tukey window (10 % tapers), zero-padded ``oversample`` times (less beyond
    :data:`MAX_FFT` points)."""
    from scipy.fft import next_fast_len, rfft, rfftfreq

    from ...core.filters import tukey

    n = t.size
    dt = (t[-1] - t[0]) / (n - 1)
    xu = np.interp(t[0] + dt * np.arange(n), t, x)
    s = np.arange(n) - 0.5 * (n - 1)
    xu = xu - xu.mean() - s * (s @ xu) / (s @ s)
    del s
    nfft = next_fast_len(oversample * n if oversample * n <= MAX_FFT else max(n, MAX_FFT))
    xu *= tukey(n, 0.1)
    spectrum = rfft(xu, nfft)
    del xu
    power = np.abs(spectrum)
    del spectrum
    power **= 2
    return rfftfreq(nfft, dt), power


def spectral_period(t: np.ndarray, x: np.ndarray, *, min_cycles: float = 2.0) -> tuple[float, float]:
    """Dominant period of a sampled oscillation from the peak of its periodogram.

    The series is resampled on a uniform grid, detrended (a drifting centre), tapered at
    its ends only (a Hann window would hide a decay that lasts a small part of the record) and
    zero-padded eightfold (less beyond half a million samples: :data:`MAX_FFT`); the peak is
    refined by a parabola through the log powers.
    Noise, quantisation and a resting tail spread their power over all frequencies, so the
    oscillation's peak stands out; only periods that fit ``min_cycles`` times in the record
    are considered.

    Returns
    -------
    period : float
        s (``nan`` when no interior peak exists).
    prominence : float
        Peak power over the median power of the searched band; white noise alone gives
        about ``log2`` of the number of samples, a decay hundreds or more.
    """
    n = t.size
    dt = (t[-1] - t[0]) / (n - 1)
    freq, power = periodogram(t, x, 8)
    # the band of frequencies searched: a run of the increasing grid (a view, not a copy)
    first = int(np.searchsorted(freq, min_cycles / (n * dt), side="left"))
    stop = int(np.searchsorted(freq, 0.45 / dt, side="right"))
    if stop - first < 5:
        return math.nan, 0.0
    p = power[first:stop]
    interior = np.flatnonzero((p[1:-1] >= p[:-2]) & (p[1:-1] >= p[2:])) + 1
    if not interior.size:
        return math.nan, 0.0
    k = interior[np.argmax(p[interior])]
    y0, y1, y2 = np.log(p[k - 1:k + 2] + 1e-300)
    denom = y0 - 2 * y1 + y2
    shift = 0.5 * (y0 - y2) / denom if denom < 0 else 0.0
    f = freq[first + k] + shift * (freq[1] - freq[0])
    median = float(np.median(p))
    if median <= 0.0:
        return 1.0 / f, math.inf if p[k] > 0 else 0.0
    return 1.0 / f, float(p[k] / median)


def power_near(t: np.ndarray, x: np.ndarray, periods: list[float], width: float = 0.15) -> list[float]:
    """Largest periodogram power (as :func:`spectral_period` computes it) within ``+-width`` of
    each frequency ``1/period``."""
    freq, power = periodogram(t, x, 8)
    return [float(np.max(power[(freq > (1 - width) / p) & (freq < (1 + width) / p)], initial=0.0)) for p in periods]


def extrema_period(t: np.ndarray, x: np.ndarray) -> float:
    """Period (s) from the spacing of the record's larger extrema, without knowing it first.

    A light smoothing (5 samples), a hysteresis of six noise scales (the noise from the second
    differences, which a smooth oscillation sampled many times a period hardly feels), three
    quantisation steps and 0.2 % of the record's range, and twice the median interval between
    the extrema of the larger half of the swings; ``nan`` when fewer than three extrema stand out.  A cross-check of the periodogram, whose low
    frequencies a hold or a step can dominate.
    """
    if x.size < 20:
        return math.nan
    d2 = np.diff(x, 2)
    sigma = float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))
    xs = smooth(x, 50.0)
    quantum = resolution(x, xs)[1]
    ext = alternating_extrema(xs, max(6.0 * sigma, 3.0 * quantum, 2e-3 * float(np.ptp(x)),
                                      1e-9 * float(np.max(np.abs(x)) or 1.0)))
    if len(ext) < 3:
        return math.nan
    tc = np.array([0.5 * (t[a] + t[b]) for a, b, _ in ext])
    v = np.array([xs[a] for a, _, _ in ext])
    pp = np.abs(np.diff(v))
    big = pp >= np.median(pp)
    return 2.0 * float(np.median(np.diff(tc)[big]))


def smoothing_window(period_samples: float) -> int:
    """Samples in the window of :func:`smooth` (odd, a tenth of a period, at least 5)."""
    return max(5, int(round(0.1 * period_samples)) | 1)


def smooth(x: np.ndarray, period_samples: float) -> np.ndarray:
    """Savitzky-Golay smoothing (quadratic, window a tenth of a period, at least 5 samples)."""
    from ...core.filters import savgol_filter

    n = smoothing_window(period_samples)
    if n > x.size:
        return x.astype(float)
    return savgol_filter(x, n, 2)


def smoothing_share(period_samples: float) -> float:
    """The weight :func:`smooth` gives a sample in its own smoothed value.

    White noise of scale ``s`` scatters about the smoothing by ``s * sqrt(1 - share)``, not ``s``:
    the smoothing follows part of each sample's own noise (a fifth to a half of its variance
    when the window holds 5 to 11 samples).
    """
    from ...core.filters import savgol_coeffs

    n = smoothing_window(period_samples)
    return float(savgol_coeffs(n, 2)[n // 2])


def resolution(x: np.ndarray, smoothed: np.ndarray) -> tuple[float, float]:
    """Noise scale and quantisation step of the samples.

    Returns
    -------
    sigma : float
        Robust (MAD) scale of the samples about their smoothing.
    quantum : float
        The sensor's step when the samples lie on a lattice (an encoder: nine in ten
        changes between samples are whole multiples of the smallest one), else 0.
    """
    sigma = float(1.4826 * np.median(np.abs(x - smoothed)))
    d = np.abs(np.diff(x))
    scale = float(np.max(np.abs(x))) or 1.0
    d = d[d > 1e-9 * scale]
    quantum = 0.0
    if d.size >= 10:
        q = float(np.mean(d[d < 1.5 * d.min()]))
        r = d / q
        if np.mean(np.abs(r - np.round(r)) < 0.05) > 0.9 and np.median(r) < 1000:
            quantum = q
    return sigma, quantum


def without_wiggles(cands: list[tuple[int, int, bool]], t: np.ndarray, xs: np.ndarray,
                    period: float) -> tuple[list[tuple[int, int, bool]], list[float]]:
    """``cands`` (:func:`alternating_extrema`) without the wiggles of the noise at a turning point.

    Turning points of a swing are half a period apart, so three extrema within a quarter period
    (a maximum, a dip, a maximum again: a glitch or a ripple at the top that the hysteresis let
    through) cannot all be the swing's, when the dip is shallow: under a quarter of the swings
    around it (a swing that starts or changes its shape there has deep ones, and they are kept).
    The dip and the lesser of the two peaks go, the greater stays.  Returns the candidates kept
    and the times of the dips dropped.
    """
    if not math.isfinite(period) or period <= 0:
        return cands, []

    def centre(e: tuple[int, int, bool]) -> float:
        return 0.5 * float(t[e[0]] + t[e[1]])

    out, dropped = list(cands), []
    k = 0
    while k + 2 < len(out):
        a, b, c = out[k], out[k + 1], out[k + 2]
        level = [float(xs[e[0]]) for e in out[max(0, k - 3):k + 6]]
        swing = float(np.median(np.abs(np.diff(level)))) if len(level) > 1 else 0.0
        depth = min(abs(float(xs[a[0]] - xs[b[0]])), abs(float(xs[c[0]] - xs[b[0]])))
        if centre(c) - centre(a) < 0.25 * period and depth < 0.25 * swing:
            sign = 1.0 if a[2] else -1.0
            keep = a if sign * xs[a[0]] >= sign * xs[c[0]] else c
            dropped.append(centre(b))
            out[k:k + 3] = [keep]
            k = max(k - 1, 0)
        else:
            k += 1
    return out, dropped


def drop_wiggles(notes: list[str], cands: list[tuple[int, int, bool]], t: np.ndarray, xs: np.ndarray,
                 period: float) -> list[tuple[int, int, bool]]:
    """:func:`without_wiggles`, with a note of the dips dropped appended to ``notes``."""
    kept, dropped = without_wiggles(cands, t, xs, period)
    if dropped:
        notes.append(f"{len(dropped)} dip(s) of the noise at a turning point (three extrema within a quarter "
                     f"period), the first at t = {dropped[0]:.4g} s: the greater extremum kept")
    return kept


def alternating_extrema(xs: np.ndarray, threshold: float, start: int = 0, stop: int | None = None,
                        seek: int = 0) -> list[tuple[int, int, bool]]:
    """Alternating maxima and minima of ``xs[start:stop]`` with hysteresis.

    An extremum is confirmed once the signal has come back from it by more than
    ``threshold``, so ripples smaller than that (noise, a sensor flickering by one count) never
    make extrema, and maxima and minima alternate by construction.  Ties extend an extremum
    into a plateau (quantised data: several equal samples at the top).

    Parameters
    ----------
    seek
        ``+1`` look for a maximum first, ``-1`` a minimum, ``0`` whichever comes.

    Returns
    -------
    list of (first, last, is_max)
        Sample indices of the first and last sample of each extremum's plateau (equal for a
        single sample); its centre is the candidate turning point.
    """
    from .compiled import extremum_scan

    stop = xs.size if stop is None else stop
    eps = 1e-12 * (float(np.max(np.abs(xs[start:stop]))) or 1.0)
    if stop - start < 2:
        return []
    xs = np.ascontiguousarray(xs, dtype=float)
    first, last, is_max = extremum_scan(xs, float(threshold), int(start), int(stop), int(seek), eps)
    return list(zip(first.tolist(), last.tolist(), is_max.tolist()))


_VERTEX_GRID = np.linspace(-0.75, 0.75, 21)  # trial vertex times of kinked_vertex, scaled


def kinked_vertex(u: np.ndarray, x: np.ndarray, degree: int = 4, *, flat: str = "",
                  shared: bool = False) -> tuple[float, float] | None:
    """Vertex ``(u_c, x_c)`` of a turning point from samples at scaled times ``u`` in [-1, 1].

    Each side is a polynomial of ``degree`` (default: quartic) in ``s = u - u_c`` without a
    linear term (the velocity is zero at the turn), sharing the vertex value; the curvatures
    may differ because Coulomb friction reverses there.  A side with few samples gets a lower
    degree (at least 2).  Linear least squares for a given ``u_c``, a bounded scalar search
    over it.  The samples of quantised data on a plateau enter like any others, so a flat top
    yields its centre.

    Parameters
    ----------
    flat
        ``"left"``: the balance was at rest before the vertex (a release from a held angle);
        ``"right"``: at rest after it (motion stopped there); ``""``: a turning point.
    shared
        ``True``: only the curvature differs between the sides, the cubic and higher terms are
        common: fewer parameters, so less noise in the vertex, at a bias that grows with the
        friction jump and the window (up to some 2e-4 of the amplitude for a strong Coulomb
        friction over a fifth of a period).

    Returns
    -------
    tuple or None
        ``None`` when a side has too few samples.  ``u_c`` lies within +-0.75; a vertex
        far from the centre (at the bound: beyond it) is better refitted in a window centred
        on it.
    """
    from scipy.optimize import minimize_scalar

    from .compiled import kinked_design, kinked_grid, kinked_lstsq

    n_left, n_right = int(np.sum(u < 0)), int(np.sum(u > 0))
    if min(n_left, n_right) < 2 or n_left + n_right < 6:
        return None
    deg_left = 0 if flat == "left" else min(degree, max(2, n_left - 2))
    deg_right = 0 if flat == "right" else min(degree, max(2, n_right - 2))
    shared = shared and not flat and deg_left == deg_right

    u = np.ascontiguousarray(u, dtype=float)
    x = np.ascontiguousarray(x, dtype=float)

    def solve(uc: float) -> tuple[float, float]:
        rss, value, solved = kinked_lstsq(u, x, float(uc), deg_left, deg_right, shared)
        if solved:
            return rss, value
        # rank deficient: numpy's minimum-norm solution
        a = kinked_design(u, float(uc), deg_left, deg_right, shared)
        coef, *_ = np.linalg.lstsq(a, x, rcond=None)
        r = a @ coef - x
        return float(r @ r), float(coef[0])

    # the residual is not unimodal in u_c when the sides differ much (a stop, a release, an
    # encoder's staircase): a grid first, then a bounded search around its best point
    grid = _VERTEX_GRID
    costs = kinked_grid(u, x, grid, deg_left, deg_right, shared)
    for g in np.flatnonzero(np.isnan(costs)):
        costs[g] = solve(grid[g])[0]
    best = int(np.argmin(costs))
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    res = minimize_scalar(lambda uc: solve(uc)[0], bounds=(lo, hi), method="bounded", options={"xatol": 1e-7})
    return float(res.x), solve(float(res.x))[1]


def vertex_at(s: np.ndarray, x: np.ndarray, degree: int = 4, *,
              search: tuple[float, float] | None = None) -> tuple[float, float]:
    """Vertex ``(s_c, x_c)`` of a polynomial without linear term in ``s - s_c`` fitted to
    samples ``x(s)`` on one side of the vertex.

    With ``search=None`` the vertex is at ``s_c = 0``: the angle of a balance known to be at
    rest then (a given release instant), from the samples after it.  Otherwise ``s_c`` is
    searched within those bounds: a turning point at the first sample of a record.
    """
    from scipy.optimize import minimize_scalar

    deg = min(degree, max(2, s.size - 2))

    def solve(sc: float) -> tuple[float, float]:
        a = np.stack([np.ones_like(s)] + [(s - sc) ** p for p in range(2, deg + 1)], axis=1)
        coef, *_ = np.linalg.lstsq(a, x, rcond=None)
        r = a @ coef - x
        return float(r @ r), float(coef[0])

    if search is None:
        return 0.0, solve(0.0)[1]
    res = minimize_scalar(lambda sc: solve(sc)[0], bounds=search, method="bounded", options={"xatol": 1e-9})
    return float(res.x), solve(float(res.x))[1]


def local_amplitude(t: np.ndarray, x: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude of the oscillation at ``period`` in windows one period long, a quarter apart.

    In each window a least-squares fit of ``a + b s + c cos(w s) + d sin(w s)`` (``w = 2 pi /
    period``, ``s`` the time from the window's centre) gives the amplitude ``hypot(c, d)``:
    the swing as the whole window sees it, far less noisy than any one sample (for white
    noise of scale ``sigma`` and ``N`` samples, ``c`` and ``d`` scatter by
    ``sigma * sqrt(2 / N)``).

    Returns
    -------
    start : ndarray
        Start time of each window, s.
    amplitude : ndarray
        Rad (nan for a window with fewer than 8 samples).
    """
    w = 2.0 * math.pi / period
    starts = np.arange(t[0], t[-1] - period + 1e-12, 0.25 * period)
    amp = np.full(starts.size, math.nan)
    lo = np.searchsorted(t, starts)
    hi = np.searchsorted(t, starts + period)
    for k, (a, b) in enumerate(zip(lo, hi)):
        if b - a < 8:
            continue
        s = t[a:b] - (starts[k] + 0.5 * period)
        basis = np.stack([np.ones_like(s), s, np.cos(w * s), np.sin(w * s)], axis=1)
        coef, *_ = np.linalg.lstsq(basis, x[a:b], rcond=None)
        amp[k] = math.hypot(coef[2], coef[3])
    return starts, amp
