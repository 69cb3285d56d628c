"""Whether a fit's losses hold when the record's first period is left out.

A free decay loses by one law all along the record, so the fit of the same record from one
period later (its first turning points left out) estimates the same loss coefficients, only
less precisely.  A loss coefficient that moves materially (:data:`~escfit.analysis.agreement.MATERIAL`,
10 % of it) and by more than :data:`~escfit.analysis.agreement.PARAMETER_SIGMAS` of the fit's own
standard errors says that the first period does not lose what the law fitted to the rest of
the record gives: its swings were kept up by a drive, guided by a hand or pushed, or the law is
not the record's (air drag takes more at large swings than viscous damping and friction
together can follow).  Either way the coefficients that moved are not determined by the record,
whatever their intervals say, and with them every other loss coefficient of the fit (they share
the swing's loss: one that moved takes its share from the others), while the swing's loss and
the other parameters may stand: the fit is partly determined and says why.  The swing's loss
stands only if both fits' coefficients give it alike: at the later fit's first amplitude, the
two losses per period must differ by less than :data:`LOSS_SHARE` of the later one (a hand that
guided the first swing, taking energy out, doubled the viscous C and the loss by half again,
while the fit from one period later found the record's own).

The move is measured in the fit's own standard error, not in the two fits' combined one: the
later fit leaves out a small share of the same samples, and for nested least squares the
difference of the estimates has a standard deviation of ``sqrt(se_later**2 - se**2)``, less
than either error (the combined error would hide a bias of four standard errors that one
period of a two-period drive leaves behind).  Records long enough to be thinned
(:mod:`escfit.balance.problems.thinning`) are fitted again on the samples the fit used.

The first turning points carry most of a decay's information on how its losses depend on the
amplitude (they are the largest swings), and with it most of the information that splits a
viscous loss (C, in proportion to the amplitude) from a friction loss (R, the same at every
amplitude): a drive switched off one or two periods into a record, its steady swings within
the reading noise of the turning points, moved C by 35 % and R by 25 % in a waveform fit that
stated each to within 9 %, and passed every residual check but the runs and lag-1 warnings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .agreement import PARAMETER_SIGMAS, ParameterDifference

__all__ = ["StartDifference", "StartDependence", "start_dependence", "LATER_PERIODS", "MIN_PERIODS", "LOSS_SHARE",
           "LOSS_MOVES"]

LATER_PERIODS = 1.0  # the second fit starts this many periods after the first one's reference turning point
MIN_PERIODS = 6.0  # periods the record must hold after that for the comparison to be made
LOSS_SHARE = 0.15  # the swing's loss per period moves with the coefficients when the two fits' differ by this share

#: how the warning says that the swing's loss moved too (the plain summary looks for it among the warnings)
LOSS_MOVES = "the swing's loss moves with them"


@dataclass(frozen=True)
class StartDifference(ParameterDifference):
    """One loss coefficient of the fit (``waveform``, its standard error ``waveform_stderr``)
    against the fit of the same record from one period later (``turning_points``, its standard
    error); :attr:`relative` and :attr:`material` as for any two estimates."""

    @property
    def sigmas(self) -> float:
        """The move in the fit's own standard errors (nan when it has none)."""
        se = self.waveform_stderr
        return abs(self.turning_points - self.waveform) / se if se > 0 else math.nan


