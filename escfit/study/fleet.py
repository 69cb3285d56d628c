"""Synthetic fleets: units drawn from a known log-normal population, recorded like Monday's rig.

A fleet directory holds

- ``fleet.toml``: the specification (model, population, load rule, rig, reading jitter,
  seed) and provenance;
- ``recordings.csv``: notch counts of every unit at every load (``unit`` and ``load_g``
  columns), readable by :func:`escfit.analysis.recordings.read_unit_curve` and ``escfit fit-many``;
- ``truth.csv``: each unit's true parameters and its seed;
- ``scenes/<unit>.toml``: the generating scene of each unit (its true values, nothing free).

:func:`record_unit` turns a generating scene and its seed back into exactly the recorded
readings, so every dataset can be regenerated from what is saved beside it.
"""

from __future__ import annotations

import csv
import datetime as _dt
import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from ..core.errors import DataError, ResultsError, SceneError
from ..balance.synthetic.unit_curves import record_unit_curve
from ..analysis.recordings import UnitCurve, write_unit_curve
from ..core.scene import load_scene
from .scenes import MODELS, POPULATION_PARAMS, Rig, generating_scene, kappa_for, load_rule

__all__ = ["LogNormal", "FleetSpec", "Fleet", "PRESETS", "preset", "generate_fleet", "load_fleet", "record_unit",
           "TRUTH_COLUMNS"]

TRUTH_COLUMNS = ("viscous.C", "coulomb.R", "escapement[2].X", "fit.kappa", "observation.sigma")


