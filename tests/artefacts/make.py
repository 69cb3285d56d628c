"""Generators of free-decay records with one real-world artefact each, and their truth.

Every generator ``<class>(seed, periods=None)`` returns an :class:`Artefact`: the CSV text a user
would hand to ``escfit init FILE --pendulum`` and the :class:`Truth` the record was made from.
The free decays are a gravity pendulum (``omega0**2 sin(theta)``) with viscous damping ``C``
(1/s) and Coulomb friction ``R`` (rad/s**2) released at rest, solved by escfit's forward
simulator (:func:`escfit.balance.waveform.sample_state`); the artefacts (a hand, a hold, a push, a
drive, a faulty clock, another channel, another quantity) are written here with numpy.

Sizes are those of a lab or phone-video record: a 1-3 s period, 30-100 periods (300 for the long
record), 20-100 Hz sampling, white noise of 0.1-1 % of the release amplitude.  The damping is
drawn so that over the record the amplitude falls by 40-60 %, half of the loss viscous and half
Coulomb, so that both are determined by a clean record.

Angles are positive to one side of the vertical; the release is at ``+A0`` or ``-A0`` (drawn);
the time of the CSV is seconds from the first row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

G = 9.80665  # m/s**2
FINE_HZ = 1000.0  # grid of the simulated state before it is sampled, Hz

__all__ = ["Truth", "Artefact", "CLASSES", "make", "G"]


@dataclass(frozen=True)
class Truth:
    """What the record was made from, and what a careful analysis should conclude.

    Attributes
    ----------
    omega0, C, R, D
        Small-swing angular frequency (rad/s), viscous damping (1/s), Coulomb friction
        (rad/s**2) and quadratic drag (1/rad) of the pendulum of the free window.
    t_free_start, t_free_end
        The free decay to fit, s on the CSV's clock: from the release (or the end of the last
        push or drive) to the end of that decay.
    release_angle_deg
        Angle at ``t_free_start`` where it is a release at rest (a turning point), deg.
    angle_column
        0-based CSV column holding the swinging quantity (the time is column 0).
    accept
        Verdicts a careful analysis may reach: ``"fit"`` (estimates within tolerance and the
        window right), ``"refuse"`` (exit 2, the message matching ``reason``), ``"not determined"``
        (exit 3, the message matching ``reason``).  The first is the one expected.
    reason
        Regular expression (case-insensitive) a refusal must match to count as one with reason.
    windows
        Other free windows (start, end) a fit may choose and still be right.
    rel_tol
        Relative tolerance floor of C and R (the runner takes the larger of it and 3 standard errors).
    expect
        One sentence: what the analysis should do with this record and why.
    """

    omega0: float
    C: float
    R: float
    t_free_start: float
    t_free_end: float
    release_angle_deg: float | None
    angle_column: int = 1
    accept: tuple[str, ...] = ("fit",)
    reason: str = ""
    windows: tuple[tuple[float, float], ...] = ()
    D: float = 0.0
    rel_tol: float = 0.15
    expect: str = ""

    @property
    def period(self) -> float:
        return 2 * math.pi / self.omega0

    def all_windows(self) -> tuple[tuple[float, float], ...]:
        return ((self.t_free_start, self.t_free_end),) + tuple(self.windows)


@dataclass(frozen=True)
class Artefact:
    """One synthetic record: its class name, seed, CSV text and truth."""

    name: str
    seed: int
    csv: str
    truth: Truth
    slow: bool = False


# ----------------------------------------------------------------------------- the pendulum


@dataclass(frozen=True)
class Pendulum:
    """Drawn physics and sampling of one record."""

    omega0: float
    C: float
    R: float
    a0: float  # release amplitude, rad (signed: the side of the release)
    rate: float  # Hz
    periods: int
    sigma: float  # noise, rad
    rng: np.random.Generator = field(compare=False)

    @property
    def period(self) -> float:
        return 2 * math.pi / self.omega0

    @property
    def duration(self) -> float:
        return self.periods * self.period


def draw(seed: int, periods: int | None = None, *, loss: tuple[float, float] = (0.4, 0.6),
         amp_deg: tuple[float, float] = (10.0, 20.0)) -> Pendulum:
    """A pendulum and its sampling from the seed (see the module's sizes)."""
    rng = np.random.default_rng(seed)
    period = rng.uniform(1.0, 3.0)
    omega0 = 2 * math.pi / period
    n = int(periods or rng.integers(30, 101))
    a0 = math.radians(rng.uniform(*amp_deg)) * rng.choice([-1.0, 1.0])
    f = rng.uniform(*loss)  # fraction of the amplitude lost over the record
    duration = n * period
    c = f / duration  # viscous: exp(-C t/2) takes about f/2 off
    r = 0.5 * f * abs(a0) * omega0**2 / (4 * n)  # Coulomb: 4R/omega0**2 per period, f/2 of A0 in n periods
    rate = rng.uniform(20.0, 100.0)
    sigma = rng.uniform(0.001, 0.01) * abs(a0)
    return Pendulum(omega0, c, r, a0, rate, n, sigma, rng)


def _scene_text(omega0: float, c: float, r: float, theta0: float, d: float = 0.0) -> str:
    omega0, c, r, theta0, d = (float(v) for v in (omega0, c, r, theta0, d))
    drag = f"[effects.drag]\nD = {d!r}\n" if d else ""
    return (f'model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = {omega0!r}\ntheta0 = {theta0!r}\n'
            f"[effects.viscous]\nC = {c!r}\n[effects.coulomb]\nR = {r!r}\n{drag}")


def free_state(p: Pendulum, theta0: float, t: np.ndarray, d: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """theta (rad) and theta' (rad/s) of the free pendulum released at rest from ``theta0`` at t = 0."""
    from escfit import load_scene
    from escfit.balance.solvers import default_solver
    from escfit.balance.waveform import sample_state

    scene = load_scene("artefact.toml", text=_scene_text(p.omega0, p.C, p.R, theta0, d))
    t = np.asarray(t, dtype=float)
    theta, omega, status = sample_state(scene.build(), np.maximum(t, 0.0), default_solver(scene))
    return np.asarray(theta, dtype=float), np.asarray(omega, dtype=float)


def turning_times(p: Pendulum, theta0: float, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (s after the release) and angles (rad) of the free decay's turning points up to ``t_end``."""
    t = np.arange(0.0, t_end, 1.0 / FINE_HZ)
    theta, omega = free_state(p, theta0, t)
    k = np.nonzero(np.sign(omega[1:]) != np.sign(omega[:-1]))[0]
    k = k[np.abs(omega[k]) + np.abs(omega[k + 1]) > 0]
    return t[k + 1], theta[k + 1]


def smoothstep(s: np.ndarray) -> np.ndarray:
    """0 at s <= 0, 1 at s >= 1, zero slope at both ends."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def hand(t: np.ndarray, t0: float, t1: float, a_start: float, a_end: float, half_swings: int) -> np.ndarray:
    """A swing led by a hand from the turning point ``a_start`` (rad, signed) at ``t0`` to the
    turning point ``|a_end|`` at ``t1`` after ``half_swings`` half swings: the amplitude moves
    smoothly between the two, the velocity is zero at both ends (the pendulum is released at rest).
    ``a_start = 0`` starts the swing from rest at the bottom."""
    s = (t - t0) / (t1 - t0)
    amp = abs(a_start) + (abs(a_end) - abs(a_start)) * smoothstep(s)
    sign = math.copysign(1.0, a_start) if a_start else math.copysign(1.0, a_end) * (-1) ** half_swings
    return sign * amp * np.cos(math.pi * half_swings * np.clip(s, 0.0, 1.0))


def grid(p: Pendulum, duration: float, *, jitter: float = 0.0) -> np.ndarray:
    """Sample times from 0 to ``duration``: uniform at the pendulum's rate, or with each interval
    scaled by ``1 + U(-jitter, jitter)``."""
    dt = 1.0 / p.rate
    if not jitter:
        return np.arange(0.0, duration, dt)
    steps = dt * (1.0 + p.rng.uniform(-jitter, jitter, int(duration / dt * 1.2) + 10))
    t = np.concatenate([[0.0], np.cumsum(steps)])
    return t[t < duration]


def noisy(p: Pendulum, theta: np.ndarray) -> np.ndarray:
    return theta + p.sigma * p.rng.standard_normal(theta.size)


def csv_text(header: list[str], columns: list[np.ndarray], fmts: list[str] | None = None) -> str:
    fmts = fmts or ["%.5f"] + ["%.6g"] * (len(columns) - 1)
    rows = [",".join(f % v for f, v in zip(fmts, row)) for row in zip(*columns)]
    return ",".join(header) + "\n" + "\n".join(rows) + "\n"


def angle_csv(t: np.ndarray, theta: np.ndarray) -> str:
    return csv_text(["time (s)", "angle (deg)"], [t, np.degrees(theta)], ["%.5f", "%.5f"])


def truth(p: Pendulum, start: float, end: float, release: float | None, **kw) -> Truth:
    return Truth(p.omega0, p.C, p.R, start, end, None if release is None else math.degrees(release), **kw)


def free_record(p: Pendulum, t_release: float, theta0: float, t: np.ndarray) -> np.ndarray:
    """theta of a free decay released at ``t_release`` from ``theta0``, at the times ``t >= t_release``."""
    theta, _ = free_state(p, theta0, t - t_release)
    return theta


# ----------------------------------------------------------------------------- the classes
# Each returns (csv, truth); :func:`make` wraps them with their name and seed.


def clean(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    return angle_csv(t, noisy(p, free_record(p, 0.0, p.a0, t))), truth(
        p, 0.0, t[-1], p.a0, expect="fit the whole record from the first row")


def guided_start(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    rest, swings = 1.0, 2 + seed % 3  # the hand leads 2-4 half swings from rest, growing the amplitude
    t_rel = rest + swings * 0.5 * p.period
    t = grid(p, t_rel + p.duration)
    theta = np.where(t < t_rel, hand(t, rest, t_rel, 0.0, p.a0, swings), 0.0)
    theta[t >= t_rel] = free_record(p, t_rel, p.a0, t[t >= t_rel])
    return angle_csv(t, noisy(p, theta)), truth(
        p, t_rel, t[-1], p.a0, expect="fit from the release at the end of the hand's swings; the swings "
        "before it grow and are not free")


def hold_release(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    hold = 2.0
    t = grid(p, hold + p.duration)
    theta = np.full(t.size, p.a0)
    theta[t >= hold] = free_record(p, hold, p.a0, t[t >= hold])
    return angle_csv(t, noisy(p, theta)), truth(
        p, hold, t[-1], p.a0, expect="fit from the end of the 2 s hold (the release), not from the first row")


def wobble(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    swings = p.rng.uniform(10.0, 30.0)
    mod = 1.0 + 0.03 * np.sin(2 * math.pi * t / (swings * p.period) + p.rng.uniform(0, 2 * math.pi))
    return angle_csv(t, noisy(p, mod * free_record(p, 0.0, p.a0, t))), truth(
        p, 0.0, t[-1], p.a0, rel_tol=0.30, accept=("fit", "not determined"),
        expect="fit the whole record (or say C and R are not separately determined): a 3 % slow modulation of the projected amplitude (a bob not in a "
        "plane) is no push; C and R get 30 %, since the modulation alone can move the start-to-end "
        "amplitude ratio by 6 %, about a tenth of the decrement, and the C/R split amplifies it")


def offset_step(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    theta = free_record(p, 0.0, p.a0, t)
    t_step = p.rng.uniform(0.3, 0.7) * t[-1]
    theta = theta + np.where(t >= t_step, 0.1 * abs(p.a0) * p.rng.choice([-1.0, 1.0]), 0.0)
    return angle_csv(t, noisy(p, theta)), truth(
        p, 0.0, t[-1], p.a0, expect="fit the whole record: the tracked origin moved by 10 % of A0, the "
        "peak-to-peak swing is unchanged (or fit the longer side of the step)",
        windows=((0.0, t_step), (t_step, t[-1])))


def glitch(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    theta = noisy(p, free_record(p, 0.0, p.a0, t))
    k = int(p.rng.uniform(0.2, 0.8) * t.size)
    theta[k:k + 3] += 0.2 * abs(p.a0) * p.rng.choice([-1.0, 1.0])
    return angle_csv(t, theta), truth(p, 0.0, t[-1], p.a0, expect="fit the whole record; three frames "
                                      "displaced by 20 % of A0 change nothing that matters")


def _pushed(p: Pendulum, fractions: list[float], push_half_swings: int = 2):
    """A record of free decays each ended by a push that brings the amplitude back to about |A0|
    over ``push_half_swings`` half swings; ``fractions`` of the total free time per decay, each
    but the last ending at a turning point.  Returns t, theta and the list of free windows."""
    pieces, windows = [], []  # (start, end, theta0 or hand arguments)
    t0, a = 0.0, p.a0
    for i, frac in enumerate(fractions):
        if i == len(fractions) - 1:
            windows.append((t0, t0 + frac * p.duration))
            pieces.append(("free", t0, t0 + frac * p.duration, a))
            break
        turns_t, turns_a = turning_times(p, a, frac * p.duration + p.period)
        k = int(np.searchsorted(turns_t, frac * p.duration))
        t_end, a_turn = t0 + turns_t[k], float(turns_a[k])
        windows.append((t0, t_end))
        pieces.append(("free", t0, t_end, a))
        a_new = math.copysign(abs(p.a0) * p.rng.uniform(0.9, 1.0), a_turn * (-1) ** push_half_swings)
        t1 = t_end + push_half_swings * 0.5 * p.period
        pieces.append(("hand", t_end, t1, (a_turn, a_new)))
        t0, a = t1, a_new
    t = grid(p, windows[-1][1])
    theta = np.zeros(t.size)
    for kind, start, end, arg in pieces:
        sel = (t >= start) & (t < end) if end < t[-1] else t >= start
        if kind == "free":
            theta[sel] = free_record(p, start, arg, t[sel])
        else:
            theta[sel] = hand(t[sel], start, end, arg[0], arg[1], push_half_swings)
    return t, theta, windows


def push_middle(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t, theta, w = _pushed(p, [0.35, 0.65])
    return angle_csv(t, noisy(p, theta)), truth(
        p, w[1][0], w[1][1], None, expect="fit the decay after the push: it is the longer one (65 % of "
        "the free time) and starts at the larger amplitude, so it holds more of the decay")


def three_pushes(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t, theta, w = _pushed(p, [0.25, 0.45, 0.30])
    return angle_csv(t, noisy(p, theta)), truth(
        p, w[1][0], w[1][1], None, accept=("fit", "refuse"), reason=r"push|grow|not a free decay|several|impuls",
        expect="fit the longest free decay (the second, 45 % of the free time), or refuse naming the pushes")


def restarts(seed: int, periods: int | None = None):
    """Swung, let decay and swung again by hand five times (a phone or a bob restarted over and over):
    each run loses some 40 % of its amplitude before the hand swings it back to about A0."""
    p = draw(seed, periods, loss=(2.0, 2.5))
    t, theta, w = _pushed(p, [0.14, 0.18, 0.32, 0.2, 0.16])
    return angle_csv(t, noisy(p, theta)), truth(
        p, w[2][0], w[2][1], None, accept=("fit", "refuse"), reason=r"restart|swung again|set swinging|push",
        expect="fit the longest free decay (the third, 32 % of the free time), or refuse naming the restarts")


def drive_off(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    swings = 1 + seed % 2  # one or two full swings of steady driven amplitude
    t_off = swings * p.period
    t = grid(p, t_off + p.duration)
    theta = p.a0 * np.cos(p.omega0 * t)  # ends at +a0, a turning point, at t_off
    theta[t >= t_off] = free_record(p, t_off, p.a0, t[t >= t_off])
    return angle_csv(t, noisy(p, theta)), truth(
        p, t_off, t[-1], p.a0, accept=("fit", "not determined"),
        expect="fit from the drive's switch-off; the steady swings before it are driven (or, where one or two steady "
        "swings lie within the noise of the turning points, say that C and R are not separately determined: "
        "fitted from the record's start, the split of the losses depends on where the decay is taken to start)")


def drive_logged(seed: int, periods: int | None = None):
    """A motor drives the pendulum off resonance (beats) for 8-12 periods, its signal logged in a
    column of its own, and is switched off mid-swing; the free decay follows."""
    from scipy.integrate import solve_ivp

    p = draw(seed, periods)
    w_d = p.omega0 * p.rng.choice([p.rng.uniform(0.8, 0.9), p.rng.uniform(1.1, 1.2)])
    force = abs(p.a0) * abs(p.omega0**2 - w_d**2)  # the driven swing's size about A0
    t_off = (8 + seed % 5 + p.rng.uniform(0.2, 0.8)) * 2 * math.pi / w_d

    def rhs(t, y):
        drive = force * math.cos(w_d * t) if t < t_off else 0.0
        return [y[1], -p.omega0**2 * math.sin(y[0]) - p.C * y[1] - p.R * np.sign(y[1]) + drive]

    def turn(t, y):
        return y[1]

    driven = solve_ivp(rhs, (0.0, t_off), [0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-12,
                       max_step=p.period / 50, dense_output=True)
    coast = solve_ivp(rhs, (t_off, t_off + 2 * p.period), driven.y[:, -1], method="DOP853", rtol=1e-10,
                      atol=1e-12, max_step=p.period / 50, dense_output=True, events=turn)
    t_turn = float(coast.t_events[0][0])  # the first turning point after the switch-off
    theta_turn = float(coast.y_events[0][0][0])
    t = grid(p, t_turn + p.duration)
    theta = np.empty_like(t)
    a, b, c = t < t_off, (t >= t_off) & (t < t_turn), t >= t_turn
    theta[a], theta[b] = driven.sol(t[a])[0], coast.sol(t[b])[0]
    theta[c] = free_record(p, t_turn, theta_turn, t[c])
    drive = np.where(t < t_off, 2.5 * np.cos(w_d * t), 0.0)
    csv = csv_text(["time (s)", "motor (V)", "angle (deg)"], [t, drive, np.degrees(noisy(p, theta))],
                   ["%.5f", "%.4f", "%.5f"])
    return csv, truth(p, t_turn, t[-1], theta_turn, angle_column=2,
                      expect="fit from the first turning point after the motor's column goes flat; the beats "
                      "before it are driven")


def _clean_rows(seed: int, periods: int | None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    return p, t, noisy(p, free_record(p, 0.0, p.a0, t))


def burst_stamps(seed: int, periods: int | None = None):
    p, t, theta = _clean_rows(seed, periods)
    k = int(p.rng.uniform(0.2, 0.8) * t.size)
    stamps = t.copy()
    stamps[k:k + 10] = t[k]  # a logger that writes ten buffered rows with one time stamp
    return angle_csv(stamps, theta), truth(p, 0.0, t[-1], p.a0, expect="fit the whole record, the ten rows "
                                           "on one stamp spread over their interval or left out")


def backwards_row(seed: int, periods: int | None = None):
    p, t, theta = _clean_rows(seed, periods)
    k = int(p.rng.uniform(0.2, 0.8) * t.size)
    stamps = t.copy()
    stamps[k] = t[k - 1] - 0.5 / p.rate  # one stamp earlier than the row before it
    return angle_csv(stamps, theta), truth(p, 0.0, t[-1], p.a0, expect="fit the whole record, the one "
                                           "backwards row left out")


def stalled_clock(seed: int, periods: int | None = None):
    p, t, theta = _clean_rows(seed, periods)
    k = int(p.rng.uniform(0.2, 0.8) * t.size)
    n = int(p.rate)  # one second of rows on a stopped clock, then it resumes with the true time
    stamps = t.copy()
    stamps[k:k + n] = t[k]
    return angle_csv(stamps, theta), truth(p, 0.0, t[-1], p.a0, expect="fit the whole record, the stalled "
                                           "second of rows left out")


def _noise_column(seed: int, periods: int | None, sine: bool):
    p, t, theta = _clean_rows(seed, periods)
    amp = math.degrees(abs(p.a0))
    if sine:
        other = amp * np.sin(p.rng.uniform(1.5, 2.5) * p.omega0 * t + p.rng.uniform(0, 2 * math.pi))
    else:
        other = 0.5 * amp * p.rng.standard_normal(t.size)
    csv = csv_text(["time (s)", "A (deg)", "B (deg)"], [t, other, np.degrees(theta)], ["%.5f", "%.5f", "%.5f"])
    return csv, truth(p, 0.0, t[-1], p.a0, angle_column=2, expect="fit column B, the decaying swing; column A "
                      + ("is a function generator's steady sine" if sine else "is white noise"))


def noise_column_white(seed: int, periods: int | None = None):
    return _noise_column(seed, periods, sine=False)


def noise_column_sine(seed: int, periods: int | None = None):
    return _noise_column(seed, periods, sine=True)


def _energy(p: Pendulum, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    theta, omega = free_state(p, p.a0, t)
    length, mass = G / p.omega0**2, 0.2
    e = 0.5 * mass * length**2 * omega**2
    return theta, e * (1.0 + 0.005 * p.rng.standard_normal(t.size))


def energy_only(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    _, e = _energy(p, t)
    return csv_text(["time (s)", "E (J)"], [t, e], ["%.5f", "%.6g"]), truth(
        p, 0.0, t[-1], p.a0, accept=("refuse",), reason=r"energ|negative|one sign|two peaks|twice|not an angle",
        expect="refuse: a kinetic energy (never negative, two peaks per swing) is not an angle")


def energy_first(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    theta, e = _energy(p, t)
    return csv_text(["time (s)", "E (J)", "angle (deg)"], [t, e, np.degrees(noisy(p, theta))],
                    ["%.5f", "%.6g", "%.5f"]), truth(
        p, 0.0, t[-1], p.a0, angle_column=2, expect="fit the angle column, not the energy column before it")


def displacement_mm(seed: int, periods: int | None = None):
    p, t, theta = _clean_rows(seed, periods)
    x = 1000.0 * G / p.omega0**2 * np.sin(theta)  # the bob's horizontal position, mm
    return csv_text(["time (s)", "x (mm)"], [t, x], ["%.5f", "%.4f"]), truth(
        p, 0.0, t[-1], p.a0, accept=("fit", "refuse"), reason=r"mm|millimet|length|displacement|unit|metre",
        expect="fit the angle asin(x/L) with L = g/omega0**2, or refuse: a length in mm is not an angle in degrees")


def acceleration(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    theta, omega = free_state(p, p.a0, t)
    alpha = -p.omega0**2 * np.sin(theta) - p.C * omega - p.R * np.sign(omega)  # the equation of motion
    a = G / p.omega0**2 * alpha  # tangential acceleration of the bob, m/s**2
    a = a + 0.005 * np.max(np.abs(a)) * p.rng.standard_normal(t.size)
    return csv_text(["time (s)", "a (m/s^2)"], [t, a], ["%.5f", "%.5f"]), truth(
        p, 0.0, t[-1], p.a0, accept=("fit", "refuse"), reason=r"accel|m/s|unit",
        expect="refuse, or fit the acceleration as L theta''; an acceleration read as degrees is wrong")


def two_runs(seed: int, periods: int | None = None):
    p = draw(seed, periods, loss=(0.85, 0.9))  # the first run fades to 10-15 % of A0
    t1 = p.duration
    stop, rest, lift, hold = p.period, 2.0, 1.5, 1.0
    t_rel2 = t1 + stop + rest + lift + hold
    t = grid(p, t_rel2 + p.duration)
    theta = np.zeros(t.size)
    run1 = t < t1
    theta[run1] = free_record(p, 0.0, p.a0, t[run1])
    last = free_record(p, 0.0, p.a0, np.array([t1]))[0]
    stopping = (t >= t1) & (t < t1 + stop)
    theta[stopping] = last * (1.0 - smoothstep((t[stopping] - t1) / stop))  # a hand stops the swing
    lifting = (t >= t1 + stop + rest) & (t < t_rel2)
    theta[lifting] = p.a0 * smoothstep((t[lifting] - t1 - stop - rest) / lift)
    run2 = t >= t_rel2
    theta[run2] = free_record(p, t_rel2, p.a0, t[run2])
    return angle_csv(t, noisy(p, theta)), truth(
        p, 0.0, t1, p.a0, windows=((t_rel2, t[-1]),), accept=("fit", "refuse"),
        reason=r"two|second|several|release|runs",
        expect="fit one of the two runs (they are alike), or refuse naming the second release")


def long_jitter(seed: int, periods: int | None = None):
    p = draw(seed, max(periods or 0, 300))  # long by definition: the length override does not shorten it
    p = replace(p, rate=min(p.rate, 30.0))  # phone video
    t = grid(p, p.duration, jitter=0.1)
    return angle_csv(t, noisy(p, free_record(p, 0.0, p.a0, t))), truth(
        p, 0.0, t[-1], p.a0, expect="fit the whole record on its own (true, uneven) time stamps")


def radians_as_degrees(seed: int, periods: int | None = None):
    p = draw(seed, periods, amp_deg=(20.0, 25.0))
    t = grid(p, p.duration)
    theta = noisy(p, free_record(p, 0.0, p.a0, t))
    return csv_text(["time (s)", "angle (deg)"], [t, theta], ["%.5f", "%.6f"]), truth(
        p, 0.0, t[-1], p.a0, accept=("fit", "refuse"), reason=r"radian|rad\b|small",
        expect="notice that a largest swing of 0.3-0.4 'degrees' is radians and fit it as such, or refuse; "
        "read as degrees R comes out 57 times too small and omega0 off by the A**2/16 of a pendulum")


def two_modes(seed: int, periods: int | None = None):
    p, t, theta = _clean_rows(seed, periods)
    second = 0.03 * abs(p.a0) * np.exp(-2 * p.C * t) * np.cos(2.7 * p.omega0 * t + p.rng.uniform(0, 2 * math.pi))
    return angle_csv(t, theta + second), truth(
        p, 0.0, t[-1], p.a0, expect="fit the main mode; a weak mode at 2.7 omega0 with 3 % of A0 is a "
        "small misfit, not a push")


def hand_stop(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    turns_t, turns_a = turning_times(p, p.a0, p.duration)
    k = turns_t.size - 3  # a hand stops the swing from a turning point about a period before the end
    t_stop, a_stop = float(turns_t[k]), float(turns_a[k])
    t = grid(p, t_stop + 3 * p.period)  # then the bob hangs still for two and a half periods
    theta = free_record(p, 0.0, p.a0, t)
    after = t >= t_stop
    s = np.clip((t[after] - t_stop) / (0.75 * p.period), 0.0, 1.0)  # brought to rest in three quarter swings
    theta[after] = a_stop * (1.0 - smoothstep(s)) * np.cos(p.omega0 * (t[after] - t_stop))
    return angle_csv(t, noisy(p, theta)), truth(
        p, 0.0, t_stop, p.a0, accept=("fit", "not determined"), reason=r"\[recording\] stop = |--stop ",
        expect="fit up to the hand (the turning point where the swing is stopped), or say that the end does "
        "not follow the decay and name [recording] stop")


def spliced_end(seed: int, periods: int | None = None):
    p = draw(seed, periods)
    t = grid(p, p.duration)
    theta = free_record(p, 0.0, p.a0, t)
    t_cut = t[-1] - 1.2 * p.period  # the last 1.2 periods come from another take: half a period out of phase
    late = t >= t_cut
    theta[late] = free_record(p, -0.5 * p.period, p.a0, t[late])
    return angle_csv(t, noisy(p, theta)), truth(
        p, 0.0, t_cut, p.a0, accept=("fit", "not determined"), reason=r"\[recording\] stop = |--stop ",
        expect="fit up to the splice, or say that the end does not follow the decay and name [recording] stop")


CLASSES = {f.__name__: f for f in (
    clean, guided_start, hold_release, wobble, offset_step, glitch, push_middle, restarts, drive_off, drive_logged,
    burst_stamps, backwards_row, stalled_clock, noise_column_white, noise_column_sine, energy_only, energy_first,
    displacement_mm, acceleration, three_pushes, two_runs, long_jitter, radians_as_degrees, two_modes,
    hand_stop, spliced_end)}
SLOW = {"long_jitter"}


def make(name: str, seed: int = 0, *, periods: int | None = None) -> Artefact:
    """The record of class ``name`` (a key of :data:`CLASSES`) drawn with ``seed``."""
    csv, tr = CLASSES[name](seed, periods)
    return Artefact(name, seed, csv, tr, name in SLOW)
