"""The readers' record of a sampled signal: :class:`TimeSeries`.

A leaf module: every reader builds a TimeSeries and the turning-point analysis
(:mod:`~escfit.balance.recordings.turning_points`) takes one; this module imports neither, so the
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

Only angles are fitted today; the readers deliver the other two so that the waveform fit can
take them as they are (never differentiated or integrated), and a fit refuses them with one line
until it does (:func:`refuse_unless_angle`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...core.errors import FitError

__all__ = ["TimeSeries", "QUANTITIES", "refuse_unless_angle"]

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
        :func:`~escfit.balance.recordings.turning_points.reduce_series`).
    source, sha256, meta
        File name, content hash and metadata (strings: how the file was read, its notes).
    quantity : str
        ``"angle"`` (rad), ``"angular_velocity"`` (rad/s) or ``"displacement"`` (m).
    """

    time: np.ndarray
    theta: np.ndarray
    release_s: float = math.nan
    source: str = ""
    sha256: str = ""
    meta: dict = field(default_factory=dict)
    quantity: str = "angle"
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


def refuse_unless_angle(series: TimeSeries) -> None:
    """Refuse, in one line, to fit a series that is not an angle (velocity and displacement
    observations are read but not yet fitted).

    Raises
    ------
    FitError
        The series is an angular velocity or a displacement.
    """
    if series.quantity == "angle":
        return
    what = {"angular_velocity": "an angular velocity (rad/s)", "displacement": "a linear displacement (m)"}
    raise FitError(f"the recording is {what[series.quantity]}; escfit reads it but does not fit such an observation "
                   "yet (only angles): give the angle column instead ([recording] angle_column), or keep the file "
                   "for a later version", series.source or None)
