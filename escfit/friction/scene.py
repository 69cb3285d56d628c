"""The ``friction_rig`` scene: rig geometry, friction laws and the reading noise.

Example::

    model = "friction_rig"

    [rig]
    k = { value = "2.0 inch", sd = "0.01 inch" }   # wire to contact point
    d = { value = "1.0 inch", sd = "0.01 inch" }   # wire height above the disc
    load_at = "reading"                            # the load column is the normal force

    [friction]
    mu = { value = 0.1, vary = true, min = 0.0, max = 1.0 }   # at load_ref, speed_ref
    mu_w = { value = 0, vary = true, prior = "normal(0, 0.02 / gf)" }   # optional, 1/N
    load_ref = "2.2 gf"
    mu_v = { value = 0, vary = true, prior = "normal(0, 0.005 s/ft)" }  # optional, s/m
    speed_ref = "6.5 ft/s"

    [observation]          # optional; without it the reading noise is estimated
    resolution = "0.5 inch"            # smallest readable step of the spot
    full_scale_load = "5 gf"           # load that moves the spot over the whole scale
    scale_length = "11.5 ft"

Geometry given with ``sd`` is a *measured* quantity: its error is shared by every reading
of the session and is sampled as a nuisance parameter with a normal prior.

The reading noise is the parameter ``observation.sigma`` (N, the standard deviation of one
``dw`` reading), the one noise vocabulary of every model family.  The ``[observation]`` table
gives it in one of three ways:

* ``sigma = "0.0074 gf"``: known (fixed); ``sigma = { value = ..., vary = true, min = ...,
  max = ..., prior = "..." }`` makes it free like any parameter;
* ``resolution`` with a calibration (``slope``, ``full_scale_load`` + ``scale_length`` or
  ``wire_stiffness`` + ``scale_distance``): known, ``sqrt(settings / 12) * resolution / slope``
  (uniform rounding of the spot in each of ``settings`` settings);
* no table (or an empty one): free, log-uniform on [1e-8, 1] N; least squares profiles it
  and the sampler samples it.

A scene still using the old ``[reading]`` table (``reading.sd``) is refused with a message
saying to rename it to ``[observation]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping

import pint

from ..core.errors import SceneError, UnitError
from ..core.params import Param, ParamSet, read_param
from ..core.scene import check_keys
from ..core.units import registry, to_canonical
from ..likelihood.priors import Prior, loguniform, normal, parse_prior, uniform
from .rig import LOAD_AT, load_sd_from_scale

__all__ = ["RigScene", "parse", "DEFAULT_SD_RANGE", "SIGMA"]

#: Bounds (N) of the log-uniform prior of the reading noise when the scene does not give it.
DEFAULT_SD_RANGE = (1e-8, 1.0)

SIGMA = "observation.sigma"
_GF_PER_N = 1000.0 / 9.80665  # gram-force per newton
_INCH = 0.0254  # m
_FT = 0.3048  # m
_TOP = {"model", "rig", "friction", "observation"}
_RIG = {"k", "d", "load_at"}
_FRICTION = {"mu", "mu_w", "load_ref", "mu_v", "speed_ref"}
_OBSERVATION = {"sigma", "resolution", "slope", "full_scale_load", "scale_length", "wire_stiffness",
            "scale_distance", "settings"}


@dataclass(frozen=True)
class RigScene:
    """A parsed friction-rig scene.

    Attributes
    ----------
    params
        ``rig.k``, ``rig.d`` (m), ``friction.mu``, optionally ``friction.mu_w`` (1/N) and
        ``friction.mu_v`` (s/m), and ``observation.sigma`` (N, the reading noise), all in
        canonical units.
    text, where
        Source TOML text and file name.
    load_at
        ``"reading"`` or ``"calibration"``: which load the readings' load column holds
        (see :data:`escfit.friction.rig.LOAD_AT`).
    load_ref, speed_ref
        Reference load (N) and speed (m/s) at which ``mu`` is quoted.
    priors
        Explicit prior of every parameter that a fit varies, by name.
    noise_note
        How ``observation.sigma`` was obtained (for reports and the results' notes).
    noise_route
        ``"sigma"`` (given in ``[observation]``, fixed or free), ``"resolution"`` (from the
        spot resolution and a calibration) or ``"estimated"`` (no ``[observation]``: free).
    """

    params: ParamSet
    text: str
    where: str
    load_at: str = "reading"
    load_ref: float = 0.0
    speed_ref: float = 0.0
    priors: Mapping[str, Prior] | None = None
    noise_note: str = ""
    noise_route: str = "estimated"
    model: str = "friction_rig"

    @property
    def laws(self) -> tuple[str, ...]:
        """Optional dependences of mu present in the scene: ``"load"``, ``"speed"``."""
        return tuple(law for law, name in (("load", "friction.mu_w"), ("speed", "friction.mu_v"))
                     if name in self.params)

    def free_names(self) -> list[str]:
        """Names of the parameters a posterior samples, in a fixed order."""
        return [p.name for p in self.params if p.name in (self.priors or {})]

    def with_geometry_sd(self, factor: float) -> "RigScene":
        """A copy with the standard deviations of ``rig.k`` and ``rig.d`` scaled by ``factor``."""
        params = ParamSet(dict(self.params.params))
        priors = dict(self.priors or {})
        for name in ("rig.k", "rig.d"):
            p = params[name]
            if p.sd is None:
                continue
            params.params[name] = replace(p, sd=p.sd * factor)
            pr = priors[name]
            if pr.kind == "normal":
                priors[name] = replace(pr, args=(pr.args[0], pr.args[1] * factor))
        return replace(self, params=params, priors=priors)


def parse(doc: Mapping[str, Any], *, where: str, text: str = "") -> RigScene:
    """Validate a friction-rig scene document and build its parameters and priors.

    Parameters
    ----------
    doc
        The parsed TOML document (``model = "friction_rig"``).
    where
        File name for messages.
    text
        The TOML source, kept for provenance.

    Raises
    ------
    SceneError
        Unknown or missing keys, ``d >= k``, non-positive geometry, bad units, a varying
        parameter without a proper prior or finite bounds, inconsistent ``[observation]`` keys,
        or the old ``[reading]`` table.  Messages name ``file [table.key]`` and the value.
    """
    if isinstance(doc, Mapping) and "reading" in doc:
        raise SceneError("the [reading] table is now [observation] (the reading noise is observation.sigma, "
                         "sd = ... is written sigma = ...): rename [reading] to [observation]", f"{where} [reading]")
    check_keys(doc, _TOP, where, required={"model", "rig", "friction"})
    rig = doc["rig"]
    check_keys(rig, _RIG, f"{where} [rig]", required={"k", "d"})
    fr = doc["friction"]
    check_keys(fr, _FRICTION, f"{where} [friction]", required={"mu"})

    params = ParamSet()
    k = read_param(rig["k"], name="rig.k", kind="length", lower=0.0, lower_open=True,
                   meaning="distance from the torsion wire to the pallet's contact point", where=f"{where} [rig.k]")
    d = read_param(rig["d"], name="rig.d", kind="length", lower=0.0, lower_open=True,
                   meaning="height of the torsion wire above the disc surface", where=f"{where} [rig.d]")
    if not d.value < k.value:
        raise SceneError(
            f"d = {_shown(rig['d'])} ({d.value:.6g} m) must be below k = {_shown(rig['k'])} ({k.value:.6g} m): "
            f"a stylus of length k hung from a wire at height d >= k cannot reach the disc",
            f"{where} [rig.d]",
        )
    params.add(k)
    params.add(d)
    load_at = rig.get("load_at", "reading")
    if load_at not in LOAD_AT:
        raise SceneError(f"load_at must be one of {list(LOAD_AT)}, got {load_at!r}", f"{where} [rig.load_at]")

    params.add(read_param(fr["mu"], name="friction.mu", kind="dimensionless", lower=0.0, where=f"{where} [friction.mu]",
                          meaning="sliding friction coefficient at the reference load and speed"))
    if "mu_w" in fr:
        params.add(_read_scaled(fr["mu_w"], "friction.mu_w", "1/N", f"{where} [friction.mu_w]",
                                "change of mu per unit normal load (positive: mu grows with load)"))
    if "mu_v" in fr:
        params.add(_read_scaled(fr["mu_v"], "friction.mu_v", "s/m", f"{where} [friction.mu_v]",
                                "change of mu per unit sliding speed (positive: mu grows with speed)"))
    for key, law in (("load_ref", "mu_w"), ("speed_ref", "mu_v")):
        if key in fr and law not in fr:
            raise SceneError(f"{key} is given but the law parameter {law} is not", f"{where} [friction.{key}]")
    load_ref = _quantity(fr.get("load_ref", 0.0), "force", f"{where} [friction.load_ref]", nonneg=True)
    speed_ref = _quantity(fr.get("speed_ref", 0.0), "m/s", f"{where} [friction.speed_ref]", nonneg=True)

    sd_param, note, route = _reading_sigma(doc.get("observation"), f"{where} [observation]", k.value, d.value)
    params.add(sd_param)
    priors = _priors(params, where)
    return RigScene(params=params, text=text, where=where, load_at=load_at, load_ref=load_ref,
                    speed_ref=speed_ref, priors=priors, noise_note=note, noise_route=route)


def _shown(raw: Any) -> str:
    value = raw.get("value") if isinstance(raw, Mapping) else raw
    return repr(value)


def _quantity(raw: Any, unit: str, where: str, *, nonneg: bool = False, positive: bool = False) -> float:
    """A number (canonical) or a string with unit, converted to ``unit`` (or a kind name)."""
    from ..core.units import CANONICAL

    if unit in CANONICAL:
        value = to_canonical(raw, unit, where)
    else:
        if isinstance(raw, bool) or not isinstance(raw, (int, float, str)):
            raise UnitError(f"expected a number or a string with a unit, got {raw!r}", where)
        if isinstance(raw, str):
            try:
                q = registry().Quantity(raw)
            except Exception:
                raise UnitError(f"cannot read {raw!r} as a quantity", where) from None
            try:
                value = float(q.to(unit).magnitude) if isinstance(q, pint.Quantity) else float(q)
            except pint.DimensionalityError:
                raise UnitError(f"{raw!r} is not in units of {unit}", where) from None
        else:
            value = float(raw)
        if not math.isfinite(value):
            raise UnitError(f"value {raw!r} is not finite", where)
    if positive and not value > 0:
        raise SceneError(f"must be positive, got {raw!r}", where)
    if nonneg and value < 0:
        raise SceneError(f"must be zero or positive, got {raw!r}", where)
    return value


def _read_scaled(raw: Any, name: str, unit: str, where: str, meaning: str) -> Param:
    """Read a parameter whose unit is not one of escfit's kinds (e.g. 1/N) into ``unit``."""
    if isinstance(raw, Mapping):
        conv = dict(raw)
        for key in ("value", "min", "max", "sd"):
            if key in conv:
                conv[key] = _quantity(conv[key], unit, f"{where}.{key}")
    else:
        conv = _quantity(raw, unit, where)
    p = read_param(conv, name=name, kind="dimensionless", meaning=meaning, where=where)
    return replace(p, unit=unit)


def _reading_sigma(table: Any, where: str, k: float, d: float) -> tuple[Param, str, str]:
    """The reading noise ``observation.sigma`` (sd of one ``dw`` reading, N) from ``[observation]``."""
    meaning = "standard deviation of one dw reading (reading noise)"
    if table is None or (isinstance(table, Mapping) and not table):
        lo, hi = DEFAULT_SD_RANGE
        return (Param(SIGMA, 1e-4, "N", meaning, True, lo, hi),
                f"reading noise observation.sigma estimated from the data (log-uniform prior on [{lo:g}, {hi:g}] N)",
                "estimated")
    if isinstance(table, Mapping) and "sd" in table:
        raise SceneError("unknown key 'sd': the reading noise is written sigma = ... (observation.sigma)",
                         f"{where}.sd")
    check_keys(table, _OBSERVATION, where)
    routes = [key for key in ("sigma", "slope", "full_scale_load", "wire_stiffness") if key in table]
    if len(routes) != 1:
        raise SceneError(
            f"give exactly one of sigma, slope, full_scale_load (with scale_length) or wire_stiffness "
            f"(with scale_distance); got {routes or 'none'}",
            where,
        )
    route = routes[0]
    if route == "sigma":
        extra = sorted(set(table) - {"sigma"})
        if extra:
            raise SceneError(f"keys {extra} are not used when sigma is given directly", where)
        p = read_param(table["sigma"], name=SIGMA, kind="force", lower=0.0, lower_open=True,
                       meaning=meaning, where=f"{where}.sigma")
        if p.vary and not (math.isfinite(p.min) and math.isfinite(p.max) and p.min > 0):
            lo, hi = max(p.min, DEFAULT_SD_RANGE[0]), min(p.max, DEFAULT_SD_RANGE[1])
            p = replace(p, min=lo, max=hi)
        return p, ("reading noise observation.sigma estimated (free in the scene)" if p.vary
                   else f"reading noise observation.sigma = {p.value:.4g} N, given in the scene"), "sigma"
    if "resolution" not in table:
        raise SceneError(f"{route} converts the scale resolution into a load; add resolution = ...", where)
    resolution = _quantity(table["resolution"], "length", f"{where}.resolution", positive=True)
    settings = table.get("settings", 2)
    if isinstance(settings, bool) or not isinstance(settings, int) or settings < 1:
        raise SceneError(f"settings must be a positive integer, got {settings!r}", f"{where}.settings")
    if route == "slope":
        _only(table, {"resolution", "slope", "settings"}, where)
        slope = _quantity(table["slope"], "m/N", f"{where}.slope", positive=True)
        how = f"calibration slope {slope / _INCH / _GF_PER_N:.4g} in/gf"
    elif route == "full_scale_load":
        _only(table, {"resolution", "full_scale_load", "scale_length", "settings"}, where)
        if "scale_length" not in table:
            raise SceneError("full_scale_load needs scale_length (the length of the scale it spans)", where)
        full = _quantity(table["full_scale_load"], "force", f"{where}.full_scale_load", positive=True)
        length = _quantity(table["scale_length"], "length", f"{where}.scale_length", positive=True)
        slope = length / full
        how = f"calibration spans {length / _FT:.4g} ft of scale for {full * _GF_PER_N:.4g} gf"
    else:
        _only(table, {"resolution", "wire_stiffness", "scale_distance", "settings"}, where)
        if "scale_distance" not in table:
            raise SceneError("wire_stiffness needs scale_distance (mirror to scale)", where)
        kappa = _quantity(table["wire_stiffness"], "stiffness", f"{where}.wire_stiffness", positive=True)
        dist = _quantity(table["scale_distance"], "length", f"{where}.scale_distance", positive=True)
        # the load's moment w*a twists the wire by w*a/kappa; the mirror doubles the angle
        slope = 2.0 * dist * math.sqrt(k * k - d * d) / kappa
        how = f"wire stiffness {kappa:.4g} N*m/rad at {dist:.4g} m"
    sd = load_sd_from_scale(resolution, slope, settings)
    # said in the rig's own units (gram-force, inches, feet), as its readings and the report's table
    note = (f"reading noise (observation.sigma) {sd * _GF_PER_N:.4g} gf = {sd:.4g} N: spot read to "
            f"{resolution / _INCH:.4g} in, {how}, uniform rounding in each of {settings} setting(s)")
    return Param(SIGMA, sd, "N", meaning), note, "resolution"


def _only(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    extra = sorted(set(table) - allowed)
    if extra:
        raise SceneError(f"keys {extra} do not belong with {sorted(allowed - {'resolution', 'settings'})}", where)


def _priors(params: ParamSet, where: str) -> dict[str, Prior]:
    """Explicit prior of every parameter that a posterior samples."""
    out: dict[str, Prior] = {}
    for p in params:
        key = f"{where} [{p.name}]"
        if p.prior is not None:
            out[p.name] = parse_prior(p.prior, unit=p.unit, where=f"{key}.prior", lower=p.min, upper=p.max)
        elif p.sd is not None:
            out[p.name] = normal(p.value, p.sd, p.min, p.max)
        elif p.vary and p.name == SIGMA:
            out[p.name] = loguniform(p.min, p.max)
        elif p.vary:
            if not (math.isfinite(p.min) and math.isfinite(p.max)):
                raise SceneError(
                    f"{p.name} varies but has no prior and the range [{p.min:g}, {p.max:g}] is open; "
                    f"add min and max or a prior such as \"normal(0, 0.1)\"",
                    key,
                )
            out[p.name] = uniform(p.min, p.max)
    return out
