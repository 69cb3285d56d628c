"""Running a Geneva scene: a pure forward function and its xarray packaging.

:func:`forward` maps parameter values (SI) to a :class:`Prediction` with no hidden state, so
fitting layers can call it directly.  :func:`simulate` runs a scene and returns an
:class:`xarray.Dataset`; :func:`json_summary` turns that into plain JSON-able numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import xarray as xr

from ..core.errors import SolverError
from ..core.status import Status
from .dynamics import acceleration
from .engines import ENGINES
from .geometry import Geometry, follower_angle, speed_ratio, speed_ratio_slope
from .terminal import TerminalCycle, terminal_cycle
from .trajectory import STATUS_MESSAGES, Trajectory, run

__all__ = ["Prediction", "forward", "simulate", "json_summary", "SOLVERS", "RISE_TOLERANCE", "rise_time"]

SCHEMA = "escfit.geneva/1"
RISE_TOLERANCE = 0.01
SOLVERS = ("dop853", "rk4")
_SOLVER_OPTIONS = {"dop853": {"rtol", "atol", "max_step"}, "rk4": {"dt", "h"}}
_ALIASES = {"ivp": "dop853"}  # the CLI's name for scipy's adaptive solver
_COMMON_OPTIONS = {"duration", "sample_interval", "max_engagements", "periodic_tol", "max_samples"}
_DEFAULTS = {"dop853": {"rtol": 1e-11, "atol": 1e-12, "max_step": 0.05}, "rk4": {"dt": 5e-4}}
# integrated engagements per run before "truncated" (about 20 s of work for either solver)
_ENGAGEMENT_BUDGET = {"dop853": 2_000, "rk4": 20_000}


@dataclass(frozen=True)
class Prediction:
    """Everything one forward run produces.

    Attributes
    ----------
    trajectory
        Sampled driver motion and per-engagement extremes (SI).
    terminal
        The periodic terminal engagement (or why there is none).
    rise_time
        Time of the first speed peak from which every later peak of the run lies within
        :data:`RISE_TOLERANCE` of the terminal peak, s; NaN when the run never settles.
    status
        Overall status, a key of :data:`escfit.geneva.trajectory.STATUS_MESSAGES`.
    """

    trajectory: Trajectory
    terminal: TerminalCycle
    rise_time: float
    status: str


def rise_time(peaks: np.ndarray, peak_times: np.ndarray, terminal_peak: float, tol: float = RISE_TOLERANCE) -> float:
    """First peak time after which all peaks stay within ``tol`` of ``terminal_peak``, s (NaN if none)."""
    if peaks.size == 0 or not math.isfinite(terminal_peak):
        return math.nan
    bad = np.flatnonzero(np.abs(peaks - terminal_peak) > tol * terminal_peak)
    first = 0 if bad.size == 0 else int(bad[-1]) + 1
    return float(peak_times[first]) if first < peaks.size else math.nan


def forward(geometry: Geometry, values: Mapping[str, float], *, duration: float, sample_times: np.ndarray,
            solver: str = "rk4", options: Mapping[str, Any] | None = None, with_terminal: bool = True,
            max_engagements: int = 20_000, periodic_tol: float = 1e-12) -> Prediction:
    """Simulate from rest: parameter values in, prediction out (pure).

    Parameters
    ----------
    geometry
        Mechanism structure.
    values
        ``geneva.driver_inertia``, ``geneva.follower_inertia`` (kg*m^2), ``geneva.torque``
        (N*m) and ``geneva.mu``.
    duration
        Run length, s.
    sample_times
        Output times, s (increasing, within ``[0, duration]``).
    solver
        ``"rk4"`` (fixed step, compiled) or ``"dop853"`` (scipy, adaptive).
    options
        Engine options (``dt`` in units of ``sqrt(I_f/K)`` for rk4; ``rtol``, ``atol``,
        ``max_step`` for dop853).
    with_terminal
        Also find the terminal engagement (needed for rise time and status).
    max_engagements, periodic_tol
        See :func:`escfit.geneva.trajectory.run`.
    """
    if solver not in SOLVERS:
        raise SolverError(f"unknown solver {solver!r}; known: {list(SOLVERS)}", "geneva")
    opts = {**_DEFAULTS[solver], **(options or {})}
    i_d, i_f = values["geneva.driver_inertia"], values["geneva.follower_inertia"]
    torque, mu = values["geneva.torque"], values["geneva.mu"]
    if not (i_d > 0 and i_f > 0 and torque > 0 and mu >= 0):
        raise SolverError(f"inertias and torque must be positive and mu >= 0, got I_d={i_d!r}, I_f={i_f!r}, "
                          f"K={torque!r}, mu={mu!r}", "geneva")
    rho, e = i_d / i_f, torque / i_f
    engine = ENGINES[solver]
    traj = run(geometry, rho, mu, e, duration, sample_times, engine, max_engagements=max_engagements,
               periodic_tol=periodic_tol, engine_options=opts)
    if with_terminal:
        guess = float(traj.eng_exit_speed[-1]) if traj.eng_exit_speed.size else None
        term = terminal_cycle(geometry, rho, mu, e, engine, opts, w_guess=guess)
    else:
        term = TerminalCycle("not_computed", span=geometry.span)
    rt = rise_time(traj.eng_peak_speed, traj.eng_peak_time, term.peak_speed)
    if traj.end_reason == "locked":
        status = "locked"
    elif traj.end_reason == "truncated":
        status = "truncated"
    elif traj.ambiguous_time is not None:
        status = "ambiguous"
    elif term.status == "no_terminal":
        status = "no_terminal"
    elif term.status == "locked" or (with_terminal and math.isnan(rt)):
        status = "not_settled"
    else:
        status = Status.OK.label  # the word every family's solvers use for a complete run
    return Prediction(traj, term, rt, status)


def simulate(scene, solver: str | None = None, **options: Any) -> xr.Dataset:
    """Run a Geneva scene from rest.

    Parameters
    ----------
    scene
        A :class:`escfit.geneva.scene.GenevaScene`.
    solver
        ``"dop853"`` (default; alias ``"ivp"``: scipy DOP853, rtol 1e-11, events located)
        or ``"rk4"`` (fixed step ``dt`` in units of ``sqrt(I_f/K)``, default 5e-4, or ``h``
        in seconds; compiled).
    **options
        ``duration`` and ``sample_interval`` (s) override the scene's ``[run]``;
        ``max_engagements`` (integrated engagements before the run ends as ``"truncated"``;
        default 2000 for dop853, 20000 for rk4), ``periodic_tol`` (default 1e-12; 0 integrates
        every engagement), ``max_samples`` (default 2e6: longer runs are sampled more
        coarsely and say so in ``attrs["notes"]``), and the solver's own options.  Unknown
        options are refused before any work.

    Returns
    -------
    xarray.Dataset
        Driver and follower angle, speed and acceleration on ``time``; per-engagement
        extremes on ``engagement``; terminal velocity, period, rise time and peak
        accelerations as scalars; ``status``, ``status_message`` and the scene text in
        ``attrs``.
    """
    solver = _ALIASES.get(solver, solver) if solver else "dop853"
    if solver not in SOLVERS:
        raise SolverError(f"unknown solver {solver!r}; known: {list(SOLVERS)}", f"{scene.where} (solver)")
    unknown = sorted(set(options) - _COMMON_OPTIONS - _SOLVER_OPTIONS[solver])
    if unknown:
        raise SolverError(f"unknown option(s) {unknown} for solver {solver!r}; allowed: "
                          f"{sorted(_COMMON_OPTIONS | _SOLVER_OPTIONS[solver])}", f"{scene.where} (options)")
    duration = float(options.pop("duration", scene.duration))
    interval = float(options.pop("sample_interval", scene.sample_interval))
    max_samples = int(options.pop("max_samples", 2_000_000))
    max_eng = int(options.pop("max_engagements", _ENGAGEMENT_BUDGET[solver]))
    ptol = float(options.pop("periodic_tol", 1e-12))
    if not (duration > 0 and interval > 0 and math.isfinite(duration)):
        raise SolverError(f"duration and sample_interval must be positive, got {duration!r}, {interval!r}",
                          f"{scene.where} (options)")
    notes = []
    if duration / interval + 1 > max_samples:
        new = duration / (max_samples - 1)
        notes.append(f"sample_interval widened from {interval:g} s to {new:g} s to keep {max_samples} samples")
        interval = new
    n = int(math.floor(duration / interval + 1e-9)) + 1
    times = np.arange(n) * interval
    values = scene.params.values()
    if "h" in options:  # step in seconds -> scaled units
        h = float(options.pop("h"))
        if not h > 0:
            raise SolverError(f"h must be a positive step in seconds, got {h!r}", f"{scene.where} (options)")
        options["dt"] = h * math.sqrt(values["geneva.torque"] / values["geneva.follower_inertia"])
    pred = forward(scene.geometry, values, duration=duration, sample_times=times, solver=solver, options=options,
                   max_engagements=max_eng, periodic_tol=ptol)
    return _dataset(scene, values, pred, solver, {**_DEFAULTS[solver], **options}, notes)


def _dataset(scene, values: Mapping[str, float], pred: Prediction, solver: str, opts: dict, notes: list) -> xr.Dataset:
    geo: Geometry = scene.geometry
    tr, term = pred.trajectory, pred.terminal
    i_f, mu = values["geneva.follower_inertia"], values["geneva.mu"]
    rho, e = values["geneva.driver_inertia"] / i_f, values["geneva.torque"] / i_f
    a, x = geo.a, tr.local_angle
    g, dg = speed_ratio(x, a), speed_ratio_slope(x, a)
    k = np.floor_divide(tr.angle - (x - geo.x_start) + 0.5 * geo.span, geo.span)
    f_angle = k * geo.follower_step + follower_angle(x, a) + geo.follower_half_angle
    f_speed = g * tr.speed
    f_acc = g * tr.acceleration + dg * tr.speed ** 2
    scale = math.sqrt(e)
    s_x, big_l = np.sin(x), 1.0 + a * a - 2.0 * a * np.cos(x)
    fric = mu * a * i_f * np.abs(s_x * (a * (1 - a * a) * s_x / big_l ** 3 * tr.speed ** 2
                                        + (a * np.cos(x) - 1.0) / big_l ** 2 * tr.acceleration))
    # peak accelerations: samples and both sides of every hand-over
    hand_w = np.concatenate((tr.eng_exit_speed, tr.eng_entry_speed))
    hand_x = np.concatenate((np.full(tr.eng_exit_speed.size, geo.x_end), np.full(tr.eng_entry_speed.size, geo.x_start)))
    hand_al = np.array([acceleration(xx, ww / scale, a, rho, mu, 1.0)[0] * e for xx, ww in zip(hand_x, hand_w)])
    hand_fa = speed_ratio(hand_x, a) * hand_al + speed_ratio_slope(hand_x, a) * hand_w ** 2
    max_da = float(np.max(np.abs(np.concatenate((tr.acceleration, hand_al)))))
    max_fa = float(np.max(np.abs(np.concatenate((f_acc, hand_fa)))))
    eng = np.arange(tr.eng_start.size)
    dur = tr.eng_end - tr.eng_start
    ds = xr.Dataset(
        {
            "driver_angle": ("time", tr.angle, _u("rad", "driver angle from first pin entry, positive in the driving sense")),
            "driver_speed": ("time", tr.speed, _u("rad/s", "driver angular speed")),
            "driver_acceleration": ("time", tr.acceleration, _u("rad/s^2", "driver angular acceleration")),
            "follower_angle": ("time", f_angle, _u("rad", "follower angle from its position at first pin entry, "
                                                          "positive in the sense it is driven (opposite to the driver)")),
            "follower_speed": ("time", f_speed, _u("rad/s", "follower angular speed, positive when driven forward")),
            "follower_acceleration": ("time", f_acc, _u("rad/s^2", "follower angular acceleration")),
            "friction_torque": ("time", fric, _u("N*m", "pin-slot friction torque about the driver axis (magnitude, "
                                                        "always opposing the drive)")),
            "local_angle": ("time", x, _u("rad", "angle of the engaged pin from the line of centres")),
            "engagement_start": ("engagement", tr.eng_start, _u("s", "time the pin entered its slot")),
            "engagement_end": ("engagement", tr.eng_end, _u("s", "time of hand-over to the next pin")),
            "entry_speed": ("engagement", tr.eng_entry_speed, _u("rad/s", "driver speed at pin entry")),
            "peak_speed": ("engagement", tr.eng_peak_speed, _u("rad/s", "largest driver speed in the engagement")),
            "peak_time": ("engagement", tr.eng_peak_time, _u("s", "time of peak_speed")),
            "min_speed": ("engagement", tr.eng_min_speed, _u("rad/s", "smallest driver speed in the engagement")),
            "min_time": ("engagement", tr.eng_min_time, _u("s", "time of min_speed")),
            "engagement_mean_speed": ("engagement", geo.span / dur if dur.size else dur,
                                      _u("rad/s", "driver rotation per engagement over its duration")),
            "terminal_peak_speed": ((), term.peak_speed, _u("rad/s", "peak driver speed of the terminal engagement")),
            "terminal_min_speed": ((), term.min_speed, _u("rad/s", "minimum driver speed of the terminal engagement")),
            "terminal_velocity": ((), term.meyer_mean, _u("rad/s", "Meyer's average terminal velocity (peak + min)/2")),
            "terminal_mean_speed": ((), term.mean_speed, _u("rad/s", "time-averaged terminal driver speed")),
            "period": ((), term.period, _u("s", "time between speed peaks at terminal velocity")),
            "rise_time": ((), pred.rise_time, _u("s", "first peak after which all peaks stay within 1% of terminal")),
            "rise_time_min": ((), rise_time(tr.eng_min_speed, tr.eng_min_time, term.min_speed),
                              _u("s", "first speed minimum after which all minima stay within 1% of terminal")),
            "contraction": ((), term.contraction, _u("", "per-engagement shrink factor of the distance of w^2/2 "
                                                         "from its terminal value")),
            "max_driver_acceleration": ((), max_da, _u("rad/s^2", "largest |driver acceleration|")),
            "max_follower_acceleration": ((), max_fa, _u("rad/s^2", "largest |follower acceleration| (at hand-over)")),
        },
        coords={
            "time": ("time", tr.time, _u("s", "time since release from rest")),
            "engagement": ("engagement", eng, _u("", "complete engagements, 0 = first pin")),
        },
    )
    from ..core.version import __version__

    ds.attrs.update(
        schema=SCHEMA,
        model="geneva",
        status=pred.status,
        status_message=STATUS_MESSAGES.get(pred.status, ""),
        terminal_status=term.status,
        slots=geo.slots,
        pins=geo.pins,
        compat=geo.compat,
        engagement_angle=geo.span,
        solver=solver,
        solver_options=repr(opts),
        n_steps=int(tr.n_steps),
        end_time=float(tr.end_time),
        ambiguous_time=float("nan") if tr.ambiguous_time is None else float(tr.ambiguous_time),
        periodic_from=-1 if tr.periodic_from is None else int(tr.periodic_from),
        rise_time_definition="first speed peak after which every peak stays within 1% of the terminal peak",
        notes="; ".join(list(notes) + list(tr.notes)),
        scene=scene.text,
        where=scene.where,
        escfit_version=__version__,
        **{f"param_{name.split('.')[1]}": float(v) for name, v in values.items()},
    )
    return ds


def _u(units: str, long_name: str) -> dict[str, str]:
    return {"units": units, "long_name": long_name}


def _num(v: Any) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def json_summary(ds: xr.Dataset) -> dict[str, Any]:
    """Plain-number summary of a Geneva run (what ``escfit simulate --json`` prints).

    Speeds are rad/s, times s, accelerations rad/s^2; undefined values (no terminal
    velocity, not settled) are ``None``.  ``peak_speed`` and ``min_speed`` are per complete
    engagement in time order (the first engagement starts from rest, so its minimum is 0).
    """
    return {
        "model": "geneva",
        "status": ds.attrs["status"],
        "status_message": ds.attrs["status_message"],
        "terminal_status": ds.attrs["terminal_status"],
        "slots": int(ds.attrs["slots"]),
        "pins": int(ds.attrs["pins"]),
        "compat": ds.attrs["compat"],
        "end_time": _num(ds.attrs["end_time"]),
        "peak_speed": [float(v) for v in ds["peak_speed"].values],
        "peak_time": [float(v) for v in ds["peak_time"].values],
        "min_speed": [float(v) for v in ds["min_speed"].values],
        "min_time": [float(v) for v in ds["min_time"].values],
        "terminal_velocity": _num(ds["terminal_velocity"]),
        "terminal_mean_speed": _num(ds["terminal_mean_speed"]),
        "terminal_peak_speed": _num(ds["terminal_peak_speed"]),
        "terminal_min_speed": _num(ds["terminal_min_speed"]),
        "rise_time": _num(ds["rise_time"]),
        "rise_time_min": _num(ds["rise_time_min"]),
        "period": _num(ds["period"]),
        "max_driver_acceleration": _num(ds["max_driver_acceleration"]),
        "max_follower_acceleration": _num(ds["max_follower_acceleration"]),
        "units": {"speed": "rad/s", "time": "s", "acceleration": "rad/s^2", "angle": "rad"},
    }
