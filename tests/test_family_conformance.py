"""Every registered model family honours the family contract, through the same calls.

The checks iterate the registry (:func:`escfit.core.family.family_names`), so a family added
with :func:`~escfit.core.family.register_family` gets them for free once it names an example
scene and recording in :data:`EXAMPLES`.  Each family is parsed, simulated, read, fitted by
least squares with ``escfit fit``, summarised (text, JSON, CSV), reported, and fitted again
with ``escfit fit-many`` (in-process); an option it does not take is refused with one line.

The toy family of ``tests/toy_family.py`` (a damped linear oscillator with a closed form) is
registered here and nowhere else: that it passes every check, and recovers the parameters its
example recording was drawn from, shows that a family needs no edit outside its own module and
its registration.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import escfit
from escfit.cli.main import FIT_FLAGS, cli
from escfit.core.errors import EscfitError
from escfit.core.family import Family, family_names, get_family, register_family

from . import toy_family

ROOT = Path(__file__).resolve().parents[1]
DATASETS = ROOT / "datasets"

register_family(toy_family.FAMILY, replace=True)  # before the parametrisation below reads the registry


def _shipped(scene: str, data: str):
    return lambda folder: (DATASETS / scene, DATASETS / data)


# family -> (folder -> (scene file, recording file)): a small, quick least-squares fit of each
EXAMPLES = {
    "balance": _shipped("monday1965/unit3_fit.toml", "monday1965/synthetic/unit3.csv"),
    "friction_rig": _shipped("friction/monday1965_rig.toml", "friction/monday1965_session_1095_steel.csv"),
    "geneva": _shipped("geneva/fit_four_pin_terminal.toml", "geneva/meyer1973_four_pin_mu020.csv"),
    "verge": _shipped("verge/m739_fit.toml", "verge/m739_output_turns.csv"),
    toy_family.NAME: toy_family.example,
}
FAMILIES = family_names()
# options of `escfit fit` that some family takes, with a value to offer one that does not
FOREIGN = (("material", "steel"), ("unit", "1"), ("solver", "rk4"), ("notch_deg", "10"), ("fmt", "raw"))


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    folder = tmp_path_factory.mktemp("examples")
    return {name: tuple(map(Path, EXAMPLES[name](folder))) for name in FAMILIES if name in EXAMPLES}


@pytest.fixture(scope="module")
def fitted(examples, tmp_path_factory):
    """``escfit fit`` of each family's example, once: name -> (exit status, output, results file)."""
    folder = tmp_path_factory.mktemp("fits")
    out = {}
    for name, (scene, data) in examples.items():
        h5 = folder / f"{name}.h5"
        res = CliRunner().invoke(cli, ["fit", str(data), "--scene", str(scene), "--out", str(h5), "--quiet"])
        out[name] = (res.exit_code, res.output, h5)
    return out


def _cli(*args: str):
    return CliRunner().invoke(cli, list(args))


def test_every_family_has_an_example():
    missing = sorted(set(FAMILIES) - set(EXAMPLES))
    assert not missing, f"families without an example scene and recording in EXAMPLES: {missing}"


@pytest.mark.parametrize("name", FAMILIES)
def test_registry_entry_is_a_family(name):
    family = get_family(name)
    assert isinstance(family, Family)
    assert family.name == name
    assert isinstance(family.problem_options, frozenset) and all(isinstance(o, str) for o in family.problem_options)
    assert isinstance(family.recorders, tuple)
    assert set(family.formats), "a family reads at least one format"
    assert isinstance(family.title({"scene": ""}), str) and family.title({"scene": ""})


@pytest.mark.parametrize("name", FAMILIES)
def test_parse_simulate_read(name, examples):
    scene_path, data = examples[name]
    scene = escfit.load_scene(scene_path)
    assert scene.model == name and scene.text and scene.where == str(scene_path)
    family = get_family(name)
    ds = escfit.simulate(scene)
    assert ds.attrs.get("status")
    summary = family.json_summary(ds)
    assert summary["status"] == ds.attrs["status"]
    json.dumps(summary)  # plain JSON values
    assert all(isinstance(line, str) for line in family.describe(ds))
    assert family.detect(data) in family.formats
    assert escfit.read_recording(data, model=name) is not None


