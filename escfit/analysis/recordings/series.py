"""The readers' record of a sampled signal: :class:`TimeSeries`.

A leaf module: every reader builds a TimeSeries and the turning-point analysis
(:mod:`~escfit.analysis.recordings.turning_points`) takes one; this module imports neither, so the
data flows one way (file -> reader -> TimeSeries -> analysis -> fit problem).

What was measured
-----------------
``quantity`` says what the samples are, always in SI units:

============================  ============  ===========================================================
quantity                      unit          recorded by
============================  ============  ===========================================================
``"angle"``                   rad           an encoder, a potentiometer, a video track about a pivot
``"angular_velocity"``        rad/s         a gyroscope, a rate gyro, a velocity pickup (volts x scale)
``"displacement"``            m             a motion detector under a mass, a linear coordinate
============================  ============  ===========================================================

The waveform fit takes each as it was measured (:mod:`escfit.balance.problems.waveform`): an
angular velocity is compared with the model's theta'(t), a displacement with the x(t) of a linear
oscillator scene; nothing is differentiated or integrated for the fit.  :func:`show_value` writes
a value of any quantity for the analysis' notes (angles in degrees, as people read them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .window import RecordWindow

__all__ = ["TimeSeries", "QUANTITIES", "show_value", "quantity_words"]

#: quantity -> SI unit of the samples
QUANTITIES = {"angle": "rad", "angular_velocity": "rad/s", "displacement": "m"}


@dataclass
class TimeSeries:
    """A sampled signal of an oscillator: by default the balance (or pendulum) angle.

    Attributes
    ----------
    time : ndarray
        Sample times, s (strictly increasing).
    theta : ndarray
        The samples in the SI unit of ``quantity`` (for an angle: rad, signed, a sensor's zero
        offset still in it).  The name is kept from when every series was an angle;
        :attr:`values` is the same array.
    release_s : float
        Release instant, s (``nan``: found from the record, see
        :func:`~escfit.analysis.recordings.turning_points.reduce_series`).
    source, sha256, meta
        File name, content hash and metadata (strings: how the file was read, its notes).
    quantity : str
        ``"angle"`` (rad), ``"angular_velocity"`` (rad/s) or ``"displacement"`` (m).
    window : RecordWindow or None
        The ``[recording]`` start, stop and release the reader resolved on this clock, and the
        file's first sample (:mod:`~escfit.analysis.recordings.window`); ``None``: none given and
        the first sample is ``time[0]``.
    """

    time: np.ndarray
    theta: np.ndarray
    release_s: float = math.nan
    source: str = ""
    sha256: str = ""
    meta: dict = field(default_factory=dict)
    quantity: str = "angle"
    window: RecordWindow | None = None
    kind = "timeseries"

    def __post_init__(self):
        if self.quantity not in QUANTITIES:
            raise ValueError(f"quantity must be one of {sorted(QUANTITIES)}, got {self.quantity!r}")

    @property
    def values(self) -> np.ndarray:
        """The samples, in :attr:`unit`."""
        return self.theta

    @property
    def unit(self) -> str:
        """SI unit of the samples: rad, rad/s or m."""
        return QUANTITIES[self.quantity]


def show_value(value: float, quantity: str = "angle", digits: int = 3, *, signed: bool = False) -> str:
    """A value of ``quantity`` (in its SI unit) for a sentence: ``"12.3 deg"``, ``"0.51 rad/s"``, ``"0.0123 m"``.

    Angles are written in degrees, as people read them; rates and displacements in their SI unit.
    """
    v = math.degrees(value) if quantity == "angle" else float(value)
    unit = "deg" if quantity == "angle" else QUANTITIES[quantity]
    return f"{v:{'+' if signed else ''}.{digits}g} {unit}"


def quantity_words(quantity: str) -> str:
    """``"angle"``, ``"angular velocity"`` or ``"displacement"``: the quantity in a sentence."""
    return quantity.replace("_", " ")