@dataclass(frozen=True)
class LogNormal:
    """A multivariate log-normal population of unit parameters.

    Attributes
    ----------
    names
        Parameter names (``viscous.C`` ...).
    median
        Population medians exp(mu), canonical units.
    spread
        Standard deviations of the logarithms (unit-to-unit scatter; 0.1 ~ 10 %).
    correlation
        Correlation matrix of the logarithms (``None``: independent).
    """

    names: tuple[str, ...]
    median: tuple[float, ...]
    spread: tuple[float, ...]
    correlation: tuple[tuple[float, ...], ...] | None = None

    def __post_init__(self) -> None:
        d = len(self.names)
        if len(self.median) != d or len(self.spread) != d:
            raise SceneError(f"population needs one median and one spread per parameter {list(self.names)}")
        if any(not m > 0 for m in self.median) or any(not s >= 0 for s in self.spread):
            raise SceneError(f"population medians must be positive and spreads >= 0, got {self.median}, {self.spread}")
        if self.correlation is not None:
            r = np.asarray(self.correlation, float)
            if r.shape != (d, d) or not np.allclose(r, r.T) or not np.allclose(np.diag(r), 1.0):
                raise SceneError(f"correlation must be a symmetric {d}x{d} matrix with unit diagonal")

    @property
    def mu(self) -> np.ndarray:
        return np.log(np.asarray(self.median, float))

    def covariance(self) -> np.ndarray:
        s = np.asarray(self.spread, float)
        r = np.eye(len(s)) if self.correlation is None else np.asarray(self.correlation, float)
        return r * np.outer(s, s)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` draws, shape (n, len(names)), canonical units."""
        return np.exp(rng.multivariate_normal(self.mu, self.covariance(), size=n, method="eigh"))

    def as_dict(self) -> dict:
        out = {"names": list(self.names), "median": list(map(float, self.median)),
               "spread": list(map(float, self.spread))}
        if self.correlation is not None:
            out["correlation"] = [list(map(float, row)) for row in self.correlation]
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "LogNormal":
        corr = d.get("correlation")
        return cls(tuple(d["names"]), tuple(d["median"]), tuple(d["spread"]),
                   None if corr is None else tuple(tuple(r) for r in corr))


@dataclass(frozen=True)
class FleetSpec:
    """What a synthetic fleet is drawn from and how it is recorded.

    Attributes
    ----------
    name
        Fleet name (directory name when shipped).
    model
        Generating model: ``"phase"``, ``"phase_drift"`` or ``"angle"``.
    population
        Log-normal population of ``viscous.C``, ``coulomb.R`` (at the reference load) and
        ``escapement[2].X`` (impulse at the reference load).
    friction_growth
        R at load L is ``R * (1 + g * (L/reference - 1))``: 1 makes R proportional to the load
        as in Monday's Table I, 0 independent of it.
    sigma
        Reading jitter before counting whole notches (rad); Monday read +-1 notch.
    n_units, seed
        Fleet size and the seed every random number derives from.
    rig
        Fixture, escapement geometry and reading schedule.
    """

    name: str
    model: str
    population: LogNormal
    friction_growth: float = 0.25
    sigma: float = 0.03
    n_units: int = 20
    seed: int = 1965
    rig: Rig = field(default_factory=Rig)

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise SceneError(f"fleet model must be one of {list(MODELS)}, got {self.model!r}")
        if tuple(self.population.names) != POPULATION_PARAMS:
            raise SceneError(f"the population must describe {list(POPULATION_PARAMS)}, got {list(self.population.names)}")
        if not 1 <= self.n_units <= 100_000:
            raise SceneError(f"n_units must be from 1 to 100000, got {self.n_units}")


def preset(model: str, *, n_units: int = 20, seed: int = 1965, name: str | None = None) -> FleetSpec:
    """A fleet whose units scatter like Monday's Table I, generated by ``model``.

    Table I's five units spread their C over 0.757 to 2.367 1/s (sd of log C about 0.45); R per
    gram of load varies by about 7 %; X came from the fixture and is common to all.  The
    angle preset uses medians C = 0.5 1/s, R = 40, X = 400 rad/s^2 (at 330.66 g) with log-sds
    0.4, 0.15 and 0.1, and R growing by a quarter of its value per reference load: the curves
    then fall from the 6.28 rad release to 1.5 - 4 rad over four to eight readings, as
    Monday's did.  Monday's phase model needs R and X about ten times larger (the
    phase-window impulse grows with amplitude like a negative Coulomb friction) and R
    proportional to the load, with R/X within about 0.6 % of 0.2525 (R and X nearly cancel:
    1 % less friction and a slow unit's amplitude grows without bound); its preset has
    C = 1.4 1/s (log-sd 0.25), X = 4119 rad/s^2 (log-sd 0.08) and R = 0.2525 X.
    """
    if model == "angle":
        pop = LogNormal(POPULATION_PARAMS, (0.5, 40.0, 400.0), (0.4, 0.15, 0.10))
        growth = 0.25
    elif model in ("phase", "phase_drift"):
        s_x, s_ratio = 0.08, 0.006
        s_r = math.hypot(s_x, s_ratio)
        rho = s_x / s_r
        pop = LogNormal(POPULATION_PARAMS, (1.4, 1040.0, 4119.0), (0.25, s_r, s_x),
                        ((1.0, 0.0, 0.0), (0.0, 1.0, rho), (0.0, rho, 1.0)))
        growth = 1.0
    else:
        raise SceneError(f"model must be one of {list(MODELS)}, got {model!r}")
    return FleetSpec(name or model, model, pop, growth, n_units=n_units, seed=seed)


PRESETS = MODELS


@dataclass
class Fleet:
    """A fleet on disk.

    Attributes
    ----------
    path
        The fleet directory.
    spec
        Its specification.
    units
        Unit names in order.
    truth
        True parameters by unit: ``{unit: {name: value}}`` (canonical units).
    seeds
        Recording seed of each unit.
    """

    path: Path
    spec: FleetSpec
    units: list[str]
    truth: dict[str, dict[str, float]]
    seeds: dict[str, int]

    @property
    def recordings(self) -> Path:
        return self.path / "recordings.csv"

    def scene_path(self, unit: str) -> Path:
        return self.path / "scenes" / f"{unit}.toml"

    def truth_array(self, names=POPULATION_PARAMS) -> np.ndarray:
        """True values, shape (units, names)."""
        return np.array([[self.truth[u][n] for n in names] for u in self.units])


def _unit_seed(seed: int, index: int) -> int:
    return int(np.random.SeedSequence([seed, 1, index]).generate_state(1)[0])


def record_unit(scene, *, seed: int, unit: str = "") -> UnitCurve:
    """Readings of one unit at every load of its generating scene.

    Parameters
    ----------
    scene
        A generating scene (see :func:`escfit.study.scenes.generating_scene`) or its path;
        its ``[fit.loads]`` table gives the reference load and kappa, and the loads are those
        of its ``# loads_g:`` header line.
    seed
        The unit's seed; load ``i`` (in file order) is recorded with ``seed + i``.
    unit
        Unit name written to the ``unit`` column.
    """
    sc = load_scene(scene) if not hasattr(scene, "model") else scene
    rig, loads = _rig_of(sc)
    vals = sc.params.values()
    table = sc.extra["fit"]["loads"]
    vals["fit.kappa"] = float(table["kappa"])
    sigma = float(sc.extra["observation"]["sigma"])
    parts = []
    for i, load in enumerate(loads):
        at = load_rule(vals, load, rig.reference)
        sc_l = sc.with_values({k: at[k] for k in ("coulomb.R", "escapement[2].X")})
        c = record_unit_curve(sc_l, every=rig.every, swings=rig.swings, notch_deg=rig.notch_deg, sigma=sigma,
                              seed=seed + i)
        parts.append((c, load))
    swing = np.concatenate([c.swing for c, _ in parts])
    value = np.concatenate([c.value for c, _ in parts])
    load = np.concatenate([np.full(c.swing.size, ld) for c, ld in parts])
    return UnitCurve(swing, value, "notches", math.radians(rig.notch_deg), load, "g", np.full(swing.size, unit),
                     source=f"<unit {unit} from {sc.where}>")


def _rig_of(sc) -> tuple[Rig, tuple[float, ...]]:
    """Reading schedule and loads from a generating scene's header comment."""
    for line in sc.text.splitlines():
        if line.startswith("# rig: "):
            rig = Rig.from_dict(json.loads(line[len("# rig: "):]))
            return rig, rig.loads
    raise SceneError("not a fleet generating scene: no '# rig: {...}' header line", sc.where)


def generate_fleet(spec: FleetSpec, out_dir: str | Path, *, force: bool = False) -> Fleet:
    """Draw ``spec.n_units`` units from the population, record them and write the fleet.

    Raises
    ------
    ResultsError
        ``out_dir`` already holds a fleet and ``force`` is false.
    """
    from ..core.scene import load_scene

    out = Path(out_dir)
    if (out / "fleet.toml").exists() and not force:
        raise ResultsError("a fleet exists here; pass force=True to replace it", str(out))
    (out / "scenes").mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([spec.seed, 0])
    draws = spec.population.sample(spec.n_units, rng)
    rig = spec.rig
    units = [f"u{i + 1:0{max(2, len(str(spec.n_units)))}d}" for i in range(spec.n_units)]
    truth, seeds, curves = {}, {}, []
    for i, unit in enumerate(units):
        c, r, x = map(float, draws[i])
        t = {"viscous.C": c, "coulomb.R": r, "escapement[2].X": x,
             "fit.kappa": kappa_for(spec.friction_growth, r, rig.reference), "observation.sigma": spec.sigma}
        seed = _unit_seed(spec.seed, i)
        header = (f"Generating scene of unit {unit} of fleet '{spec.name}' (model {spec.model}); nothing is free.\n"
                  f"Recorded by escfit.study.fleet.record_unit(scene, seed={seed}, unit='{unit}'); load i uses seed "
                  f"+ i.\nrig: {json.dumps(rig.as_dict())}")
        text = generating_scene(rig, spec.model, t, header=header)
        path = out / "scenes" / f"{unit}.toml"
        with atomic_path(path, force=True) as tmp:
            tmp.write_text(text)
        curves.append(record_unit(load_scene(path), seed=seed, unit=unit))
        truth[unit], seeds[unit] = t, seed
    allc = UnitCurve(np.concatenate([c.swing for c in curves]), np.concatenate([c.value for c in curves]), "notches",
                     math.radians(rig.notch_deg), np.concatenate([c.load for c in curves]), "g",
                     np.concatenate([c.unit for c in curves]))
    with atomic_path(out / "recordings.csv", force=True) as tmp:
        write_unit_curve(tmp, allc, comments=[
            f"Synthetic fleet '{spec.name}': {spec.n_units} units generated by the {spec.model} model "
            f"(escfit.study.generate_fleet, seed {spec.seed}).",
            "Notch counts every second cycle at three fixture loads; truth in truth.csv, generating scenes in scenes/."])
    with atomic_path(out / "truth.csv", force=True) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["unit", "seed", *TRUTH_COLUMNS])
        for u in units:
            w.writerow([u, seeds[u], *(repr(truth[u][n]) for n in TRUTH_COLUMNS)])
    with atomic_path(out / "fleet.toml", force=True) as tmp:
        tmp.write_text(_manifest(spec))
    return load_fleet(out)


def _toml_value(v) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else repr(v)


def _manifest(spec: FleetSpec) -> str:
    from ..core.version import __version__

    pop = spec.population.as_dict()
    lines = [
        "# Synthetic fleet specification, written by escfit.study.generate_fleet.",
        "# Regenerate: escfit.study.generate_fleet(escfit.study.load_fleet(DIR).spec, DIR, force=True)",
        f"name = {_toml_value(spec.name)}",
        f"model = {_toml_value(spec.model)}",
        f"n_units = {spec.n_units}",
        f"seed = {spec.seed}",
        f"friction_growth = {_toml_value(float(spec.friction_growth))}",
        f"sigma = {_toml_value(float(spec.sigma))}",
        f"escfit_version = {_toml_value(__version__)}",
        f"generated = {_toml_value(_dt.datetime.now(_dt.timezone.utc).date().isoformat())}",
        "",
        "[population]",
        *(f"{k} = {_toml_value(v)}" for k, v in pop.items()),
        "",
        "[rig]",
        *(f"{k} = {_toml_value(v)}" for k, v in spec.rig.as_dict().items()),
    ]
    return "\n".join(lines) + "\n"


def load_fleet(path: str | Path) -> Fleet:
    """Read a fleet directory written by :func:`generate_fleet`.

    Raises
    ------
    DataError
        Missing or malformed ``fleet.toml`` or ``truth.csv``.
    """
    p = Path(path)
    man = p / "fleet.toml"
    if not man.is_file():
        raise DataError("not a fleet directory (no fleet.toml)", str(p))
    try:
        doc = tomllib.loads(man.read_text(encoding="utf-8"))
        spec = FleetSpec(doc["name"], doc["model"], LogNormal.from_dict(doc["population"]),
                         float(doc["friction_growth"]), float(doc["sigma"]), int(doc["n_units"]), int(doc["seed"]),
                         Rig.from_dict(doc["rig"]))
    except (KeyError, TypeError, tomllib.TOMLDecodeError) as exc:
        raise DataError(f"malformed fleet specification ({type(exc).__name__}: {exc})", str(man)) from None
    units, truth, seeds = [], {}, {}
    try:
        with (p / "truth.csv").open(newline="") as fh:
            for row in csv.DictReader(fh):
                u = row["unit"]
                units.append(u)
                seeds[u] = int(row["seed"])
                truth[u] = {n: float(row[n]) for n in TRUTH_COLUMNS}
    except (OSError, KeyError, ValueError) as exc:
        raise DataError(f"cannot read the fleet's truth table ({type(exc).__name__}: {exc})",
                        str(p / "truth.csv")) from None
    return Fleet(p, replace(spec), units, truth, seeds)
