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
from ...core.params import ParamSet

__all__ = ["release_from_record"]

REL_TOL = 0.05  # a fixed scene theta0 may differ from the record's reference angle by this fraction
FREE_SPAN = 0.2  # a free release angle may move this fraction of the reference angle either way


def release_from_record(params: ParamSet, measured: float, source: str, restoring: str = "spring") -> list[str]:
    """Set ``oscillator.theta0`` from the record's signed reference angle (rad), in place.

    A pendulum's reference beyond 180 deg is refused (the angles are in another unit).

    - theta0 free in the scene: kept, but its bounds (or their mirror image: the sign is a
      convention) must contain ``measured``;
    - theta0 fixed within :data:`REL_TOL` of ``|measured|``: kept fixed, signed as the record;
    - theta0 fixed elsewhere: refused (another scene's data);
    - theta0 not given by the scene (``nan``): free around ``measured``, +-:data:`FREE_SPAN`.

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
    if not math.isfinite(measured) or measured == 0.0:
        raise DataError(f"the record's reference turning point is at {measured!r} rad: no decay to fit", source)
    if restoring == "pendulum" and abs(measured) >= math.pi:
        raise DataError(f"the record's reference turning point lies {math.degrees(abs(measured)):.4g} deg from the "
                        "centre, but a pendulum cannot swing past 180 deg: are the angles in another unit? set "
                        "[recording] angle_unit (and scale)", source)
    if math.isnan(p.value):
        span = FREE_SPAN * abs(measured)
        params.params[p.name] = replace(p, value=measured, vary=True, min=measured - span, max=measured + span,
                                        prior=None)
        return [f"release angle free around the record's reference turning point, {measured:+.5g} rad "
                f"({math.degrees(measured):+.4g} deg) from the centre"]
    if p.vary:
        notes = []
        if not p.min <= measured <= p.max and p.min <= -measured <= p.max:
            # the scene's sign is a convention; the record decides on which side the decay starts
            p = replace(p, value=-p.value, min=-p.max, max=-p.min)
            params.params[p.name] = p
            notes.append(f"theta0's range mirrored to the record's side ([{p.min:.4g}, {p.max:.4g}] rad)")
        if not p.min <= measured <= p.max:
            raise DataError(f"the record's reference turning point is at {measured:+.4g} rad, outside theta0's bounds "
                            f"[{p.min:.4g}, {p.max:.4g}] in the scene", source)
        if not p.min <= p.value <= p.max or math.copysign(1.0, p.value) != math.copysign(1.0, measured):
            params.params[p.name] = replace(p, value=measured)
        return notes
    if abs(abs(p.value) - abs(measured)) > REL_TOL * abs(measured):
        raise DataError(f"the record's reference turning point is at {measured:+.4g} rad but the scene releases the "
                        f"balance at theta0 = {p.value:.4g} rad: another scene's data (leave theta0 out to take it from "
                        "the record, or make it free)", source)
    if math.copysign(1.0, p.value) != math.copysign(1.0, measured):
        params.params[p.name] = replace(p, value=-p.value)
        return [f"release angle {p.value:+.4g} rad taken on the record's side ({-p.value:+.4g} rad)"]
    return []
