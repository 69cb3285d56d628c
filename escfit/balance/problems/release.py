"""The release of a recorded decay: where the model starts.

A record seldom starts with the balance held at a known angle.  The turning-point analysis
finds a reference instant at which the balance is at rest (the release, or the first
turning point of a record that starts mid-swing); the model is released there, at rest, which
is exact physics.  The reference angle is itself a noisy reading, so the release angle is a
free parameter centred on it unless the scene says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import replace

from ...core.errors import DataError
from ...analysis.quantity import OTHER_QUANTITY
from ...core.params import ParamSet

__all__ = ["swing_unit_warnings", "table_unit_warnings", "release_from_record"]

REL_TOL = 0.05  # a fixed scene theta0 may differ from the record's reference angle by this fraction
FREE_SPAN = 0.2  # a free release angle may move this fraction of the reference angle either way


def release_from_record(params: ParamSet, measured: float, source: str, restoring: str = "spring",
                        unit: str = "rad") -> list[str]:
    """Set ``oscillator.theta0`` from the record's signed reference angle (rad), in place.

    A pendulum's reference beyond 180 deg is refused (the angles are in another unit).

    - theta0 free in the scene: kept, but its bounds (or their mirror image: the sign is a
      convention) must contain ``measured``;
    - theta0 fixed within :data:`REL_TOL` of ``|measured|``: kept fixed, signed as the record;
    - theta0 fixed elsewhere: refused (another scene's data);
    - theta0 not given by the scene (``nan``): free around ``measured``, +-:data:`FREE_SPAN`.

    ``unit`` is ``"m"`` for a linear oscillator: ``measured`` is then its reference displacement
    (m), the scene's ``x0``, and the messages say so.

    Returns
    -------
    list of str
        Notes for the results (what was done).

    Raises
    ------
    DataError
        When the scene's release angle contradicts the record.
    """
    p = params["oscillator.theta0"]
    linear = unit == "m"
    key, word = ("x0", "displacement") if linear else ("theta0", "angle")

    def shown(x: float) -> str:
        return f"{x:+.5g} m" if linear else f"{x:+.5g} rad ({math.degrees(x):+.4g} deg)"

    if not math.isfinite(measured) or measured == 0.0:
        raise DataError(f"the record's reference turning point is at {measured!r} {unit}: no decay to fit", source)
    if restoring == "pendulum" and abs(measured) >= math.pi:
        raise DataError(f"the record's reference turning point lies {math.degrees(abs(measured)):.4g} deg from the "
                        "centre, but a pendulum cannot swing past 180 deg: are the angles in another unit? set "
                        "[recording] angle_unit (and scale)", source)
    if math.isnan(p.value):
        span = FREE_SPAN * abs(measured)
        params.params[p.name] = replace(p, value=measured, vary=True, min=measured - span, max=measured + span,
                                        prior=None)
        return [f"release {word} free around the record's reference turning point, {shown(measured)} from the centre"]
    if p.vary:
        notes = []
        if not p.min <= measured <= p.max and p.min <= -measured <= p.max:
            # the scene's sign is a convention; the record decides on which side the decay starts
            p = replace(p, value=-p.value, min=-p.max, max=-p.min)
            params.params[p.name] = p
            notes.append(f"{key}'s range mirrored to the record's side ([{p.min:.4g}, {p.max:.4g}] {unit})")
        if not p.min <= measured <= p.max:
            raise DataError(f"the record's reference turning point is at {measured:+.4g} {unit}, outside {key}'s bounds "
                            f"[{p.min:.4g}, {p.max:.4g}] in the scene", source)
        if not p.min <= p.value <= p.max or math.copysign(1.0, p.value) != math.copysign(1.0, measured):
            params.params[p.name] = replace(p, value=measured)
        return notes
    if abs(abs(p.value) - abs(measured)) > REL_TOL * abs(measured):
        raise DataError(f"the record's reference turning point is at {measured:+.4g} {unit} but the scene releases the "
                        f"{'oscillator' if linear else 'balance'} at {key} = {p.value:.4g} {unit}: another scene's data "
                        f"(leave {key} out to take it from the record, or make it free)", source)
    if math.copysign(1.0, p.value) != math.copysign(1.0, measured):
        params.params[p.name] = replace(p, value=-p.value)
        return [f"release {word} {p.value:+.4g} {unit} taken on the record's side ({-p.value:+.4g} {unit})"]
    return []


def swing_unit_warnings(series, tp, restoring: str = "spring") -> list[str]:
    """The record's largest swing held against its angle unit (see
    :func:`escfit.analysis.quantity.swing_unit_check`) and, for a pendulum swinging 60 deg or more,
    its waveform against the pendulum's at that amplitude
    (:func:`escfit.analysis.pendulum_unit.waveform_shape`), as ``escfit init`` and a fit both do.

    Returns
    -------
    list of str
        A warning naming ``[recording] angle_unit = "rad"`` when radians look read as degrees;
        one naming the keys of :data:`escfit.analysis.quantity.OTHER_QUANTITY` when a large
        pendulum swing is not flattened as a pendulum's is.

    Raises
    ------
    DataError
        Degrees read as radians: a pendulum past 180 deg or a swing of more than two turns,
        naming ``[recording] angle_unit = "deg"`` (``--angle-unit deg``); a pendulum "in degrees"
        past 180 deg, naming the keys that read the column as what it is.  A pendulum of 60-179
        deg without a pendulum's waveform is a warning naming the same keys (a tracked angle
        about a misplaced pivot can lose the waveform's flattening).
    """
    import numpy as np

    if getattr(series, "quantity", "angle") != "angle" or not len(tp.theta):
        return []
    times = np.concatenate([[tp.release_time], np.asarray(tp.time, float)])
    theta = np.concatenate([[tp.release_theta], np.asarray(tp.theta, float)])
    amplitudes = np.abs(theta - tp.centre(times))
    warnings = _unit_warnings(series, float(np.nanmax(amplitudes)), restoring, swings=0.5 * len(tp.theta))
    if restoring == "pendulum" and _judged_unit(series):
        from ...analysis.pendulum_unit import waveform_shape

        t = np.asarray(series.time, float)
        shape = waveform_shape(t, np.asarray(series.theta, float) - tp.centre(t), times, amplitudes)
        if shape is not None and not shape.pendulum:
            # a warning, not a refusal: an angle taken from a video track about a pivot placed a
            # fraction e of the length off adds e A^2/24 to the third harmonic, which cancels the
            # pendulum's A^2/192 at e = 1/8, so a true angle can look sinusoidal (or peaked)
            warnings.append(f"{_column(series)}read as an angle in {_judged_unit(series)}: {shape.sentence()}: a "
                            "pendulum's angle measured about its pivot has it (an angle from a track about a pivot "
                            "placed an eighth of the length off can lose it); if the column is no angle in that "
                            f"unit, set [recording] {OTHER_QUANTITY}")
    return warnings


def table_unit_warnings(series, amplitude: float, restoring: str = "spring") -> list[str]:
    """A table of turning points' largest amplitude (rad about the centre) held against its angle
    unit, as :func:`swing_unit_warnings` holds a sampled record's."""
    if getattr(series, "quantity", "angle") != "angle":
        return []
    return _unit_warnings(series, amplitude, restoring, swings=0.0)


