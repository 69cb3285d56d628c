"""One run of the Geneva escapement: the engagement loop shared by every engine.

The driver starts at rest with its first pin entering a slot (Meyer's initial condition).
Each engagement is integrated by an engine (:mod:`escfit.geneva.engines`); at hand-over the
next pin takes the driver's speed unchanged, because the follower is momentarily at rest at
both ends of an engagement, so no impulse passes between the pins.

Once the motion is periodic to round-off (two successive engagements agree to
``periodic_tol``), later engagements are copies of the last one shifted in time and angle:
the run then costs one more engagement however long it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .engines import END_COMPLETE, END_LOCKED, EngagementResult
from .geometry import Geometry

__all__ = ["Trajectory", "run", "STATUS_MESSAGES"]

STATUS_MESSAGES = {
    "ok": "run complete; the driver settled to its terminal velocity",
    "not_settled": "run complete but too short for the peak speed to settle within 1% of its terminal value",
    "no_terminal": "run complete; without enough friction the driver keeps accelerating (no terminal velocity)",
    "ambiguous": "both friction signs were consistent at some instant (friction can wedge the pin); "
                 "the branch continuous with the motion was followed",
    "locked": "no friction sign is consistent: the pin jams in the slot; the run ends there",
    "truncated": "engagement budget exhausted before the requested duration",
}


@dataclass(frozen=True)
class Trajectory:
    """Driver motion of one run, in SI units.

    Attributes
    ----------
    time, angle, speed, acceleration
        Samples of driver time (s), angle from first pin entry (rad), speed (rad/s) and
        angular acceleration (rad/s^2).
    local_angle
        Local angle ``x`` of the engaged pin at each sample, rad.
    eng_start, eng_end, eng_entry_speed, eng_exit_speed
        Per complete engagement: start and end times (s), speeds at entry and hand-over.
    eng_peak_speed, eng_peak_time, eng_min_speed, eng_min_time
        Per complete engagement: largest and smallest driver speed and their times.
    end_reason
        ``"duration"``, ``"locked"`` or ``"truncated"``.
    end_time
        Time the run ended, s (the requested duration unless locked or truncated).
    ambiguous_time
        First time both friction signs were consistent, s, or ``None``.
    n_steps
        Integration steps (or scipy steps) taken.
    periodic_from
        Index of the first engagement copied from its predecessor, or ``None``.
    options, notes
        Engine options used; remarks on the run (records dropped ...).
    """

    time: np.ndarray
    angle: np.ndarray
    speed: np.ndarray
    acceleration: np.ndarray
    local_angle: np.ndarray
    eng_start: np.ndarray
    eng_end: np.ndarray
    eng_entry_speed: np.ndarray
    eng_exit_speed: np.ndarray
    eng_peak_speed: np.ndarray
    eng_peak_time: np.ndarray
    eng_min_speed: np.ndarray
    eng_min_time: np.ndarray
    end_reason: str
    end_time: float
    ambiguous_time: float | None
    n_steps: int
    periodic_from: int | None
    options: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()


Engine = Callable[..., EngagementResult]


def run(geometry: Geometry, rho: float, mu: float, e: float, duration: float, sample_times: np.ndarray,
        engine: Engine, *, max_engagements: int = 20_000, periodic_tol: float = 1e-12, max_records: int = 1_000_000,
        engine_options: dict[str, Any] | None = None) -> Trajectory:
    """Simulate from rest for ``duration`` seconds.

    Parameters
    ----------
    geometry
        The mechanism.
    rho
        ``I_d/I_f``.
    mu
        Pin-slot friction coefficient.
    e
        ``K/I_f``, rad/s^2 (sets the time scale ``1/sqrt(e)``).
    duration
        Run length, s.
    sample_times
        Increasing output times in ``[0, duration]``, s.
    engine
        One of :data:`escfit.geneva.engines.ENGINES`.
    max_engagements
        Budget of integrated engagements (copies in the periodic regime are free); when it
        runs out the run ends with ``end_reason = "truncated"``.
    max_records
        Most per-engagement records kept (periodic copies beyond it are dropped, noted).
    periodic_tol
        Relative agreement of two successive engagements at which the motion is taken as
        periodic; ``0`` integrates every engagement.
    engine_options
        Passed to the engine (``dt`` for rk4; ``rtol``, ``atol``, ``max_step`` for dop853).
    """
    opts = dict(engine_options or {})
    scale = math.sqrt(e)  # scaled time = t*scale, scaled speed = w/scale
    ts = np.asarray(sample_times, dtype=float) * scale
    t_stop = duration * scale
    n_s = ts.size
    s_x, s_w, s_a = np.empty(n_s), np.empty(n_s), np.empty(n_s)
    s_k = np.empty(n_s, dtype=np.int64)
    a, x_start, x_end, span = geometry.a, geometry.x_start, geometry.x_end, geometry.span
    recs: list[tuple[float, ...]] = []
    t, x, w, k, j = 0.0, x_start, 0.0, 0, 0
    steps, amb, end_reason, periodic_from = 0, math.nan, "duration", None
    notes: list[str] = []
    while True:
        if k >= max_engagements:
            end_reason = "truncated"
            break
        res = engine(x, x_end, t, w, t_stop, a, rho, mu, ts[j:], **_engine_opts(opts, w, span))
        steps += res.n_steps
        n = res.n_samples
        s_x[j:j + n], s_w[j:j + n], s_a[j:j + n], s_k[j:j + n] = res.samp_x, res.samp_w, res.samp_alpha, k
        j += n
        if math.isnan(amb) and not math.isnan(res.ambiguous_t):
            amb = res.ambiguous_t
        if res.reason == END_LOCKED:
            end_reason = "locked"
            t = res.t
            break
        if res.reason != END_COMPLETE:
            t = res.t
            break
        recs.append((t, res.t, w, res.w, res.peak_w, res.peak_t, res.min_w, res.min_t))
        t, x, w, k = res.t, x_start + (res.x - x_end), res.w, k + 1
        if periodic_tol > 0 and len(recs) >= 3 and _repeats(recs[-1], recs[-2], periodic_tol):
            periodic_from = k
            j, t = _continue_periodically(recs, k, t, t_stop, ts, j, s_x, s_w, s_a, s_k, engine, opts,
                                          x_start, x_end, a, rho, mu, span, max_records, notes)
            break
    if j < n_s and end_reason == "duration" and periodic_from is None:
        # samples exactly at the final time can be left by round-off
        s_x[j:], s_w[j:], s_a[j:], s_k[j:] = s_x[j - 1], s_w[j - 1], s_a[j - 1], s_k[j - 1]
        j = n_s
    rec = np.array(recs, dtype=float).reshape(-1, 8)
    inv = 1.0 / scale
    return Trajectory(
        time=ts[:j] * inv,
        angle=s_k[:j] * span + (s_x[:j] - x_start),
        speed=s_w[:j] * scale,
        acceleration=s_a[:j] * e,
        local_angle=s_x[:j].copy(),
        eng_start=rec[:, 0] * inv,
        eng_end=rec[:, 1] * inv,
        eng_entry_speed=rec[:, 2] * scale,
        eng_exit_speed=rec[:, 3] * scale,
        eng_peak_speed=rec[:, 4] * scale,
        eng_peak_time=rec[:, 5] * inv,
        eng_min_speed=rec[:, 6] * scale,
        eng_min_time=rec[:, 7] * inv,
        end_reason=end_reason,
        end_time=min(t, t_stop) * inv,
        ambiguous_time=None if math.isnan(amb) else amb * inv,
        n_steps=steps,
        periodic_from=periodic_from,
        options=opts,
        notes=tuple(notes),
    )


def _engine_opts(opts: dict[str, Any], w: float, span: float) -> dict[str, Any]:
    """rk4: keep at least ~400 steps per engagement when the driver runs fast."""
    if "dt" in opts and w > 0:
        return {**opts, "dt": min(opts["dt"], span / (400.0 * w))}
    return opts


def _repeats(r1: tuple[float, ...], r0: tuple[float, ...], tol: float) -> bool:
    d1, d0 = r1[1] - r1[0], r0[1] - r0[0]
    return (abs(r1[3] - r0[3]) <= tol * abs(r1[3]) and abs(d1 - d0) <= tol * d1
            and abs(r1[4] - r0[4]) <= tol * r1[4] and abs(r1[6] - r0[6]) <= tol * max(r1[4], 1e-300))


def _continue_periodically(recs, k, t, t_stop, ts, j, s_x, s_w, s_a, s_k, engine, opts, x_start, x_end, a, rho,
                           mu, span, max_records, notes):
    """Fill samples and engagement records after ``t`` by repeating the last engagement."""
    last = recs[-1]
    period = last[1] - last[0]
    w_in = last[3]  # the entry speed of the repeated engagement equals the last exit speed
    n_more = int(math.floor((t_stop - t) / period + 1e-12))
    n_keep = max(0, min(n_more, max_records - len(recs)))
    if n_keep < n_more:
        notes.append(f"engagement records stop after {len(recs) + n_keep} engagements (max_records); "
                     f"the time series covers the whole run")
    sh = t - last[0] + period * np.arange(n_keep)
    base = np.array(last)
    block = np.tile(base, (n_keep, 1))
    block[:, [0, 1, 5, 7]] += sh[:, None]
    block[:, 2] = w_in
    recs.extend(map(tuple, block))
    rest = ts[j:]
    if rest.size:
        m = np.floor((rest - t) / period + 1e-12)
        phase = np.clip(rest - t - m * period, 0.0, period)
        order = np.argsort(phase, kind="stable")
        res = engine(x_start, x_end, 0.0, w_in, period * (1 + 1e-9), a, rho, mu, phase[order],
                     **_engine_opts(opts, w_in, span))
        got = res.n_samples
        px, pw, pa = np.empty(rest.size), np.empty(rest.size), np.empty(rest.size)
        px[order[:got]], pw[order[:got]], pa[order[:got]] = res.samp_x, res.samp_w, res.samp_alpha
        if got < rest.size:  # phases a hair past the end of the engagement
            px[order[got:]], pw[order[got:]], pa[order[got:]] = res.x, res.w, res.alpha
        s_x[j:], s_w[j:], s_a[j:], s_k[j:] = px, pw, pa, k + m.astype(np.int64)
    return ts.size, t_stop
