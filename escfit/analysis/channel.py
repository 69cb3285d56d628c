"""Which of several columns is the free decay: each scored by its shape, a clear winner or none.

When a file holds several columns that could be the signal and no ``[recording]`` key names one,
each candidate is scored as a free decay (:func:`decay_score`)::

    score = explained * min(1, fall / FULL_FALL)

``explained`` is the fraction of the column's variance a sinusoid near its periodogram peak
explains, stretch by stretch (:func:`~escfit.analysis.quantity.swing_shape`); ``fall`` is how much
that sinusoid's amplitude falls from the first quarter of the record to the last.  A free decay
scores near 1; a function generator's steady sine (no fall), white noise (no sinusoid explains
it), a clock or a running total (no oscillation) score near 0; an energy column (troughs pinned at
its minimum, or a one-sided column at twice a neighbour's frequency), an acceleration and any
column whose label says another quantity score 0.

Margin rule: the best column is chosen only if it scores at least :data:`MIN_SCORE` and every
other at most :data:`MARGIN` times its score.  One motion in several columns: when every rival above
that margin oscillates at the best's frequency (within :data:`SAME_FREQUENCY`) and its amplitude
falls by the same share (within :data:`SAME_FALL`), the columns record one decay (a laser and a
coil on one mass, x and y of one tracked bob): they give the same frequency and decay rate, but
their amplitudes, and so the friction, are only as right as each one's calibration, so the one
column whose label names an angle (else a displacement) is chosen, the note naming the others;
when no label or several decide, the refusal says they hold one motion.  A column that is
another's time derivative (:func:`rate_of`: a tracker's ``x`` and ``x velocity``) is that
column's rate, not a second sensor: of a position and its rate the position is chosen.  Axes of one sensor (labels
that differ only in an axis letter, ``Gyroscope x``, ``y`` and ``z``, one unit): a body swinging
about one axis turns fastest about it, the others seeing only the sensor's tilt and the body's
wobble, so the axis whose oscillation is :data:`AXIS_DOMINANCE` times every other's is chosen when
it scores :data:`MIN_SCORE` (the note says so).  Otherwise :class:`ChannelChoice` has no ``chosen``
and :meth:`ChannelChoice.refusal` names the candidates with their scores and the key to set.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .quantity import ENERGY_FLOOR, SwingShape, label_quantity, swing_shape

__all__ = ["ChannelChoice", "choose_channel", "decay_score", "MIN_SCORE", "MARGIN", "FULL_FALL"]

MIN_SCORE = 0.2
MARGIN = 0.5
FULL_FALL = 0.5  # a swing losing half its amplitude over the record counts fully as a decay
AXIS_DOMINANCE = 3.0  # an axis of one sensor oscillating this many times more than the others is the motion's
SAME_FREQUENCY = 0.005  # columns whose frequencies agree this closely (relative) ...
SAME_FALL = 0.1  # ... and whose amplitudes fall by shares this close hold one motion
SQUARE_FALL = 0.1  # a column keeping (1 - fall)^2 of a neighbour's amplitude, within this, is its square
RATE_CORRELATION = 0.95  # a column this correlated with another's time derivative ...
RATE_SCALE = 1.25  # ... and equal to it within this factor, in the file's units, is that column's rate


@dataclass(frozen=True)
class ChannelChoice:
    """The column chosen as the free decay, with every candidate's score and why.

    Attributes
    ----------
    chosen : str or None
        The chosen column's label (None: no clear winner).
    scores : dict of str to float
        Each candidate's score, 0-1.
    why : dict of str to str
        Each candidate's shape in words.
    reason : str
        The note (a choice) or the refusal's reason.
    key : str
        The ``[recording]`` key that names the column.
    """

    chosen: str | None
    scores: dict[str, float]
    why: dict[str, str]
    reason: str
    key: str = "angle_column"
    shapes: dict[str, SwingShape] = field(default_factory=dict, repr=False)
    positions: dict[str, int] = field(default_factory=dict)  # label -> 1-based column, where the reader knows it
    units: dict[str, str | None] = field(default_factory=dict)

    def key_of(self, label: str) -> str:
        """The key that names ``label``: ``displacement_column`` or ``velocity_column`` where its unit says so."""
        said = label_quantity(label, self.units.get(label))
        return {"displacement": "displacement_column", "angular_velocity": "velocity_column"}.get(said, self.key)

    def listing(self) -> str:
        """``'ch2' 0.98 (a decaying oscillation ...), 'ch1' 0.03 (...)``, best first."""
        order = sorted(self.scores, key=lambda c: -self.scores[c])
        return ", ".join(f"{_shown(c)} {self.scores[c]:.2f} ({self.why[c]})" for c in order)

    def note(self) -> str:
        """The sentence said when a column was chosen."""
        rest = [c for c in sorted(self.scores, key=lambda c: -self.scores[c]) if c != self.chosen]
        others = "; ".join(f"{_shown(c)} {100 * self.scores[c]:.0f} %: {self.why[c]}" for c in rest)
        said = "" if self.reason == "clear winner" else f"{self.reason}; "
        return (said + f"{_shown(self.chosen, 'column ')} chosen: {self.why[self.chosen]}, score "
                f"{self.scores[self.chosen]:.2f}"
                + (f"; {others}" if others else "") + f" ([recording] {self.key} chooses another)")

    def refusal(self) -> str:
        """The one-line reason no column was chosen, naming the key to set."""
        best = max(self.scores, key=self.scores.get) if self.scores else "..."
        value = self.positions[best] if best.startswith("column ") and best in self.positions else repr(best)
        return f"{self.reason}: {self.listing()}; set [recording] {self.key} = {value} (or another column)"


def _shown(label: str, prefix: str = "") -> str:
    """A column in a sentence: ``column 3`` for a table without a header, else its quoted name."""
    return label if label.startswith("column ") and label[7:].isdigit() else f"{prefix}{label!r}"


def _words(shape: SwingShape, score: float) -> str:
    if shape.monotone:
        return "monotone, no oscillation (a clock? a total?)"
    if not math.isfinite(shape.frequency) or shape.explained < 0.2:
        return f"no dominant oscillation, {100 * shape.explained:.0f} % of its variance a sinusoid (noise?)"
    if shape.fall < 0.02:
        return (f"a steady sine at {shape.frequency:.4g} Hz, {100 * shape.explained:.0f} % of its variance, "
                f"amplitude not falling (a drive?)")
    if shape.fall < 0:
        return f"an oscillation at {shape.frequency:.4g} Hz growing, not decaying"
    return (f"a decaying oscillation at {shape.frequency:.4g} Hz explains {100 * shape.explained:.0f} % of its "
            f"variance, its amplitude falling {100 * shape.fall:.0f} %")


def decay_score(time: np.ndarray, values: np.ndarray, *, name: str = "", unit: str | None = None,
                shape: SwingShape | None = None) -> tuple[float, str, SwingShape]:
    """``(score, words, shape)`` of one column as a free decay (see the module docstring)."""
    shape = shape if shape is not None else swing_shape(time, values)
    said = label_quantity(name, unit)
    if said in ("acceleration", "energy", "velocity", "time"):
        return 0.0, f"labelled {unit or name!r}: {'an' if said[0] in 'aeiou' else 'a'} {said}", shape
    if shape.energy_like:
        return 0.0, ("an even function of the swing, such as an energy (two peaks per swing, never below its "
                     "floor)"), shape
    score = shape.explained * min(1.0, max(0.0, shape.fall) / FULL_FALL)
    return float(score), _words(shape, score), shape


def _double_of_a_neighbour(label: str, shapes: dict[str, SwingShape], values: dict[str, np.ndarray]) -> str:
    """Why a column is the square of another candidate's swing ("" when it is not): at twice
    its frequency, and one-sided (troughs at its minimum: an energy) or with its amplitude
    falling as the square of the other's (what is left is ``(1 - fall)^2``: a bob's height,
    ``L (1 - cos theta)``, beside its horizontal position)."""
    me = shapes[label]
    if not math.isfinite(me.frequency):
        return ""
    for other, s in shapes.items():
        if other == label or not math.isfinite(s.frequency) or abs(me.frequency / s.frequency - 2.0) >= 0.05 \
                or s.explained <= 0.5:
            continue
        if me.trough_floor <= ENERGY_FLOOR:
            return "an energy (never below its minimum, at twice a neighbour's frequency)"
        if math.isfinite(me.fall) and math.isfinite(s.fall) and s.fall >= 0.2 \
                and abs((1.0 - me.fall) - (1.0 - s.fall) ** 2) <= SQUARE_FALL:
            return (f"the height beside the horizontal swing of {_shown(other)} (at twice its frequency, its "
                    "amplitude falling as the square of that one's)")
    return ""


def _one_motion(best: str, rivals: list[str], shapes: dict[str, SwingShape]) -> list[str] | None:
    """The rivals, if every one decays as ``best`` does: the same frequency within
    :data:`SAME_FREQUENCY` and a fall within :data:`SAME_FALL` (one motion seen by several
    sensors, or a sensor and the drive's monitor of it); else None."""
    me = shapes[best]
    if not rivals or not math.isfinite(me.frequency):
        return None
    for c in rivals:
        s = shapes[c]
        if not (math.isfinite(s.frequency) and abs(s.frequency / me.frequency - 1.0) <= SAME_FREQUENCY
                and abs(s.fall - me.fall) <= SAME_FALL):
            return None
    return rivals


def rate_of(time: np.ndarray, position: np.ndarray, rate: np.ndarray) -> float | None:
    """The correlation of ``rate`` with the time derivative of ``position`` when ``rate`` is that
    derivative (correlated by :data:`RATE_CORRELATION` or more, and equal to it within a factor
    :data:`RATE_SCALE` in the file's units: a tracker's ``x`` and its ``x velocity``); else None.

    A neighbour a quarter period out of phase (the other axis of a bob going round) correlates
    with the derivative too, but is ``omega`` times smaller or larger: the scale tells them apart.
    """
    t, x, v = (np.asarray(a, float) for a in (time, position, rate))
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(v)
    if ok.sum() < 10 or np.any(np.diff(t[ok]) <= 0.0):
        return None
    dx = np.gradient(x[ok], t[ok])
    v = v[ok]
    dx, v = dx - dx.mean(), v - v.mean()
    norm = math.sqrt(float(np.dot(dx, dx)) * float(np.dot(v, v)))
    if norm == 0.0:
        return None
    r = float(np.dot(dx, v)) / norm
    scale = float(np.dot(dx, v) / np.dot(dx, dx))
    if r < RATE_CORRELATION or not 1.0 / RATE_SCALE <= scale <= RATE_SCALE:
        return None
    return r


_LINEAR_RATE = re.compile(r"\b(velocity|speed|vel|v)\b")
_ANGULAR = re.compile(r"\b(angular|omega|rotation|rotational|spin|gyro\w*)\b")


def _names_linear_rate(label: str) -> bool:
    """Whether a label names a linear velocity (``X Velocity``, ``v_x``): not an angular one.

    The unit in brackets is left out first (``CH2 (V)`` is a voltage, not a ``v``)."""
    from .roles import base_name

    words = " ".join(re.split(r"[^a-z]+", base_name(label)))
    return bool(_LINEAR_RATE.search(words)) and not _ANGULAR.search(words)


def _drop_rates(group: list[str], columns: dict[str, np.ndarray],
                time: np.ndarray | dict[str, np.ndarray]) -> tuple[list[str], str, list[str]]:
    """``group`` without the columns that are another member's time derivative (a rate of a rate,
    an acceleration beside its velocity, included), a sentence saying which, and the rate columns
    dropped."""
    said, rates = [], []
    for b in group:
        for a in group:
            if a == b:
                continue
            t = time[a] if isinstance(time, dict) else time
            if isinstance(time, dict) and not np.array_equal(time[a], time[b]):
                continue
            r = rate_of(t, columns[a], columns[b])
            if r is not None:
                rates.append(b)
                said.append(f"{_shown(b)} is the rate of change of {_shown(a)} (its time derivative, r = {r:.3f})")
                break
    return [c for c in group if c not in rates], "; ".join(said), sorted(rates)


def axis_base(label: str) -> tuple[str, str] | None:
    """``(label without its axis letter, the letter)`` for a label naming one axis (a word ``x``,
    ``y`` or ``z``, any case); None otherwise."""
    words = re.split(r"([^\w]+)", label)
    axes = [i for i, w in enumerate(words) if w.lower() in ("x", "y", "z")]
    if len(axes) != 1:
        return None
    i = axes[0]
    return "".join(words[:i] + ["*"] + words[i + 1:]).lower(), words[i].lower()


def _size(shape: SwingShape) -> float:
    """A column's typical oscillation amplitude (its unit): the median over its stretches."""
    a = np.asarray(shape.amplitudes, float)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if a.size else 0.0


def _dominant_axis(candidates: list[str], shapes: dict[str, SwingShape], units: dict[str, str | None]) -> str | None:
    """Of two or more columns that are axes of one sensor (one unit), the one oscillating
    :data:`AXIS_DOMINANCE` times more than every other; None when they are not axes or none dominates."""
    if len(candidates) < 2:
        return None
    bases = [axis_base(c) for c in candidates]
    if any(b is None for b in bases) or len({b[0] for b in bases}) != 1 or len({b[1] for b in bases}) != len(bases):
        return None
    if len({units.get(c) for c in candidates}) != 1:
        return None
    sizes = {c: _size(shapes[c]) for c in candidates}
    top = max(sizes, key=sizes.get)
    if all(sizes[top] >= AXIS_DOMINANCE * sizes[c] for c in candidates if c != top):
        return top
    return None


def _plainest(best: str, same: list[str], units: dict[str, str | None]) -> str | None:
    """Of columns holding one motion, the only one whose label says the quantity fitted (an
    angle, else a displacement); None when no label, or several, say so (the amplitudes, and so
    the friction, depend on which column's calibration is right)."""
    for wanted in ("angle", "displacement"):
        named = [c for c in [best, *same] if label_quantity(c, units.get(c)) == wanted]
        if named:
            return named[0] if len(named) == 1 else None
    return None


def choose_channel(time: np.ndarray | dict[str, np.ndarray], columns: dict[str, np.ndarray], *,
                   units: dict[str, str | None] | None = None, key: str = "angle_column") -> ChannelChoice:
    """Score each candidate column as a free decay and choose a clear winner, if there is one.

    Parameters
    ----------
    time : ndarray, or dict of label to ndarray
        Sample times, s (one clock for all, or each column's own).
    columns : dict of str to ndarray
        Candidate label -> values (any unit; rows without a reading may be nan).
    units : dict, optional
        Candidate label -> unit as the file gives it.
    key : str
        The ``[recording]`` key that names the column (said in the note and the refusal).

    Returns
    -------
    ChannelChoice
    """
    units = units or {}
    scores, why, shapes = {}, {}, {}
    for label, values in columns.items():
        t = time[label] if isinstance(time, dict) else time
        v = np.asarray(values, float)
        ok = np.isfinite(v) & np.isfinite(t)
        scores[label], why[label], shapes[label] = decay_score(t[ok], v[ok], name=label, unit=units.get(label))
    for label in columns:
        square = _double_of_a_neighbour(label, shapes, columns) if scores[label] > 0 else ""
        if square:
            scores[label], why[label] = 0.0, square
    order = sorted(scores, key=lambda c: -scores[c])
    best = order[0] if order else None
    second = scores[order[1]] if len(order) > 1 else 0.0
    if best is not None and scores[best] >= MIN_SCORE and second <= MARGIN * scores[best]:
        return ChannelChoice(best, scores, why, "clear winner", key, shapes, units=dict(units))
    axis = _dominant_axis([c for c in order if scores[c] > MARGIN * scores[best]] if best else [], shapes, units)
    if axis is not None and scores[axis] >= MIN_SCORE:
        others = [c for c in order if c != axis]
        ratio = min(_size(shapes[axis]) / max(_size(shapes[c]), 1e-300) for c in others)
        reason = (f"axes of one sensor: {_shown(axis)} oscillates {ratio:.3g} times more than "
                  f"{' and '.join(_shown(c) for c in others)}, the axis the body swings about")
        return ChannelChoice(axis, scores, why, reason, key, shapes, units=dict(units))
    if best is not None and scores[best] >= MIN_SCORE:
        same = _one_motion(best, [c for c in order[1:] if scores[c] > MARGIN * scores[best]], shapes)
        if same is not None:
            kept, rates, dropped = _drop_rates([best, *same], columns, time)
            if len(kept) == 1:  # a position and its rate: the position is what the model's angle follows
                linear = key == "angle_column" and all(_names_linear_rate(c) for c in dropped) \
                    and label_quantity(kept[0], units.get(kept[0])) is None
                reason = (f"one motion in {len(dropped) + 1} columns: {rates}; the position is fitted"
                          + (", as a displacement (its rate is named a velocity, not an angular one)" if linear
                             else ""))
                return ChannelChoice(kept[0], scores, why, reason, "displacement_column" if linear else key, shapes,
                                     units=dict(units))
            chosen = _plainest(best, same, units)
            if chosen is None:
                reason = (f"one motion in several columns ({', '.join(_shown(c) for c in [best, *same])} decay at "
                          f"the same frequency, {shapes[best].frequency:.4g} Hz, and rate), and no label says which "
                          "is the calibrated angle")
                return ChannelChoice(None, scores, why, reason, key, shapes, units=dict(units))
            others = ", ".join(_shown(c) for c in [best, *same] if c != chosen)
            reason = (f"one motion in several columns: {others} decay{'s' if len(same) == 1 else ''} at the same "
                      f"frequency ({shapes[best].frequency:.4g} Hz) and rate as {_shown(chosen)}, whose label "
                      "names the quantity fitted")
            return ChannelChoice(chosen, scores, why, reason, key, shapes, units=dict(units))
    if best is None or scores[best] < MIN_SCORE:
        reason = f"no column has the shape of a free decay (a score of {MIN_SCORE:g} at least)"
    else:
        reason = (f"no clear free decay: the runner-up scores more than {MARGIN:g} of the best's score")
    return ChannelChoice(None, scores, why, reason, key, shapes, units=dict(units))