@dataclass(frozen=True)
class StartDependence:
    """The fit against the fit of the same record from one period later.

    Attributes
    ----------
    start : float
        The later fit's reference turning point (s, the record's clock).
    differences : tuple of StartDifference
        The loss coefficients of both fits.
    moved : tuple of str
        Every loss coefficient compared when one of them moved materially and beyond the fit's
        standard errors; empty when none did.
    """

    start: float
    differences: tuple
    moved: tuple
    loss: tuple[float, float, float] | None = None

    @property
    def loss_moves(self) -> bool:
        """Whether the swing's loss per period at the later fit's first amplitude differs between
        the fits by more than :data:`LOSS_SHARE` of the later fit's (only when coefficients moved)."""
        if not self.moved or self.loss is None:
            return False
        _, here, later = self.loss
        return bool(math.isfinite(here) and math.isfinite(later) and later > 0
                    and abs(here - later) > LOSS_SHARE * later)

    def clause(self, short) -> str:
        """The warning on what moved and why it matters (``short``: name -> symbol)."""
        moved = [d for d in self.differences if d.name in self.moved and d.material and d.sigmas > 1.0]
        said = ", ".join(
            f"{short(d.name)} from {_shown(d.waveform, d)} to {_shown(d.turning_points, d)} ({_signed(d)}"
            f"{d.sigmas:.2g} of its standard errors)" for d in moved)
        names = _listed([short(n) for n in self.moved])
        verb = "is" if len(self.moved) == 1 else "are"
        return (f"{names} {verb} not determined by this record: fitted again from one period later (the turning "
                f"point at t = {self.start:.6g} s), {said}; the record's first period does not lose what the law "
                "fitted to the rest of it gives (its first swings driven, guided or pushed, or a damping law that "
                "is not the record's, such as air drag at large swings): leave it out with [recording] start, or "
                f"add the effect the record shows; {self._loss_words()}")

    def _loss_words(self) -> str:
        if not self.loss_moves:
            return "the swing's loss and the other parameters stand"
        amplitude, here, later = self.loss
        return (f"{LOSS_MOVES} (at {math.degrees(amplitude):.3g} deg, {100 * here:.3g} % a period in the fit, "
                f"{100 * later:.3g} % from one period later), and the figures in words with it; the other parameters "
                "stand")

    def note(self) -> str:
        """One sentence for the notes when nothing moved."""
        z = max([d.sigmas for d in self.differences if math.isfinite(d.sigmas)], default=0.0)
        return (f"fitted again from one period later (t = {self.start:.6g} s), the losses move by {z:.2g} of their "
                "standard errors at most")


def _listed(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _nil(value: float, d: StartDifference) -> bool:
    """Whether ``value`` is 0 to within a millionth of the two fits' errors (a bound's value)."""
    se = max(abs(d.waveform_stderr), abs(d.turning_points_stderr))
    return abs(value) <= 1e-6 * se if math.isfinite(se) and se > 0 else value == 0.0


def _shown(value: float, d: StartDifference) -> str:
    return "0" if _nil(value, d) else f"{value:.4g}"


def _signed(d: StartDifference) -> str:
    """The move as a share of the fit's value and a comma (a factor beyond tenfold; nothing from or to 0)."""
    if _nil(d.waveform, d) or _nil(d.turning_points, d):
        return ""
    change = 100 * (d.turning_points - d.waveform) / abs(d.waveform)
    if change >= 900:
        return f"{d.turning_points / d.waveform:.2g} times, "
    return (f"{change:+.0f} %" if abs(change) >= 10 else f"{change:+.2g} %") + ", "


def start_dependence(differences: list[StartDifference], start: float,
                     loss: tuple[float, float, float] | None = None) -> StartDependence:
    """Which loss coefficients move when the record's first period is left out (see the module docstring).

    Parameters
    ----------
    differences : list of StartDifference
        Each loss coefficient of the fit against the fit from one period later.
    start : float
        The later fit's reference turning point, s.
    loss : tuple of float, optional
        ``(amplitude, fit's, later fit's)``: the swing's loss per period (a fraction of the
        amplitude) by each fit's coefficients at one amplitude (rad), the later fit's first.

    Returns
    -------
    StartDependence
    """
    moved = any(d.material and d.sigmas > PARAMETER_SIGMAS for d in differences)
    return StartDependence(float(start), tuple(differences), tuple(d.name for d in differences) if moved else (),
                           loss)