@pytest.mark.parametrize("name", FAMILIES)
def test_unknown_problem_option_is_refused(name, examples):
    scene, data = examples[name]
    with pytest.raises(EscfitError, match="no_such_option"):
        get_family(name).problem(escfit.load_scene(scene), data, no_such_option=1)


@pytest.mark.parametrize("name", FAMILIES)
def test_fit_refuses_an_option_the_family_does_not_take(name, examples, tmp_path):
    family = get_family(name)
    option, value = next((o, v) for o, v in FOREIGN if o not in family.problem_options)
    scene, data = examples[name]
    out = tmp_path / "fit.h5"
    res = _cli("fit", str(data), "--scene", str(scene), "--out", str(out), FIT_FLAGS[option], value)
    assert res.exit_code == 2
    assert res.output.count("\n") == 1 and FIT_FLAGS[option] in res.output and repr(name) in res.output
    assert not out.exists()


@pytest.mark.parametrize("name", FAMILIES)
def test_fit_summary_report(name, fitted, examples, tmp_path):
    status, output, h5 = fitted[name]
    assert status in (0, 3), output  # 3: fitted, but the family's checks found a parameter undetermined
    scene, data = examples[name]
    problem = escfit.inference.make_problem(escfit.load_scene(scene), data)
    res = _cli("summary", str(h5), "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    # every free parameter but the noise scales least squares profiles out
    assert doc["model"] == name and set(doc["parameters"]) == set(problem.names) - set(problem.noise_names), \
        (list(doc["parameters"]), problem.names, problem.noise_names)
    res = _cli("summary", str(h5), "--csv")
    assert res.exit_code == 0 and [r.split(",")[0] for r in res.output.splitlines()[1:]] == list(doc["parameters"])
    report = tmp_path / "report.md"
    res = _cli("report", str(h5), "--out", str(report), "--format", "md")
    assert res.exit_code == 0, res.output
    loaded = escfit.load_results(h5)
    assert get_family(name).title(loaded.attrs) in report.read_text(encoding="utf-8")


@pytest.mark.parametrize("name", FAMILIES)
def test_derived_quantities_are_rows(name, fitted):
    from escfit.report.quantities import parameter_draws

    res = escfit.load_results(fitted[name][2])
    rows, note = get_family(name).derived(parameter_draws(res), res.attrs)
    assert isinstance(note, str)
    for label, unit, values, formula in rows:
        assert isinstance(label, str) and isinstance(unit, str) and isinstance(formula, str)
        assert np.asarray(values, float).size >= 1


@pytest.mark.parametrize("name", FAMILIES)
def test_fit_many_in_process(name, examples, fitted, tmp_path):
    scene, data = examples[name]
    out = tmp_path / "fleet"
    res = _cli("fit-many", str(data), "--scene", str(scene), "--out", str(out), "--workers", "0", "--quiet")
    assert res.exit_code == 0, res.output
    res = _cli("summary", str(out), "--json")
    assert res.exit_code == 0, res.output
    units = json.loads(res.output)["units"]
    assert [u["status"] for u in units] == ["ok"] * len(units) and units
    single = json.loads(_cli("summary", str(fitted[name][2]), "--json").output)["parameters"]
    assert set(single) <= set(units[0])


def test_toy_family_recovers_its_truth(fitted):
    """The toy's example recording is drawn from known values; least squares must find them
    within four standard errors (a 1-in-15000 miss for a correct fit)."""
    doc = json.loads(_cli("summary", str(fitted[toy_family.NAME][2]), "--json").output)["parameters"]
    for name in ("toy.omega", "toy.gamma"):
        row = doc[name]
        assert abs(row["estimate"] - toy_family.TRUTH[name]) <= 4 * row["stderr"], (name, row)
        assert row["stderr"] > 0 and math.isfinite(row["stderr"])


def test_toy_closed_form_solves_its_equation():
    """The toy's closed form against a numerical integration of x'' + 2 gamma x' + omega^2 x = 0."""
    from scipy.integrate import solve_ivp

    omega, gamma, x0 = 6.0, 0.35, 0.02
    t = np.linspace(0, 5, 101)
    sol = solve_ivp(lambda _, y: [y[1], -2 * gamma * y[1] - omega ** 2 * y[0]], (0, 5), [x0, 0.0], t_eval=t,
                    rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(toy_family.displacement(t, omega, gamma, x0), sol.y[0], atol=1e-10)