def _judged_unit(series) -> str:
    """The angle unit the column was read in, when a plain one (deg or rad, scale 1): else ``""``."""
    meta = getattr(series, "meta", {}) or {}
    unit = str(meta.get("angle_unit", "")).split(" (")[0].strip()
    plain = unit.lower() in ("deg", "degree", "degrees", "°", "rad", "radian", "radians")
    return unit if plain and float(meta.get("scale", 1) or 1) == 1.0 else ""


def _column(series) -> str:
    """``"column 'x' "`` for the column read as the angle (as the reader named it), or ``""``."""
    name = str((getattr(series, "meta", {}) or {}).get("angle_column", "")).strip()
    return f"{name if name.startswith('column ') else 'column ' + repr(name)} " if name else ""


def _unit_warnings(series, amplitude: float, restoring: str, swings: float) -> list[str]:
    from ...analysis.quantity import swing_unit_check

    meta = getattr(series, "meta", {}) or {}
    unit = str(meta.get("angle_unit", "")).split(" (")[0]
    check = swing_unit_check(amplitude, unit, restoring=restoring, swings=swings,
                             scale=float(meta.get("scale", 1) or 1))
    option = f" (--angle-unit {check.key.split(chr(34))[1]})" if check.key.startswith("angle_unit = ") else ""
    if check.verdict == "refuse":
        raise DataError(_column(series) + check.sentence() + option, series.source)
    return [f"{check.sentence()}{option} if the column holds radians"] if check.verdict == "suspect" else []
