"""Other oscillations in a record besides the swing: a second mode refused or named.

A record of one oscillator's free decay has one spectral peak (and its harmonics, for an
anharmonic swing).  A structure, a rod or two coupled oscillators ring in several modes: fitted
as one oscillator, the model would follow whichever mode the working period picked.  Two of
comparable size are refused naming both; a weak one is named in a note and the fit follows the
main swing.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.errors import DataError
from .extrema import periodogram

__all__ = ["other_modes", "check_other_modes", "TwoModes", "SECOND_MODE_SHARE", "MIN_PROMINENCE"]

# a second oscillation with this share of the main one's spectral power is another mode (real
# decays in the shared corpus stay under 0.04; a struck rod's second mode holds 0.53)
SECOND_MODE_SHARE = 0.2
MIN_PROMINENCE = 50.0  # a periodogram peak over the median power; white noise alone gives ~log2(n)


class TwoModes(DataError):
    """A record refused for ringing in two modes of comparable size.

    Attributes
    ----------
    modes : tuple of float
        The two periods (s), the slower first: what ``[recording] mode`` chooses between.
    """

    def __init__(self, message: str, where: str | None = None,
                 modes: tuple[float, float] = (math.nan, math.nan)) -> None:
        super().__init__(message, where)
        self.modes = modes


def other_modes(t: np.ndarray, x: np.ndarray, period: float, *, min_ratio: float = 0.5, harmonic_tol: float = 0.04,
                min_cycles: float = 3.0) -> list[tuple[float, float, float]]:
    """Oscillations besides the one at ``period``: the strongest faster one and the strongest
    slower one, each as ``(period s, share, prominence)``.

    Only frequencies beyond ``1/min_ratio`` times the main one (faster) or below ``min_ratio``
    times it (slower) are searched: nearer ones belong to the main oscillation (a pendulum's
    frequency sweeps that far as its swing decays; two close modes show as beats instead).
    Whole multiples of the main frequency (the harmonics of an anharmonic swing, within
    ``harmonic_tol``) are skipped, and a slower one must fit ``min_cycles`` times in the record.
    The share is the larger of the peak's power over the main peak's and the power within 15 %
    of its frequency over that within 15 % of the main one (the share of the motion: a faster
    mode of the same Q decays faster, so its peak is lower than its share).
    The prominence is the peak's power over the median power within 30 % of its frequency: the
    noise floor under a faster one, and the skirt of a hold's, a step's or a drift's low
    frequencies under a slower one, which a coherent oscillation stands far above.  Empty when
    the main peak has no power.
    """
    dt = (t[-1] - t[0]) / (t.size - 1)
    freq, power = periodogram(t, x, 4)
    f0 = 1.0 / period
    main = float(np.max(power[(freq > f0 * 0.9) & (freq < f0 * 1.1)], initial=0.0))
    if main <= 0.0:
        return []
    ratio = freq / f0
    not_harmonic = np.abs(ratio - np.round(ratio)) > harmonic_tol * np.maximum(np.round(ratio), 1.0)
    sides = [(freq <= 0.45 / dt) & (ratio > 1.0 / min_ratio) & not_harmonic,
             (ratio < min_ratio) & (freq * (t[-1] - t[0]) >= min_cycles)]
    main_band = (freq > f0 * 0.85) & (freq < f0 * 1.15)
    main_energy = float(np.sum(power[main_band]))
    found = []
    for side in sides:
        if not side.any():
            continue
        p = np.where(side, power, 0.0)
        peaks = np.flatnonzero((p[1:-1] >= p[:-2]) & (p[1:-1] >= p[2:]) & (p[1:-1] > 0)) + 1
        if not peaks.size:
            continue
        k = int(peaks[np.argmax(p[peaks])])
        near = power[(freq > 0.7 * freq[k]) & (freq < 1.3 * freq[k])]
        floor = float(np.median(near)) if near.size else 0.0
        band = (freq > 0.85 * freq[k]) & (freq < 1.15 * freq[k]) & ~main_band
        energy = float(np.sum(power[band])) / main_energy if main_energy > 0 else 0.0
        # a faster mode of the same Q decays faster: its peak is lower than its share of the motion
        share = max(float(p[k] / main), energy)
        found.append((1.0 / float(freq[k]), share, float(p[k] / floor) if floor > 0 else math.inf))
    return found


def check_other_modes(t: np.ndarray, x: np.ndarray, period: float, where: str) -> tuple[list[str], list[tuple]]:
    """Refuse a record with a second oscillation of :data:`SECOND_MODE_SHARE` of the main one's
    power or more (naming both); a weaker one that stands out of its neighbourhood of the
    spectrum by :data:`MIN_PROMINENCE` is a note: the fit follows the main swing only.  A slower
    one must stand out that far to count at all: a hold, a step or a drift puts a smooth skirt of
    power at low frequencies, with no peak of its own.

    Returns the notes and the weak oscillations noted, ``(period s, share of the power)`` each."""
    notes, weak = [], []
    for other, share, prominence in other_modes(t, x, period):
        side = "faster" if other < period else "slower"
        if side == "slower" and prominence < MIN_PROMINENCE:
            continue  # the skirt of a hold's, a step's or a drift's low frequencies, not an oscillation
        if share >= SECOND_MODE_SHARE:
            slow, fast = max(period, other), min(period, other)
            raise TwoModes(f"besides the swing of period {period:.4g} s the record holds a second oscillation of period "
                           f"{other:.4g} s ({side}) with {100 * share:.0f} % of its power: two modes (a structure's, "
                           "a rod's) or two coupled oscillators, not one oscillator's free decay, and which one to fit "
                           f"is not determined; set [recording] mode = 1 to fit the slower (period {slow:.4g} s) or "
                           f"mode = 2 the faster ({fast:.4g} s), the other filtered out", where, (slow, fast))
        if prominence >= MIN_PROMINENCE:
            notes.append(f"a weak second oscillation of period {other:.4g} s ({side}, {100 * share:.2g} % of the main "
                         f"swing's power) rides on the swing of period {period:.4g} s: the fit follows "
                         "the main swing, the second one stays in the residuals")
            weak.append((float(other), float(share)))
    return notes, weak
