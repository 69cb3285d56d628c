"""What every balance effect and every solver must honour, checked over the registries.

Like scikit-learn's ``check_estimator``: the cases are generated from
:data:`escfit.balance.effects.EFFECTS` and :data:`escfit.balance.solvers.SOLVERS`, so a new
effect (with its ``example``) or a new solver gets every check without an edit here.  For
every effect and every solver that claims the effect's example scene:

- **defaults mean absence**: the record with the effect's slots at their defaults runs as the
  scene without the effect;
- **batch equals single**: a solver's batch path and its sampler give each set what the
  one-set solve gives;
- **agreement**: its turning points agree with an independent scipy integration
  (``tests/conformance_reference.py``);

for every solver that does not claim it, the refusal names a solver that can, and that solver
runs it; and every smooth effect's ``torque`` has derivatives that match finite differences
and is one of the terms the integrating solvers add up.
"""

from __future__ import annotations

import functools
import importlib
import math

import numpy as np
import pytest

import escfit
from escfit.balance import acceleration as acceleration_module
from escfit.balance.batch import solve_batch
from escfit.balance.effects import EFFECTS
from escfit.balance.kernel_records import SLOTS
from escfit.balance.solvers import SOLVERS, capability, solve_system
from escfit.balance.system import System
from escfit.balance.waveform import sample_state
from escfit.core.errors import SolverError

from .conformance_reference import reference_turns, smooth_torques

W0, A0, SWINGS = 10.0, 1.0, 12
#: solver options for the agreement checks (rk4: 4000 steps per period of the stiffest piece)
OPTIONS = {"dop853": {"rtol": 1e-12}, "rk4": {"h": 2.0 * math.pi / (1.2 * W0) / 4000}, "ivp": {"rtol": 1e-12,
                                                                                                  "atol": 1e-14}}
TOLERANCE = {"exact": 1e-9, "dop853": 1e-9, "ivp": 1e-8, "rk4": 1e-8}  # of the release angle


def example_tables(key: str) -> dict[str, str]:
    cls = EFFECTS[key]
    assert hasattr(cls, "example"), f"effect {key!r} declares no example(w0, a0): it cannot join the conformance suite"
    return cls.example(W0, A0)


def scene_text(tables: dict[str, str]) -> str:
    oscillator = tables.get("oscillator", f"omega0 = {W0!r}\ntheta0 = {A0!r}\n")
    body = ""
    for key, text in tables.items():
        if key == "oscillator":
            continue
        body += text if text.startswith("[[") else f"[effects.{key}]\n{text}"
    return f'model = "balance"\nswitching = "angle"\n[oscillator]\n{oscillator}[run]\nswings = {SWINGS}\n{body}'


def load(tables: dict[str, str]):
    return escfit.load_scene("conformance.toml", text=scene_text(tables))


def claims(solver: str, scene) -> bool:
    try:
        capability(scene.build(), solver)
    except SolverError:
        return False
    return True


CASES = [(e, s) for e in EFFECTS for s in SOLVERS]


def claimed(effect: str, solver: str):
    scene = load(example_tables(effect))
    if not claims(solver, scene):
        pytest.skip(f"{solver} does not claim {effect} (refusal checked separately)")
    return scene


# -- defaults mean absence -----------------------------------------------------------------

@pytest.mark.parametrize("effect, solver", CASES)
def test_defaults_mean_absence(effect, solver):
    scene = claimed(effect, solver)
    own = [s.name for s in SLOTS if s.name in {x.name for x in getattr(EFFECTS[effect], "SLOTS", ())}]
    if not own:
        pytest.skip(f"{effect} owns no record slot (it fills the oscillator's)")
    without = load({k: v for k, v in example_tables(effect).items() if k != effect})
    k = scene.build().k.copy()
    for slot in SLOTS:
        if slot.name in own:
            k[slot.name] = slot.default
    reset = solve_system(System(k, scene.structure), SWINGS, solver, **OPTIONS.get(solver, {}))
    plain = solve_system(without.build(), SWINGS, solver, **OPTIONS.get(solver, {}))
    assert reset.status == plain.status
    np.testing.assert_array_equal(reset.theta_turn, plain.theta_turn)
    np.testing.assert_array_equal(reset.time, plain.time)


