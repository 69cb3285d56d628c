"""Every refusal of a bad scene names the file, key and value."""

from __future__ import annotations

import numpy as np
import pytest

from escfit import SceneError, UnitError, load_scene

from .conftest import balance_toml

IMPULSE = '[[effects.escapement]]\nkind = "impulse"\nfrom = {lo}\nto = {hi}\nX = 10.0\n'


@pytest.mark.parametrize("text, fragments", [
    (balance_toml() + "[effects.viscous]\nC = 1\nD = 2\n", ["bad.toml", "effects.viscous", "'D'"]),
    (balance_toml().replace("theta0 = 1.0", 'theta0 = "3 m"'), ["theta0", "'3 m'", "[length]", "angle"]),
    (balance_toml().replace("omega0 = 10.0", 'inertia = "-1e-9 kg*m^2"\nstiffness = "1e-6 N*m"'), ["inertia", "-1e-9"]),
    (balance_toml(effects=IMPULSE.format(lo=0.3, hi=0.3)), ["escapement 1", "'from'", "below"]),
    (balance_toml(effects=IMPULSE.format(lo=0.0, hi=0.5) + IMPULSE.format(lo=0.4, hi=0.9)), ["overlap", "1", "2"]),
    (balance_toml(effects="[effects.magnet]\nB = 1\n"), ["unknown effect", "magnet"]),
    (balance_toml(effects="[effects.viscous]\nC = -0.5\n"), ["effects.viscous", "-0.5", "physical range"]),
    (balance_toml(effects='[effects.coulomb]\nR = "1 N*m"\n'), ["coulomb", "'1 N*m'", "angular acceleration"]),
    (balance_toml(effects='[effects.coulomb]\ntorque = "1e-9 N*m"\n'), ["torque", "needs [oscillator] inertia"]),
    (balance_toml(effects="[effects.viscous]\nC = { value = 9, min = 0, max = 5, vary = true }\n"), ["viscous", "outside"]),
    # a negative frequency: the physical range is named, not a backwards interval of the clipped bounds
    (balance_toml().replace("omega0 = 10.0", "omega0 = { value = -8.0, vary = true, min = -11, max = -6.4 }"),
     ["omega0", "-8.0", "physical range [1e-09,"]),
    (balance_toml().replace("omega0 = 10.0", "omega0 = { value = 8.0, vary = true, min = -11, max = -6.4 }"),
     ["omega0", "min -11 and max -6.4 lie outside the physical range [1e-09,"]),
    (balance_toml(effects='[effects.viscous]\nC = { value = 1, vary = "yes" }\n'), ["vary", "'yes'"]),
    (balance_toml(switching="phase", effects="[effects.hairspring]\nangles = [0.5]\nomega0 = [9.0, 11.0]\n")
     .replace("omega0 = 10.0\n", "", 1), ["hairspring", "switching = 'angle'"]),
    (balance_toml(effects="[effects.hairspring]\nangles = [0.5]\nomega0 = [9.0, 11.0]\n"), ["omega0 per piece"]),
    (balance_toml(switching="phase", effects=IMPULSE.format(lo=-2.0, hi=0.5)), ["phase offsets", "-2.0"]),
    (balance_toml(theta0=2.0, effects="[effects.banking]\nangle = 1.5\n"), ["theta0", "banking angle"]),
    (balance_toml(switching="sideways"), ["switching", "'sideways'"]),
    (balance_toml() + "[run]\n", ["not valid TOML"]),
    (balance_toml().replace("swings = 20", "swings = 0"), ["swings", "0"]),
    ('model = "pendulum"\n', ["unknown model", "'pendulum'"]),
    ("[oscillator]\nomega0 = 1\n", ["missing key 'model'"]),
    (balance_toml(effects='[[effects.escapement]]\nkind = "unlock"\nfrom = -1\nto = -0.5\neps = 0.3\n'),
     ["eps", "exactly one impulse window"]),
    (balance_toml(effects="[effects.viscous_drift]\nthresholds = [0.1]\nrates = [0.01, 0]\n"), ["viscous_drift", "needs"]),
    # text pint would evaluate as arithmetic (a hang), numbers the solvers cannot hold, values of the wrong type
    (balance_toml(theta0="9**9**9 rad"), ["theta0", "'9**9**9 rad'", "not a number and a unit"]),
    (balance_toml(effects='[effects.coulomb]\nR = "1 rad/s**999999"\n'), ["[effects.coulomb].R", "not a number and a unit"]),
    (balance_toml(omega0=1e-300), ["omega0", "1e-300", "physical range"]),
    (balance_toml(omega0=1e155), ["omega0", "1e+155", "physical range"]),
    (balance_toml(effects='[[effects.escapement]]\nkind = "impulse"\nfrom = -0.3\nto = 0.3\nX = 10\nswings = [1, 2]\n'),
     ["escapement 1].swings", "[1, 2]"]),
    ('model = [1, 2]\n', ["unknown model", "[1, 2]"]),
])
def test_bad_scene_is_refused_with_a_clear_message(text, fragments):
    with pytest.raises(SceneError) as info:
        load_scene("bad.toml", text=text)
    msg = str(info.value)
    assert msg.startswith("bad.toml")
    for frag in fragments:
        assert frag in msg, (frag, msg)


