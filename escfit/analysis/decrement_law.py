"""Whether the fitted damping law loses what the record loses, amplitude by amplitude.

A fit can follow a record's envelope to within a few degrees everywhere and still have the
wrong law of loss: the least squares spread the misfit over the record, so every turning point
stays within a few standard errors of the model, while the loss per half swing the model
takes at large amplitude is a quarter more than the record's and at small amplitude less.  The
headline figures ("loses 1.97 % each period, starting from 108 deg") and the split between the
laws are then those of a compromise, not of the record.

The record's own losses show it.  From the turning-point amplitudes ``A_k`` (the record's, and
the model's at the same turning points) the loss per half swing is ``(A_k - A_{k+2}) / 2`` at
``(A_k + 2 A_{k+1} + A_{k+2}) / 4`` (same side: a zero offset cancels;
:func:`escfit.analysis.decrements.from_readings`).  Both are binned by the record's amplitude into
:data:`BINS` bins of equal count; a bin's standard error is the scatter of the record's losses
in it over the square root of their number (neighbouring losses share a reading with the
opposite sign, so this errs on the large side).  The law is **refuted** when a bin's mean loss
differs from the model's by more than :data:`LAW_SIGMAS` standard errors *and* by more than
:data:`LAW_SHARE` of the model's loss there: a difference a user would see in every figure
derived from the law.  Records with fewer than :data:`MIN_LOSSES` losses are not judged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .decrements import from_readings

__all__ = ["LawMismatch", "law_mismatch", "refuted_caution", "LAW_REFUTED", "LAW_DRIFTS", "LESS_AT_LARGE", "BINS", "LAW_SIGMAS", "LAW_SHARE", "MIN_LOSSES"]

BINS = 6  # amplitude bins of equal count
LAW_SIGMAS = 5.0  # a bin this many standard errors from the model's loss refutes the law ...
LAW_SHARE = 0.15  # ... when the difference is also this share of the model's loss there
MIN_LOSSES = 24  # fewer losses measure no law
SIDE_SIGMAS = 2.0  # the largest amplitudes' bin says which way the record departs beyond this many errors

#: how the caution of a refuted law begins (the plain summary looks for it among the warnings)
LAW_REFUTED = "the record's loss per half swing does not follow the model's damping law"

#: what an envelope drifting from the model's says (the plain summary looks for it among the warnings)
LAW_DRIFTS = "the model's damping law does not follow the record's decay"

#: what a record losing less at large amplitude than the fitted laws suggests
LESS_AT_LARGE = ("it loses less at large amplitude than the model's laws allow (a scale that reads large angles short, "
                 "or a loss of another kind; escfit compare weighs the laws)")


@dataclass(frozen=True)
class LawMismatch:
    """The record's losses per half swing against the model's, bin by bin (radians, or the
    readings' unit).

    Attributes
    ----------
    amplitude, record, model, error : ndarray
        Each bin's mean amplitude, the record's mean loss per half swing, the model's at the
        same turning points, and the record's standard error.
    """

    amplitude: np.ndarray
    record: np.ndarray
    model: np.ndarray
    error: np.ndarray

    @property
    def sigmas(self) -> np.ndarray:
        return np.abs(self.record - self.model) / self.error

    @property
    def share(self) -> np.ndarray:
        return np.abs(self.record - self.model) / np.maximum(np.abs(self.model), 1e-300)

    @property
    def refuted(self) -> bool:
        """Whether some bin differs beyond both :data:`LAW_SIGMAS` and :data:`LAW_SHARE`."""
        return bool(np.any((self.sigmas > LAW_SIGMAS) & (self.share > LAW_SHARE)))

    @property
    def worst(self) -> int:
        """The refuting bin furthest from the model, in standard errors."""
        bad = (self.sigmas > LAW_SIGMAS) & (self.share > LAW_SHARE)
        return int(np.argmax(np.where(bad, self.sigmas, -1.0)))

    @property
    def at_large(self) -> int:
        """How the record's loss compares with the model's in the bin of largest amplitude: +1
        more (a law stronger at large amplitude, such as air drag, is missing), -1 less, 0 within
        :data:`SIDE_SIGMAS` standard errors."""
        top = int(np.argmax(self.amplitude))
        z = (self.record[top] - self.model[top]) / self.error[top]
        return 1 if z > SIDE_SIGMAS else -1 if z < -SIDE_SIGMAS else 0

    def caution(self, show, losses: str, drag: bool) -> str:
        """The evidence and what it suggests, in words.

        ``show(value)`` writes an amplitude or a loss; ``losses`` names the fitted laws'
        coefficients (``"C and R"``); ``drag`` says whether the model has air drag already.
        """
        k = self.worst
        if self.at_large > 0:
            why = "it loses more at large amplitude than the model's laws allow" + ("" if drag else " (add [effects.drag])")
        elif self.at_large < 0:
            why = LESS_AT_LARGE
        else:
            why = "escfit compare weighs the damping laws"
        return (f"{LAW_REFUTED}: at {show(self.amplitude[k])} "
                f"the record loses {show(self.record[k])} a half swing, the model {show(self.model[k])} "
                f"({self.sigmas[k]:.0f} standard errors, {100 * self.share[k]:.0f} %): {why}; {losses} and the loss at "
                "the start are a compromise of the whole record")


def law_mismatch(swing: np.ndarray, record: np.ndarray, model: np.ndarray) -> LawMismatch | None:
    """The bins of the record's and the model's losses per half swing (module docstring).

    Parameters
    ----------
    swing
        Turning-point numbers (integers, increasing).
    record, model
        The record's and the model's amplitudes at those turning points (unsigned, same unit).

    Returns
    -------
    LawMismatch or None
        ``None`` with fewer than :data:`MIN_LOSSES` losses or a bin without scatter.
    """
    rec = from_readings(swing, np.abs(np.asarray(record, float)))
    mod = from_readings(swing, np.abs(np.asarray(model, float)))
    if rec.amplitude.size < MIN_LOSSES:
        return None
    order = np.argsort(rec.amplitude)
    groups = [g for g in np.array_split(order, BINS) if g.size >= 3]
    amp = np.array([rec.amplitude[g].mean() for g in groups])
    got = np.array([rec.decrement[g].mean() for g in groups])
    want = np.array([mod.decrement[g].mean() for g in groups])
    error = np.array([rec.decrement[g].std(ddof=1) / math.sqrt(g.size) for g in groups])
    if not (np.all(np.isfinite(error)) and np.all(error > 0)):
        return None
    return LawMismatch(amp, got, want, error)


def refuted_caution(amplitude, show, losses: str, drag: bool) -> str:
    """The caution of a fit whose damping law the record's losses refute, or ``""``.

    ``amplitude`` is the fit's :class:`~escfit.analysis.agreement.TurnDifferences` of the
    turning amplitudes (record minus model, with the record's own); ``show``, ``losses`` and
    ``drag`` as for :meth:`LawMismatch.caution`.
    """
    if amplitude is None or amplitude.size is None:
        return ""
    law = law_mismatch(amplitude.swing, amplitude.size, np.abs(amplitude.size) - amplitude.difference)
    return law.caution(show, losses, drag) if law is not None and law.refuted else ""
