"""A model family written outside escfit: a linear damped oscillator with a closed form.

This module is all a new family needs: a scene parser, a closed-form simulation, a reader of its
recording format, a fit problem and the :class:`~escfit.core.family.FamilyBase` entry that ties
them together.  Registered with :func:`escfit.core.family.register_family` (see
``tests/test_family_conformance.py``), it reaches ``escfit fit``, ``summary``, ``report`` and
``fit-many`` with no edit anywhere else.

Model (displacement ``x`` in m, time ``t`` in s, released at rest from ``x0`` at ``t = 0``)::

    x'' + 2 gamma x' + omega**2 x = 0
    x(t) = x0 exp(-gamma t) (cos(wd t) + gamma / wd sin(wd t)),  wd = sqrt(omega**2 - gamma**2)

Readings are ``x`` at the recorded times with independent normal errors of standard deviation
``observation.sigma`` (m).  The recording format ``toy-samples`` is a CSV file whose header is
``t,x``.
"""

from __future__ import annotations

import csv
import hashlib
import math
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from escfit.core.errors import DataError, FitError, SceneError
from escfit.core.family import FamilyBase
from escfit.core.params import Param, ParamSet
from escfit.core.scene import check_keys
from escfit.likelihood.priors import uniform
from escfit.likelihood.problem import FAIL_RESIDUAL, ProblemBase

NAME = "toy_oscillator"
FORMAT = "toy-samples"

# parameter -> (unit, meaning, lower, upper)
PARAMS = {
    "toy.omega": ("1/s", "undamped angular frequency omega", 0.1, 100.0),
    "toy.gamma": ("1/s", "damping rate gamma (x'' + 2 gamma x' + omega^2 x = 0)", 0.0, 10.0),
    "toy.x0": ("m", "release displacement x0 (at rest)", -1.0, 1.0),
    "observation.sigma": ("m", "standard deviation of a reading", 1e-9, 1.0),
}


def displacement(t, omega: float, gamma: float, x0: float) -> np.ndarray:
    """The closed form of the module docstring (underdamped: ``gamma < omega``; NaN otherwise)."""
    t = np.asarray(t, float)
    if not gamma < omega:
        return np.full(t.shape, np.nan)
    wd = math.sqrt(omega ** 2 - gamma ** 2)
    return x0 * np.exp(-gamma * t) * (np.cos(wd * t) + gamma / wd * np.sin(wd * t))


@dataclass(frozen=True)
class ToyScene:
    """A parsed toy scene (``[toy]`` omega, gamma, x0; ``[observation]`` sigma; ``[run]`` duration, samples)."""

    params: ParamSet
    duration: float
    samples: int
    text: str
    where: str
    model: str = NAME


@dataclass(frozen=True)
class Samples:
    """A toy recording: times (s) and displacements (m)."""

    t: np.ndarray
    x: np.ndarray
    where: str