# -- batch equals single -------------------------------------------------------------------

def _spread(scene, n=5, seed=0):
    rng = np.random.default_rng(seed)
    free = [name for name, value in scene.params.values().items() if value > 0 and name != "oscillator.theta0"]
    return [scene.build({name: scene.params[name].value * rng.uniform(0.8, 1.2) for name in free})
            for _ in range(n)]


@pytest.mark.parametrize("effect, solver", CASES)
def test_batch_equals_single(effect, solver):
    scene = claimed(effect, solver)
    spec = SOLVERS[solver]
    if not spec.batch and spec.sampler is None:
        pytest.skip(f"{solver} has no batch path")
    systems = _spread(scene)
    if spec.batch:
        batch = solve_batch(systems, SWINGS)
        for i, one_set in enumerate(systems):
            one = solve_system(one_set, SWINGS, solver)
            np.testing.assert_array_equal(batch[i].theta_turn, one.theta_turn)
            np.testing.assert_array_equal(batch[i].time, one.time)
            assert batch[i].status == one.status and batch[i].final == one.final
    if spec.sampler is not None:
        times = np.linspace(0.0, 3.0 * math.pi / W0, 41)
        values, summary = spec.sampler(System.stack(systems), times, np.zeros(len(systems)))
        for i, one_set in enumerate(systems):
            theta, _, _ = sample_state(one_set, times, solver)
            assert summary["usable"][i] == 1
            np.testing.assert_array_equal(values[i], theta)


# -- agreement with an independent integration ---------------------------------------------

@functools.lru_cache(maxsize=None)
def _reference(effect: str) -> tuple[np.ndarray, str]:
    return reference_turns(load(example_tables(effect)).build().k[0], SWINGS)


@pytest.mark.parametrize("effect, solver", CASES)
def test_agrees_with_an_independent_integration(effect, solver):
    scene = claimed(effect, solver)
    traj = solve_system(scene.build(), SWINGS, solver, **OPTIONS.get(solver, {}))
    turns, status = _reference(effect)
    assert traj.status == status, (traj.status, status, traj.theta_turn, turns)
    assert traj.theta_turn.size == turns.size
    assert turns.size >= 3, "the example should swing a few times"
    np.testing.assert_allclose(traj.theta_turn, turns, rtol=0.0, atol=TOLERANCE[solver] * A0)


# -- refusals name a solver that can -------------------------------------------------------

@pytest.mark.parametrize("effect, solver", CASES)
def test_refusal_names_a_solver_that_can(effect, solver):
    scene = load(example_tables(effect))
    if claims(solver, scene):
        pytest.skip(f"{solver} claims {effect}")
    with pytest.raises(SolverError) as info:
        capability(scene.build(), solver)
    named = [name for name in SOLVERS if f"'{name}'" in str(info.value).split("use solver", 1)[-1]]
    assert "use solver" in str(info.value) and named, str(info.value)
    for name in named:
        traj = solve_system(scene.build(), SWINGS, name, **OPTIONS.get(name, {}))
        assert traj.theta_turn.size >= 1


# -- smooth torques ------------------------------------------------------------------------

SMOOTH = [key for key, cls in EFFECTS.items() if hasattr(importlib.import_module(cls.__module__), "torque")]


