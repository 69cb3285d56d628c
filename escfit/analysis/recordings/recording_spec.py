"""How to read a raw recording: the ``[recording]`` options and the conversions they drive.

A scene's ``[recording]`` table says which columns (or MATLAB variables) hold the time and
the angle, in which units, and which part of the record to keep::

    [recording]
    time_column = "t (s)"          # name or 1-based position; or
    time_unit = "ms"               # the time column's unit where its header names none (or names it wrong)
    sample_rate = "500 Hz"         # a uniform clock: time = row / rate (row 0 at t = 0)
    angle_column = "angle (deg)"   # name or 1-based position (.mat: a selector or a list of them)
    angle_unit = "deg"             # any pint angle unit, or "counts" with counts_per_turn
    counts_per_turn = 40000        # only with angle_unit = "counts"
    scale = 1.0                    # multiplies the raw readings before the unit applies
    start = "13 s"                 # optional window: 13 s after the record's first sample
    stop = "60 s"                  # (or "abs 1407000060 s": the file's own clock; see below)
    release = "14.2 s"             # optional: the model is released here (the free decay starts here)
    readings = "samples"           # or "amplitudes": one amplitude per half swing per row
    velocity_column = "Gyroscope x (rad/s)"   # instead of angle_column: an angular velocity
    velocity_unit = "rad/s"        # an angular velocity (deg/s, rpm; Hz = turn/s); or "V" with scale in rad/s per V
    displacement_column = "Position (m)"      # instead of angle_column: a linear coordinate
    displacement_unit = "m"        # any pint length; or "V" with scale in m per V
    format = "phyphox"             # the file's format where detection cannot decide (see detect.FORMATS)
    run = 2                        # which run of a file holding several (CASSY, PASCO, Vernier), from 1
    lift_angle = "52 deg"          # timegrapher files that do not say the lift angle set
    bph = 28800                    # timegrapher files that do not say the beat rate
    mode = 1                       # a record ringing in two modes: fit the slower (1) or the faster (2)

Every key is optional; what is not given is detected from the file where that is safe.
The command line overrides the table key by key (:func:`merge_spec`).

The window: start, stop, release
--------------------------------
Times are read on the record's clock measured from its first sample, or on the file's own
clock with the prefix ``abs`` (:mod:`~escfit.analysis.recordings.window` gives the rule); every
format that yields a sampled series applies them in one place
(:func:`~escfit.analysis.recordings.rawsteps.build_series`).

The user's choice wins over the analysis' own search for the free decay
(:func:`~escfit.analysis.recordings.turning_points.reduce_series`): with ``release`` the model is
released at that instant (at the turning point there, or at the held angle when the record is
flat up to it; an instant more than a tenth of a period from both takes the next turning point,
with a note); with ``start`` alone the free decay starts at the first turning point at or after
it, and no push, hold or drive before it is looked for.  ``stop`` ends the record.

Conversions
-----------
``theta (rad) = raw * scale * rad_per_unit`` where ``rad_per_unit`` is pint's factor of the
angle unit, or ``2*pi / counts_per_turn`` for ``counts``; ``scale`` turns volts (or any
sensor reading) into the unit, so a sensor of 0.5 rad/V is ``angle_unit = "rad"``,
``scale = 0.5``.  Times are converted to s; a logger's faulty stamps (written in bursts, a row
out of order, a stalled clock) are repaired by the time-base stage
(:mod:`escfit.analysis.timebase`), and what it cannot repair is refused naming
``sample_rate``, which replaces the time column by row number / rate.  Unit strings are parsed only if they fit a small grammar
(:func:`safe_unit_text`), because pint evaluates arithmetic and ``9**9**9`` never returns.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields, replace
from typing import Any, Callable, Mapping

from ...core.errors import DataError, SceneError
from ...core.units import COMMON_UNITS, COUNT_WORDS, angular_frequency_factor, common_factor, registry, to_canonical
from .window import WINDOW_KEYS, Instant, parse_instant

__all__ = ["RecordingSpec", "recording_spec_from_table", "merge_spec", "parse_option", "parse_seconds", "safe_unit_text",
           "is_angle_unit", "rad_per_unit", "seconds_per_unit", "header_role", "COUNT_WORDS"]

Column = str | int | tuple[str, ...]
TIME_WORDS = frozenset({"t", "time", "zeit", "sec", "secs", "seconds", "s", "timestamp", "time_stamp", "elapsed"})
UNIT_WORDS = frozenset({"deg", "degree", "degrees", "rad", "radian", "radians"} | COUNT_WORDS)
ANGLE_WORDS = frozenset({"theta", "angle", "phi", "alpha", "position", "pos", "winkel", "encoder", "θ", "φ", "α"}
                        | UNIT_WORDS)


@dataclass(frozen=True)
class RecordingSpec:
    """Options for reading a raw recording; ``None`` means "detect from the file".

    Attributes
    ----------
    time_column : str, int, tuple of str or None
        Column name, 1-based position, or (.mat) selector(s) of the time stamps.
    sample_rate : float or None
        Uniform sampling rate, Hz (exclusive with ``time_column``).
    time_unit : str or None
        Unit of the time column (s, ms, us, min): where its header names none, or names the wrong one.
    angle_column : str, int, tuple of str or None
        Column name, 1-based position, or (.mat) selector(s) of the angle.
    angle_unit : str or None
        Unit of ``raw * scale``: a pint angle unit or ``"counts"``.
    counts_per_turn : float or None
        Encoder counts per revolution (only with ``angle_unit = "counts"``).
    scale : float or None
        Factor applied to the raw readings before the unit (``None``: 1).
    start, stop : Instant or None
        Window to keep (inclusive), s after the first sample or on the file's clock (see
        "The window" above; a plain number given here is a time after the first sample).
    release : Instant or None
        Where the free decay starts: the model is released there (same clock rule).
    readings : str
        ``"samples"`` (default): the angle sampled in time; ``"amplitudes"``: each row is
        already the amplitude of one half swing (a pointer read at every turning point), row 0
        being the release.
    velocity_column, displacement_column : str, int or None
        Instead of ``angle_column``: a column holding an angular velocity or a linear
        displacement (the series' ``quantity``).
    velocity_unit, displacement_unit : str or None
        Unit of ``raw * scale``: a pint angular velocity (rad/s, deg/s, rpm) or length (m, mm);
        a voltage (V, mV) means the sensor's reading, and ``scale`` (required) is then the SI
        value per that unit (rad/s per V, m per V).
    format : str or None
        The file's format (one of :data:`escfit.analysis.recordings.detect.FORMATS`) where detection
        cannot decide.
    run : int or None
        Which run (from 1) of a file holding several side by side (CASSY, PASCO, Vernier).
    lift_angle : float or None
        Lift angle set on a timegrapher, rad, for files that do not record it.
    bph : int or None
        Beats per hour of the watch, for timegrapher files that do not record it.
    mode : int or None
        Of a record ringing in two modes, the one fitted: 1 the slower, 2 the faster; the other
        is filtered out (:mod:`escfit.analysis.mode_filter`).
    """

    time_column: Column | None = None
    sample_rate: float | None = None
    angle_column: Column | None = None
    angle_unit: str | None = None
    counts_per_turn: float | None = None
    scale: float | None = None
    start: Instant | None = None
    stop: Instant | None = None
    readings: str = "samples"
    velocity_column: Column | None = None
    velocity_unit: str | None = None
    displacement_column: Column | None = None
    displacement_unit: str | None = None
    format: str | None = None
    run: int | None = None
    lift_angle: float | None = None
    bph: int | None = None
    release: Instant | None = None
    mode: int | None = None
    time_unit: str | None = None

    def __post_init__(self):
        for key in WINDOW_KEYS:  # a plain number is a time after the first sample
            value = getattr(self, key)
            if value is not None and not isinstance(value, Instant):
                object.__setattr__(self, key, Instant(float(value), False, f"{float(value):g} s"))

    @property
    def quantity(self) -> str:
        """What the chosen column measures: ``"angle"``, ``"angular_velocity"`` or ``"displacement"``."""
        if self.velocity_column is not None or (self.velocity_unit is not None and self.displacement_column is None):
            return "angular_velocity"
        if self.displacement_column is not None or self.displacement_unit is not None:
            return "displacement"
        return "angle"

    @property
    def signal_column(self) -> Column | None:
        """The column of the chosen quantity (``None``: detect it)."""
        return {"angle": self.angle_column, "angular_velocity": self.velocity_column,
                "displacement": self.displacement_column}[self.quantity]

    @property
    def signal_unit(self) -> str | None:
        """The unit option of the chosen quantity."""
        return {"angle": self.angle_unit, "angular_velocity": self.velocity_unit,
                "displacement": self.displacement_unit}[self.quantity]

    @classmethod
    def from_options(cls, **options: Any) -> RecordingSpec:
        """Build a spec from command-line style values (see :func:`merge_spec`)."""
        return merge_spec(cls(), **options)


KEYS = tuple(f.name for f in fields(RecordingSpec))

_UNIT_TOKEN = re.compile(r"[^\W\d][\w°µ]*|°|\d+(?:\.\d+)?|\*\*|[-*/^()]|\s+")
_NUMBER = re.compile(r"\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d{1,3})?")


def safe_unit_text(text: str) -> bool:
    """Whether ``text`` is a unit expression pint may evaluate without risk.

    Allowed: names, numbers, ``*``, ``/``, parentheses, spaces and powers (``**`` or ``^``)
    whose exponent is a one- or two-digit integer (optionally negative) not raised again;
    at most 40 characters.
    """
    if not isinstance(text, str) or not text.strip() or len(text) > 40:
        return False
    pieces = _UNIT_TOKEN.findall(text)
    if "".join(pieces) != text:
        return False
    toks = [p for p in pieces if not p.isspace()]
    i = 0
    while i < len(toks):
        if toks[i] == "-":
            return False  # a minus sign only inside an exponent
        if toks[i] in ("**", "^"):
            j = i + 1 + (i + 1 < len(toks) and toks[i + 1] == "-")
            if j >= len(toks) or not re.fullmatch(r"\d{1,2}", toks[j]):
                return False
            if j + 1 < len(toks) and toks[j + 1] in ("**", "^"):
                return False
            i = j
        i += 1
    return True


def _parse_unit(text: str, where: str):
    if not safe_unit_text(text):
        raise DataError(f"cannot read {text!r} as a unit (letters, digits, * / ^ and parentheses, at most "
                    "40 characters)", where)
    try:
        q = registry().parse_expression(text.strip())
    except Exception:
        try:  # free-text unit labels (LabVIEW's Y_Unit_Label "Deg", "Sec") in another case
            q = registry().parse_expression(text.strip().lower())
        except Exception:
            raise DataError(f"unknown unit {text!r}", where) from None
    if not hasattr(q, "units"):
        raise DataError(f"{text!r} is a number, not a unit", where)
    return q


def is_angle_unit(text: str) -> bool:
    """Whether ``text`` is a pint angle unit (deg, rad, grad, turn, arcmin ...) or a counts word."""
    if text.strip().lower() in COUNT_WORDS:
        return True
    if text.strip() in COMMON_UNITS:  # radians, degrees, seconds: no pint
        return COMMON_UNITS[text.strip()][0] == "angle"
    try:
        q = _parse_unit(text, "")
    except DataError:
        return False
    return q.to_root_units().units == registry().radian


def rad_per_unit(unit: str, counts_per_turn: float | None, where: str, *, hint: str = "") -> float:
    """Radians per ``unit``: pint's factor, or ``2*pi / counts_per_turn`` for counts.

    Raises
    ------
    DataError
        Unknown or non-angle units (``hint`` names the option to set), counts without
        ``counts_per_turn``.
    """
    if unit.strip().lower() in COUNT_WORDS:
        if counts_per_turn is None:
            raise DataError(f"angle unit {unit!r} needs [recording] counts_per_turn", where)
        return 2.0 * math.pi / counts_per_turn
    if (factor := common_factor(unit, "angle")) is not None:
        return factor
    q = _parse_unit(unit, where)
    if q.to_root_units().units != registry().radian:
        raise DataError(f"{unit!r} is not an angle unit{hint}", where)
    return float(q.to("rad").magnitude)


def seconds_per_unit(unit: str, where: str) -> float:
    """Seconds per ``unit`` (a pint time unit such as s, ms, min)."""
    if (factor := common_factor(unit, "time")) is not None:
        return factor
    q = _parse_unit(unit, where)
    if q.dimensionality != registry().second.dimensionality:
        raise DataError(f"{unit!r} is not a time unit", where)
    return float(q.to("s").magnitude)


# --- what a column name says ---------------------------------------------------------------------

def _name_unit(name: str) -> tuple[str, str | None]:
    """Split ``Time ( s )``, ``t [s]``, ``phi / deg``, ``angle_deg`` into (base, unit)."""
    m = re.fullmatch(r"(.*?)\s*[(\[]\s*([^()\[\]]*?)\s*[)\]]\s*", name) or re.fullmatch(r"(.+?)\s*/\s*(\S+)", name)
    if m and m.group(1).strip() and m.group(2):
        return m.group(1).strip(), m.group(2)
    m = re.fullmatch(r"(.+)_([^\W\d_]+|°)", name)
    if m:
        unit = m.group(2)
        if unit.lower() in COUNT_WORDS or is_angle_unit(unit) or (safe_unit_text(unit) and _is_time_unit(unit)):
            return m.group(1), unit
    return name.strip(), None


def _is_time_unit(unit: str) -> bool:
    try:
        seconds_per_unit(unit, "")
    except DataError:
        return False
    return True


def header_role(name: str) -> tuple[str | None, str | None]:
    """Role (``"time"``, ``"angle"`` or None) and unit (or None) of a column name.

    Units come from ``Time ( s )``, ``t [s]``, ``phi / deg`` or a unit suffix ``angle_deg``,
    ``t_s``; names that are units (``deg``, ``counts``) carry themselves.  The role comes
    from the name (t, time, zeit, sec, s / theta, angle, phi, position, pos, winkel, encoder,
    deg, rad, counts; a trailing number is ignored), else from the unit's dimension.
    """
    base, unit = _name_unit(name)
    word = re.sub(r"[\s_]*\d+$", "", base.lower())
    if unit is None and word in UNIT_WORDS:
        unit = word
    if word in TIME_WORDS:
        return "time", unit
    if word in ANGLE_WORDS:
        return "angle", unit
    if unit is not None:
        if is_angle_unit(unit):
            return "angle", unit
        if _is_time_unit(unit):
            return "time", unit
    return None, unit


# --- validation of the [recording] keys -------------------------------------------------------

def _column(value: Any, where: str, cli: bool) -> Column:
    if isinstance(value, str) and cli:
        parts = [p.strip() for p in value.split(",")] if "," in value else [value.strip()]
        if len(parts) > 1:
            value = parts
        elif parts[0].isdigit():
            value = int(parts[0])
    if isinstance(value, bool) or not isinstance(value, (str, int, list, tuple)):
        raise SceneError(f"expected a column name, a 1-based position or a list of names, got {value!r}", where)
    if isinstance(value, int):
        if value < 1:
            raise SceneError(f"column positions count from 1, got {value}", where)
        return value
    if isinstance(value, str):
        if not value.strip():
            raise SceneError("empty column name", where)
        return value
    if not value or not all(isinstance(v, str) and v.strip() for v in value):
        raise SceneError(f"a list of columns must hold non-empty names, got {value!r}", where)
    return tuple(value) if len(value) > 1 else value[0]


def _quantity(value: Any, kind: str, where: str) -> float:
    if isinstance(value, str):
        m = _NUMBER.match(value)
        rest = value[m.end():].strip() if m else value
        if not m or len(value) > 60 or (rest and not safe_unit_text(rest)):
            raise SceneError(f"cannot read {value!r} as a number with a unit", where)
        if not rest:
            value = float(value)
    return to_canonical(value, kind, where)


def _positive(value: Any, kind: str, where: str) -> float:
    v = _quantity(value, kind, where)
    if not v > 0:
        raise SceneError(f"must be positive, got {value!r}", where)
    return v


def _number(value: Any, where: str, cli: bool) -> float:
    if cli and isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            raise SceneError(f"expected a number, got {value!r}", where) from None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value == 0:
        raise SceneError(f"expected a finite non-zero number, got {value!r}", where)
    return float(value)


def _angle_unit(value: Any, where: str, cli: bool) -> str:
    if not isinstance(value, str) or not is_angle_unit(value):
        volts = isinstance(value, str) and value.strip() in ("V", "mV", "volt", "volts")
        raise SceneError(f"expected an angle unit (deg, rad, grad, turn, arcmin ... or 'counts'), got {value!r}" + (
            ": a column in volts keeps its angle_unit for the angle (deg or rad) and takes scale, the angle per "
            "volt" if volts else ""), where)
    return value.strip()


def _signal_unit(dimension: str, what: str):
    def parse(value: Any, where: str, cli: bool) -> str:
        if isinstance(value, str) and safe_unit_text(value):
            try:
                q = registry().parse_expression(value.strip())
                dim = q.dimensionality if hasattr(q, "dimensionality") else None
            except Exception:
                dim = None
            if dim is not None and dim == registry().volt.dimensionality:
                return value.strip()
            if dimension == "rad/s":  # an angular velocity: the rule of every angular frequency (Hz = turn/s)
                try:
                    angular_frequency_factor(value, where)
                    return value.strip()
                except SceneError:
                    pass
            elif dim is not None and dim == registry().parse_expression(dimension).dimensionality:
                return value.strip()
        raise SceneError(f"expected {what} (e.g. {dimension}) or a voltage (V, mV) with scale, got {value!r}", where)
    return parse


def _time_unit(value: Any, where: str, cli: bool) -> str:
    if not (isinstance(value, str) and safe_unit_text(value) and _is_time_unit(value.strip())):
        raise SceneError(f"expected a time unit (s, ms, us, min), got {value!r}", where)
    return value.strip()


def _format(value: Any, where: str, cli: bool) -> str:
    from .formats_list import FORMAT_NAMES

    if value not in FORMAT_NAMES:
        raise SceneError(f"unknown format {value!r}; one of {', '.join(FORMAT_NAMES)}", where)
    return value


def _run(value: Any, where: str, cli: bool) -> int:
    if cli and isinstance(value, str) and value.strip().isdigit():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 10000:
        raise SceneError(f"run counts from 1, got {value!r}", where)
    return value


def _lift(value: Any, where: str, cli: bool) -> float:
    v = _quantity(value, "angle", where) if isinstance(value, str) else math.radians(_number(value, where, cli))
    if not math.radians(10.0) <= v <= math.radians(90.0):
        raise SceneError(f"a lift angle lies within 10-90 deg, got {value!r} (a number is in deg)", where)
    return v


_PARSE: dict[str, Callable[[Any, str, bool], Any]] = {
    "time_column": _column,
    "sample_rate": lambda v, w, cli: _positive(v, "frequency", w),
    "time_unit": _time_unit,
    "angle_column": _column,
    "angle_unit": _angle_unit,
    "counts_per_turn": lambda v, w, cli: _positive(v, "dimensionless", w),
    "scale": _number,
    "start": lambda v, w, cli: _instant(v, w),
    "stop": lambda v, w, cli: _instant(v, w),
    "release": lambda v, w, cli: _instant(v, w),
    "readings": lambda v, w, cli: _readings(v, w),
    "velocity_column": _column,
    "velocity_unit": _signal_unit("rad/s", "an angular velocity unit"),
    "displacement_column": _column,
    "displacement_unit": _signal_unit("m", "a length unit"),
    "format": _format,
    "run": _run,
    "lift_angle": _lift,
    "bph": lambda v, w, cli: _bph(v, w, cli),
    "mode": lambda v, w, cli: _mode(v, w, cli),
}


def _mode(value: Any, where: str, cli: bool) -> int:
    if cli and isinstance(value, str) and value.strip().isdigit():
        value = int(value)
    if isinstance(value, bool) or value not in (1, 2):
        raise SceneError(f"mode is 1 (the slower of a record's two modes) or 2 (the faster), got {value!r}", where)
    return value


def _instant(value: Any, where: str) -> Instant:
    """A window key: a time (``"13 s"``, a number in s) or ``"abs <time>"`` (the file's own clock)."""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise SceneError(f"expected a time such as \"13 s\" or \"abs 1407000013 s\", got {value!r}", where)
    return parse_instant(value, where, lambda v, w: _quantity(v, "time", w))


def _bph(value: Any, where: str, cli: bool) -> int:
    if cli and isinstance(value, str) and value.strip().isdigit():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not 3600 <= value <= 172800:
        raise SceneError(f"bph is a whole number of beats per hour in 3600-172800, got {value!r}", where)
    return value


def _readings(value: Any, where: str) -> str:
    if value not in ("samples", "amplitudes"):
        raise SceneError(f"readings must be 'samples' or 'amplitudes', got {value!r}", where)
    return value


def parse_seconds(value: Any, where: str) -> float:
    """A duration given as text or a number (s): ``"2 ms"``, ``0.002``; SceneError if bad."""
    return _quantity(value, "time", where)


def parse_option(key: str, value: Any, where: str) -> Any:
    """Validate one option given as text (a file's metadata, the command line); SceneError if bad."""
    return _PARSE[key](value, where, True)


def _check(spec: RecordingSpec, where_of: Callable[[str], str]) -> RecordingSpec:
    if spec.time_column is not None and spec.sample_rate is not None:
        raise SceneError("give time_column or sample_rate, not both", where_of("sample_rate"))
    counts = spec.angle_unit is not None and spec.angle_unit.lower() in COUNT_WORDS
    if spec.counts_per_turn is not None and spec.angle_unit is not None and not counts:
        raise SceneError(f"counts_per_turn goes with angle_unit = 'counts', not {spec.angle_unit!r}",
                         where_of("counts_per_turn"))
    if counts and spec.counts_per_turn is None:
        raise SceneError("angle_unit = 'counts' needs counts_per_turn", where_of("angle_unit"))
    chosen = [k for k in ("angle_column", "velocity_column", "displacement_column") if getattr(spec, k) is not None]
    if len(chosen) > 1:
        raise SceneError(f"give one of angle_column, velocity_column, displacement_column, not {' and '.join(chosen)}",
                         where_of(chosen[-1]))
    for unit_key, col_key in (("velocity_unit", "velocity_column"), ("displacement_unit", "displacement_column")):
        if getattr(spec, unit_key) is not None and spec.quantity != col_key.split("_")[0].replace("velocity",
                                                                                              "angular_velocity"):
            raise SceneError(f"{unit_key} goes with {col_key}", where_of(unit_key))
        unit = getattr(spec, unit_key)
        if unit is not None and registry().parse_expression(unit).dimensionality == registry().volt.dimensionality \
                and spec.scale is None:
            raise SceneError(f"{unit_key} = {unit!r} is the sensor's reading: give scale, the SI value per {unit} "
                             f"({'rad/s' if col_key.startswith('velocity') else 'm'} per {unit})", where_of(unit_key))
    for early, late, strict in (("start", "stop", True), ("start", "release", False), ("release", "stop", False)):
        a, b = getattr(spec, early), getattr(spec, late)
        if a is None or b is None or a.absolute != b.absolute:
            continue  # across clocks they are compared by the reader, which knows the file's clock
        if a.seconds > b.seconds or (strict and a.seconds == b.seconds):
            raise SceneError(f"{early} ({a.shown()}) must come before {late} ({b.shown()})", where_of(late))
    return spec


def recording_spec_from_table(table: Mapping, where: str) -> RecordingSpec:
    """Validate a scene's ``[recording]`` table.

    Parameters
    ----------
    table
        The parsed TOML table (keys as in the module docstring).
    where
        The scene file, used as ``"<where> [recording].<key>"`` in messages.

    Raises
    ------
    SceneError
        Unknown keys (the known ones are listed), wrong types or units, conflicting keys.
    """
    def where_of(key: str) -> str:
        return f"{where} [recording].{key}"

    if not isinstance(table, Mapping):
        raise SceneError(f"[recording] must be a table, got {table!r}", f"{where} [recording]")
    unknown = sorted(set(table) - set(KEYS))
    if unknown:
        raise SceneError(f"unknown key(s) {unknown}; known: {', '.join(KEYS)}", where_of(unknown[0]))
    values = {k: _PARSE[k](v, where_of(k), False) for k, v in table.items()}
    return _check(RecordingSpec(**values), where_of)


def merge_spec(spec: RecordingSpec | None, *, where: str = "command line", **overrides: Any) -> RecordingSpec:
    """Override ``spec`` key by key with command-line values.

    Parameters
    ----------
    spec
        The scene's spec (``None``: all keys unset).
    where
        Named in messages as ``"<where> --<option>"``.
    **overrides
        ``time_column``, ``sample_rate``, ... as the command line gives them: ``None`` leaves
        the key alone; a string of digits is a 1-based column position and commas separate a
        list of .mat selectors; quantities may be strings with units.  Giving ``sample_rate``
        drops the scene's ``time_column`` and vice versa; a non-counts ``angle_unit`` drops its
        ``counts_per_turn``.

    Raises
    ------
    SceneError
        Unknown options, bad values, conflicting keys.
    """
    def where_of(key: str) -> str:
        return f"{where} --{key.replace('_', '-')}"

    unknown = sorted(set(overrides) - set(KEYS))
    if unknown:
        raise SceneError(f"unknown option(s) {unknown}; known: {', '.join(KEYS)}", where)
    given = {k: _PARSE[k](v, where_of(k), True) for k, v in overrides.items() if v is not None}
    base = spec or RecordingSpec()
    if "sample_rate" in given:
        base = replace(base, time_column=None)
    if "time_column" in given:
        base = replace(base, sample_rate=None)
    columns = ("angle_column", "velocity_column", "displacement_column")
    if any(k in given for k in columns):  # the command line's column replaces the scene's, whatever its quantity
        base = replace(base, **{k: None for k in columns if k not in given})
    unit = given.get("angle_unit")
    if unit is not None and unit.lower() not in COUNT_WORDS and "counts_per_turn" not in given:
        base = replace(base, counts_per_turn=None)
    return _check(replace(base, **given), where_of)
