"""Synthetic recordings in the pulse, timegrapher and time-series formats (known truth).

Each recorder solves the scene (with its dense solution, by the scene's default solver: the
closed form, or dop853 where the scene has a smooth torque), measures what the instrument would
measure and adds its noise; each format's reader reads the files back, so every format
has a round trip: simulate -> write -> read -> fit -> recover the scene's values.
:func:`record` is the one entry point a command line needs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import BalanceScene, solve
from ..trajectory import Trajectory
from ...core.errors import SceneError
from .runs import complete
from ..observation.timegrapher import TimegrapherObservation, beat_events, window_readings
from ...analysis.recordings.pulses import PulseTrain, write_pulses
from ...analysis.recordings.timegrapher import TimegrapherRecording, write_tg_json, write_timegrapher_csv
from ...analysis.recordings.timeseries import TimeSeries, write_timeseries

__all__ = ["record_pulses", "record_timegrapher", "record_timeseries", "record", "RECORDERS", "TG_PRESET_BPH",
           "swing_directions"]

TG_PRESET_BPH = (12000, 14400, 17280, 18000, 19800, 21600, 25200, 28800, 36000, 43200, 72000)  # tg's presets
RECORDERS = ("unit-curve", "pulses", "timegrapher", "timeseries")


def _solve(scene: BalanceScene, swings: int | None) -> Trajectory:
    if scene.switching != "angle":
        raise SceneError("recorders of passage times need angle switching (a physical escapement)", scene.where)
    return complete(solve(scene, swings=swings or scene.swings, dense=True), scene)


def swing_directions(theta0: float, n: int) -> np.ndarray:
    """Direction ``s`` (+1: theta increasing) of half swings ``1 .. n`` of a release at rest from
    ``theta0``: towards zero first, then alternating (as every solver counts them)."""
    s1 = 1.0 if theta0 < 0.0 else -1.0
    return s1 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)


def _provenance(scene: BalanceScene, recorder: str, seed: int, **settings) -> dict:
    meta = {"generated_by": f"escfit.balance.synthetic.instruments.{recorder}", "scene": Path(scene.where).name, "seed": str(seed)}
    meta.update({k: repr(v) for k, v in settings.items()})
    return meta


def record_pulses(scene: BalanceScene, *, notches: int = 60, sigma_t: float = 1e-4, swings: int | None = None,
                  duration: float | None = None, offset: float = 0.0, release_s: float = 0.0,
                  seed: int = 0) -> PulseTrain:
    """Simulate a photo-cell pulse train of a notched balance.

    Parameters
    ----------
    scene
        Balance scene (angle switching) giving the truth.
    notches
        Notches per turn; the short zero tooth sits at ``theta = offset``.
    sigma_t
        Timing noise of each pulse, s.
    swings, duration
        Record this many half swings (default: the scene's) or stop after ``duration`` s.
    offset
        Zero offset of the notch scale, rad: notch ``k`` sits at ``theta = k*2*pi/notches + offset``.
    release_s
        Release instant on the chart's clock, s.
    seed
        Seed of the noise generator.
    """
    if notches < 4:
        raise SceneError(f"notches must be at least 4, got {notches}")
    tr = _solve(scene, swings)
    notch = 2 * math.pi / notches
    n = tr.amplitude.size
    theta0 = scene.params["oscillator.theta0"].value
    starts = np.concatenate([[theta0], tr.theta_turn[:-1]])  # each half swing starts where the last ended
    m_all, x_all, zero_all = [], [], []
    for m, s in enumerate(swing_directions(theta0, n), start=1):
        x_start, x_end = s * starts[m - 1], s * tr.theta_turn[m - 1]
        # teeth k with x = s*(k*notch + offset) strictly inside (x_start, x_end), in crossing order
        lo, hi = sorted((s * x_start - offset, s * x_end - offset))
        k = np.arange(math.floor(lo / notch) + 1, math.ceil(hi / notch))
        k = k[(k * notch > lo) & (k * notch < hi)]
        x = s * (k * notch + offset)
        order = np.argsort(x)
        m_all.append(np.full(k.size, m))
        x_all.append(x[order])
        zero_all.append((k[order] % notches) == 0)
    m_arr, x_arr, zero = np.concatenate(m_all), np.concatenate(x_all), np.concatenate(zero_all)
    t = tr.dense.crossings(m_arr, x_arr)
    rng = np.random.default_rng(seed)
    t_obs = release_s + t + sigma_t * rng.standard_normal(t.size)
    keep = np.isfinite(t_obs)
    if duration is not None:
        keep &= t <= duration
    order = np.argsort(t_obs[keep], kind="stable")
    meta = _provenance(scene, "record_pulses", seed, notches=notches, sigma_t=sigma_t, offset=offset,
                       swings=swings or scene.swings, duration=duration)
    return PulseTrain(t_obs[keep][order], zero[keep][order], notches, release_s, np.zeros(0, dtype=np.int64),
                      f"<synthetic from {scene.where}>", "", meta)


def record_timeseries(scene: BalanceScene, *, rate_hz: float = 500.0, swings: int | None = None,
                      duration: float | None = None, sigma: float = 0.0, quantum: float = 0.0, offset: float = 0.0,
                      seed: int = 0) -> TimeSeries:
    """Simulate a sampled free decay from the release (sample 0 is the release).

    Parameters
    ----------
    rate_hz
        Sampling rate, Hz.
    swings, duration
        Length: this many half swings (default: the scene's) or ``duration`` seconds.
    sigma
        Gaussian noise of each sample, rad.
    quantum
        Quantisation step of the sensor, rad (0 = none); applied after the noise.
    offset
        Zero offset of the sensor, rad (added to every sample).
    seed
        Seed of the noise generator.
    """
    if not rate_hz > 0:
        raise SceneError(f"rate_hz must be positive, got {rate_hz!r}")
    from ..waveform import sample_scene

    tr = complete(solve(scene, swings=swings or scene.swings), scene)  # the scene's default solver: pendulums too
    end = tr.time[-1] if duration is None else min(duration, tr.time[-1])
    t = np.arange(0.0, end, 1.0 / rate_hz)
    theta, _ = sample_scene(scene, t)  # any restoring torque, through the scene's default solver
    rng = np.random.default_rng(seed)
    y = theta + offset + sigma * rng.standard_normal(t.size)
    if quantum > 0:
        y = quantum * np.round(y / quantum)
    meta = _provenance(scene, "record_timeseries", seed, rate_hz=rate_hz, sigma_rad=sigma, quantum_rad=quantum,
                       offset_rad=offset)
    return TimeSeries(t, y, 0.0, f"<synthetic from {scene.where}>", "", meta)


def record_timegrapher(scene: BalanceScene, *, fmt: str = "json", lift_angle_deg: float = 52.0,
                       true_lift_deg: float | None = None, bph: int | None = None, sample_rate: float = 48000.0,
                       window_s: float = 2.0, sigma_deg: float = 0.5, sigma_t: float = 1e-4,
                       swings: int | None = None, duration: float | None = None, release_s: float = 0.25,
                       seed: int = 0) -> TimegrapherRecording:
    """Simulate a timegrapher recording of the decay.

    Parameters
    ----------
    fmt
        ``"json"`` (tg's dump: readings at the centres of back-to-back windows, rejected ones
        left out, fractions unrounded) or ``"csv"`` (one row per beat: the reading of the
        window ending there, whole degrees, blank when rejected; rate and beat error).
    lift_angle_deg, true_lift_deg
        Lift angle set on the instrument and the escapement's true one (default: equal), deg.
    bph
        Nominal beats per hour set on the instrument (default: tg's preset nearest the scene).
    sample_rate
        Audio sample rate, Hz; beat times are whole samples.
    window_s
        Averaging window of an amplitude reading, s.
    sigma_deg, sigma_t
        Amplitude reading noise (deg) and beat timing noise (s).
    swings, duration
        Length of the recording.
    release_s
        Release instant on the recording's clock, s.
    seed
        Seed of the noise generator.
    """
    if fmt not in ("json", "csv"):
        raise SceneError(f"fmt must be 'json' or 'csv', got {fmt!r}")
    tr = _solve(scene, swings)
    n = tr.amplitude.size
    lift_true = math.radians(true_lift_deg if true_lift_deg is not None else lift_angle_deg)
    tz, pulse = beat_events(tr.dense, n, lift_true)
    if duration is not None:
        pulse, tz = pulse[tz <= duration], tz[tz <= duration]
    if bph is None:
        omega0 = scene.params["oscillator.omega0"].value if "oscillator.omega0" in scene.params else 2 * math.pi
        bph = min(TG_PRESET_BPH, key=lambda b: abs(b - 7200.0 * omega0 / (2 * math.pi)))
    rng = np.random.default_rng(seed)
    beat_true = release_s + tz
    beat = np.round((beat_true + sigma_t * rng.standard_normal(tz.size)) * sample_rate) / sample_rate
    tictoc = np.arange(tz.size) % 2 == 0
    obs = TimegrapherObservation
    if fmt == "json":
        centres = np.arange(beat_true[0] + 0.5 * window_s, beat_true[-1] - 0.5 * window_s + 1e-12, window_s)
        amp_time = np.round(centres * sample_rate) / sample_rate
        start, end = amp_time - 0.5 * window_s, amp_time + 0.5 * window_s
        resolution, align, shown, rate, be = 0.0, "centre", False, None, None
    else:
        amp_time = beat.copy()
        start, end = amp_time - window_s, amp_time
        resolution, align, shown = 1.0, "end", True
        rate, be = _rate_and_beat_error(beat, window_s, bph)
    frac = window_readings(beat_true, pulse, start, end)
    mu = lift_angle_deg * frac
    y = obs.amp_sample(mu, sigma_deg, resolution, (135.0, 360.0), rng)
    if fmt == "csv":
        y = np.where(start >= beat[0], y, np.nan)  # no reading before a full window of beats
    meta = _provenance(scene, "record_timegrapher", seed, lift_angle_deg=lift_angle_deg,
                       true_lift_deg=true_lift_deg if true_lift_deg is not None else lift_angle_deg,
                       sigma_deg=sigma_deg, sigma_t=sigma_t, window_s=window_s)
    return TimegrapherRecording(beat, tictoc, amp_time, y, math.radians(lift_angle_deg), int(bph), window_s, align,
                                resolution, (135.0, 360.0), shown, release_s, rate, be,
                                sample_rate if fmt == "json" else math.nan, "tg-json" if fmt == "json" else "csv",
                                f"<synthetic from {scene.where}>", "", meta)


def _rate_and_beat_error(beat: np.ndarray, window: float, bph: int) -> tuple[np.ndarray, np.ndarray]:
    """Rate (s/day) and beat error (ms) over the window ending at each beat, as displayed."""
    rate = np.full(beat.size, np.nan)
    be = np.full(beat.size, np.nan)
    nominal = 3600.0 / bph  # s per beat
    for i in range(beat.size):
        a = np.searchsorted(beat, beat[i] - window, side="left")
        if beat[i] - window < beat[0] or i - a < 3:
            continue
        d = np.diff(beat[a:i + 1])
        rate[i] = round(86400.0 * (nominal / d.mean() - 1.0), 1)
        be[i] = round(1000.0 * abs(d[0::2].mean() - d[1::2].mean()) / 2.0, 1)
    return rate, be


def record(scene: BalanceScene, recorder: str, out: str | Path, *, noise: float | None = None, seed: int = 0,
           comments: list[str] | None = None, **options) -> Path:
    """Simulate a recording of ``scene`` and write it to ``out`` in the recorder's format.

    Parameters
    ----------
    recorder
        One of :data:`RECORDERS`.
    noise
        The recorder's main noise: reading sd of unit curves (rad), pulse timing sd (s),
        timegrapher amplitude sd (deg), time-series sample sd (rad); ``None`` for each
        recorder's default.
    seed
        Seed of the noise generator.
    comments
        Extra comment lines (the file always says which scene, recorder and seed made it).
    **options
        Passed to the recorder (e.g. ``fmt="csv"`` for the timegrapher; ``notch_deg=6`` and
        ``notch_reading="nearest"`` for notch readings of a unit curve, see
        :func:`escfit.balance.synthetic.unit_curves.record_unit_curve`).
    """
    out = Path(out)
    if noise is not None and (isinstance(noise, bool) or not isinstance(noise, (int, float))
                              or not (math.isfinite(noise) and noise >= 0)):
        raise SceneError(f"noise must be a finite number >= 0, got {noise!r}", scene.where)
    call = ", ".join([f"{Path(scene.where).name!r}", f"{recorder!r}", f"noise={noise!r}", f"seed={seed}"]
                     + [f"{k}={v!r}" for k, v in options.items()])
    head = [f"generated by escfit.balance.synthetic.instruments.record({call})"] + list(comments or [])
    if recorder == "unit-curve":
        from .unit_curves import record_unit_curve
        from ...analysis.recordings import write_unit_curve

        curve = record_unit_curve(scene, sigma=0.0 if noise is None else noise, seed=seed, **options)
        write_unit_curve(out, curve, comments=head)
    elif recorder == "pulses":
        train = record_pulses(scene, seed=seed, **({} if noise is None else {"sigma_t": noise}), **options)
        write_pulses(out, train, comments=head)
    elif recorder == "timegrapher":
        rec = record_timegrapher(scene, seed=seed, **({} if noise is None else {"sigma_deg": noise}), **options)
        if rec.format == "tg-json":
            write_tg_json(out, rec, extra={"generated_by": head[0][len("generated by "):]})
        else:
            write_timegrapher_csv(out, rec, comments=head)
    elif recorder == "timeseries":
        unit = options.pop("unit", "rad")
        series = record_timeseries(scene, seed=seed, **({} if noise is None else {"sigma": noise}), **options)
        write_timeseries(out, series, unit=unit, comments=head)
    else:
        raise SceneError(f"unknown recorder {recorder!r}; choose one of {', '.join(RECORDERS)}")
    return out
