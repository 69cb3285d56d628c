"""The friction rig's entry in the model-family registry (``model = "friction_rig"``).

:data:`FAMILY` tells the inference layer how to read a rig readings file (format
``"rig-readings"``, :func:`escfit.friction.readers.read_readings`, detected from its header)
and build the session's :class:`~escfit.friction.problem.RigProblem`.  Fitting goes through
:func:`escfit.inference.fit`::

    from escfit.inference import fit
    result = fit("datasets/friction/monday1965_rig.toml",
                 "datasets/friction/monday1965_session_1095_steel.csv", method="emcee", seed=1965)

or ``escfit fit fits/friction_monday_steel.toml``.
"""

from __future__ import annotations

import csv
import hashlib
from pathlib import Path
from typing import Any

from ..core.errors import DataError, FitError
from ..core.textfile import decode_text
from ..core.family import FamilyBase
from ..core.scene import load_scene
from .readers import Readings, read_readings

__all__ = ["FAMILY", "RigFamily", "FORMAT", "PROBLEM_OPTIONS"]

FORMAT = "rig-readings"
PROBLEM_OPTIONS = frozenset({"material"})


class RigFamily(FamilyBase):
    """Registry entry of ``model = "friction_rig"`` (see :class:`~escfit.core.family.Family`).

    ``fit_defaults``: the log posterior is closed-form and vectorised over the ensemble, so
    32 walkers x 3000 steps (about 40 autocorrelation times of the Monday sessions' 5
    parameters, burn-in a quarter of the run) take a few seconds.
    """

    name = "friction_rig"
    package = "escfit.friction"
    problem_options = PROBLEM_OPTIONS
    fit_defaults = {"walkers": 32, "steps": 3000, "n_starts": 8, "predictive_draws": 400}

    @property
    def formats(self) -> dict[str, Any]:
        """Format name -> reader ``(path) -> Readings``."""
        return {FORMAT: read_readings}

    def detect(self, path) -> str:
        """``"rig-readings"`` when the file's header (first line that is neither blank nor a
        ``#`` comment) has ``load_<unit>`` and ``dw_<unit>`` columns; else a DataError."""
        where = str(path)
        p = Path(path)
        if not p.is_file():
            raise DataError("data file not found", where)
        try:
            raw = p.read_bytes()
        except OSError as exc:
            raise DataError(f"cannot read ({exc.strerror or exc})", where) from None
        text = decode_text(raw, where, what="a table of rig readings")
        for lineno, line in enumerate(text.splitlines(), start=1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            try:
                cells = [c.strip() for c in next(csv.reader([line]))]
            except csv.Error as exc:  # a field beyond the csv module's limit
                raise DataError(f"cannot read as a table ({exc})", f"{where}:{lineno}") from None
            names = {c.partition("_")[0] for c in cells if "_" in c}
            if {"load", "dw"} <= names:
                return FORMAT
            raise DataError(f"not a rig readings file: the header {cells} has no load_<unit> and dw_<unit> "
                            "columns (see docs/friction.md)", f"{where}:{lineno}")
        raise DataError("empty file: no header and no readings", where)

    def problem(self, scene, data, **options):
        """The fit problem of a rig scene (object or path) and a session (Readings or path).

        Options: ``material`` selects one material of a file holding several; such a file is
        refused without it, with the materials listed.
        """
        from .problem import RigProblem

        self.refuse_unknown_options(options, getattr(scene, "where", None))
        material = options.get("material")
        sc = load_scene(scene) if not hasattr(scene, "model") else scene
        if sc.model != self.name:
            raise FitError(f"the scene's model is {sc.model!r}, not {self.name!r}", getattr(sc, "where", None))
        sha = ""
        if isinstance(data, (str, Path)):
            self.detect(data)
            sha = hashlib.sha256(Path(data).read_bytes()).hexdigest()
            data = read_readings(data)
        elif not isinstance(data, Readings):
            raise FitError(f"cannot fit data of type {type(data).__name__}; give rig Readings or a readings file")
        if material is not None:
            data = data.only(material)
        elif len(data.materials()) > 1:
            raise FitError(f"the file holds {len(data.materials())} materials {data.materials()}; a session is one "
                           "material: choose one with material=...", data.where)
        return RigProblem(sc, data, sha256=sha, material=material)

    def title(self, attrs) -> str:
        return "Friction rig model"

    def figures(self, result) -> dict[str, bytes]:
        """The readings dw against the load per sliding speed, with the model (:mod:`escfit.friction.figures`)."""
        from .figures import figures

        return figures(result)


FAMILY = RigFamily()
