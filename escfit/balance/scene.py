"""Balance-wheel scenes: reading and validating ``model = "balance"`` TOML documents."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from ..core.errors import SceneError
from ..core.params import Param, ParamSet, read_param
from ..core.scene import check_keys
from ..core.suggest import did_you_mean, one_of
from ..core.units import BARE_ANGLE_LIMIT, to_canonical
from .effects import EFFECTS
from .effects.base import OMEGA0_RANGE, ReadContext, squared
from .system import Structure, System

__all__ = ["BalanceScene", "parse", "TOP_KEYS"]

TOP_KEYS = {"model", "switching", "title", "oscillator", "run", "effects", "observation", "fit", "recording"}


@dataclass(frozen=True)
class BalanceScene:
    """A balance wheel under an escapement, with only the effects the file names.

    Attributes
    ----------
    switching
        ``"angle"`` (windows at balance angles, the physics) or ``"phase"`` (Monday's
        programs: windows at fixed phases of each half cycle).
    restoring
        ``"spring"`` (hairspring: restoring acceleration ``omega0**2 * theta``) or
        ``"pendulum"`` (gravity: ``omega0**2 * sin(theta)``, ``omega0 = sqrt(g/L)``),
        from ``[oscillator] restoring``.
    coordinate
        ``"angle"`` (a balance, a pendulum: theta in rad, R in rad/s^2) or ``"linear"`` (a mass on
        a spring, ``[oscillator] coordinate = "linear"``: the same equation in a displacement x
        in m, released at ``x0``, with R a friction force per mass in m/s^2; the release keeps
        the parameter name ``oscillator.theta0``, in m).
    effects
        The effect objects, in reading order (structure only).
    params
        All numeric parameters, named ``oscillator.theta0``, ``viscous.C`` ...
    swings
        Number of half swings to simulate.
    inertia
        Moment of inertia (kg*m^2) if the file gave one (only needed for conversions).
    text, where
        Source TOML text and file name.
    extra
        Tables other layers read (``observation``, ``fit``), kept verbatim.
    """

    switching: str
    effects: tuple
    params: ParamSet
    swings: int
    inertia: float | None
    text: str
    where: str
    title: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)
    model: str = "balance"
    restoring: str = "spring"
    coordinate: str = "angle"

    @property
    def linear(self) -> bool:
        """Whether the scene is a linear oscillator (a displacement in m) rather than an angle."""
        return self.coordinate == "linear"

    @functools.cached_property
    def structure(self) -> Structure:
        """What the scene's effects fix for all its parameter sets (needs, prepared record)."""
        return Structure(self.effects, self.restoring, self.switching)

    def effect(self, key: str):
        """The effect named ``key`` or ``None``."""
        return next((e for e in self.effects if e.key == key), None)

    def build(self, values: Mapping[str, float] | None = None) -> System:
        """Assemble the numeric system for a parameter set (defaults: the scene's values).

        Parameters
        ----------
        values
            Values by name overriding the scene's; unnamed parameters keep theirs.
        """
        vals = self.params.values() if values is None else self.params.with_values(values).values()
        return self.system(vals)

    def system(self, vals: Mapping[str, float], n: int = 1) -> System:
        """Assemble the coefficient records from a complete name -> value mapping (ties resolved).

        Parameters
        ----------
        vals
            Every parameter by name: numbers, or arrays of ``n`` entries (one per parameter set).
        n
            Number of parameter sets.
        """
        k = self.structure.records(n)
        omega0 = vals.get("oscillator.omega0", math.nan)
        k["theta0"] = vals["oscillator.theta0"]
        k["omega0"] = omega0
        k["sp_w2"][:, 0] = squared(omega0)  # the linear spring (or gravity), unless a hairspring's pieces replace it
        for eff in self.effects:
            eff.fill(vals, k)
        return System(k, self.structure)

    def with_values(self, values: Mapping[str, float]) -> "BalanceScene":
        """A copy whose parameters take the given values."""
        from dataclasses import replace

        return replace(self, params=self.params.with_values(values))