def parse(doc: Mapping[str, Any], *, where: str, text: str) -> ToyScene:
    """A toy scene; ``[fit] vary`` lists the free parameters by name (``"toy.gamma"``)."""
    check_keys(doc, {"model", "title", "toy", "observation", "run", "fit"}, where, {"model", "toy"})
    toy, obs = doc["toy"], doc.get("observation", {"sigma": 1e-3})
    check_keys(toy, {"omega", "gamma", "x0"}, f"{where} [toy]", {"omega", "gamma", "x0"})
    check_keys(obs, {"sigma"}, f"{where} [observation]", {"sigma"})
    run, fit = doc.get("run", {}), doc.get("fit", {})
    check_keys(run, {"duration", "samples"}, f"{where} [run]")
    check_keys(fit, {"vary"}, f"{where} [fit]")
    given = {**{f"toy.{k}": v for k, v in toy.items()}, "observation.sigma": obs["sigma"]}
    vary = set(fit.get("vary", []))
    unknown = sorted(vary - set(PARAMS))
    if unknown:
        raise SceneError(f"unknown parameter(s) {unknown} in vary; known: {sorted(PARAMS)}", f"{where} [fit].vary")
    params = ParamSet()
    for name, (unit, meaning, lo, hi) in PARAMS.items():
        value = given[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
            raise SceneError(f"{name} must be a number in [{lo:g}, {hi:g}] {unit}, got {value!r}", where)
        params.add(Param(name, float(value), unit, meaning, vary=name in vary, min=lo, max=hi))
    return ToyScene(params, float(run.get("duration", 5.0)), int(run.get("samples", 200)), text, where)


def simulate(scene: ToyScene, solver: str | None = None, **options):
    """The closed form on the scene's ``[run]`` grid, as an :class:`xarray.Dataset`."""
    import xarray as xr

    if solver not in (None, "closed_form") or options:
        raise SceneError(f"the toy oscillator has one solver, closed_form, and no options; got {solver!r} {options}",
                         scene.where)
    v = scene.params.values()
    t = np.linspace(0.0, scene.duration, scene.samples)
    x = displacement(t, v["toy.omega"], v["toy.gamma"], v["toy.x0"])
    status = "ok" if np.all(np.isfinite(x)) else "overdamped"
    return xr.Dataset({"x": ("time", x, {"units": "m"})}, coords={"time": ("time", t, {"units": "s"})},
                      attrs={"model": NAME, "status": status, "solver": "closed_form", "scene": scene.text})


def json_summary(ds) -> dict[str, Any]:
    return {"status": ds.attrs["status"], "samples": int(ds.sizes["time"]), "x_last": float(ds["x"].values[-1])}


def read_samples(path) -> Samples:
    """A ``toy-samples`` CSV file (header ``t,x``)."""
    where = str(path)
    try:
        rows = list(csv.reader(Path(path).read_text(encoding="utf-8").splitlines()))
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read the file ({exc})", where) from None
    if not rows or [c.strip() for c in rows[0]] != ["t", "x"]:
        raise DataError("not a toy-samples file: the header must be 't,x'", where)
    try:
        values = np.array([[float(c) for c in r] for r in rows[1:] if r], float).reshape(-1, 2)
    except ValueError as exc:
        raise DataError(f"a reading is not a number ({exc})", where) from None
    if not values.shape[0]:
        raise DataError("no readings", where)
    return Samples(values[:, 0], values[:, 1], where)


def write_samples(path, t, x) -> None:
    lines = ["t,x", *(f"{a!r},{b!r}" for a, b in zip(map(float, t), map(float, x)))]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


class ToyProblem(ProblemBase):
    """The toy scene's free parameters fitted to samples, built whole in the constructor."""

    family = NAME
    reading_units = "m"
    DERIVED = {"toy.Q": ("", "quality factor omega / (2 gamma)")}

    def __init__(self, scene: ToyScene, data: Samples, sha256: str = ""):
        self.scene, self.data, self.sha256 = scene, data, sha256
        self.params = scene.params
        free = scene.params.free()
        if not free:
            raise FitError("nothing to fit: [fit] vary names no parameter", scene.where)
        self.names = [p.name for p in free]
        self.priors = [uniform(p.min, p.max) for p in free]
        self.failures: Counter = Counter()
        self.notes = [f"{data.t.size} samples from {Path(data.where).name}"]
        self.data_warnings: list[str] = []
        self._base = scene.params.values()

    @property
    def initial(self) -> np.ndarray:
        return np.array([self._base[n] for n in self.names], float)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([p.lower for p in self.priors]), np.array([p.upper for p in self.priors])

    def values(self, vec) -> dict[str, float]:
        out = dict(self._base)
        if isinstance(vec, Mapping):
            out.update({k: float(v) for k, v in vec.items()})
        else:
            out.update(zip(self.names, map(float, np.asarray(vec, float).ravel())))
        return out

    @property
    def observed(self) -> np.ndarray:
        return self.data.x

    def expected(self, values: Mapping[str, float]) -> np.ndarray:
        return displacement(self.data.t, values["toy.omega"], values["toy.gamma"], values["toy.x0"])

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        r = (self.data.x - self.expected(values)) / values["observation.sigma"]
        if not np.all(np.isfinite(r)):
            self.failures["overdamped (gamma >= omega)"] += 1
            return np.full(r.shape, FAIL_RESIDUAL)
        return r

    def loglike_pointwise(self, values: Mapping[str, float]) -> np.ndarray:
        s = values["observation.sigma"]
        r = (self.data.x - self.expected(values)) / s
        return -0.5 * r ** 2 - math.log(s) - 0.5 * math.log(2 * math.pi)

    def log_prior(self, vec) -> float:
        return float(sum(p.logpdf(v) for p, v in zip(self.priors, np.asarray(vec, float))))

    def log_likelihood(self, values: Mapping[str, float]) -> float:
        ll = float(np.sum(self.loglike_pointwise(values)))
        if not math.isfinite(ll):
            self.failures["overdamped (gamma >= omega)"] += 1
            return -math.inf
        return ll

    def obs_coords(self) -> dict[str, Any]:
        n = self.data.t.size
        return {"obs": np.arange(n), "curve": ("obs", np.array([""] * n)),
                "x": ("obs", self.data.t, {"units": "s", "long_name": "time"})}

    def provenance(self) -> dict[str, Any]:
        return {"scene": self.scene.text, "scene_file": self.scene.where, "data_file": self.data.where,
                "data_sha256": self.sha256, "data_kind": FORMAT, "solver": "closed_form", "solver_options": {}}

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        g = values["toy.gamma"]
        return {"toy.Q": values["toy.omega"] / (2 * g) if g > 0 else math.inf}


class ToyFamily(FamilyBase):
    """The registry entry of ``model = "toy_oscillator"``."""

    name = NAME
    formats = {FORMAT: read_samples}
    fit_defaults = {"n_starts": 2, "walkers": 8, "steps": 200, "predictive_draws": 20}
    problem_options = frozenset()

    def parse(self, doc, where, text):
        return parse(doc, where=where, text=text)

    def simulate(self, scene, solver=None, **options):
        return simulate(scene, solver, **options)

    def json_summary(self, ds):
        return json_summary(ds)

    def detect(self, path) -> str:
        try:
            with open(path, encoding="utf-8") as f:
                head = f.readline().strip()
        except (OSError, UnicodeDecodeError) as exc:
            raise DataError(f"cannot read the file ({exc})", str(path)) from None
        if head.replace(" ", "") != "t,x":
            raise DataError("not a toy-samples file: the header must be 't,x'", str(path))
        return FORMAT

    def problem(self, scene, data, **options):
        self.refuse_unknown_options(options, scene.where)
        sha = ""
        if isinstance(data, (str, Path)):
            sha = hashlib.sha256(Path(data).read_bytes()).hexdigest()
            data = self.read(data)
        return ToyProblem(scene, data, sha)

    def title(self, attrs) -> str:
        return "Damped linear oscillator (toy) model"

    def derived(self, draws, attrs):
        """The quality factor at every draw."""
        if "toy.gamma" not in draws:
            return [], ""
        return [("quality factor Q", "", draws["toy.omega"] / (2 * draws["toy.gamma"]), "ω / 2γ")], ""


FAMILY = ToyFamily()

#: the values the example recording is drawn from
TRUTH = {"toy.omega": 6.0, "toy.gamma": 0.35, "toy.x0": 0.02, "observation.sigma": 2e-4}

SCENE = f"""model = "{NAME}"
title = "Toy damped oscillator"
[toy]
omega = 5.5
gamma = 0.2
x0 = 0.02
[observation]
sigma = {TRUTH["observation.sigma"]!r}
[fit]
vary = ["toy.omega", "toy.gamma"]
"""


def example(folder: Path) -> tuple[Path, Path]:
    """A toy scene (omega and gamma free) and a recording drawn from :data:`TRUTH` (seed 7),
    written into ``folder``."""
    t = np.linspace(0.0, 5.0, 200)
    x = displacement(t, TRUTH["toy.omega"], TRUTH["toy.gamma"], TRUTH["toy.x0"])
    x = x + np.random.default_rng(7).normal(0.0, TRUTH["observation.sigma"], t.size)
    scene, data = folder / "toy.toml", folder / "toy.csv"
    scene.write_text(SCENE, encoding="utf-8")
    write_samples(data, t, x)
    return scene, data
