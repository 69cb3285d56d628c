"""Turning points of recorded decays against known truth: quantised flat tops, every kind of
start, resting tails, anharmonic swings, drifting centres, noise, refusals and real records.

The truth is the closed form of a damped linear oscillator with Coulomb friction (checked
against the exact balance solver below) or a gravity pendulum integrated by scipy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.core.errors import DataError
from escfit.analysis.recordings.extrema import spectral_period
from escfit.analysis.recordings.timeseries import TimeSeries, timeseries_to_unit_curve
from escfit.analysis.recordings.turning_points import TurningPoints, reduce_series

from .conftest import SHARED

W0 = 2 * math.pi  # 1 s small-amplitude period
Q = 1 / 200  # encoder step: 200 counts per radian of amplitude
REAL = SHARED / "realdata"


def decay(t, theta0, c=0.05, r=0.05, w0=W0, release=0.0):
    """Exact ``theta'' + c theta' + w0^2 theta = -r sgn(theta')`` released at rest at ``release``
    (held before), and its turning points ``(times, angles)``, the release first and the stop last."""
    w1 = math.sqrt(w0**2 - c**2 / 4)
    half = math.pi / w1
    turn_t, turn_v = [release], [theta0]
    while abs(w0**2 * turn_v[-1]) > r and turn_t[-1] < t[-1] + 1:
        e = r * math.copysign(1.0, turn_v[-1]) / w0**2  # centre of this half swing
        turn_t.append(turn_t[-1] + half)
        turn_v.append(e - (turn_v[-1] - e) * math.exp(-c * half / 2))
    tt, tv = np.array(turn_t), np.array(turn_v)
    k = np.clip(np.searchsorted(tt, t, side="right") - 1, 0, tt.size - 1)
    tau, th = t - tt[k], tv[k]
    e = r * np.sign(th) / w0**2
    y = e + (th - e) * np.exp(-c * tau / 2) * (np.cos(w1 * tau) + c / (2 * w1) * np.sin(w1 * tau))
    y = np.where((t < release) | (k == tt.size - 1), np.where(t < release, theta0, tv[-1]), y)
    return y, tt, tv


def pendulum(t, theta0, c=0.03, w0=W0):
    """A gravity pendulum ``theta'' = -w0^2 sin(theta) - c theta'`` released at rest at t = 0."""
    from scipy.integrate import solve_ivp

    def turn(_, y):
        return y[1]

    sol = solve_ivp(lambda _, y: [y[1], -w0**2 * math.sin(y[0]) - c * y[1]], (0.0, t[-1] + 1.0), [theta0, 0.0],
                    dense_output=True, events=turn, rtol=1e-10, atol=1e-12)
    te = sol.t_events[0][sol.t_events[0] > 1e-9]
    return sol.sol(t)[0], np.r_[0.0, te], np.r_[theta0, sol.sol(te)[0]]


def quantise(y, q=Q):
    return q * np.round(y / q)


def series(t, y, **kw) -> TimeSeries:
    return TimeSeries(np.asarray(t, float), np.asarray(y, float), source="synthetic.csv", **kw)


def truth_index(tp: TurningPoints, tt: np.ndarray, period: float) -> np.ndarray:
    """Index of the true turning point nearest each one found (they must be within P/8)."""
    k = np.argmin(np.abs(tp.time[:, None] - tt[None, :]), axis=1)
    assert np.all(np.abs(tp.time - tt[k]) < period / 8)
    return k


def test_closed_form_truth_is_the_exact_solvers():
    import escfit
    from escfit.balance import solve

    text = ('model = "balance"\n[oscillator]\nomega0 = 6.283185307179586\ntheta0 = 1.0\n[run]\nswings = 12\n'
            '[effects.viscous]\nC = 0.3\n[effects.coulomb]\nR = 2.0\n')
    traj = solve(escfit.load_scene("decay.toml", text=text), "exact", dense=True)
    t = np.linspace(0.0, 5.0, 777)
    y, tt, tv = decay(t, 1.0, c=0.3, r=2.0)
    np.testing.assert_allclose(tt[1:], traj.time, rtol=1e-12)
    np.testing.assert_allclose(tv[1:], traj.theta_turn, rtol=1e-12)
    np.testing.assert_allclose(y, traj.dense.theta(t), atol=1e-12)