def parse(doc: Mapping[str, Any], *, where: str, text: str) -> BalanceScene:
    """Validate a balance scene document (see the README's scene reference)."""
    check_keys(doc, TOP_KEYS, where)
    switching = doc.get("switching", "angle")
    if switching not in ("angle", "phase"):
        raise SceneError(f"switching must be 'angle' or 'phase', got {switching!r}", f"{where} [switching]")
    osc = doc.get("oscillator")
    if osc is None:
        raise SceneError("missing table [oscillator]", where)
    ow = f"{where} [oscillator]"
    # theta0 may be left out: a sampled recording supplies the release itself (see escfit.balance.problems.release)
    check_keys(osc, {"omega0", "inertia", "stiffness", "theta0", "restoring", "coordinate", "x0"}, ow)
    restoring = _read_restoring(osc, doc, switching, ow)
    coordinate = _read_coordinate(osc, doc, restoring, switching, ow)
    params = ParamSet()
    inertia = None
    if "inertia" in osc:
        inertia = to_canonical(osc["inertia"], "inertia", f"{ow}.inertia")
        if not inertia > 0:
            raise SceneError(f"inertia must be positive, got {osc['inertia']!r}", f"{ow}.inertia")
    effects_doc = doc.get("effects", {})
    if not isinstance(effects_doc, Mapping):
        raise SceneError("[effects] must be a table", where)
    has_spring = "hairspring" in effects_doc
    if has_spring and ("omega0" in osc or "stiffness" in osc):
        raise SceneError("with [effects.hairspring] give omega0 per piece there, not in [oscillator]", ow)
    if not has_spring:
        params.add(_read_omega0(osc, inertia, ow))
    if coordinate == "linear":
        params.add(_read_x0(osc, ow))
    elif "theta0" in osc:
        params.add(read_param(osc["theta0"], name="oscillator.theta0", kind="angle", bare_limit=BARE_ANGLE_LIMIT,
                              meaning="release angle (rad); released at rest", where=f"{ow}.theta0"))
    else:  # nan: taken from the recording's reference turning point when fitting
        params.add(Param("oscillator.theta0", math.nan, "rad",
                         "release angle (rad); released at rest (from the recording)"))
    run = doc.get("run", {})
    check_keys(run, {"swings"}, f"{where} [run]")
    swings = run.get("swings", 120)
    if isinstance(swings, bool) or not isinstance(swings, int) or not 1 <= swings <= 10_000_000:
        raise SceneError(f"swings must be a whole number from 1 to 1e7, got {swings!r}", f"{where} [run].swings")
    ctx = ReadContext(where=where, inertia=inertia, switching=switching, coordinate=coordinate)
    unknown = sorted(set(effects_doc) - set(EFFECTS))
    if unknown:
        hints = "".join(did_you_mean(k, EFFECTS) for k in unknown)
        raise SceneError(f"unknown effect(s) {unknown}{hints}; known effects: {sorted(EFFECTS)}", f"{where} [effects]")
    if "viscous_drift" in effects_doc and "viscous" not in effects_doc:
        raise SceneError("viscous_drift changes C and needs [effects.viscous]", f"{where} [effects.viscous_drift]")
    effects = []
    for key, cls in EFFECTS.items():
        if key in effects_doc:
            eff, ps = cls.read(effects_doc[key], ctx)
            effects.append(eff)
            for p in ps:
                params.add(p)
    _resolve_ties(params)
    if restoring == "pendulum" and abs(params["oscillator.theta0"].value) >= math.pi:
        raise SceneError(f"a pendulum released at |theta0| >= 180 deg never swings back; got theta0 = "
                         f"{params['oscillator.theta0'].value:g} rad (must lie within +-pi)", f"{ow}.theta0")
    bank = next((e for e in effects if e.key == "banking"), None)
    if bank is not None and abs(params["oscillator.theta0"].value) > bank.angle:
        raise SceneError(f"theta0 = {params['oscillator.theta0'].value:g} rad lies beyond the banking angle "
                         f"{bank.angle:g} rad", f"{ow}.theta0")
    title = doc.get("title", "")
    _check_observation_model(doc.get("observation"), where)
    extra = {k: doc[k] for k in ("observation", "fit", "recording") if k in doc}
    return BalanceScene(switching, tuple(effects), params, swings, inertia, text, where, str(title), extra,
                        restoring=restoring, coordinate=coordinate)


# What ``[observation] model`` may say: turning-point amplitudes or notch counts of a unit curve,
# every sample of a recording, a timegrapher's readings, the times of a pickup's pulses
OBSERVATION_MODELS = ("amplitude", "notches", "waveform", "timegrapher", "passage_times")


def _check_observation_model(table: Any, where: str) -> None:
    """Refuse an ``[observation] model`` no observation model has, listing every valid one."""
    if isinstance(table, Mapping) and "model" in table and table["model"] not in OBSERVATION_MODELS:
        raise SceneError(one_of("observation model", table["model"], OBSERVATION_MODELS),
                         f"{where} [observation].model")


