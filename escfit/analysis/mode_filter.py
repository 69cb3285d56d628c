"""One mode of a record that rings in two, isolated by a zero-phase filter.

A linear structure (a beam, a rod, two coupled pendulums) rings in several modes at once.  Each
mode is a damped oscillator of its own, so each can be fitted alone once the others are taken
out.  A one-oscillator model fitted to the sum follows neither mode.  The record analysis refuses
such a record (:mod:`escfit.analysis.recordings.modes`) and names ``[recording] mode``; with
``mode = 1`` (the slower mode, the lowest) or ``mode = 2`` (the faster one), this stage keeps that
mode and removes the other.

The filter works in the frequency domain with zero phase, so it shifts no turning point and moves
no release.  A mode at frequency ``f1`` and another at ``f2 = r f1`` (``r >= 2``: the analysis calls
nearer peaks one oscillation) are split at a raised-cosine crossover running from
``f1 r^(1/3)`` to ``f1 r^(2/3)``.  A damped mode's line has tails, and from :data:`CLEAN_RATIO`
apart on the tails that cross over no longer matter: on two modes of one size (Q 60 and 40),
the kept mode's C came out within 0.04 % of the truth at ``r = 2.5`` and 2.7, but 0.7 % low at
2.3 and 1.7 % low at 2.05, a dozen standard errors off.  Nearer modes are still isolated, with a
warning that says so.  The lower mode is kept with a low-pass (the
centre and its slow drift stay with it), the upper one with the matching high-pass.  The record
is mirrored at both ends before the transform, by three periods of the slower mode, so the ends
do not wrap into each other.  The ends still carry the filter's edge (on two modes of one size a
period ratio of 2.7 apart: 7 % of the kept mode's amplitude in its first period, 0.7 % in the
second, 0.17 % in the third and 0.03 % after), so :data:`TRIM_PERIODS` periods of the slower mode
are cut from each end;
a free decay's release at a turning point is exact physics wherever it is taken, so the fit
starts at the first turning point after the cut.  The samples must be evenly spaced (within
:data:`EVEN`); a logger's uneven clock is repaired before this stage or the record is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import DataError
from .recordings.extrema import spectral_period
from .recordings.modes import MIN_PROMINENCE, SECOND_MODE_SHARE, other_modes

__all__ = ["ModeSplit", "two_modes", "isolate_mode", "EVEN"]

EVEN = 0.02  # the samples' intervals within this share of their median: evenly spaced
PAD_PERIODS = 3.0  # the record is mirrored at each end over this many periods of the slower mode
CLEAN_RATIO = 2.5  # modes this many times apart in frequency, or more, are parted cleanly by the filter
TRIM_PERIODS = 2.0  # periods of the slower mode cut from each end of the filtered record (the filter's edge)
MIN_PERIODS = 6.0  # periods of the slower mode the record must keep after the cut


@dataclass(frozen=True)
class ModeSplit:
    """A record's two modes and the one kept.

    Attributes
    ----------
    periods : tuple of float
        The two modes' periods (s), the slower first.
    share : float
        The weaker mode's spectral power over the stronger one's.
    chosen : int
        The mode kept: 1 the slower, 2 the faster.
    crossover : tuple of float
        The filter's crossover band (Hz): full pass on the kept side of the first, none beyond the second.
    trimmed : float
        Time cut from each end of the record (s).
    stronger : int
        The mode with more of the record's power: 1 the slower, 2 the faster.
    """

    periods: tuple
    share: float
    chosen: int
    crossover: tuple
    trimmed: float = 0.0
    stronger: int = 1

    @property
    def kept_weaker(self) -> bool:
        """Whether the mode kept holds under half the other's power (a support's rocking, say,
        rather than the swing)."""
        return self.chosen != self.stronger and self.share < 0.5

    @property
    def close(self) -> bool:
        """Whether the modes lie under :data:`CLEAN_RATIO` apart: the filter leaves some of the other."""
        return self.periods[0] / self.periods[1] < CLEAN_RATIO

    @property
    def warns(self) -> bool:
        """Whether the choice is a warning (the weaker mode kept, or modes too close), not a note."""
        return self.kept_weaker or self.close

    def sentence(self) -> str:
        """The decision and its evidence, for the record's notes."""
        kept, other = self.periods[self.chosen - 1], self.periods[2 - self.chosen]
        which = "slower" if self.chosen == 1 else "faster"
        power = (f"it holds {100 * self.share:.0f} % of the other's power: if the other is the oscillation you "
                 f"recorded, set mode = {3 - self.chosen}" if self.kept_weaker else
                 f"the weaker holds {100 * self.share:.0f} % of the stronger's power; mode = {3 - self.chosen} fits "
                 "the other")
        close = (f"; the modes lie only {self.periods[0] / self.periods[1]:.3g} times apart, under the "
                 f"{CLEAN_RATIO:g} from which the filter parts them cleanly: the damping found may be off by a "
                 "per cent or two, beyond its interval" if self.close else "")
        return (f"two modes, of periods {self.periods[0]:.4g} s and {self.periods[1]:.4g} s: the {which} one "
                f"(period {kept:.4g} s, [recording] mode = {self.chosen}) is fitted and the other ({other:.4g} s) "
                f"filtered out with zero phase (crossover {self.crossover[0]:.4g} to {self.crossover[1]:.4g} Hz), "
                f"the first and last {self.trimmed:.3g} s, where the filter's edge lies, left out; {power}{close}")