@pytest.mark.parametrize("rate, phase", [(50, 0.5), (60, 0.2), (80, 0.13), (100, 0.37)])
def test_quantised_flat_tops_are_each_one_turning_point(rate, phase):
    """An encoder's extrema are plateaus of equal samples; every one is found, at its centre."""
    t = np.arange(0.0, 30.0, 1 / rate) + phase / rate
    y, tt, tv = decay(t, 1.0)
    x = quantise(y)
    near = [x[np.abs(t - tk) < 0.1] for tk in tt[1:-1] if tk < 29]
    flat = [np.sum(w == (w.max() if w.mean() > 0 else w.min())) >= 2 for w in near]
    assert np.mean(flat) > 0.5  # the data do have flat tops: a zero derivative at the turn
    tp = reduce_series(series(t, x))
    in_record = tt[(tt > t[0] + 0.1) & (tt < t[-1] - 0.2)]
    assert tp.swing.size == in_record.size
    np.testing.assert_array_equal(tp.swing, np.arange(1, tp.swing.size + 1))
    k = truth_index(tp, tt, 1.0)
    np.testing.assert_array_equal(k, tp.swing)  # swing k ends at the k-th turn after the release
    assert np.max(np.abs(tp.theta - tv[k])) < Q / 2
    assert np.max(np.abs(tp.time - tt[k])) < 0.01  # 1 % of the period
    assert tp.period == pytest.approx(1.0, rel=1e-3)
    assert abs(tp.offset) < Q / 4 and tp.offset_rate == 0.0
    assert math.isnan(tp.stop_time) and math.isnan(tp.rest_theta)


@pytest.mark.parametrize("start", [0.3, 0.5, 0.46])
def test_a_record_that_starts_late_is_referred_to_its_first_turning_point(start):
    """Mid-swing (0.3 s after the release), exactly at a negative turn (0.5 s), or just before
    one (0.46 s): the reference is that negative turn and swings count from there."""
    t = np.arange(0.0, 15.0, 1 / 60)
    y, tt, tv = decay(t + start, 1.0)
    tt = tt - start
    tp = reduce_series(series(t, quantise(y)))
    assert tp.release_time == pytest.approx(tt[1], abs=0.01)
    assert tp.release_theta == pytest.approx(tv[1], abs=Q / 2)
    assert tp.release_theta < 0
    k = truth_index(tp, tt, 1.0)
    np.testing.assert_array_equal(k, tp.swing + 1)
    assert any("starts" in n for n in tp.notes)


def test_a_held_start_is_released_where_motion_starts():
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 15.0, 1 / 60)
    y, tt, tv = decay(t, -0.8, release=1.7)
    tp = reduce_series(series(t, quantise(y + 0.001 * rng.standard_normal(t.size))))
    assert tp.release_time == pytest.approx(1.7, abs=0.01)
    assert tp.release_theta == pytest.approx(-0.8, abs=Q)
    k = truth_index(tp, tt, 1.0)
    np.testing.assert_array_equal(k, tp.swing)
    assert tp.theta[0] > 0 and any("held at" in n for n in tp.notes)


def test_an_explicit_release_instant_wins():
    t = np.arange(0.0, 10.0, 1 / 60)
    y, tt, _ = decay(t, 0.8, release=1.7)
    tp = reduce_series(series(t, quantise(y), release_s=1.7))
    assert tp.release_time == 1.7 and tp.release_theta == pytest.approx(0.8, abs=Q)
    np.testing.assert_array_equal(truth_index(tp, tt, 1.0), tp.swing)


