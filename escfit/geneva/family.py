"""The Geneva escapement's entry in the model-family registry.

:data:`FAMILY` tells the inference layer how to read a Geneva recording (a driver-speed
trace or terminal speeds, detected from the CSV header) and build its
:class:`~escfit.geneva.problem.GenevaProblem`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..core.family import FamilyBase
from ..core.scene import load_scene

__all__ = ["FAMILY", "GenevaFamily"]

PROBLEM_OPTIONS = frozenset({"fmt"})


class GenevaFamily(FamilyBase):
    """Registry entry of ``model = "geneva"`` (see :class:`~escfit.core.family.Family`).

    ``fit_defaults``: a speed trace's least-squares cost is rugged (a wrong period puts the
    speed oscillation out of phase), so the cost is ranked at 24 start points spread over
    the priors and Levenberg-Marquardt runs from the best 3.  One forward run costs 2-5 ms
    (a trace of 200 samples, or one terminal cycle), so the default 16 walkers x 600 steps
    take 20-50 s; the shipped recipes use 8 walkers with the ``"de-t"`` moves (Student-t
    proposals fitted to the walkers, with differential evolution): 1220-1525 steps to
    convergence, where differential evolution alone (two to three times faster than the
    stretch move here) needed 2382-2977.
    """

    name = "geneva"
    package = "escfit.geneva"
    problem_options = PROBLEM_OPTIONS
    fit_defaults = {"walkers": 16, "steps": 600, "n_starts": 24, "n_refine": 3, "predictive_draws": 160}

    @property
    def formats(self) -> dict[str, Any]:
        """Format name -> reader ``(path) -> recording``."""
        from .data import FORMATS

        return dict(FORMATS)

    def detect(self, path) -> str:
        from .data import detect_format

        return detect_format(path)

    def problem(self, scene, data, **options):
        """The fit problem of a Geneva scene (object or path) and a recording (object or path).

        Options: ``fmt`` (``"speed-trace"`` or ``"terminal-speeds"``; detected from the
        file's header when ``None``).
        """
        from .data import read_data
        from .problem import GenevaProblem

        self.refuse_unknown_options(options, getattr(scene, "where", None))
        sc = load_scene(scene) if not hasattr(scene, "model") else scene
        if isinstance(data, (str, Path)):
            data = read_data(data, options.get("fmt"))
        return GenevaProblem(sc, data)

    def title(self, attrs) -> str:
        return "Geneva escapement model"


FAMILY = GenevaFamily()
