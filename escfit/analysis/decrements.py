"""Losses per half swing measured from a record's turning-point amplitudes.

Three consecutive half swings ``k, k+1, k+2`` give the loss ``(A_k - A_{k+2}) / 2`` at
``(A_k + 2 A_{k+1} + A_{k+2}) / 4``: ``A_k`` and ``A_{k+2}`` lie on the same side, so a zero
offset of the scale cancels, as it does in the weighted mean amplitude.  Readings further apart
(Monday's every fourth half swing) give ``(A_i - A_j)/(j - i)`` at ``(A_i + A_j)/2`` when
``j - i`` is even.  All angles are in radians here.  What each damping law predicts for them is
:mod:`escfit.balance.decrement`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Decrements", "from_readings", "from_turns", "binned"]


@dataclass(frozen=True)
class Decrements:
    """Decrements per half swing measured from amplitudes.

    Attributes
    ----------
    amplitude
        Amplitude at which each decrement is measured (rad).
    decrement
        Loss of amplitude per half swing (rad; negative: the amplitude grew).
    error
        Half-width of each decrement's interval (rad) when the readings are intervals (notch
        counts), else zeros.
    swing
        Half swing at the start of each measurement.
    """

    amplitude: np.ndarray
    decrement: np.ndarray
    error: np.ndarray
    swing: np.ndarray


def from_readings(swing, amplitude, half_width=None) -> Decrements:
    """Decrements from amplitude readings of one curve (see the module docstring).

    Parameters
    ----------
    swing
        Half swing of each reading (integers, increasing).
    amplitude
        Amplitude readings (rad, unsigned; a constant zero offset of the scale may remain).
    half_width
        Half-width of each reading's interval (rad), for notch counts; ``None``: exact readings.
    """
    s = np.asarray(swing, np.int64)
    a = np.asarray(amplitude, float)
    h = np.zeros_like(a) if half_width is None else np.broadcast_to(np.asarray(half_width, float), a.shape)
    amp, dec, err, start = [], [], [], []
    for i in range(a.size - 1):
        if i + 2 < a.size and s[i + 1] == s[i] + 1 and s[i + 2] == s[i] + 2:
            amp.append((a[i] + 2 * a[i + 1] + a[i + 2]) / 4)
            dec.append((a[i] - a[i + 2]) / 2)
            err.append((h[i] + h[i + 2]) / 2)
        elif s[i + 1] - s[i] >= 2 and (s[i + 1] - s[i]) % 2 == 0:
            g = s[i + 1] - s[i]
            amp.append((a[i] + a[i + 1]) / 2)
            dec.append((a[i] - a[i + 1]) / g)
            err.append((h[i] + h[i + 1]) / g)
        else:
            continue
        start.append(s[i])
    return Decrements(np.array(amp), np.array(dec), np.array(err), np.array(start, np.int64))


def from_turns(theta) -> Decrements:
    """Decrements from consecutive signed turning-point angles (rad) in the sensor's frame.

    ``|theta_k - theta_{k+1}| = A_k + A_{k+1}`` whatever the centre, so with
    ``S_k = |theta_k - theta_{k+1}|`` the decrement ``(A_k - A_{k+2})/2 = (S_k - S_{k+1})/2``
    at ``(S_k + S_{k+1})/4`` needs no estimate of the centre (a drifting centre should be
    removed from ``theta`` first).
    """
    e = np.asarray(theta, float)
    span = np.abs(np.diff(e))
    if span.size < 2:
        return Decrements(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, np.int64))
    return Decrements((span[:-1] + span[1:]) / 4, (span[:-1] - span[1:]) / 2, np.zeros(span.size - 1),
                      np.arange(span.size - 1, dtype=np.int64))


def binned(amplitude, decrement, *, bins: int = 8, min_count: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Means of the decrements in amplitude bins of equal count, with their standard errors.

    Returns
    -------
    amplitude, decrement, standard error
        One entry per bin holding at least ``min_count`` measurements.
    """
    a, d = np.asarray(amplitude, float), np.asarray(decrement, float)
    order = np.argsort(a)
    groups = [g for g in np.array_split(order, max(1, min(bins, a.size // min_count))) if g.size >= min_count]
    return (np.array([a[g].mean() for g in groups]), np.array([d[g].mean() for g in groups]),
            np.array([d[g].std(ddof=1) / math.sqrt(g.size) for g in groups]))