def test_a_resting_tail_is_cut_and_reported():
    """Strong friction stops the balance at 4.5 s short of the centre; then the encoder
    flickers by one count for 55 s.  Motion lasts under a tenth of the record."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 1 / 60)
    y, tt, tv = decay(t, 1.0, r=2.0)
    x = quantise(y)
    rest = t > tt[-1]
    x[rest] += Q * rng.integers(-1, 2, rest.sum())
    tp = reduce_series(series(t, x))
    assert abs(tp.stop_time - tt[-1]) < 0.5
    assert tp.rest_theta == pytest.approx(tv[-1], abs=2 * Q)
    assert tp.swing.size == tt.size - 1  # the stop is the last turning point
    np.testing.assert_array_equal(truth_index(tp, tt, 1.0), tp.swing)
    note = [n for n in tp.notes if n.startswith("motion stopped at t = ")]
    assert note and "deg from the centre" in note[0]
    meta = timeseries_to_unit_curve(series(t, x)).meta
    assert float(meta["stop_time_s"]) == tp.stop_time and float(meta["rest_theta_rad"]) == tp.rest_theta
    assert tp.period == pytest.approx(1.0, rel=0.01)


@pytest.mark.parametrize("start", [0.0, 0.3])
def test_a_large_anharmonic_pendulum_is_numbered_without_skips(start):
    """150 deg: the period shrinks by 40 % along the record; counting, not dividing times by
    a period, keeps the numbers right."""
    t = np.arange(0.0, 40.0, 1 / 80)
    y, tt, tv = pendulum(t + start, math.radians(150.0))
    tt = tt - start
    tp = reduce_series(series(t, y))
    ref = 0 if start == 0.0 else 1
    assert tp.release_time == pytest.approx(tt[ref], abs=0.01)
    k = truth_index(tp, tt, 1.0)
    np.testing.assert_array_equal(k, tp.swing + ref)
    assert k[-1] >= np.searchsorted(tt, t[-1]) - 2  # nothing missing up to the end
    assert np.max(np.abs(tp.theta - tv[k])) < 1e-3
    half = np.diff(np.r_[tp.release_time, tp.time])
    assert half[0] / half[-1] > 1.3


def test_a_drifting_centre_is_measured():
    t = np.arange(0.0, 30.0, 1 / 60)
    y, tt, tv = decay(t, 1.0)
    rate = math.radians(1.0) / 30.0
    tp = reduce_series(series(t, quantise(y + 0.01 + rate * t)))
    assert tp.offset_rate == pytest.approx(rate, rel=0.2)
    assert tp.offset == pytest.approx(0.01, abs=Q / 2)
    assert any("centre drifts" in n for n in tp.notes)
    curve = timeseries_to_unit_curve(series(t, quantise(y + 0.01 + rate * t)))
    k = truth_index(tp, tt, 1.0)
    assert np.max(np.abs(curve.value - np.abs(tv[k]))) < Q
    assert float(curve.meta["offset_rate_rad_per_s"]) == tp.offset_rate


def test_the_period_survives_heavy_noise():
    """88 samples per period, noise 2 % of the amplitude."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 20.0, 1 / 88)
    y, tt, _ = decay(t, 1.0, c=0.1, r=0.001)
    x = y + 0.02 * rng.standard_normal(t.size)
    assert spectral_period(t, x)[0] == pytest.approx(1.0, rel=0.01)
    tp = reduce_series(series(t, x))
    assert tp.period == pytest.approx(1.0, rel=0.01)
    np.testing.assert_array_equal(truth_index(tp, tt, 1.0), tp.swing)


def test_the_spectral_period_ignores_drift_and_a_resting_tail():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 100.0, 1 / 50)
    y, _, _ = decay(t, 1.0, r=1.0)  # stops after 9 s of 100
    x = quantise(y + 0.3 * t / 100) + Q * rng.integers(-1, 2, t.size)
    assert spectral_period(t, x)[0] == pytest.approx(1.0, rel=0.03)


def _noise():
    t = np.arange(0.0, 20.0, 1 / 60)
    return series(t, 0.05 * np.random.default_rng(3).standard_normal(t.size))


def _growing():
    t = np.arange(0.0, 20.0, 1 / 60)
    return series(t, 0.1 * np.exp(0.1 * t) * np.cos(W0 * t))


def _sparse():
    t = np.arange(0.0, 20.0, 1 / 6)
    return series(t, decay(t, 1.0)[0])


def _wrapped():
    t = np.arange(0.0, 20.0, 1 / 60)
    return series(t, np.angle(np.exp(1j * (3.0 + decay(t, 1.0)[0]))))


@pytest.mark.parametrize("make, message", [
    (_noise, r"synthetic.csv: no oscillation found: the spectrum has no clear peak"),
    (_growing, r"the swing grows from .* not a free decay"),
    (_sparse, r"spans only 6.0 samples; .* at least 8: sample at 16 Hz or faster"),
    (_wrapped, r"the angle jumps by .* a wrapped angle\? unwrap it"),
])
def test_what_is_not_a_free_decay_is_refused(make, message):
    with pytest.raises(DataError, match=message):
        reduce_series(make())


@pytest.mark.parametrize("strict", [True, False])
@pytest.mark.parametrize("gap,hidden", [((5.2, 5.8), 1), ((5.2, 6.3), 2), ((5.2, 6.8), 3), ((5.3, 8.2), 6)])
def test_turning_points_lost_in_a_gap_of_the_samples_are_counted_across(strict, gap, hidden):
    """A dropout of the samples hides one to six turning points (half swings of 0.5 s from t = 0):
    the turning points after it keep the half-swing numbers of the exact decay's, the parity of
    the jump following their sides, and the period is the decay's."""
    t = np.arange(0.0, 20.0, 1 / 60)
    y, tt, _ = decay(t, 1.0)
    keep = (t < gap[0]) | (t > gap[1])
    tp = reduce_series(series(t[keep], y[keep]), strict=strict)
    assert any(f"{hidden} turning point(s) fall in gaps of the samples" in n for n in tp.notes), tp.notes
    assert not any("irregular interval" in n for n in tp.notes), tp.notes
    times = np.asarray(tp.time, float)
    exact = np.argmin(np.abs(times[:, None] - tt[None, :]), axis=1)  # which exact turning point each is
    ref = int(np.argmin(np.abs(tt - tp.release_time)))
    np.testing.assert_array_equal(tp.swing, exact - ref)
    assert tp.period == pytest.approx(2 * (tt[1] - tt[0]), rel=2e-3)