@pytest.mark.parametrize("effect", SMOOTH)
def test_torque_derivatives_match_finite_differences(effect):
    torque = importlib.import_module(EFFECTS[effect].__module__).torque
    k = load(example_tables(effect)).build().k[0]
    rng = np.random.default_rng(7)
    for _ in range(20):
        x, v = rng.uniform(-1.5, 1.5) * A0, rng.uniform(-1.5, 1.5) * A0 * W0
        a, a_x, a_v = torque(x, v, k)
        hx, hv = 1e-6 * A0, 1e-6 * A0 * W0
        fd_x = (torque(x + hx, v, k)[0] - torque(x - hx, v, k)[0]) / (2 * hx)
        fd_v = (torque(x, v + hv, k)[0] - torque(x, v - hv, k)[0]) / (2 * hv)
        scale = abs(a) + 1e-12
        assert a_x == pytest.approx(fd_x, rel=1e-6, abs=1e-6 * scale / A0), (effect, x, v)
        assert a_v == pytest.approx(fd_v, rel=1e-6, abs=1e-6 * scale / (A0 * W0)), (effect, x, v)


def test_every_smooth_torque_is_added_up():
    """The integrators' smooth term is the sum of every registered effect's torque, derivatives too."""
    tables = {}
    for effect in SMOOTH:
        tables.update(example_tables(effect))
    k = load(tables).build().k[0]
    for x, v in ((0.3, -2.0), (-0.9, 5.0), (1.2, 0.7)):
        total = np.sum([f(x, v, k) for f in smooth_torques()], axis=0)
        assert all(f(x, v, k)[0] != 0.0 for f in smooth_torques())  # each example's torque acts here
        np.testing.assert_allclose(acceleration_module.smooth_terms(x, v, k), total, rtol=1e-15, atol=0.0)


# -- each dissipative effect's part of the decrement ---------------------------------------

LOSSES = [key for key, cls in EFFECTS.items() if getattr(cls, "LOSS", None) is not None]


def test_every_effect_declares_its_coordinates_and_a_random_instance():
    """What the scene reader (a mass on a spring takes only the effects whose ``coordinates`` hold
    ``"linear"``) and the random-scene comparison (``benchmarks/random_scenes.py``) ask of an effect."""
    from escfit.balance.synthetic.random_scenes import ALL_EFFECTS, Scale

    rng = np.random.default_rng(0)
    for key, cls in EFFECTS.items():
        assert cls.coordinates <= {"angle", "linear"} and "angle" in cls.coordinates, key
        assert key in ALL_EFFECTS, f"{key} is not drawn by the random-scene comparison"
        text = cls.random(rng, Scale(W0, A0))
        assert f"effects.{key}]" in text, (key, text)


def test_every_effect_says_whether_it_takes_a_part_of_the_decrement():
    """An effect either declares its loss (``LOSS`` and ``decrement``) or is one that dissipates
    nothing of its own or has no single coefficient (springs, pins, windows, the drift of C)."""
    from escfit.balance.decrement import LAWS

    for key, cls in EFFECTS.items():
        loss = getattr(cls, "LOSS", None)
        if loss is None:
            assert not hasattr(cls, "decrement"), key
            continue
        assert callable(getattr(cls, "decrement", None)), f"{key} declares LOSS but no decrement(value, swing)"
        assert loss.parameter.startswith(f"{key}.") and key in LAWS and "angle" in cls.coordinates
    colours = [EFFECTS[k].LOSS.colour for k in LOSSES]
    symbols = [EFFECTS[k].LOSS.symbol for k in LOSSES]
    assert len(set(colours)) == len(colours) and len(set(symbols)) == len(symbols)