def test_unit_error_is_a_scene_error_and_a_value_error():
    with pytest.raises(ValueError):
        load_scene("bad.toml", text=balance_toml().replace("theta0 = 1.0", 'theta0 = "1 furlong"'))
    assert issubclass(UnitError, SceneError)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(SceneError, match="nope.toml: scene file not found"):
        load_scene(tmp_path / "nope.toml")


def test_units_are_converted():
    text = balance_toml(effects='[effects.viscous]\nc = "8.41e-11 N*m*s/rad"\n').replace(
        "omega0 = 10.0", 'inertia = "1.2e-9 kg*m^2"\nstiffness = "1.184352528e-6 N*m/rad"'
    ).replace("theta0 = 1.0", 'theta0 = "300 deg"')
    scene = load_scene("ok.toml", text=text)
    assert scene.params["viscous.C"].value == pytest.approx(8.41e-11 / 1.2e-9, rel=1e-12)
    assert scene.params["oscillator.omega0"].value == pytest.approx(31.4159265, rel=1e-8)
    assert scene.params["oscillator.theta0"].value == pytest.approx(5.2359877559, rel=1e-10)


def test_a_scene_without_theta0_simulates_nothing_and_fits_only_sampled_recordings():
    """theta0 may be left out (a sampled recording supplies the release); elsewhere it is refused clearly."""
    from escfit.balance import solve
    from escfit.core.errors import FitError, SolverError
    from escfit.inference import make_problem
    from escfit.analysis.recordings import UnitCurve

    scene = load_scene("bad.toml", text=balance_toml().replace("theta0 = 1.0\n", ""))
    with pytest.raises(SolverError, match="theta0 is not given"):
        solve(scene)
    curve = UnitCurve(np.arange(3), np.array([1.0, 0.9, 0.8]), "amplitude", unit=np.array(["", "", ""]))
    with pytest.raises(FitError, match="leaves theta0 out"):
        make_problem(scene, curve)



def test_a_byte_order_mark_is_dropped_and_latin1_is_named(tmp_path):
    marked = tmp_path / "marked.toml"
    marked.write_bytes(b"\xef\xbb\xbf" + balance_toml(theta0="300 deg").encode())
    assert load_scene(marked).params["oscillator.theta0"].value == pytest.approx(np.radians(300))
    latin = tmp_path / "latin.toml"
    latin.write_bytes(('title = "Andr\u00e9"\n' + balance_toml()).encode("latin-1"))
    with pytest.raises(SceneError) as info:
        load_scene(latin)
    assert str(info.value) == (f"{latin}:1: not UTF-8 text: byte 0xe9 on line 1 (in Latin-1 / Windows-1252 that is "
                               "'é'); save the file as UTF-8")


def test_unit_text_is_never_evaluated_as_arithmetic_but_fractions_read():
    import signal

    from escfit.core.units import UnsafeUnitText, to_canonical, ureg

    def ring(*_):
        raise TimeoutError("pint evaluated arithmetic")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(10)
    try:
        for text in ("9**9**9 rad", "rad**999999", "2**3 rad"):
            for parse in (ureg.Quantity, ureg, ureg.parse_units_as_container, ureg.parse_units,
                          lambda s: ureg.Quantity(1.0, "rad").to(s)):
                with pytest.raises(UnsafeUnitText):
                    parse(text)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert to_canonical("pi/2 rad", "angle", "w") == pytest.approx(np.pi / 2, rel=1e-15)
    assert to_canonical("1/4 turn", "angle", "w") == pytest.approx(np.pi / 2, rel=1e-15)
    assert to_canonical("300 deg", "angle", "w") == pytest.approx(np.radians(300), rel=1e-15)


def test_a_misspelt_observation_model_key_is_suggested():
    """``modle = "waveform"`` left the default model, whose list of keys lacked ``model``."""
    from escfit.balance.observation import observation_from_table

    with pytest.raises(SceneError) as info:
        observation_from_table({"modle": "waveform"}, "s.toml", "amplitude")
    assert "'modle'" in str(info.value) and "did you mean 'model'" in str(info.value)
