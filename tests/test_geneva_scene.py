"""Geneva scenes: every refused input names the file, key and value."""

from __future__ import annotations

import pytest

from escfit.core.errors import SceneError, SolverError, UnitError
from escfit.geneva import simulate
from escfit.core.scene import load_scene

GOOD = {
    "slots": "4",
    "driver_inertia": '"3e-6 lbf*inch*s^2"',
    "follower_inertia": '"50e-6 lbf*inch*s^2"',
    "torque": '"0.08 lbf*inch"',
    "mu": "0.20",
    "compat": '"none"',
}


def text(run='duration = "0.2 s"', extra_top="", **changes):
    body = {**GOOD, **changes}
    lines = "\n".join(f"{k} = {v}" for k, v in body.items() if v is not None)
    return f'model = "geneva"\n{extra_top}\n[geneva]\n{lines}\n[run]\n{run}\n'


def refuse(exc=SceneError, **kw):
    with pytest.raises(exc) as info:
        load_scene("bad.toml", text=text(**kw))
    return str(info.value)


def test_good_scene_reads_si_values():
    sc = load_scene("good.toml", text=text())
    vals = sc.params.values()
    assert vals["geneva.driver_inertia"] == pytest.approx(3e-6 * 0.1129848290276167)
    assert vals["geneva.torque"] == pytest.approx(0.08 * 0.1129848290276167)
    assert sc.slots == 4 and sc.compat == "none" and sc.duration == pytest.approx(0.2)
    assert sc.model == "geneva" and sc.text.startswith('model = "geneva"') and sc.where == "good.toml"


def test_bare_numbers_are_si_and_free_parameters_are_read():
    sc = load_scene("si.toml", text=text(driver_inertia="3.4e-7", torque='{ value = 0.009, vary = true, min = 0.001 }',
                                         mu='{ value = 0.2, vary = true, max = 1.0, prior = "uniform(0, 1)" }'))
    assert sc.params["geneva.driver_inertia"].value == pytest.approx(3.4e-7)
    assert [p.name for p in sc.params.free()] == ["geneva.torque", "geneva.mu"]


@pytest.mark.parametrize("value", ["5", "2", "4.0", '"4"', "true"])
def test_slots_must_be_3_4_or_6(value):
    msg = refuse(slots=value)
    assert "bad.toml [geneva].slots" in msg and "3, 4 or 6" in msg


def test_non_positive_inertia_refused():
    msg = refuse(driver_inertia='"-3e-6 lbf*inch*s^2"')
    assert "[geneva].driver_inertia" in msg and "-3e-6 lbf*inch*s^2" in msg
    msg = refuse(follower_inertia="0")
    assert "[geneva].follower_inertia" in msg and "0" in msg


def test_zero_torque_and_negative_friction_refused():
    msg = refuse(torque='"0 lbf*inch"')
    assert "[geneva].torque" in msg and "0 lbf*inch" in msg
    msg = refuse(mu="-0.1")
    assert "[geneva].mu" in msg and "-0.1" in msg


def test_wrong_units_refused():
    msg = refuse(UnitError, torque='"0.08 lbf"')
    assert "[geneva].torque" in msg and "0.08 lbf" in msg and "torque" in msg
    msg = refuse(UnitError, driver_inertia='"3e-6 kg"')
    assert "[geneva].driver_inertia" in msg and "3e-6 kg" in msg
    msg = refuse(UnitError, run='duration = "0.2 m"')
    assert "[run].duration" in msg and "0.2 m" in msg


def test_unknown_and_missing_keys_refused():
    msg = refuse(spring="1")
    assert "bad.toml [geneva]" in msg and "spring" in msg
    msg = refuse(mu=None)
    assert "missing" in msg and "mu" in msg
    msg = refuse(run="steps = 10")
    assert "[run]" in msg and "steps" in msg
    msg = refuse(extra_top="solver = 'rk4'")
    assert "solver" in msg


def test_unknown_compat_and_bad_duration_refused():
    msg = refuse(compat='"meyer"')
    assert "[geneva].compat" in msg and "'meyer'" in msg and "meyer1973" in msg
    msg = refuse(run='duration = "-1 s"')
    assert "[run].duration" in msg and "-1 s" in msg
    msg = refuse(run='duration = "1 ms"\nsample_interval = "2 ms"')
    assert "sample_interval" in msg and "2 ms" in msg


def test_unknown_solver_and_option_refused_before_work():
    sc = load_scene("good.toml", text=text())
    with pytest.raises(SolverError, match="unknown solver 'euler'"):
        simulate(sc, "euler")
    with pytest.raises(SolverError, match=r"unknown option\(s\) \['dt'\] for solver 'dop853'"):
        simulate(sc, "dop853", dt=1e-3)