def _read_restoring(osc: Mapping, doc: Mapping, switching: str, where: str) -> str:
    """``[oscillator] restoring``: ``"spring"`` (default) or ``"pendulum"``, with its refusals."""
    restoring = osc.get("restoring", "spring")
    if restoring not in ("spring", "pendulum"):
        raise SceneError(one_of("restoring", restoring, ("spring", "pendulum")), f"{where}.restoring")
    if restoring == "pendulum":
        effects = doc.get("effects", {})
        if isinstance(effects, Mapping) and "hairspring" in effects:
            raise SceneError("restoring = 'pendulum' takes its restoring torque from gravity (omega0**2 * sin(theta)) "
                             "and cannot be combined with [effects.hairspring]", f"{where}.restoring")
        if switching == "phase":
            raise SceneError("restoring = 'pendulum' needs switching = 'angle': phase switching assumes the fixed "
                             "half period of a linear spring", f"{where}.restoring")
    return restoring


def _linear_effects() -> tuple[str, ...]:
    """The effects that act on a mass on a spring (``coordinates`` holds ``"linear"``); the others act on an angle."""
    return tuple(key for key, cls in EFFECTS.items() if "linear" in getattr(cls, "coordinates", ()))


def _read_coordinate(osc: Mapping, doc: Mapping, restoring: str, switching: str, where: str) -> str:
    """``[oscillator] coordinate``: ``"angle"`` (default) or ``"linear"`` (a displacement in m), with its refusals."""
    coordinate = osc.get("coordinate", "angle")
    if coordinate not in ("angle", "linear"):
        raise SceneError(f"coordinate must be 'angle' or 'linear', got {coordinate!r}", f"{where}.coordinate")
    if coordinate == "angle":
        if "x0" in osc:
            raise SceneError("x0 is a linear oscillator's release displacement: with coordinate = 'linear'; a balance "
                             "or pendulum is released at theta0", f"{where}.x0")
        return coordinate
    for key, why in (("theta0", "give its release displacement as x0 (a length, e.g. \"5 cm\")"),
                     ("inertia", "give omega0 (rad/s); masses and forces enter per mass"),
                     ("stiffness", "give omega0 (rad/s); masses and forces enter per mass")):
        if key in osc:
            raise SceneError(f"a linear oscillator (coordinate = 'linear') takes no {key}: {why}", f"{where}.{key}")
    if restoring != "spring" or switching != "angle":
        raise SceneError("a linear oscillator (coordinate = 'linear') is a mass on a spring: restoring = 'spring' "
                         "and switching = 'angle'", f"{where}.coordinate")
    effects = doc.get("effects", {})
    other = sorted(set(effects) - set(_linear_effects())) if isinstance(effects, Mapping) else []
    if other:
        raise SceneError(f"effect(s) {other} act on a balance's angle; a linear oscillator takes "
                         f"{', '.join(_linear_effects())}", f"{where}.coordinate")
    return coordinate


def _read_x0(osc: Mapping, where: str) -> Param:
    """A linear oscillator's release displacement, m (``nan``: from the recording)."""
    meaning = "release displacement x0 (m); released at rest"
    if "x0" not in osc:
        return Param("oscillator.theta0", math.nan, "m", meaning + " (from the recording)")
    return read_param(osc["x0"], name="oscillator.theta0", kind="length", meaning=meaning, where=f"{where}.x0")


def _read_omega0(osc: Mapping, inertia: float | None, where: str) -> Param:
    meaning = "undamped natural frequency omega0 (rad/s)"
    if "omega0" in osc:
        if "stiffness" in osc:
            raise SceneError("give 'omega0' or 'stiffness' (with inertia), not both", where)
        return read_param(osc["omega0"], name="oscillator.omega0", kind="angular_frequency", lower=OMEGA0_RANGE[0],
                          upper=OMEGA0_RANGE[1], meaning=meaning, where=f"{where}.omega0")
    if "stiffness" not in osc:
        raise SceneError("give 'omega0' (rad/s) or 'stiffness' with 'inertia'", where)
    if inertia is None:
        raise SceneError("'stiffness' needs 'inertia' to give omega0", where)
    return read_param(osc["stiffness"], name="oscillator.omega0", kind="stiffness", lower=0.0, lower_open=True,
                      meaning=meaning, where=f"{where}.stiffness", convert=lambda k: math.sqrt(max(k, 0.0) / inertia),
                      unit="1/s")


def _resolve_ties(params: ParamSet) -> None:
    from dataclasses import replace

    for p in list(params):
        if p.tie is not None:
            other, factor = p.tie
            params.params[p.name] = replace(p, value=factor * params[other].value)
