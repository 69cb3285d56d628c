"""What a recorded channel measures, judged from the shape of its signal against what it claims.

A free decay of an angle, an angular velocity or a displacement oscillates about a centre: one
peak and one trough per period, the peaks falling and the troughs rising towards the centre as
the swing dies.  Other columns a lab file holds beside it do not:

- an energy (kinetic ``~ theta'**2``, potential ``~ theta**2``) is never below its minimum, which
  it touches twice a swing: its troughs stay at the minimum while its peaks fall, and its
  spectrum lies at twice the swing's frequency;
- a length (mm, m) is a displacement and an acceleration (m/s^2) is neither an angle nor anything
  escfit fits; their labels say so and a guess must not read them as degrees;
- an angle's unit can be checked against the swing's size: a lab pendulum or balance swings
  degrees to a few hundred degrees, so a column "in degrees" swinging a few hundredths of a
  degree over many clean swings is radians, and one "in radians" swinging more than
  :data:`MAX_TURNS` turns without a wrap is degrees.

:func:`swing_shape` measures the shape (numpy only), :func:`check_quantity` turns it into a
:class:`QuantityCheck`: the quantity the shape and label are consistent with, the evidence, and a
verdict ``"ok"``, ``"suspect"`` (a note) or ``"refuse"`` (a one-line error naming the key to set).

Thresholds
----------
``SMALL_DEG`` (0.05): a largest swing below this many "degrees" over at least ``CLEAN_SWINGS``
swings explained to ``CLEAN_EXPLAINED`` by a sinusoid is suspect (radians of a 3-degree swing
read as degrees); only a note, since a real sub-arcminute swing is possible.
``MAX_TURNS`` (2): a half range above 2 turns (4 pi rad) in radians is refused: no swinging
oscillator escfit fits turns that far, and a wrapped angle (``atan2``) spans at most one turn.
``SMALL_SWING_DEG`` (1): a measured decay whose largest amplitude about its centre is below one
"degree" over ``CLEAN_SWINGS`` swings or more earns a warning naming ``angle_unit = "rad"``
(:func:`swing_unit_check`): radians read as degrees shrink a 40-degree swing to 0.7 "degrees",
which a pendulum's fit takes for a small swing, with the wrong omega0.
``ENERGY_FALL`` (0.3) and ``ENERGY_FLOOR`` (0.05): the peaks fall by 30 % of the range or more
while every swing's trough stays within 5 % of the range above the minimum.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SwingShape", "QuantityCheck", "swing_shape", "check_quantity", "label_quantity", "swing_unit_check",
           "COLUMN_KEYS", "OTHER_QUANTITY", "SMALL_DEG", "SMALL_SWING_DEG", "MAX_TURNS", "ENERGY_FALL", "ENERGY_FLOOR"]

SMALL_DEG = 0.05
CLEAN_SWINGS = 4
CLEAN_EXPLAINED = 0.9
MAX_TURNS = 2.0
SMALL_SWING_DEG = 1.0
ENERGY_FALL = 0.3
ENERGY_FLOOR = 0.05
#: what fixes a column whose values cannot be the angle claimed
OTHER_QUANTITY = ("angle_unit (--angle-unit) if it is an angle in another unit, displacement_column with "
                  "displacement_unit (--displacement-column) if it is a position (a track's x), or angle_column "
                  "(--angle-column) if another column is the angle")
COLUMN_KEYS = {"angle": "angle_column", "angular_velocity": "velocity_column", "displacement": "displacement_column"}
_CHUNK_PERIODS = 3.0
_MIN_CHUNK = 24
_ENERGY_WORDS = ("energy", "energie", "e_kin", "ekin", "e_pot", "epot", "kinetic", "kinetisch", "potential")
_ACCEL_WORDS = ("acc", "accel", "acceleration", "beschleunigung", "accelerometer")


@dataclass(frozen=True)
class SwingShape:
    """The shape of a sampled signal as a swing.

    Attributes
    ----------
    frequency : float
        Dominant frequency of the periodogram, Hz (nan: no oscillation found).
    explained : float
        Fraction (0-1) of the within-stretch variance explained by a sinusoid near that frequency,
        fitted stretch by stretch (about 3 periods each, with its own centre and slope).
    amplitudes : ndarray
        The sinusoid's amplitude in each stretch, in the signal's unit.
    fall : float
        ``1 - (last amplitudes)/(first amplitudes)``: 0 for a steady sine, near 1 for a decay to rest.
    trough_rise, peak_fall : float
        How far the stretches' minima rise and maxima fall over the record, as fractions of the range.
    swings : float
        Periods in the record.
    monotone : bool
        No oscillation at all: the signal only rises or only falls (a clock, a total).
    """

    frequency: float
    explained: float
    amplitudes: np.ndarray
    fall: float
    trough_rise: float
    peak_fall: float
    trough_floor: float
    swings: float
    monotone: bool

    @property
    def energy_like(self) -> bool:
        """Troughs pinned at the minimum while the peaks fall: an energy, not a coordinate."""
        return (self.explained > 0.5 and self.peak_fall >= ENERGY_FALL and self.trough_floor <= ENERGY_FLOOR)


@dataclass(frozen=True)
class QuantityCheck:
    """What a column's signal is consistent with, and the verdict on what it was read as.

    Attributes
    ----------
    quantity : str
        What the shape and label say: ``"angle"``, ``"angular_velocity"``, ``"displacement"``,
        ``"acceleration"``, ``"energy"`` or ``"unknown"``.
    unit : str
        The unit the column is read in (``""``: none).
    evidence : tuple of str
        Sentences saying what was measured.
    verdict : str
        ``"ok"``, ``"suspect"`` (a note is due) or ``"refuse"``.
    key : str
        The ``[recording]`` setting that fixes it (``'angle_unit = "rad"'``), or ``""``.
    shape : SwingShape or None
    """

    quantity: str
    unit: str
    evidence: tuple[str, ...] = ()
    verdict: str = "ok"
    key: str = ""
    shape: SwingShape | None = field(default=None, repr=False)

    def sentence(self, name: str = "") -> str:
        """One line: the column, the evidence, the key to set."""
        who = f"column {name!r}: " if name else ""
        fix = f"; set [recording] {self.key}" if self.key else ""
        return f"{who}{'; '.join(self.evidence)}{fix}"


def _uniform(time: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, float]:
    dt = float(np.median(np.diff(time)))
    if not dt > 0:
        return x, 1.0
    if np.allclose(np.diff(time), dt, rtol=1e-3, atol=0):
        return x, dt
    n = min(int((time[-1] - time[0]) / dt) + 1, 1 << 20)
    grid = np.linspace(time[0], time[-1], n)
    return np.interp(grid, time, x), float(grid[1] - grid[0])


def dominant_frequency(time: np.ndarray, x: np.ndarray) -> float:
    """The periodogram's highest peak above the lowest bins, Hz: a linearly detrended, Hann-windowed FFT
    refined by a parabola through the peak bin and its neighbours (nan for fewer than 8 samples)."""
    u, dt = _uniform(np.asarray(time, float), np.asarray(x, float))
    n = u.size
    if n < 8:
        return math.nan
    k = np.arange(n)
    u = u - np.polyval(np.polyfit(k, u, 1), k)
    power = np.abs(np.fft.rfft(u * np.hanning(n))) ** 2
    power[:3] = 0.0  # the trend's leakage, and no swing with fewer than 2 periods in the record
    i = int(np.argmax(power))
    if i == 0 or power[i] <= 0:
        return math.nan
    shift = 0.0
    if 0 < i < power.size - 1:
        a, b, c = np.log(power[i - 1:i + 2] + 1e-300)
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den < 0 else 0.0
    return float((i + shift) / (n * dt))


def swing_shape(time: np.ndarray, x: np.ndarray) -> SwingShape:
    """Measure a signal's shape as a swing (see :class:`SwingShape`); ``time`` in s, increasing."""
    t = np.asarray(time, float)
    x = np.asarray(x, float)
    ok = np.isfinite(t) & np.isfinite(x)
    t, x = t[ok], x[ok]
    span = float(np.ptp(x)) if x.size else 0.0
    steps = np.diff(x)
    monotone = bool(x.size > 2 and (np.all(steps >= 0) or np.all(steps <= 0)))
    f = dominant_frequency(t, x) if x.size >= 8 and span > 0 and not monotone else math.nan
    empty = SwingShape(math.nan, 0.0, np.zeros(0), 0.0, 0.0, 0.0, 1.0, 0.0, monotone or span == 0)
    if not math.isfinite(f) or t[-1] <= t[0]:
        return empty
    period = 1.0 / f
    dt = float(np.median(np.diff(t)))
    # stretches of 3 periods; a short record (under 12 periods) in 4 stretches of at least a period each
    length = max(min(_CHUNK_PERIODS * period, (t[-1] - t[0]) / 4), period, _MIN_CHUNK * dt)
    nchunks = max(1, int((t[-1] - t[0]) // length))
    edges = np.searchsorted(t, t[0] + length * np.arange(nchunks + 1))
    edges[-1] = t.size
    within = fitted = 0.0
    amps, lows, highs = [], [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        if hi - lo < 6:  # a stretch the samples skip (a gap of the record)
            continue
        tc, xc = t[lo:hi] - t[lo:hi].mean(), x[lo:hi]
        base = np.column_stack([np.ones_like(tc), tc])
        line = xc - base @ np.linalg.lstsq(base, xc, rcond=None)[0]
        best = (math.inf, 0.0)
        for w in 2 * math.pi * f * np.linspace(0.85, 1.15, 13):
            design = np.column_stack([base, np.cos(w * tc), np.sin(w * tc)])
            coef = np.linalg.lstsq(design, xc, rcond=None)[0]
            res = float(np.sum((xc - design @ coef) ** 2))
            if res < best[0]:
                best = (res, math.hypot(coef[2], coef[3]))
        within += float(np.sum((xc - xc.mean()) ** 2))
        fitted += max(0.0, float(np.sum(line ** 2)) - best[0])
        amps.append(best[1])
        lows.append(float(xc.min()))
        highs.append(float(xc.max()))
    if not amps or within <= 0:
        return empty
    amps = np.asarray(amps)
    m = max(1, len(amps) // 4) if len(amps) >= 4 else 1
    first, last = float(np.mean(amps[:m])), float(np.mean(amps[-m:]))
    fall = 1.0 - last / first if first > 0 else 0.0
    lows, highs = np.asarray(lows), np.asarray(highs)
    return SwingShape(frequency=f, explained=min(1.0, fitted / within), amplitudes=amps, fall=fall,
                      trough_rise=float((np.mean(lows[-m:]) - np.mean(lows[:m])) / span),
                      peak_fall=float((np.mean(highs[:m]) - np.mean(highs[-m:])) / span),
                      trough_floor=float((lows.max() - x.min()) / span) if len(lows) > 1 else 1.0,
                      swings=float((t[-1] - t[0]) * f), monotone=False)


def _dimension(unit: str | None) -> str | None:
    """``"angle"``, ``"angular_velocity"``, ``"length"``, ``"acceleration"``, ``"energy"``, ``"time"`` or None."""
    if not unit:
        return None
    from ..core.units import COMMON_UNITS, COUNT_WORDS, registry, safe_unit_text

    text = unit.strip().replace("°", "deg").replace("²", "^2")
    if text in COMMON_UNITS:  # radians, degrees, seconds: no pint
        return COMMON_UNITS[text][0]
    if text.lower() in COUNT_WORDS or not safe_unit_text(text):
        return None
    ureg = registry()
    try:
        q = ureg.parse_expression(text)
        dim = q.dimensionality
    except Exception:
        return None
    for name, ref in (("length", "m"), ("acceleration", "m/s^2"), ("energy", "J"), ("time", "s"),
                      ("velocity", "m/s")):
        if dim == ureg.parse_expression(ref).dimensionality:
            return name
    if dim == ureg.parse_expression("rad").dimensionality and "rad" in str(q.to_root_units().units):
        return "angle"
    if dim == ureg.parse_expression("1/s").dimensionality:
        return "angular_velocity"
    return None


def label_quantity(name: str | None, unit: str | None) -> str | None:
    """What a column's name and unit say it holds: ``"angle"``, ``"angular_velocity"``, ``"displacement"``,
    ``"velocity"``, ``"acceleration"``, ``"energy"``, ``"time"`` or None (the label does not say)."""
    words = set(re.findall(r"[^\W\d_]+", (name or "").lower()))
    low = (name or "").lower()
    dim = _dimension(unit)
    if dim == "acceleration" or words & set(_ACCEL_WORDS):
        return "acceleration"
    if dim == "energy" or any(w in low for w in _ENERGY_WORDS):
        return "energy"
    return {"length": "displacement", "angle": "angle", "angular_velocity": "angular_velocity",
            "velocity": "velocity", "time": "time"}.get(dim)


def _in_unit(unit: str, si: float) -> float | None:
    """An angle in rad expressed in ``unit`` (deg or rad families), else None."""
    u = unit.strip().lower()
    if u in ("deg", "degree", "degrees", "°"):
        return math.degrees(si)
    if u in ("rad", "radian", "radians"):
        return si
    return None


def check_quantity(time: np.ndarray, values: np.ndarray, *, claimed: str = "angle", unit: str = "",
                   name: str = "", given_by: str = "file", scale: float = 1.0,
                   shape: SwingShape | None = None) -> QuantityCheck:
    """Judge whether a column read as ``claimed`` in ``unit`` has the shape of that quantity.

    Parameters
    ----------
    time : ndarray
        Sample times, s.
    values : ndarray
        The samples in the SI unit of ``claimed`` (rad, rad/s, m), before any unwrapping.
    claimed : str
        ``"angle"``, ``"angular_velocity"`` or ``"displacement"``.
    unit : str
        The unit the column is read in, as the file or the options say it.
    name : str
        The column's name (its label may say another quantity).
    given_by : str
        Where the unit came from: ``"file"`` (a label), ``"option"`` (the user's key: only notes
        then, the user has said it) or ``"assumed"``.
    scale : float
        The ``scale`` option; unit checks apply to scale 1 only (a scale turns a sensor's volts).

    Returns
    -------
    QuantityCheck
    """
    shape = shape if shape is not None else swing_shape(time, values)
    what = claimed.replace("_", " ")
    evidence: list[str] = []
    said = label_quantity(name, unit) or label_quantity(name, None)
    if shape.energy_like:
        evidence.append("an even function of the swing, such as an energy (two peaks per swing, never below its "
                        f"floor): its troughs stay within {100 * shape.trough_floor:.0f} % of the range above its "
                        f"minimum while its peaks fall by {100 * shape.peak_fall:.0f} %: not {'an' if what[0] in 'aeiou' else 'a'} {what}")
        return QuantityCheck("energy", unit, tuple(evidence), "refuse", COLUMN_KEYS.get(claimed, "angle_column"),
                             shape)
    if said in ("acceleration", "energy", "velocity") or (said == "displacement" and claimed != "displacement"):
        evidence.append(f"labelled {unit or name!r}: {'an' if said[0] in 'aeiou' else 'a'} {said.replace('_', ' ')}, "
                        f"not {'an' if what[0] in 'aeiou' else 'a'} {what}"
                        + (" (escfit fits angles, angular velocities and displacements)"
                           if said in ("acceleration", "energy", "velocity") else ""))
        key = "displacement_column" if said == "displacement" else ""
        return QuantityCheck(said, unit, tuple(evidence), "suspect" if given_by == "option" else "refuse", key, shape)
    if claimed != "angle" or scale != 1.0 or not unit or values.size < 2:
        return QuantityCheck(claimed, unit, (), "ok", "", shape)
    half = 0.5 * float(np.ptp(values))
    half_in = _in_unit(unit, half)
    if half_in is None:
        return QuantityCheck(claimed, unit, (), "ok", "", shape)
    if _in_unit(unit, 1.0) == 1.0 and half > MAX_TURNS * 2 * math.pi:
        evidence.append(f"read in {unit} it swings {half:.4g} rad = {half / (2 * math.pi):.3g} turns either way "
                        f"without a wrap: no swinging oscillator turns that far; degrees read as radians?")
        return QuantityCheck(claimed, unit, tuple(evidence), "suspect" if given_by == "option" else "refuse",
                             'angle_unit = "deg"', shape)
    biggest = float(shape.amplitudes.max()) if shape.amplitudes.size else half
    big_in = _in_unit(unit, biggest)
    if _in_unit(unit, 1.0) != 1.0 and big_in is not None and big_in < SMALL_DEG and \
            shape.swings >= CLEAN_SWINGS and shape.explained >= CLEAN_EXPLAINED:
        evidence.append(f"read in {unit} its largest swing is {big_in:.3g} {unit} over {shape.swings:.0f} clean swings "
                        f"({100 * shape.explained:.0f} % a sinusoid): a pendulum's swing is degrees, these look like "
                        "radians")
        return QuantityCheck(claimed, unit, tuple(evidence), "suspect", 'angle_unit = "rad"', shape)
    return QuantityCheck(claimed, unit, (), "ok", "", shape)


def swing_unit_check(amplitude: float, unit: str, *, restoring: str = "spring", swings: float = 0.0,
                     scale: float = 1.0) -> QuantityCheck:
    """Hold a measured decay's largest amplitude against the angle unit it was read in.

    Used by ``escfit init`` and by a fit alike, so that a unit slip is caught at the same point
    both ways: degrees read as radians (a pendulum past 180 degrees, or any swing beyond
    :data:`MAX_TURNS` turns) are refused; a pendulum "in degrees" past 180 degrees is no angle
    in degrees (pixels, millimetres) and is refused naming :data:`OTHER_QUANTITY`; radians read
    as degrees (a largest swing under :data:`SMALL_SWING_DEG` over :data:`CLEAN_SWINGS` swings
    or more) are suspect.

    Parameters
    ----------
    amplitude : float
        Largest amplitude about the centre, rad, as read (after the unit and ``scale``).
    unit : str
        The angle unit the column was read in (``deg``, ``rad``; other units are not judged).
    restoring : str
        ``"pendulum"`` (cannot swing past 180 deg) or ``"spring"``.
    swings : float
        Periods measured in the record.
    scale : float
        The ``scale`` option; a scaled column (a sensor's volts) is not judged.

    Returns
    -------
    QuantityCheck
        ``verdict`` ``"refuse"``, ``"suspect"`` or ``"ok"``; ``key`` the ``[recording]`` setting to make.
    """
    if scale != 1.0 or not math.isfinite(amplitude) or amplitude <= 0:
        return QuantityCheck("angle", unit)
    if _in_unit(unit, 1.0) == 1.0:  # radians
        pendulum = restoring == "pendulum" and amplitude >= math.pi
        if pendulum or amplitude > MAX_TURNS * 2 * math.pi:
            past = ", past the 180 deg a pendulum can swing" if pendulum else ": no swinging oscillator turns that far"
            return QuantityCheck("angle", unit, (
                f"read in {unit} the swing's amplitude is {amplitude:.4g} rad = {amplitude / (2 * math.pi):.3g} "
                f"turns{past}; read in degrees it is {amplitude:.4g} deg",), "refuse", 'angle_unit = "deg"')
    elif _in_unit(unit, 1.0) is not None:  # degrees
        in_deg = math.degrees(amplitude)
        if restoring == "pendulum" and amplitude >= math.pi:
            return QuantityCheck("angle", unit, (
                f"read as an angle in {unit} it swings {in_deg:.4g} deg from its centre, past the 180 deg a pendulum "
                "can swing back from (it would go over the top): not an angle in degrees",), "refuse", OTHER_QUANTITY)
        if in_deg < SMALL_SWING_DEG and swings >= CLEAN_SWINGS:
            return QuantityCheck("angle", unit, (
                f"read in {unit} the largest swing is {in_deg:.3g} deg over {swings:.0f} swings; read in radians it "
                f"is {math.degrees(in_deg):.3g} deg, a usual pendulum's swing",), "suspect", 'angle_unit = "rad"')
    return QuantityCheck("angle", unit)