def test_unit_curve_meta_and_the_sign_of_the_release():
    """The scene releases at +theta0, the record's reference turn is negative: magnitudes
    match, so it is accepted with a note; another magnitude is refused."""
    t = np.arange(0.0, 12.0, 1 / 60)
    y, tt, tv = decay(t + 0.5, 1.0)
    ts = series(t, quantise(y))
    curve = timeseries_to_unit_curve(ts, release_theta=abs(tv[1]))
    meta = curve.meta
    assert set(meta) >= {"release_time_s", "release_theta_rad", "offset_rad", "offset_rate_rad_per_s",
                         "stop_time_s", "rest_theta_rad", "period_s", "notes"}
    assert all(isinstance(v, str) for v in meta.values())
    assert all(math.isfinite(float(meta[k])) for k in ("release_time_s", "release_theta_rad", "offset_rad", "period_s"))
    assert float(meta["release_theta_rad"]) == pytest.approx(tv[1], abs=Q)
    assert "other side of the centre" in meta["notes"] and "; " in meta["notes"]
    np.testing.assert_array_equal(curve.swing, np.arange(1, curve.swing.size + 1))
    with pytest.raises(DataError, match=r"starts at -0.98\d* rad but the scene releases the balance at 1.5"):
        timeseries_to_unit_curve(ts, release_theta=1.5)


def _real(path):
    if not path.exists():
        pytest.skip("shared real data not present")
    return path


def test_real_pohl_wheel_video_track():
    """Tracker angles of a Pohl wheel, 30 frames/s, the centre near 84 deg: 11 alternating
    extrema in 8 s (the first the reference), period about 1.37 s."""
    data = np.genfromtxt(_real(REAL / "pohl_heilaut" / "derived" / "tracker_video_frames.csv"), delimiter=",",
                         names=True, skip_header=2)
    ts = series(data["t_s"], np.unwrap(np.radians(data["angle_deg"])))
    tp = reduce_series(ts)
    assert tp.swing.size + 1 == 11
    assert np.all(np.diff(np.sign(np.diff(np.r_[tp.release_theta, tp.theta]))) != 0)  # alternating
    assert tp.period == pytest.approx(1.37, abs=0.03)
    assert math.degrees(tp.offset) == pytest.approx(84.0, abs=3.0)
    half = np.diff(np.r_[tp.release_time, tp.time])
    assert np.all((half > 0.4 * tp.period) & (half < 0.8 * tp.period))


def test_real_string_pendulum_video_track():
    """116 s of a string pendulum at 20 samples/s: over 140 half swings, none skipped."""
    data = np.loadtxt(_real(REAL / "string_pendulum_video" / "lab1_data.txt"))
    tp = reduce_series(series(data[:, 0], data[:, 1]))
    assert tp.swing.size >= 140
    half = np.diff(np.r_[tp.release_time, tp.time])
    assert np.all(np.abs(half / np.median(half) - 1) < 0.1)
    assert tp.period == pytest.approx(1.646, rel=0.01)
    amp = np.abs(tp.theta - tp.centre(tp.time))
    assert amp[0] == pytest.approx(0.68, abs=0.03) and amp[-1] == pytest.approx(0.19, abs=0.03)


def test_real_large_amplitude_pendulum_starting_mid_swing():
    """17 s of a string pendulum let go near 1.44 rad, tracked at 29.6 frames/s; the record
    starts mid-swing, so the reference is the first (negative) turning point."""
    data = np.loadtxt(_real(REAL / "string_pendulum_video" / "trial1_rawdata.txt"))
    tp = reduce_series(series(data[:, 0], data[:, 1]))
    assert tp.release_time == pytest.approx(0.266, abs=0.02)
    assert tp.release_theta == pytest.approx(-1.44, abs=0.01)
    assert tp.swing.size == 18 and np.all(np.diff(np.sign(tp.theta)) != 0)
    half = np.diff(np.r_[tp.release_time, tp.time])
    assert np.all(np.abs(half / np.median(half) - 1) < 0.1)


