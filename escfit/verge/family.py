"""The verge escapement's entry in the model-family registry.

:data:`FAMILY` tells the inference layer how to read turns-to-arm readings and build their
fit problem (:class:`~escfit.verge.problem.TurnsProblem`).

Cost
----
One forward run of the M739 mechanism (about 360 motion phases to 26 turns) takes 45 ms
of CPU at step 0.2, so fits are counted in forward runs: least squares needs about ten per start
and emcee ``walkers * (steps + 1)`` plus the predictive draws.  The defaults (3 starts;
8 walkers x 300 steps with de-t moves; 16 predictive draws; ~2500 runs)
take about 110 s of CPU and converge on the shipped M739 example (R-hat 1.02).  In one
dimension emcee's stretch move mixes slowly (autocorrelation ~27 steps against ~5 with
differential evolution); the ``"de-t"`` mixture (Student-t proposals fitted to the walkers, with
differential evolution) is the default: the shipped recipe converges (R-hat <= 1.01, ESS >= 400)
after 400 steps, where ``"de"`` needed 976.
"""

from __future__ import annotations

from pathlib import Path

from ..core.errors import DataError
from ..core.family import FamilyBase
from ..core.scene import load_scene
from .data import FORMAT, TurnsData, detect_turns, read_turns_csv
from .problem import TurnsProblem

__all__ = ["FAMILY", "VergeFamily"]

PROBLEM_OPTIONS = frozenset({"step"})


class VergeFamily(FamilyBase):
    """Registry entry of ``model = "verge"`` (see :class:`~escfit.core.family.Family`)."""

    name = "verge"
    package = "escfit.verge"
    problem_options = PROBLEM_OPTIONS
    formats = {FORMAT: read_turns_csv}
    fit_defaults = {"walkers": 8, "steps": 300, "n_starts": 3, "predictive_draws": 16, "moves": "de-t"}

    def detect(self, path) -> str:
        """``"turns-to-arm"`` for a table with columns ``label, spin_rpm, turns``; else a DataError."""
        return detect_turns(path)

    def problem(self, scene, data, **options) -> TurnsProblem:
        """The fit problem of a verge scene (object or path) and turns-to-arm data (object or path).

        Options: ``step`` (RK4 step, rad of spin; default the scene's ``[fit] step`` or
        :data:`~escfit.verge.problem.FIT_STEP`).
        """
        sc = load_scene(scene) if not hasattr(scene, "model") else scene
        self.refuse_unknown_options(options, sc.where)
        if isinstance(data, (str, Path)):
            fmt = self.detect(data)
            data = self.formats[fmt](data)
        if not isinstance(data, TurnsData):
            raise DataError(f"a verge fit reads turns-to-arm data, got {type(data).__name__}", sc.where)
        return TurnsProblem(sc, data, step=options.get("step"))

    def title(self, attrs) -> str:
        return "Verge escapement model"


FAMILY = VergeFamily()
