"""Synthetic fleets: regeneration from the saved scene and seed, truth, forward-model agreement."""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.core.errors import DataError, ResultsError, SceneError
from escfit.balance.problems.curves import FitProblem
from escfit.analysis.recordings import read_unit_curve
from escfit.study import (MODELS, POPULATION_PARAMS, LogNormal, Rig, fit_scene, generate_fleet, load_fleet, preset,
                          record_unit)

from .conftest import DATASETS

FLEETS = DATASETS / "fleet"


def test_shipped_fleets_are_small_and_complete():
    total = sum(p.stat().st_size for p in FLEETS.rglob("*") if p.is_file())
    assert total < 1_000_000, total
    for model in MODELS:
        fleet = load_fleet(FLEETS / model)
        assert fleet.spec.model == model and len(fleet.units) == 20
        curve = read_unit_curve(fleet.recordings)
        assert sorted(set(curve.unit)) == fleet.units
        assert curve.kind == "notches" and curve.notch == pytest.approx(math.radians(6))
        assert sorted(set(curve.load)) == list(Rig().loads)
        for unit in fleet.units:
            assert fleet.scene_path(unit).is_file()
        assert (FLEETS / "scenes" / f"{model}.toml").is_file()


@pytest.mark.parametrize("model", MODELS)
def test_each_unit_regenerates_from_its_scene_and_seed(model):
    fleet = load_fleet(FLEETS / model)
    curve = read_unit_curve(fleet.recordings)
    for unit in fleet.units[:3]:
        again = record_unit(fleet.scene_path(unit), seed=fleet.seeds[unit], unit=unit)
        rows = curve.unit == unit
        np.testing.assert_array_equal(again.value, curve.value[rows])
        np.testing.assert_array_equal(again.swing, curve.swing[rows])
        np.testing.assert_array_equal(again.load, curve.load[rows])


@pytest.mark.parametrize("model", MODELS)
def test_generator_and_fit_scene_share_one_forward_model(model):
    """At the true values the fit scene's expected readings are the generator's noise-free curve."""
    fleet = load_fleet(FLEETS / model)
    unit = fleet.units[0]
    curve = read_unit_curve(fleet.recordings)
    data = curve.select(np.flatnonzero(curve.unit == unit))
    problem = FitProblem(escfit.load_scene("fit.toml", text=fit_scene(fleet.spec.rig, model)), data)
    truth = fleet.truth[unit]
    expected = problem.expected(problem.values({n: truth[n] for n in problem.names}))
    gen = escfit.load_scene(fleet.scene_path(unit))
    text = gen.text.replace("sigma = 0.03", "sigma = 1e-12")  # the same draw without jitter
    clean = record_unit(escfit.load_scene("clean.toml", text=text), seed=fleet.seeds[unit], unit=unit)
    # notches counted from the noise-free amplitude are its floor
    np.testing.assert_array_equal(np.floor(expected / data.notch + 1e-9), clean.value)


def test_population_draws_scatter_as_specified(tmp_path):
    spec = preset("angle", n_units=400, seed=3)
    fleet = generate_fleet(spec, tmp_path / "big")
    logs = np.log(fleet.truth_array())
    np.testing.assert_allclose(logs.mean(axis=0), spec.population.mu, atol=0.05)
    np.testing.assert_allclose(logs.std(axis=0, ddof=1), spec.population.spread, rtol=0.12)
    kappa = np.array([fleet.truth[u]["fit.kappa"] for u in fleet.units])
    np.testing.assert_allclose(kappa, 0.25 * fleet.truth_array()[:, 1] / spec.rig.reference)


def test_phase_preset_keeps_r_and_x_nearly_cancelling():
    spec = preset("phase", n_units=2000, seed=5)
    draws = spec.population.sample(2000, np.random.default_rng(0))
    ratio = np.log(draws[:, 1] / draws[:, 2])
    assert np.std(ratio) == pytest.approx(0.006, rel=0.1)


def test_refusals(tmp_path):
    generate_fleet(preset("angle", n_units=2, seed=1), tmp_path / "f")
    with pytest.raises(ResultsError, match="force"):
        generate_fleet(preset("angle", n_units=2, seed=1), tmp_path / "f")
    with pytest.raises(SceneError, match="model must be one of"):
        preset("verge")
    with pytest.raises(SceneError, match="one median and one spread"):
        LogNormal(POPULATION_PARAMS, (1.0, 2.0), (0.1, 0.1, 0.1))
    with pytest.raises(SceneError, match="positive"):
        LogNormal(POPULATION_PARAMS, (1.0, -2.0, 3.0), (0.1, 0.1, 0.1))
    with pytest.raises(SceneError, match="symmetric"):
        LogNormal(POPULATION_PARAMS, (1.0, 2.0, 3.0), (0.1, 0.1, 0.1), ((1.0, 0.5, 0.0), (0.0, 1.0, 0.0), (0, 0, 1.0)))
    with pytest.raises(DataError, match="no fleet.toml"):
        load_fleet(tmp_path)
    with pytest.raises(SceneError, match="rig"):
        record_unit(DATASETS / "scenes" / "monday_sample_angle.toml", seed=1)


def test_fit_scenes_parse_with_the_same_free_parameters():
    names = None
    for model in MODELS:
        scene = escfit.load_scene(FLEETS / "scenes" / f"{model}.toml")
        free = [p.name for p in scene.params.free()]
        assert free == ["viscous.C", "coulomb.R", "escapement[2].X"]
        assert scene.switching == ("angle" if model == "angle" else "phase")
        assert (scene.effect("viscous_drift") is not None) == (model == "phase_drift")
        names = names or free
