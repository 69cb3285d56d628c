"""The balance wheel's (and the gravity pendulum's) entry in the model-family registry.

:data:`FAMILY` tells the inference layer how to read a balance recording of any supported
format and build its fit problem: unit curves (amplitudes or notch counts per swing),
photo-cell passage times, timegrapher readings and sampled angles (turning points or the
whole waveform), including raw tables and MATLAB files read with a scene's ``[recording]``
options.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import DataError, FitError
from ..core.family import FamilyBase
from ..core.scene import load_scene

__all__ = ["FAMILY", "BalanceFamily", "make_problem", "read_data"]

PROBLEM_OPTIONS = frozenset({"solver", "solver_options", "unit", "fmt", "notch_deg", "recording"})


def make_problem(scene, data, *, solver: str | None = None, solver_options: dict | None = None,
                 unit: str | None = None, fmt: str | None = None, notch_deg: float | None = None,
                 recording: dict | None = None):
    """The fit problem of a balance scene and a recording of any supported format.

    Parameters
    ----------
    scene
        Balance scene (object or path).
    data
        A :class:`~escfit.analysis.recordings.UnitCurve` (amplitudes or notch counts per swing), a
        :class:`~escfit.analysis.recordings.pulses.PulseTrain` (photo-cell passage times), a
        :class:`~escfit.analysis.recordings.timegrapher.TimegrapherRecording`, a
        :class:`~escfit.analysis.recordings.timeseries.TimeSeries` (a sampled angle: turning points or
        the whole waveform are fitted, see :mod:`escfit.balance.problems.from_series`), or the path of a
        file holding one of them, including raw tables and MATLAB files.
    solver, solver_options
        Forward solver (default: the scene's, see :func:`escfit.balance.default_solver`);
        passage-time and timegrapher fits need the exact solver's log.
    unit
        Keep only this unit of a multi-unit unit-curve file.
    fmt
        ``"unit-curve"``, ``"pulses"``, ``"timegrapher"``, ``"timeseries"`` or ``"raw"``
        (a raw table or ``.mat`` file read with the scene's ``[recording]`` options); detected
        from the file's content when ``None``.
    notch_deg
        Notch angle of notch counts (deg) when the file does not say.
    recording
        ``[recording]`` options overriding the scene's key by key (the command line's).

    Returns
    -------
    FitProblem, WaveformProblem or RecordingProblem
    """
    from . import default_solver
    from ..analysis.recordings.pulses import PulseTrain
    from ..analysis.recordings.timegrapher import TimegrapherRecording
    from ..analysis.recordings.timeseries import TimeSeries
    from .problems.curves import FitProblem
    from .problems.facts import RecordFacts
    from .problems.from_series import problem_from_series
    from ..analysis.recordings import UnitCurve
    from ..analysis.recordings.rawsteps import warnings_of

    sc = load_scene(scene) if not hasattr(scene, "model") else scene
    solver = solver or default_solver(sc)
    spec = _recording_spec(sc, recording)
    if isinstance(data, (str, Path)):
        data = _read_data(data, spec, fmt, notch_deg, _scene_notch_deg(sc))
    options = dict(solver_options or {})
    if unit is not None and not isinstance(data, UnitCurve):
        raise FitError("--unit selects a unit of a unit-curve file; this recording holds one unit",
                       getattr(data, "source", None))
    if isinstance(data, TimeSeries):
        readings = spec.readings if spec is not None else "samples"
        warnings = list(warnings_of(data.meta))  # large repairs of the time base
        if data.meta.get("angle_unit_assumed"):
            warnings.append("the recording gives no angle unit and radians were assumed: if the angles are in another "
                            "unit (deg, encoder counts, a sensor's volts, a position in mm) set [recording] angle_unit "
                            "and scale")
        more = RecordFacts(data_warnings=tuple(warnings), trailing=tuple(_override_notes(sc, recording)))
        return problem_from_series(sc, data, solver=solver, solver_options=options, readings=readings, more=more)
    if math.isnan(sc.params["oscillator.theta0"].value):
        raise FitError("the scene leaves theta0 out, which only a sampled recording (a time series) can supply; "
                       "give [oscillator] theta0", sc.where)
    if isinstance(data, UnitCurve):
        if unit is not None:
            rows = np.flatnonzero(data.unit == unit)
            if not rows.size:
                raise FitError(f"no readings of unit {unit!r}; units in the file: {sorted(set(data.unit))}",
                               data.source)
            data = data.select(rows)
        return FitProblem(sc, data, solver, options)
    if isinstance(data, PulseTrain):
        from .problems.pulses import PulseFitProblem

        return PulseFitProblem(sc, data, solver, options)
    if isinstance(data, TimegrapherRecording):
        from .problems.timegrapher import TimegrapherFitProblem

        return TimegrapherFitProblem(sc, data, solver, options)
    raise FitError(f"cannot fit data of type {type(data).__name__}; give a recording or a file path")


def _recording_spec(scene, overrides: dict | None):
    """The scene's ``[recording]`` options with command-line overrides, or ``None`` if neither."""
    from ..analysis.recordings.recording_spec import merge_spec, recording_spec_from_table

    table = scene.extra.get("recording")
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    if table is None and not given:
        return None
    spec = recording_spec_from_table(table or {}, f"{scene.where}")
    return merge_spec(spec, **given) if given else spec


def _override_notes(scene, overrides: dict | None) -> list[str]:
    """Notes for command-line options that replace a different key of the scene's ``[recording]``."""
    table = scene.extra.get("recording") or {}
    given = {k for k, v in (overrides or {}).items() if v is not None}
    notes = [f"--{k.replace('_', '-')} replaces the scene's [recording] {k} = {table[k]!r}"
             for k in sorted(given) if k in table]
    for new, old in (("sample_rate", "time_column"), ("time_column", "sample_rate")):
        if new in given and old in table and old not in given:
            notes.append(f"--{new.replace('_', '-')} replaces the scene's [recording] {old} = {table[old]!r}")
    return notes


def _scene_notch_deg(sc) -> float | None:
    """The scene's ``[observation] notch_deg`` in degrees, if it gives one (a default for the data file)."""
    obs = sc.extra.get("observation")
    if not isinstance(obs, dict) or "notch_deg" not in obs:
        return None
    from .observation.notches import _notch_angle

    return math.degrees(_notch_angle(obs["notch_deg"], f"{sc.where} [observation].notch_deg"))


def read_data(path, *, recording: dict | None = None, fmt: str | None = None, notch_deg: float | None = None,
              where: str | None = None):
    """Read a balance recording file as a fit does with a scene whose ``[recording]`` table is ``recording``.

    Parameters
    ----------
    path
        The file.
    recording
        ``[recording]`` options (scene-table keys and values); empty or ``None``: detect everything.
    fmt, notch_deg
        As :func:`make_problem`.
    where
        Where ``recording`` comes from, for messages (default: the file).

    Returns
    -------
    UnitCurve, PulseTrain, TimegrapherRecording or TimeSeries
    """
    from ..analysis.recordings.recording_spec import recording_spec_from_table

    spec = recording_spec_from_table(recording, where or str(path)) if recording else None
    return _read_data(path, spec, fmt, notch_deg)


def _read_data(path, spec, fmt: str | None, notch_deg: float | None, default_notch_deg: float | None = None):
    """Read a recording file: escfit's own formats, an instrument's or program's file, or a raw
    table or MATLAB file (read with the scene's ``[recording]`` options)."""
    from ..analysis.recordings.rawseries import read_raw_series
    from ..analysis.recordings.detect import detect_format, read_recording, read_with_spec
    from ..analysis.recordings.formats_list import ESCFIT_FORMATS

    fmt = fmt or (spec.format if spec is not None else None)
    if fmt == "raw" or (spec is not None and fmt not in ESCFIT_FORMATS):
        return read_with_spec(path, spec, fmt)
    detected = fmt
    if detected is None:
        try:
            detected = detect_format(path)
        except DataError as exc:
            if "cannot tell the recording format" not in exc.message:
                raise  # several formats, a file escfit cannot read, an empty file: said as it is
            return read_raw_series(path, None)
    if detected not in ESCFIT_FORMATS:
        return read_with_spec(path, spec, detected)
    options = {}
    if detected == "unit-curve":
        options = {"notch_deg": notch_deg, "default_notch_deg": default_notch_deg}
    return read_recording(path, detected, **options)


class BalanceFamily(FamilyBase):
    """Registry entry of ``model = "balance"`` (see :class:`~escfit.core.family.Family`)."""

    name = "balance"
    # the stretch move by default: it follows the exactly degenerate ridges of Monday's phase
    # convention (R and X trade off at fixed K), where differential evolution failed to mix
    # (R-hat 1.4 after 1500 steps against 1.06); the shipped multi-load recipes, whose ridges are
    # narrow but not degenerate, ask for "de" (autocorrelation time 16-22 steps against ~43), the
    # quick start (unit 3) for "de-t" (8.7 steps: docs/performance.md section 4e)
    fit_defaults = {"walkers": 32, "steps": "auto", "max_steps": 20000, "n_starts": 8, "predictive_draws": 400,
                    "moves": "stretch"}
    package = "escfit.balance"
    problem_options = PROBLEM_OPTIONS
    recorders = ("unit-curve", "pulses", "timegrapher", "timeseries")

    def describe(self, ds) -> list[str]:
        """Half swings, first and last amplitude, last half period and rate."""
        if not ds.sizes.get("swing", 0):
            return []
        a = ds["amplitude"].values
        return [f"  {a.size} half swings; amplitude {a[0]:.6g} -> {a[-1]:.6g} rad; last half period "
                f"{ds['half_period'].values[-1]:.10g} s, rate {ds['rate'].values[-1]:.4f} s/day"]

    def record(self, scene, recorder: str, path, **options) -> None:
        """A synthetic recording (:func:`escfit.balance.synthetic.instruments.record`)."""
        from .synthetic.instruments import record

        record(scene, recorder, path, **options)

    def title(self, attrs) -> str:
        from .derived import model_title

        return model_title(attrs)

    def derived(self, draws, attrs):
        """Q, logarithmic decrement, amplitude lost per half swing, torques (:mod:`escfit.balance.derived`)."""
        from .derived import derived_quantities

        return derived_quantities(draws, attrs)

    def plain(self, draws, attrs, observed=None):
        """The loss per period and where it goes, Q, the halving time; an escapement's share taken by
        friction (:mod:`escfit.balance.plain`)."""
        from .plain import plain_sentences

        return plain_sentences(draws, attrs, observed)

    def splits_units(self, scene) -> bool:
        """Scenes without a ``[recording]`` table (whose files are raw tables instead) may read
        unit-curve files holding several units."""
        return scene.extra.get("recording") is None

    def units_of(self, path, *, notch_deg: float | None = None):
        """The units of a unit-curve file (each a :class:`~escfit.analysis.recordings.UnitCurve`);
        None for any other file."""
        from ..analysis.recordings import read_unit_curve
        from ..analysis.recordings.detect import detect_format

        try:
            if detect_format(path) != "unit-curve":
                return None
        except (DataError, OSError):
            return None  # not a unit curve: the family's reader on the worker says what is wrong
        return split_units(read_unit_curve(path, notch_deg=notch_deg), path)

    @property
    def formats(self) -> dict[str, Any]:
        """Format name -> reader ``(path) -> recording``."""
        from functools import partial

        from ..analysis.recordings.rawseries import read_raw_series
        from ..analysis.recordings.detect import read_recording

        from ..analysis.recordings.detect import read_with_spec
        from ..analysis.recordings.formats_list import ESCFIT_FORMATS, FORMAT_NAMES

        readers = {n: partial(read_recording, fmt=n) for n in ESCFIT_FORMATS}
        readers.update({n: partial(read_with_spec, spec=None, fmt=n) for n in FORMAT_NAMES if n not in ESCFIT_FORMATS})
        return {**readers, "raw": read_raw_series}

    def read(self, path, fmt: str | None = None, **options):
        """:func:`read_data`: options ``recording`` (a ``[recording]`` table) and ``notch_deg``."""
        return read_data(path, fmt=fmt, **options)

    def detect(self, path) -> str:
        from ..analysis.recordings.detect import detect_format

        return detect_format(path)

    def agreement(self, problem, lsq, refit, *, seed: int = 0):
        """A fit of a sampled record held against the record
        (:func:`escfit.balance.problems.agreement.check_agreement`); ``None`` for other recordings."""
        from .problems.agreement import check_agreement

        return check_agreement(problem, lsq, refit, seed=seed)

    def problem(self, scene, data, **options):
        self.refuse_unknown_options(options, getattr(scene, "where", None))
        return make_problem(scene, data, **options)

    def figures(self, result) -> dict[str, bytes]:
        """Data against the model, drawn by the kind of the readings (see :mod:`escfit.balance.figures`),
        and the decrement per half swing of a decay (:mod:`escfit.balance.decrement_figure`)."""
        from .decrement_figure import decrement_figure
        from .figures import figures

        out = figures(result)
        decrement = decrement_figure(result)
        return out if decrement is None else {**out, "decrement per half swing": decrement}


def split_units(curve, source) -> list[tuple[str, Any]]:
    """``(unit name, UnitCurve)`` of each unit of a unit curve, in order of appearance; a curve
    without a ``unit`` column is one unit named after its file."""
    names = list(dict.fromkeys(map(str, curve.unit))) if curve.unit.size else [""]
    out = []
    for name in names:
        rows = np.flatnonzero(curve.unit == name) if curve.unit.size else np.arange(curve.swing.size)
        part = curve.select(rows)
        if name:
            part.unit = np.full(rows.size, name)
        out.append((name or Path(curve.source or str(source)).stem, part))
    return out


FAMILY = BalanceFamily()
