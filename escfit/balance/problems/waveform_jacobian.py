"""The waveform fit's Jacobian from the integrator's sensitivities (solver dop853).

The standardised residuals of a waveform fit are ``e = W (y - mu)``, with ``W`` the noise's
standardisation (white, AR(1)-whitened or over the rounding spread: linear) and the mean::

    mu(t) = gain * m(t - t_release) - offset - offset_rate * (t - t_ref)

where ``m`` is the model's angle, angular velocity or displacement.  Its derivatives are
therefore ``-W dmu/dp`` with::

    dmu/dp           = gain * dm/dp        for a scene parameter (forward sensitivities,
                                            :mod:`escfit.balance.sensitivity`)
    dmu/dt_release   = -gain * dm/dt       (the model's own rate)
    dmu/doffset      = -1
    dmu/doffset_rate = -(t - t_ref)
    dmu/dgain        = m

One augmented run gives every column, to the integrator's accuracy at the tolerance the
readings' noise allows (:mod:`escfit.balance.problems.tolerance`); forward differences need a run
per parameter and a far tighter tolerance.  :func:`residual_jacobian` returns None when it does
not apply (another solver, a scene with switches other than turning points, a parameter of the
noise model, a run that failed), and the caller falls back to forward differences.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

__all__ = ["residual_jacobian", "OBSERVATION_COLUMNS", "RECORD_STEP"]

#: the observation model's parameters whose columns are written in closed form
OBSERVATION_COLUMNS = frozenset({"observation.t_release", "observation.offset", "observation.offset_rate",
                                 "observation.gain"})

#: relative step of the central differences of the record's assembly (no model run; exact for fields linear in
#: the parameters, an error near 1e-12 relative for omega0**2)
RECORD_STEP = 1e-6


def residual_jacobian(problem, vals: Mapping[str, float], names: list[str]) -> np.ndarray | None:
    """d e / d p of the standardised residuals, shape (readings, len(names)); None where it does not apply.

    Parameters
    ----------
    problem
        A :class:`~escfit.balance.problems.waveform.WaveformProblem` with solver dop853.
    vals
        Every parameter's value (``problem.values(...)``).
    names
        The parameters differentiated by, in the columns' order.
    """
    if not getattr(problem, "has_sensitivities", False) or problem.solver != "dop853" \
            or not set(problem.solver_options) <= {"rtol", "atol", "max_segments", "max_steps"}:
        return None
    from ..sensitivity import covers, record_tangents, sample_sensitivities

    scene_names = [n for n in names if not n.startswith("observation.")]
    if any(n.startswith("observation.") and n not in OBSERVATION_COLUMNS for n in names):
        return None
    system = problem.scene.system(vals)
    if not covers(system) or system.refusals()[0]:
        return None
    steps = np.array([RECORD_STEP * max(abs(float(vals[n])), 1e-3) for n in scene_names])
    tangents = record_tangents(problem.scene.system, dict(vals), scene_names, steps)
    t = problem.sample_time - float(vals["observation.t_release"])
    if t[0] < 0.0:
        return None
    motion, sens, _ = sample_sensitivities(system, t, tangents, **problem.solver_options)
    if motion is None:
        return None
    velocity = problem.quantity == "angular_velocity"
    model, rate, dm = (motion[1], motion[2], sens[1]) if velocity else (motion[0], motion[1], sens[0])
    gain = float(vals.get("observation.gain", 1.0))
    dmu = np.empty((len(names), t.size))
    for j, name in enumerate(names):
        if name in scene_names:
            dmu[j] = gain * dm[scene_names.index(name)]
        elif name == "observation.t_release":
            dmu[j] = -gain * rate
        elif name == "observation.offset":
            dmu[j] = -1.0
        elif name == "observation.offset_rate":
            dmu[j] = -(problem.sample_time - problem.observation.t_ref)
        else:  # observation.gain
            dmu[j] = model
    jac = problem.standardise(-dmu, vals).T
    return jac if np.all(np.isfinite(jac)) else None
