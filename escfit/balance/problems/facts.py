"""What the analysis of a record found, handed whole to the fit problem built from it.

:func:`~escfit.balance.problems.from_series.problem_from_series` analyses a record once and
builds its problem; everything the analysis adds to the problem (the notes that say what was
done to the record, the data warnings, the measured period, the parameters held at the
record's measurement, the turning points and the stretch of the record used) travels in one
:class:`RecordFacts` given to the problem's constructor, so a problem is complete when it is
made and nothing is set on it from outside afterwards.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

__all__ = ["RecordFacts"]


@dataclass(frozen=True)
class RecordFacts:
    """The record's facts a problem carries.

    Attributes
    ----------
    notes
        What was done to the record, in sentences; they come before the problem's own notes.
    data_warnings
        What in the record limits the fit; they come after the problem's own.
    measured_period
        The record's period (:class:`~escfit.balance.problems.period.MeasuredPeriod`), or None.
    held
        Parameters held at the record's measurement, which the fit may move (``Problem.hold``).
    turning_points
        The record's :class:`~escfit.analysis.recordings.timeseries.TurningPoints`, or None.
    record_window
        ``(first sample, last sample, first instant fitted, last instant fitted)`` in s on the
        record's clock, or None.
    given_scene
        The scene as the user wrote it (the agreement check builds its turning-point fit from
        it), or None.
    trailing
        Notes that come after the problem's own (the command line's overrides of the scene).
    """

    notes: tuple[str, ...] = ()
    data_warnings: tuple[str, ...] = ()
    measured_period: Any = None
    held: tuple[str, ...] = ()
    turning_points: Any = None
    record_window: tuple[float, float, float, float] | None = None
    given_scene: Any = None
    trailing: tuple[str, ...] = ()

    def plus(self, more: "RecordFacts | None") -> "RecordFacts":
        """These facts with ``more``'s notes, warnings and trailing notes after their own."""
        if more is None:
            return self
        return replace(self, notes=self.notes + more.notes, data_warnings=self.data_warnings + more.data_warnings,
                       trailing=self.trailing + more.trailing)

    def give(self, problem) -> None:
        """Complete ``problem`` with these facts (its constructor calls this last)."""
        problem.notes = list(self.notes) + list(getattr(problem, "notes", ()) or ()) + list(self.trailing)
        problem.data_warnings = list(getattr(problem, "data_warnings", ()) or ()) + list(self.data_warnings)
        problem.measured_period = self.measured_period
        problem.held = tuple(self.held)
        problem.turning_points = self.turning_points
        problem.other_modes = tuple(getattr(self.turning_points, "other_modes", ()))
        problem.record_window = self.record_window
        problem.given_scene = self.given_scene
