"""How a run ended: one status enum for every solver of every model family.

A compiled kernel returns a :class:`Status` as a plain integer; the Python front ends turn it
back into the enum.  Each member has a ``label``, the word written to results files, printed
by ``escfit simulate --json`` and compared against by callers, and a ``message`` saying what
it means.  Several members share a label where a caller needs no finer distinction (a pendulum
driven over the top and a step size below rounding are both ``"failed"``); the member keeps
the finer reason.

Values are stable: they are stored in compiled kernels' results and may be written to files.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["Status", "LABELS"]


class Status(IntEnum):
    """Outcome of a run.

    ``OK``
        Everything asked for was computed.
    ``STOPPED``
        Friction holds the oscillator at rest (or it creeps to rest without another turning
        point) before the end of the run.
    ``BANKED``
        Balance runs: complete, but at least one half swing ended on the banking pins.
    ``MAX_SEGMENTS``
        The segment budget (exact pieces, located events) ran out first.
    ``PHASE_BREAKDOWN``
        Monday's phase convention: a half cycle ended on the side it started.
    ``OVER_THE_TOP``
        A pendulum reached |theta| = pi and has no further turning point.
    ``STEP_UNDERFLOW``
        An adaptive step fell below the rounding of the time.
    ``STEP_BUDGET``
        The integration-step budget ran out first.
    ``REFUSED``
        The parameter set was refused before any work (a batch member; see its message).
    ``FAILED``
        Any other failure of the model (the families' integrators).
    """

    OK = 0
    STOPPED = 1
    BANKED = 2
    MAX_SEGMENTS = 3
    PHASE_BREAKDOWN = 4
    OVER_THE_TOP = 5
    STEP_UNDERFLOW = 6
    STEP_BUDGET = 7
    REFUSED = 8
    FAILED = 9

    @property
    def label(self) -> str:
        """The word results files and the command line use for this status."""
        return LABELS[self][0]

    @property
    def message(self) -> str:
        """What the status means, in one sentence."""
        return LABELS[self][1]


#: label and message of each status
LABELS: dict[Status, tuple[str, str]] = {
    Status.OK: ("ok", "all requested half swings computed"),
    Status.STOPPED: ("stopped", "friction holds the balance at rest (or it creeps to rest without another turning "
                                "point)"),
    Status.BANKED: ("banked", "run complete; at least one half swing ended on the banking pins"),
    Status.MAX_SEGMENTS: ("max_segments", "segment budget exhausted before the requested swings (pathological "
                                          "input)"),
    Status.PHASE_BREAKDOWN: ("phase_breakdown", "phase switching: some half cycle ended on the side it started (or C "
                                                "reached 2*omega0); the numbers are what Monday's programs compute, "
                                                "but they no longer describe a swinging balance"),
    Status.OVER_THE_TOP: ("failed", "the pendulum went over the top (|theta| reached pi) and has no further turning "
                                    "point"),
    Status.STEP_UNDERFLOW: ("failed", "the step size fell below the rounding of the time (the equation is too stiff "
                                      "or the tolerances too tight)"),
    Status.STEP_BUDGET: ("max_segments", "step budget exhausted before the requested swings (stiff or pathological "
                                         "input, e.g. an overdamped creep to rest: use the exact solver)"),
    Status.REFUSED: ("failed", "the parameter set was refused before any work"),
    Status.FAILED: ("failed", "the solver failed"),
}
