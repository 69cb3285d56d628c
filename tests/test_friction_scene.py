"""friction_rig scenes: parameters, priors, the reading noise observation.sigma, forward predictions and refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.core.errors import SceneError, SolverError, UnitError
from escfit.friction import json_summary, simulate
from escfit.core.scene import load_scene

GF = 0.00980665
IN = 0.0254

BASE = """\
model = "friction_rig"
[rig]
k = { value = "2.0 inch", sd = "0.01 inch" }
d = { value = "1.0 inch", sd = "0.01 inch" }
[friction]
mu = { value = 0.1, vary = true, min = 0.0, max = 1.0 }
"""


def scene(extra: str = "", base: str = BASE):
    return load_scene("rig.toml", text=base + extra)


def test_brief_example_parses_with_shared_geometry_priors():
    s = scene()
    assert s.model == "friction_rig"
    assert s.params["rig.k"].value == pytest.approx(2 * IN)
    assert s.params["rig.d"].sd == pytest.approx(0.01 * IN)
    assert s.free_names() == ["rig.k", "rig.d", "friction.mu", "observation.sigma"]
    assert s.priors["rig.k"].family == "normal" and s.priors["rig.k"].args == pytest.approx((2 * IN, 0.01 * IN))
    assert s.priors["friction.mu"].family == "uniform"
    assert s.priors["observation.sigma"].family == "loguniform"  # no [observation]: estimated
    assert s.laws == ()


def test_reading_resolution_routes_agree():
    full = scene('[observation]\nresolution = "0.5 inch"\nfull_scale_load = "5 gf"\nscale_length = "11.5 ft"\n')
    slope = scene('[observation]\nresolution = "0.5 inch"\nslope = "27.6 inch/gf"\n')
    sd = full.params["observation.sigma"].value
    assert sd / GF == pytest.approx(math.sqrt(1 / 6) * 0.5 * 5 / 138, rel=1e-12)
    assert slope.params["observation.sigma"].value == pytest.approx(sd, rel=1e-12)
    assert "observation.sigma" not in full.free_names()
    assert "uniform rounding" in full.noise_note
    direct = scene('[observation]\nsigma = "0.0074 gf"\n')
    assert direct.params["observation.sigma"].value == pytest.approx(0.0074 * GF)


def test_wire_stiffness_route_uses_the_optical_lever():
    s = scene('[observation]\nresolution = "0.5 inch"\nwire_stiffness = "1e-5 N*m"\nscale_distance = "15 ft"\n')
    slope = 2 * 15 * 12 * IN * math.sqrt(3) * IN / 1e-5
    assert s.params["observation.sigma"].value == pytest.approx(math.sqrt(1 / 6) * 0.5 * IN / slope, rel=1e-12)


def test_laws_with_units_and_references():
    s = scene('mu_w = { value = 0.0, vary = true, prior = "normal(0, 0.02 / gf)" }\nload_ref = "2.2 gf"\n'
              'mu_v = { value = "0.001 s/ft", vary = true, prior = "normal(0, 0.005 s/ft)" }\n'
              'speed_ref = "6.5 ft/s"\n')
    assert s.laws == ("load", "speed")
    assert s.params["friction.mu_w"].unit == "1/N"
    assert s.priors["friction.mu_w"].args[1] == pytest.approx(0.02 / GF)
    assert s.params["friction.mu_v"].value == pytest.approx(0.001 / 0.3048)
    assert s.priors["friction.mu_v"].args[1] == pytest.approx(0.005 / 0.3048)
    assert s.load_ref == pytest.approx(2.2 * GF) and s.speed_ref == pytest.approx(6.5 * 0.3048)


@pytest.mark.parametrize(
    "text,where,words",
    [
        (BASE.replace('"1.0 inch"', '"2.0 inch"'), "rig.toml [rig.d]", ["'2.0 inch'", "must be below k", "'2.0 inch'"]),
        (BASE.replace('"1.0 inch"', '"2.5 inch"'), "rig.toml [rig.d]", ["d = '2.5 inch'", "cannot reach the disc"]),
        (BASE.replace('"2.0 inch", sd', '"0 inch", sd'), "rig.toml [rig.k]", ["'0 inch'", "physical range"]),
        (BASE.replace('"1.0 inch", sd', '"-1 inch", sd'), "rig.toml [rig.d]", ["'-1 inch'"]),
        (BASE + "colour = 1\n", "rig.toml [friction]", ["unknown key(s) ['colour']"]),
        (BASE.replace("[rig]", "[rig]\nlength = 1"), "rig.toml [rig]", ["unknown key(s) ['length']"]),
        (BASE + "[extra]\n", "rig.toml", ["unknown key(s) ['extra']"]),
        (BASE.replace("[rig]", '[rig]\nload_at = "pan"'), "rig.toml [rig.load_at]", ["'pan'"]),
        (BASE.replace("min = 0.0, max = 1.0", "min = 0.0"), "rig.toml [friction.mu]", ["open", "add min and max"]),
        (BASE + 'mu_w = { value = 0, vary = true, prior = "cauchy(0, 1)" }\n', "rig.toml [friction.mu_w].prior",
         ["'cauchy(0, 1)'"]),
        (BASE + 'mu_w = { value = 0, vary = true, prior = "normal(0, 0.1 s)" }\n', "rig.toml [friction.mu_w].prior",
         ["'0.1 s'", "1/N"]),
        (BASE + 'load_ref = "2 gf"\n', "rig.toml [friction.load_ref]", ["mu_w"]),
        (BASE + '[observation]\nresolution = "0.5 inch"\n', "rig.toml [observation]", ["exactly one"]),
        (BASE + '[observation]\nsigma = "1 gf"\nslope = "1 inch/gf"\n', "rig.toml [observation]", ["exactly one"]),
        (BASE + '[observation]\nslope = "1 inch/gf"\n', "rig.toml [observation]", ["add resolution"]),
        (BASE + '[observation]\nresolution = "0.5 inch"\nfull_scale_load = "5 gf"\n', "rig.toml [observation]",
         ["scale_length"]),
        (BASE + '[observation]\nsigma = "-1 gf"\n', "rig.toml [observation].sigma", ["'-1 gf'"]),
        (BASE + '[observation]\nresolution = "0.5 inch"\nslope = "0 inch/gf"\n', "rig.toml [observation].slope",
         ["positive", "'0 inch/gf'"]),
        (BASE + '[observation]\nresolution = "0.5 inch"\nslope = "1 inch"\n', "rig.toml [observation].slope", ["m/N"]),
        (BASE + '[observation]\nsd = "0.0074 gf"\n', "rig.toml [observation].sd", ["sigma = ..."]),
        (BASE + '[observation]\nsigma = "0.0074 gf"\nnoise = "white"\n', "rig.toml [observation]",
         ["unknown key(s) ['noise']"]),
        (BASE + '[reading]\nsd = "0.0074 gf"\n', "rig.toml [reading]", ["rename [reading] to [observation]"]),
    ],
)
def test_refusals_name_key_and_value(text, where, words):
    with pytest.raises(SceneError) as info:
        load_scene("rig.toml", text=text)
    assert info.value.where == where, info.value
    for w in words:
        assert w in info.value.message, info.value.message


def test_old_reading_table_is_refused_in_one_line_naming_the_file():
    with pytest.raises(SceneError) as info:
        load_scene("old_rig.toml", text=BASE + '[reading]\nresolution = "0.5 inch"\nslope = "27.6 inch/gf"\n')
    text = str(info.value)
    assert "\n" not in text and text.startswith("old_rig.toml [reading]: ")
    assert "[observation]" in text and "observation.sigma" in text


def test_free_sigma_with_open_range_gets_the_default_bounds():
    s = scene('[observation]\nsigma = { value = "0.01 gf", vary = true }\n')
    pr = s.priors["observation.sigma"]
    assert pr.kind == "loguniform" and (pr.lo, pr.hi) == (1e-8, 1.0)
    assert s.noise_route == "sigma" and "free" in s.noise_note
    given = scene('[observation]\nsigma = { value = "0.01 gf", vary = true, prior = "loguniform(1e-6 N, 1e-3 N)" }\n')
    assert given.priors["observation.sigma"].args == pytest.approx((1e-6, 1e-3))


def test_length_given_as_force_is_a_unit_error():
    with pytest.raises(UnitError, match="'2 gf'"):
        load_scene("rig.toml", text=BASE.replace('"2.0 inch", sd', '"2 gf", sd'))


def test_simulate_predicts_dw_for_a_grid_of_loads():
    s = scene('[observation]\nsigma = "0.0074 gf"\n')
    ds = simulate(s, loads=np.array([1.0, 2.2]) * GF)
    assert ds["dw"].dims == ("load", "speed")
    assert ds["dw"].values[:, 0] / GF == pytest.approx(np.array([1.0, 2.2]) * 0.1 / math.sqrt(3))
    assert ds["calibration_load"].values[1, 0] == pytest.approx(2.2 * GF - ds["dw"].values[1, 0])
    assert ds.attrs["lever_ratio"] == pytest.approx(math.sqrt(3))
    summary = json_summary(ds)
    assert summary["kind"] == "prediction" and summary["load_gf"] == [1.0, 2.2]
    with pytest.raises(SolverError, match="'rk4'"):
        simulate(s, solver="rk4")


def test_simulate_with_speed_law_spans_monday_speeds():
    s = scene('mu_v = { value = "0.01 s/ft" }\nspeed_ref = "6.5 ft/s"\n[observation]\nsigma = "0.0074 gf"\n')
    ds = simulate(s)
    assert ds.sizes["speed"] == 4
    assert ds["mu"].values[0] == pytest.approx(0.1 + 0.01 * (np.array([3, 5, 7.5, 10]) - 6.5))