@pytest.mark.parametrize("effect", LOSSES)
@pytest.mark.parametrize("restoring", ["spring", "pendulum"])
def test_the_declared_part_is_what_a_half_swing_loses(effect, restoring):
    """The effect alone, at a tenth of its example's coefficient, on a spring and on a pendulum
    released at 1 rad: the amplitude the compiled DOP853 integration loses over each of the first
    half swings against ``law_parts`` at that half swing's mean amplitude (first order in the
    damping: within 2 % of the loss)."""
    from escfit.balance.decrement import law_parts

    loss = EFFECTS[effect].LOSS
    tables = {effect: example_tables(effect)[effect]}
    osc = f"omega0 = {W0!r}\ntheta0 = {A0!r}\n" + ('restoring = "pendulum"\n' if restoring == "pendulum" else "")
    scene = load({"oscillator": osc, **tables})
    value = 0.1 * scene.params[loss.parameter].value
    tr = solve_system(scene.build({loss.parameter: value}), 4, "dop853", rtol=1e-12)
    amp = np.abs(tr.theta_turn)
    for a, b in zip(amp[:-1], amp[1:]):
        part = law_parts(np.array([0.5 * (a + b)]), omega0=W0, restoring=restoring, **{loss.symbol: value})[effect]
        assert abs((a - b) - part[0]) <= 0.02 * (a - b), (effect, restoring, a - b, part[0])


# -- forward sensitivities -----------------------------------------------------------------

@pytest.mark.parametrize("effect", SMOOTH)
def test_smooth_torque_is_linear_in_its_record_fields(effect):
    """The sensitivities' parameter term is the smooth torque evaluated on the record's tangent
    (:mod:`escfit.balance.sensitivity`): each smooth torque must be linear in its own fields."""
    torque = importlib.import_module(EFFECTS[effect].__module__).torque
    own = [s.name for s in getattr(EFFECTS[effect], "SLOTS", ())]
    assert own, f"{effect} has a torque but no record field of its own"
    k = load(example_tables(effect)).build().k.copy()
    records = np.repeat(k, 3)
    rng = np.random.default_rng(11)
    for name in own:
        records[name][:2] = rng.uniform(0.1, 2.0, 2)
        records[name][2] = 0.7 * records[name][0] - 1.3 * records[name][1]
    for x, v in rng.uniform(-1.5, 1.5, (6, 2)) * (A0, A0 * W0):
        a0, a1, a2 = (np.array(torque(x, v, records[i])) for i in range(3))
        np.testing.assert_allclose(a2, 0.7 * a0 - 1.3 * a1, rtol=1e-12, atol=1e-12 * np.max(np.abs(a0) + np.abs(a1)))


@pytest.mark.parametrize("effect", list(EFFECTS))
def test_sensitivities_match_central_differences(effect):
    """d theta(t)/dp from the variational equation against central differences of the dop853
    sampler at rtol 1e-13, for every parameter of every effect the sensitivities cover."""
    from escfit.balance.batch_dop853 import sample_batch_dop853
    from escfit.balance.sensitivity import covers, record_tangents, sample_sensitivities

    scene = load(example_tables(effect))
    if not claims("dop853", scene):
        pytest.skip(f"dop853 does not claim {effect}")
    vals = scene.params.values()
    if not covers(scene.system(vals)):
        pytest.skip(f"{effect} switches within a half swing: least squares keeps forward differences")
    names = [n for n, v in vals.items() if v != 0.0]
    t = np.linspace(0.01, SWINGS * math.pi / W0, 400)
    tangents = record_tangents(scene.system, vals, names, np.array([1e-6 * abs(vals[n]) for n in names]))
    motion, sens, _ = sample_sensitivities(scene.system(vals), t, tangents, rtol=1e-12)
    assert motion is not None
    for j, name in enumerate(names):
        h = 1e-5 * abs(vals[name])
        batch = {key: np.array([v, v]) for key, v in vals.items()}
        batch[name] = np.array([vals[name] + h, vals[name] - h])
        y, _ = sample_batch_dop853(scene.system(batch, 2), t, np.zeros(2), rtol=1e-13)
        ref = (y[0] - y[1]) / (2 * h)
        scale = np.max(np.abs(ref))
        if name.endswith("_static"):  # it decides only whether the balance stays at a turning point
            assert scale == 0.0 and np.all(sens[0, j] == 0.0), (effect, name)
            continue
        assert scale > 0.0 and np.max(np.abs(sens[0, j] - ref)) < 2e-6 * scale, (effect, name)
