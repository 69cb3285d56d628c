"""Phase clocks: nested phases are counted once, repeated phases add up."""

import pytest

from escfit.core import timings


class _Clocks:
    """Hand-advanced wall and CPU clocks, so the bookkeeping is checked exactly."""

    def __init__(self):
        self.wall = 100.0
        self.cpu = 7.0

    def spend(self, wall, cpu):
        self.wall += wall
        self.cpu += cpu


def test_nested_phase_is_charged_to_the_inner_one_only(monkeypatch):
    clocks = _Clocks()
    monkeypatch.setattr(timings.time, "perf_counter", lambda: clocks.wall)
    monkeypatch.setattr(timings.time, "process_time", lambda: clocks.cpu)
    timings.reset()
    with timings.phase("outer"):
        clocks.spend(0.05, 0.01)
        with timings.phase("inner"):
            clocks.spend(0.1, 0.08)
        clocks.spend(0.02, 0.02)
    with timings.phase("inner"):
        clocks.spend(0.05, 0.03)
    got = timings.phases()
    timings.reset()
    assert list(got) == ["outer", "inner"]
    # outer keeps only what it spent outside inner; inner adds its two stretches
    assert got["outer"] == pytest.approx((0.07, 0.03), abs=1e-12)
    assert got["inner"] == pytest.approx((0.15, 0.11), abs=1e-12)


def test_process_clock_and_table():
    wall, cpu = timings.since_process_start()
    assert wall > 0 and cpu > 0
    timings.reset()
    with timings.phase("work"):
        sum(i * i for i in range(200000))
    text = timings.table((wall, cpu))
    timings.reset()
    lines = text.splitlines()
    assert lines[0].split() == ["phase", "wall", "s", "CPU", "s"]
    assert [ln.split()[0] for ln in lines[1:]] == ["start-up", "work", "other", "total"]
    total_wall = float(lines[-1].split()[-2])
    assert total_wall >= wall