def two_modes(t: np.ndarray, x: np.ndarray, *, min_share: float = SECOND_MODE_SHARE
              ) -> tuple[tuple[float, float], float, int] | None:
    """The periods of a record's two modes (s, the slower first), the weaker one's share of the
    stronger's power and which is the stronger (1 the slower, 2 the faster), when a second
    oscillation holds ``min_share`` of the main one's power or more (by default
    :data:`~escfit.analysis.recordings.modes.SECOND_MODE_SHARE`, the record analysis' refusal) and
    stands out of its neighbourhood of the spectrum as the analysis asks of a weak one; else None."""
    period, prominence = spectral_period(t, x)
    if not math.isfinite(period) or prominence < MIN_PROMINENCE:
        return None
    found = [(p, s) for p, s, prom in other_modes(t, x, period)
             if s >= min_share and (prom >= MIN_PROMINENCE or (p < period and s >= SECOND_MODE_SHARE))]
    if not found:
        return None
    other, share = max(found, key=lambda f: f[1])
    main_first = share <= 1.0  # the periodogram's main peak holds more power than the other
    stronger = (1 if period > other else 2) if main_first else (2 if period > other else 1)
    return (max(period, other), min(period, other)), float(min(share, 1.0 / share)), stronger


def isolate_mode(t: np.ndarray, x: np.ndarray, mode: int, where: str) -> tuple[np.ndarray, np.ndarray, ModeSplit]:
    """The times and samples of ``t``, ``x`` (s, any unit) with only mode ``mode`` kept (1 the
    slower, 2 the faster) and the filter's edges cut off.

    Raises
    ------
    DataError
        The record holds one mode only, its samples are not evenly spaced, or it is too short for
        the cut.
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    dt = np.diff(t)
    step = float(np.median(dt))
    if not np.all(np.abs(dt - step) <= EVEN * step):
        raise DataError(f"[recording] mode = {mode}: isolating a mode needs evenly spaced samples (intervals within "
                        f"{100 * EVEN:g} % of their median, {step:.4g} s); these range from {dt.min():.4g} to "
                        f"{dt.max():.4g} s", where)
    found = two_modes(t, x, min_share=0.0)  # asked for, a weak second mode is taken out too
    if found is None:
        raise DataError(f"[recording] mode = {mode}: the record holds one oscillation, not two modes; remove the key",
                        where)
    periods, share, stronger = found
    f1, f2 = 1.0 / periods[0], 1.0 / periods[1]
    r = f2 / f1
    lo, hi = f1 * r ** (1.0 / 3.0), f1 * r ** (2.0 / 3.0)
    pad = min(x.size - 1, int(math.ceil(PAD_PERIODS * periods[0] / step)))
    padded = np.concatenate([x[pad:0:-1], x, x[-2:-pad - 2:-1]])
    freq = np.fft.rfftfreq(padded.size, step)
    s = np.clip((freq - lo) / (hi - lo), 0.0, 1.0)
    low_pass = 0.5 * (1.0 + np.cos(math.pi * s))  # 1 below lo, 0 above hi
    gain = low_pass if mode == 1 else 1.0 - low_pass
    kept = np.fft.irfft(np.fft.rfft(padded) * gain, n=padded.size)[pad:pad + x.size]
    trim = TRIM_PERIODS * periods[0]
    inside = (t >= t[0] + trim) & (t <= t[-1] - trim)
    if t[-1] - t[0] - 2 * trim < MIN_PERIODS * periods[0]:
        raise DataError(f"[recording] mode = {mode}: the record spans {(t[-1] - t[0]) / periods[0]:.3g} periods of its "
                        f"slower mode ({periods[0]:.4g} s); isolating a mode needs "
                        f"{MIN_PERIODS + 2 * TRIM_PERIODS:g} (the filter's edge is cut from each end)", where)
    return t[inside], kept[inside], ModeSplit(periods, share, mode, (lo, hi), trim, stronger)