@pytest.mark.parametrize("rate", [9.0, 11.0, 13.0])
def test_a_coarse_record_is_read_with_a_note(rate):
    """9 to 13 samples a period (a 30 fps video of a fast swing): the turning points come from
    sinusoid arcs through the few samples at each turn; against the exact decay their times are
    within 2 % of a period and their angles within 2 % of the first swing, and the period within
    0.5 %; a note says what the coarse sampling costs."""
    rng = np.random.default_rng(int(rate))
    t = np.arange(0.0, 20.0, 1.0 / rate) + rng.uniform(0, 0.05)
    y, tt, tv = decay(t, 1.0)
    tp = reduce_series(series(t, y))
    assert any("spans only" in n and "arc" in n for n in tp.notes), tp.notes
    period = 2 * math.pi / W0
    assert tp.period == pytest.approx(period, rel=5e-3)
    for time, value in zip(tp.time, tp.theta):
        k = int(np.argmin(np.abs(tt - time)))
        assert abs(time - tt[k]) < 0.02 * period and abs(value - tv[k]) < 0.02



def test_a_ripple_at_a_turning_point_is_not_two_more_turning_points():
    """A decaying swing, 100 samples a period, with one frame 6 % of the swing low just after
    the peak at 5 s (a tracker wavering): the hysteresis of a small step lets through a
    maximum, a dip and a maximum within a tenth of a period.  The dip and the lesser peak go;
    every other extremum is the clean signal's."""
    from escfit.analysis.recordings.extrema import alternating_extrema, without_wiggles

    t = np.arange(0.0, 20.0, 1.0 / 100.0)
    clean = np.exp(-0.1 * t) * np.cos(2 * math.pi * t)
    peak = int(np.argmin(np.abs(t - 5.0)))
    rippled = clean.copy()
    rippled[peak + 2] -= 0.06 * clean[peak]  # one frame low, the next back on the curve
    cands = alternating_extrema(rippled, 0.01, 0)
    reference = alternating_extrema(clean, 0.01, 0)
    assert len(cands) == len(reference) + 2  # the ripple's two extra extrema
    kept, dropped = without_wiggles(cands, t, rippled, 1.0)
    assert [c[0] for c in kept] == [c[0] for c in reference] and len(dropped) == 1
    assert without_wiggles(reference, t, clean, 1.0) == (reference, [])  # a clean swing is left alone
    deep = clean.copy()
    deep[peak + 2] -= 0.5 * clean[peak]  # half the swing: a shoulder of the waveform (a sound), not noise
    cands = alternating_extrema(deep, 0.01, 0)
    assert without_wiggles(cands, t, deep, 1.0) == (cands, [])


def test_a_swing_that_grows_steadily_is_refused():
    """A sound's pressure (or a driven swing) growing by 5 % a period, every half swing larger than
    the one before: not a free decay, refused as sustained (the last third of the swings is 15 %
    larger than the first, under the fifth the rule asked before)."""
    t = np.arange(0.0, 5.0, 1.0 / 200.0)
    y = 0.6 * (1.0 + 0.05 * t) * np.cos(2 * math.pi * t)
    with pytest.raises(DataError, match="a driven or sustained oscillation"):
        reduce_series(series(t, y + 1e-4 * np.random.default_rng(0).standard_normal(t.size)))


def test_a_spurious_pair_within_a_swing_that_goes_on_is_not_its_fading():
    """Turning points of a fast decay (a fifth lost per half swing) with one spurious pair of
    extrema at half swing 5, a twentieth of a half period apart and two hundredths of the swing
    apart: the intervals break there, but the turning points around it stand far above the
    noise, so the decay is not cut there as faded (it kept 6 of 42 turning points)."""
    from types import SimpleNamespace

    from escfit.analysis.recordings.motion import faded_end

    k = np.arange(40)
    times = 0.5 * k
    values = 0.2 * 0.8 ** k * (-1.0) ** k
    a = values[5]
    times = np.r_[times[:6], times[5] + 0.025, times[5] + 0.05, times[6:] + 0.05]
    values = np.r_[values[:6], a * 0.98, a, values[6:]]
    rec = SimpleNamespace(band=1e-5, notes=[], show=lambda v, *a, **k: f"{v:.3g}")
    assert faded_end(rec, times, values) == times.size, rec.notes
    # where the swing has really faded, the noise's extrema are cut as before
    noisy = values.copy()
    noisy[30:] = 1e-4 * (-1.0) ** np.arange(noisy.size - 30)
    noisy_times = times.copy()
    noisy_times[31] = noisy_times[30] + 0.02
    assert faded_end(rec, noisy_times, noisy) <= 31
