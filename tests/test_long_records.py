"""Long records: the fast paths give what the strict reader and the numpy reference give."""

import numpy as np
import pytest

from escfit.analysis.recordings.compiled import kinked_design, kinked_lstsq
from escfit.analysis.recordings.extrema import kinked_vertex
from escfit.analysis.recordings.episodes import _window_range
from escfit.analysis.recordings.timeseries import read_timeseries
from escfit.core.csvtable import read_numbers, read_table
from escfit.core.errors import DataError


def _strict(path):
    t = read_table(path)
    return np.array(t.floats(t.header[0])), np.array(t.floats(t.header[1])), t.meta


def test_plain_numbers_read_as_the_strict_reader_reads_them(tmp_path):
    rng = np.random.default_rng(1)
    t = np.arange(500) / 300.0
    x = 0.2 * np.sin(9 * t) + 1e-3 * rng.standard_normal(t.size)
    rows = "".join(f"{a:.6f}, {b:.9e}\r\n" if i % 3 else f"{float(a)!r},{float(b)!r}\r\n"
                   for i, (a, b) in enumerate(zip(t, x)))
    path = tmp_path / "r.csv"
    path.write_text(f"# rate_hz: 300\n# a note\ntime_s,theta_rad\r\n{rows}\n", newline="")
    fast = read_numbers(path)
    assert fast is not None and fast.header == ["time_s", "theta_rad"] and fast.meta == {"rate_hz": "300"}
    tt, xx, meta = _strict(path)
    assert np.array_equal(fast.column("time_s"), tt) and np.array_equal(fast.column("theta_rad"), xx)
    series = read_timeseries(path)
    assert np.array_equal(series.time, tt) and np.array_equal(series.theta, xx)


@pytest.mark.parametrize("body", ["0.0,1\n0.1,x\n", "0.0,1\n0.1,2,3\n", "0.0,1\n# late comment\n0.1,2\n",
                                  '0.0,"1"\n', "0.0,1\n0.1,\n", "0.0,nan\n"])
def test_anything_but_plain_numbers_goes_to_the_strict_reader(tmp_path, body):
    path = tmp_path / "r.csv"
    path.write_text("time_s,theta_rad\n" + body)
    assert read_numbers(path) is None


def test_a_problem_in_a_long_record_is_named_by_its_line(tmp_path):
    t = np.arange(100) * 0.01
    rows = [f"{a:.6f},{np.sin(a):.6f}" for a in t]
    rows[57] = f"{t[57]:.6f},0.5x"
    path = tmp_path / "r.csv"
    path.write_text("time_s,theta_rad\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"r\.csv:59"):
        read_timeseries(path)


def test_window_ranges_equal_a_pass_over_each_window():
    rng = np.random.default_rng(2)
    x = rng.standard_normal(3000)
    lo = np.sort(rng.integers(0, 3000, 400))
    hi = np.minimum(lo + rng.integers(-5, 200, 400), 3000)
    want = np.array([np.ptp(x[a:b]) if b > a else 0.0 for a, b in zip(lo, hi)])
    assert np.array_equal(_window_range(x, lo, hi), want)


def test_window_medians_equal_a_median_per_window():
    """The running medians of the push and free-law tests, one strided call per window width,
    give bit for bit the median of each window (ends clipped, an empty window nan)."""
    from escfit.analysis.free_law import window_medians

    rng = np.random.default_rng(3)
    x = rng.standard_normal(500)
    j = np.arange(-10, 520)
    for lo, hi in ((j - 7, j), (j + 2, j + 2 + 7), (np.maximum(0, j - 7), np.maximum(1, j - 1))):
        want = np.array([np.median(x[max(0, a):max(0, b)]) if min(b, 500) > max(a, 0) else np.nan
                         for a, b in zip(lo, hi)])
        assert np.array_equal(window_medians(x, lo, hi), want, equal_nan=True)


@pytest.mark.parametrize("uc, degs, shared", [(0.05, (4, 4), False), (-0.6, (4, 3), False), (0.3, (4, 4), True),
                                              (0.0, (0, 4), False), (0.7, (6, 2), False)])
def test_compiled_least_squares_agree_with_numpy(uc, degs, shared):
    rng = np.random.default_rng(3)
    u = np.sort(rng.uniform(-1.0, 1.0, 60))
    x = 0.3 - 2.0 * (u - 0.05) ** 2 + 0.4 * np.where(u < 0.05, (u - 0.05) ** 3, 0.0) + 1e-3 * rng.standard_normal(60)
    a = kinked_design(u, uc, degs[0], degs[1], shared)
    coef, *_ = np.linalg.lstsq(a, x, rcond=None)
    r = a @ coef - x
    rss, value, solved = kinked_lstsq(u, x, uc, degs[0], degs[1], shared)
    assert solved
    assert rss == pytest.approx(float(r @ r), rel=1e-10)
    assert value == pytest.approx(coef[0], rel=1e-11, abs=1e-13)


def test_the_vertex_of_a_kinked_parabola_is_found():
    # curvatures -2 and -3 either side of a vertex at u = 0.1, value 0.25: exact samples
    u = np.linspace(-1.0, 1.0, 41)
    s = u - 0.1
    x = 0.25 - np.where(s < 0, 2.0, 3.0) * s**2
    uc, value = kinked_vertex(u, x, 4)
    assert uc == pytest.approx(0.1, abs=1e-6) and value == pytest.approx(0.25, abs=1e-9)


@pytest.mark.parametrize("end", ["\r\r\n", "\r"])
def test_a_byte_order_mark_and_other_line_ends_read_as_the_strict_reader_reads_them(tmp_path, end):
    t = np.arange(40) * 0.01
    text = end.join(["# release_s: 0.05", "time_s,theta_deg"] + [f"{a:.2f},{10 * np.cos(9 * a):.4f}" for a in t]) + end
    path = tmp_path / "r.csv"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    series = read_timeseries(path)
    tt, xx, meta = _strict(path)
    assert np.array_equal(series.time, tt) and np.array_equal(series.theta, np.radians(1.0) * xx)
    assert series.release_s == 0.05
