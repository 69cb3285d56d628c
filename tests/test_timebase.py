"""The time-base stage (escfit.analysis.timebase): a logger's faulty stamps repaired, with known truth.

A clean damped sine sampled at 50 Hz (period 1.3 s) is written as CSV with the fault of a
logger or a phone in its time column, read through the reader `escfit fit` uses
(:func:`escfit.balance.family.read_data`), and the repaired time base is held against the true
sample times.  Burst stamps and a row out of order also go through `escfit init --pendulum` and
`escfit fit`, which must recover the true period.  What cannot be repaired is refused in one line
naming ``sample_rate``.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.timebase import time_base
from escfit.balance.family import read_data
from escfit.analysis.recordings.rawseries import notes_of, warnings_of
from escfit.cli.main import cli
from escfit.core.errors import DataError

RATE = 50.0  # Hz
PERIOD = 1.3  # s
N = 1500  # 30 s
STAMP = 1e-12  # s: the stamps are written with 17 digits


def truth() -> tuple[np.ndarray, np.ndarray]:
    """True sample times (s) and a damped sine (rad: 0.1 rad, decay rate 0.05 1/s)."""
    t = np.arange(N) / RATE
    return t, 0.1 * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / PERIOD)


def write(tmp_path, name, stamps, theta, header="time_s,theta_rad"):
    p = tmp_path / name
    p.write_text(header + "\n" + "".join(f"{s:.17g},{v:.8f}\n" for s, v in zip(stamps, theta)))
    return p


def bursts(t, every=0.2):
    """Stamps of a logger that stamps a buffer: the time floored to ``every`` s."""
    return np.floor(t / every + 1e-9) * every


# -- each fault, read as `escfit fit` reads it ---------------------------------------------------------
def test_burst_stamps_are_retimed_to_the_true_clock(tmp_path):
    t, a = truth()
    ts = read_data(write(tmp_path, "bursts.csv", bursts(t), a))  # 10 rows per stamp
    np.testing.assert_allclose(ts.time, t, rtol=0, atol=2 * STAMP)  # each burst starts on its stamp: exact
    np.testing.assert_array_equal(ts.theta, np.round(a, 8))
    # every row re-timed: a warning, not a note
    (warning,) = warnings_of(ts.meta)
    assert warning.startswith(f"time stamps repeat in bursts of ~10 rows: all {N} rows re-timed by a straight line")
    assert float(re.search(r"([\d.]+) Hz", warning).group(1)) == pytest.approx(RATE, rel=1e-6)


def test_irregular_bursts_are_retimed_by_the_fitted_rate(tmp_path):
    """At 48 Hz, stamps floored to 0.2 s hold 9 or 10 rows: the fitted rate is the true one and the
    clock is off by less than one interval (the rows' phase within a stamp is unknown)."""
    t = np.arange(N) / 48.0
    a = 0.1 * np.cos(2 * math.pi * t / PERIOD)
    ts = read_data(write(tmp_path, "b48.csv", bursts(t), a, header="Time (s),Angle (rad)"))  # the raw-table reader
    assert 1.0 / np.mean(np.diff(ts.time)) == pytest.approx(48.0, rel=1e-4)
    assert np.max(np.abs(ts.time - t)) < 1.0 / 48.0
    (warning,) = warnings_of(ts.meta)
    assert "re-timed by a straight line" in warning and " 48 Hz" in warning


def arrivals(t, seed=5):
    """Stamps of a computer that stamps rows as they come out of an evenly sampling logger's buffer:
    clusters of 5 to 30 rows, the cluster's last row taken at ``t`` then 0 to 0.15 s of latency
    (exponential, mean 0.03 s), the rows of a cluster 1 ms apart."""
    rng = np.random.default_rng(seed)
    stamps, i, last = np.empty_like(t), 0, -np.inf
    while i < t.size:
        k = min(int(rng.integers(5, 31)), t.size - i)
        arrive = max(t[i + k - 1] + min(rng.exponential(0.03), 0.15), last + 1e-3)
        stamps[i:i + k] = arrive + 1e-3 * np.arange(k)
        last, i = stamps[i + k - 1], i + k
    return stamps


def test_arrival_stamps_of_an_even_logger_are_retimed_on_a_line(tmp_path):
    """Stamps off the true clock by up to 0.15 s (a ninth of a period): the readings step evenly across
    the clusters' gaps, so every row goes on the line; the times are then off the truth by one
    constant latency only (0.03 s on average), not by the stamps' scatter."""
    t, a = truth()
    stamps = arrivals(t)
    assert np.max(np.abs(np.diff(stamps - t))) > 0.05  # the stamps' own steps are far off the truth
    ts = read_data(write(tmp_path, "arrive.csv", stamps, a))
    err = ts.time - t
    assert np.std(err) < 0.2 / RATE and 0.0 < np.mean(err) < 0.1
    assert 1.0 / np.mean(np.diff(ts.time)) == pytest.approx(RATE, rel=2e-3)
    (warning,) = warnings_of(ts.meta)
    assert "time stamps arrive in clusters" in warning and "the logger sampled evenly" in warning, warning


def test_stamps_of_a_logger_sampling_in_bursts_are_kept(tmp_path):
    """A logger that really samples in bursts (10 rows 1 ms apart every 0.2 s): the readings step
    far more across the gaps than within a burst, so the stamps are the sample times."""
    t = (np.arange(N) // 10) * 0.2 + (np.arange(N) % 10) * 1e-3
    a = 0.1 * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / PERIOD)
    ts = read_data(write(tmp_path, "burst_sampled.csv", t, a))
    np.testing.assert_allclose(ts.time, t, rtol=0, atol=STAMP)
    assert any("stamps are kept as the sample times" in n and "as samples taken in bursts do" in n
               for n in notes_of(ts.meta)), notes_of(ts.meta)


def test_kept_burst_stamps_written_twice_keep_one_row_a_stamp(tmp_path):
    """The same burst-sampled logger writing its stamps to 1 ms, with a few rows twice (a copy of
    the row) and a few readings taken a fraction of a millisecond after the one before (the same
    stamp, another reading): one row a stamp is kept, each at its true time (refused before as
    "time does not increase", naming a constant rate that would have put every burst wrong)."""
    t = (np.arange(N) // 10) * 0.2 + (np.arange(N) % 10) * 1e-3
    a = 0.1 * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / PERIOD)
    copies, ticks = np.arange(37, N, 97), np.arange(81, N, 113)
    stamps, values = np.insert(t, copies, t[copies - 1]), np.insert(a, copies, a[copies - 1])
    at = ticks + np.searchsorted(copies, ticks)  # the same rows in the longer arrays
    stamps = np.insert(stamps, at, stamps[at - 1])
    values = np.insert(values, at, values[at - 1] + 1e-4)
    ts = read_data(write(tmp_path, "burst_twice.csv", stamps, values))
    np.testing.assert_allclose(ts.time, t, rtol=0, atol=STAMP)
    np.testing.assert_allclose(ts.theta, a, rtol=0, atol=1e-8)
    said = [w for w in warnings_of(ts.meta) + notes_of(ts.meta) if "on the same stamp as the row before" in w]
    assert said and said[0].startswith(f"{copies.size + ticks.size} row(s)"), said


def test_arrival_stamps_with_noisy_readings_are_kept_with_a_warning(tmp_path):
    """Readings dominated by noise cannot say whether the rows were even: the stamps are kept and
    the user is warned, with the fix."""
    t, _ = truth()
    stamps = arrivals(t)
    noise = np.random.default_rng(8).standard_normal(N)
    ts = read_data(write(tmp_path, "noisy.csv", stamps, noise))
    np.testing.assert_allclose(ts.time - ts.time[0], stamps - stamps[0], rtol=0, atol=1e-9)
    (warning,) = warnings_of(ts.meta)
    assert "the readings cannot tell whether the rows were taken evenly" in warning
    assert "set [recording] sample_rate" in warning


@pytest.mark.parametrize("stamps", [
    lambda t: np.r_[t[:700], t[:800] + 3.0],  # the clock set back by 11 s
    lambda t: np.r_[t[:300], np.full(1200, t[300])],  # the clock stalled
])
def test_a_refusal_suggests_the_true_rate(stamps):
    t, a = truth()
    s = stamps(t)
    with pytest.raises(DataError) as info:
        time_base(s, np.resize(a, s.size))
    rate = float(re.search(r"about ([\d.]+) Hz", str(info.value)).group(1))
    assert rate == pytest.approx(RATE, rel=0.02), str(info.value)


def test_a_restarted_clock_keeps_the_longest_run(tmp_path):
    """Three runs appended, the clock starting again at each: the longest (800 rows) is kept whole,
    with a warning naming the others, not joined into one record nor refused."""
    t, a = truth()
    stamps = np.r_[t[:400], t[:300], t[:800]]
    theta = np.r_[a[:400], a[:300], a[:800]]
    ts = read_data(write(tmp_path, "runs.csv", stamps, theta))
    np.testing.assert_allclose(ts.time - ts.time[0], t[:800], rtol=0, atol=STAMP)
    np.testing.assert_array_equal(ts.theta, np.round(a[:800], 8))
    (warning,) = warnings_of(ts.meta)
    assert "the clock starts again 2 time(s)" in warning and "the file holds 3 runs" in warning
    assert "rows 701-1500" in warning and "rows 1-400, rows 401-700" in warning, warning


def test_one_backwards_row_is_dropped(tmp_path):
    t, a = truth()
    stamps = t.copy()
    stamps[500] = stamps[498]  # a phone export: one row's stamp two rows early
    ts = read_data(write(tmp_path, "back.csv", stamps, a))
    np.testing.assert_allclose(ts.time, np.delete(t, 500), rtol=0, atol=STAMP)
    np.testing.assert_array_equal(ts.theta, np.round(np.delete(a, 500), 8))
    assert "1 row(s) out of time order dropped (time going backwards for one row: the first stamped 9.96 s after " \
           "9.98 s)" in notes_of(ts.meta)
    assert not warnings_of(ts.meta)  # one row of 1500


def test_two_neighbours_in_reverse_order_are_swapped(tmp_path):
    t, a = truth()
    order = np.arange(N)
    order[[700, 701]] = [701, 700]
    ts = read_data(write(tmp_path, "swap.csv", t[order], a[order]))
    np.testing.assert_allclose(ts.time, t, rtol=0, atol=STAMP)
    np.testing.assert_array_equal(ts.theta, np.round(a, 8))
    assert any(n.startswith("1 pair(s) of neighbouring rows written in reverse time order swapped (the first at "
                            "t = 14 s)") for n in notes_of(ts.meta))


def test_a_duplicated_row_is_dropped(tmp_path):
    t, a = truth()
    ts = read_data(write(tmp_path, "dup.csv", np.insert(t, 700, t[700]), np.insert(a, 700, a[700])))
    np.testing.assert_allclose(ts.time, t, rtol=0, atol=STAMP)
    assert "1 row(s) repeating the previous row exactly (stamp and reading) dropped, the first at t = 14 s" \
        in notes_of(ts.meta)


def test_a_stalled_clock_cuts_the_record_keeping_the_longest_stretch(tmp_path):
    t, a = truth()
    stamps = t.copy()
    stamps[600:700] = stamps[600]  # the clock stops at 12 s for 2 s, then shows the time again
    ts = read_data(write(tmp_path, "stall.csv", stamps, a))
    np.testing.assert_allclose(ts.time, t[700:], rtol=0, atol=STAMP)  # 14 s to the end: 800 rows against 601
    np.testing.assert_array_equal(ts.theta, np.round(a[700:], 8))
    (warning,) = warnings_of(ts.meta)  # 700 rows of 1500 left out
    assert warning.startswith("the clock stalls (the stamp 12 s repeats over 100 rows): the record is cut there")
    assert "t = 14 to 29.98 s (800 of 1500 rows" in warning


def test_a_gap_is_kept_and_noted(tmp_path):
    t, a = truth()
    keep = (t < 10.0) | (t >= 11.0)  # one second missing
    ts = read_data(write(tmp_path, "gap.csv", t[keep], a[keep]))
    np.testing.assert_allclose(ts.time, t[keep], rtol=0, atol=STAMP)
    assert "1 gap(s) in the samples kept as gaps (the fit takes irregular times): the longest 1.02 s (51 intervals) " \
           "after t = 9.98 s" in notes_of(ts.meta)
    assert not warnings_of(ts.meta)


def test_jittered_frame_times_are_kept_and_their_jitter_measured(tmp_path):
    """Frame times of a phone camera, each off by up to +-20 % of the interval (uniform): kept as
    stamped.  A step is h + u2 - u1, triangular on +-0.4 h, whose median absolute deviation is
    0.4 h (1 - 1/sqrt 2): the jitter (1.4826 MAD) is 0.1737 h."""
    t, a = truth()
    stamps = t + np.random.default_rng(7).uniform(-0.2, 0.2, N) / RATE
    ts = read_data(write(tmp_path, "phone.csv", stamps, a))
    np.testing.assert_allclose(ts.time, stamps, rtol=0, atol=STAMP)
    assert any(n.startswith("the sampling interval jitters: 0.02") for n in notes_of(ts.meta))
    tb = time_base(stamps)
    assert tb.interval == pytest.approx(1 / RATE, rel=0.02)
    assert tb.jitter == pytest.approx(1.4826 * 0.4 * (1 - 1 / math.sqrt(2)) / RATE, rel=0.15)
    assert not tb.repairs[:-1] and tb.rows.size == N


def test_the_stage_result_says_which_rows_it_kept():
    t, a = truth()
    stamps = t.copy()
    stamps[[300, 301]] = stamps[[301, 300]]
    stamps[900] = stamps[898]
    tb = time_base(stamps, a)
    expected = np.delete(np.arange(N), 900)
    expected[[300, 301]] = [301, 300]
    np.testing.assert_array_equal(tb.rows, expected)
    np.testing.assert_array_equal(tb.time, stamps[expected])
    assert tb.changed == 3 and not tb.large and tb.rows_read == N
    assert tb.interval == pytest.approx(1 / RATE) and tb.jitter == pytest.approx(0.0, abs=1e-12)


# -- refusals ----------------------------------------------------------------------------------------
def _often_backwards():
    t, _ = truth()
    s = t.copy()
    s[25::50] -= 0.1  # 30 rows stamped too early
    return s


@pytest.mark.parametrize("stamps, message, rate", [
    (lambda t: _often_backwards(), r"time goes backwards at 30 of 1500 rows", True),
    (lambda t: np.r_[t[:700], t[:800] + 3.0], r"time goes backwards: 13.98 then 3.0 s, and neither dropping nor "
                                              r"swapping",
     True),
    (lambda t: np.full(N, 3.0), r"the clock stalls \(the stamp 3 s repeats over 1500 rows\)", False),
    (lambda t: np.r_[t[:300], np.full(1200, t[300])], r"the stamp 6 s repeats over 1200 rows", True),
    (lambda t: t * 1e-300, r"the sampling interval is 2e-302 s", False),
    (lambda t: t * 1e300, r"the sampling interval is 2e\+298 s", False),
    (lambda t: bursts(t) + 0.01 * bursts(t)**2, r"time stamps repeat in bursts \(~10 rows\) but do not follow a straight", True),
])
def test_what_cannot_be_repaired_is_refused_in_one_line_naming_sample_rate(tmp_path, stamps, message, rate):
    t, a = truth()
    stamps = stamps(t)
    path = write(tmp_path, "bad.csv", stamps, a[:stamps.size] if stamps.size <= N else np.resize(a, stamps.size))
    with pytest.raises(DataError) as info:
        read_data(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(str(path) + ":"), msg
    assert re.search(message, msg), msg
    assert "set [recording] sample_rate (or --sample-rate) to the logger's rate" in msg
    assert ("Hz, measured from the stamps)" in msg) == rate, msg


def test_sample_rate_reads_what_the_stage_refuses(tmp_path):
    t, a = truth()
    path = write(tmp_path, "bad.csv", _often_backwards(), a)
    ts = read_data(path, recording={"sample_rate": "50 Hz"})
    np.testing.assert_allclose(ts.time, t, rtol=1e-12)
    assert not warnings_of(ts.meta)


# -- through the command line --------------------------------------------------------------------------
@pytest.mark.parametrize("fault, said", [
    ("bursts", "warning: time stamps repeat in bursts of ~10 rows"),
    ("backwards", "note: 1 row(s) out of time order dropped"),
])
def test_init_and_fit_recover_the_period_instead_of_refusing(tmp_path, fault, said):
    t, a = truth()
    stamps = bursts(t) if fault == "bursts" else t.copy()
    if fault == "backwards":
        stamps[500] = stamps[498]
    data = write(tmp_path, f"{fault}.csv", stamps, a + 2e-4 * np.random.default_rng(3).standard_normal(N))
    scene, out = tmp_path / "scene.toml", tmp_path / "fit.h5"
    runner = CliRunner()
    r = runner.invoke(cli, ["init", str(data), "--pendulum", "--out", str(scene)])
    assert r.exit_code == 0, r.output
    assert said in r.output, r.output
    r = runner.invoke(cli, ["fit", str(data), "--scene", str(scene), "--method", "leastsq", "--out", str(out),
                            "--quiet"])
    assert r.exit_code == 0, r.output
    assert said in r.output, r.output
    p = json.loads(runner.invoke(cli, ["summary", str(out), "--json"]).output)["parameters"]
    omega0 = p["oscillator.omega0"]["estimate"]
    # the sine's period 1.3 s; omega0 of the fitted pendulum is sqrt(omega1^2 + (C/2)^2) with C/2 =
    # 0.05 1/s (0.005 % of omega0) and a period longer by theta^2/16 < 0.07 % at 0.1 rad
    assert 2 * math.pi / omega0 == pytest.approx(PERIOD, rel=0.005)


def test_a_log_written_on_change_that_waited_at_the_end_is_read_as_stamped(tmp_path):
    """A logger that writes a row only when the angle changes (an encoder): rows dense where the
    swing is fast, sparse at its turning points, and one last row half a minute later, when the
    pendulum had stopped.  The rows are read as stamped, up to the wait (a step forward longer
    than all the rest of the record ends it).  (The wait no longer counts in the mean step that
    stamps "in clusters" are measured against: on a real encoder log of this kind it had made
    two thirds of the steps look short, and the stamps were refused as bursts off a line.)"""
    t = np.arange(0.0, 30.0, 2e-5)
    theta = 0.5 * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / PERIOD)
    counts = np.round(theta / (2 * math.pi / 4000))  # a 4000-count encoder, its changes stamped to 20 us
    rows = np.r_[0, np.flatnonzero(np.diff(counts)) + 1]
    stamps = np.r_[t[rows], t[rows[-1]] + 30.7]
    angles = np.r_[counts[rows], counts[rows[-1]]] * 2 * math.pi / 4000
    series = read_data(write(tmp_path, "on_change.csv", stamps, angles))
    np.testing.assert_allclose(series.time, stamps[:-1], rtol=0, atol=1e-9)
