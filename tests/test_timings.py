"""Phase clocks: nested phases are counted once, repeated phases add up."""

import time

from escfit.core import timings


def test_nested_phase_is_charged_to_the_inner_one_only():
    timings.reset()
    with timings.phase("outer"):
        time.sleep(0.05)
        with timings.phase("inner"):
            time.sleep(0.1)
    with timings.phase("inner"):
        time.sleep(0.05)
    got = timings.phases()
    timings.reset()
    assert list(got) == ["outer", "inner"]
    # sleeping costs wall time, not CPU: outer holds its own 0.05 s, inner its two sleeps
    assert 0.045 < got["outer"][0] < 0.09
    assert 0.145 < got["inner"][0] < 0.25
    assert got["outer"][1] < 0.04 and got["inner"][1] < 0.04


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
