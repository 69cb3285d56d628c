"""Verge scenes: reading and validating ``model = "verge"`` TOML documents.

A scene holds one rotor-driven safing-and-arming mechanism with a straight-sided verge
runaway escapement (geometry, masses, gear train) and one operating point (spin rate,
friction, restitution, cut-off angle).  Layout (see ``datasets/verge/m739.toml``)::

    model = "verge"
    [verge]                        # operating point and fuze layout
    configuration = 2              # 1 or 2 (figures 1 and 2 of the report)
    spin = "30000 rpm"             # a unit is required (rpm, rps, Hz = rev/s, or rad/s)
    mu = 0.10                      # gear teeth, gear pivots, escape-wheel pivot
    mu1 = 0.10                     # verge faces and verge pivot; "mu" ties it to mu
    restitution = 0.0
    phi_cut = "1485 deg"           # cumulative escape-wheel angle at which gearing ends
    phi_start = "139 deg"          # escape-wheel angle at the start, on the entrance face
    rotor_start = "-120.134 deg"
    [verge.escapement]  a, b, c, alpha_en, alpha_ex, lambda, teeth, teeth_spanned
    [verge.bodies]      m1, m2, m3, mp, i1, i2, i3, ip, rc1, rcp, psi_c, rho_p, rho1, rho2, rho3
    [verge.fuze]        r1, r2, r3, r4
    [verge.gears]       ng1, ng2, np2, np3, caprp1, caprp2, rp2, rp3, theta1, theta2,
                        caprb1, caprb2, rb2, rb3, capro1, capro2, ro2, ro3, j1, j2
    [observation]       sigma: noise of a turns-to-arm reading (fits only; see
                        escfit/verge/problem.py, which checks the table)
    [fit]               step: RK4 step of fits, rad of spin (fits only)

Numbers without a unit are SI (m, kg, kg*m^2, rad); strings carry their unit
(``"0.226 in"``, ``"0.3165e-4 lbf*s**2/in"``, ``"43.5352 deg"``).  Every physical value may
be a free-parameter table ``{ value = ..., vary = true, min = ..., max = ..., prior = "..." }``
(see ``datasets/verge/m739_fit.toml``); ``mu1 = "mu"`` ties the escapement's coefficient to
the gear train's.
Parameters are named ``verge.<key>`` (``verge.mu``, ``verge.a``, ``verge.caprb1``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import pint

from ..core.errors import SceneError, UnitError
from ..core.params import Param, ParamSet, read_param
from ..core.scene import check_keys
from ..core.units import registry
from .geometry import Constants, build_constants
from .kinematics import coupled_kinematics

__all__ = ["VergeScene", "parse", "PARAM_SPECS", "to_report_units", "INCH", "LBF"]

INCH = 0.0254  # m
LBF = 4.4482216152605  # N

# SI -> report units (in, lbf*s^2/in, in*lbf*s^2, rad, rad/s)
_TO_REPORT = {
    "length": 1.0 / INCH,
    "mass": INCH / LBF,
    "inertia": 1.0 / (LBF * INCH),
    "angle": 1.0,
    "angular_frequency": 1.0,
    "dimensionless": 1.0,
}

# key -> (table, kind, meaning, lower, upper, lower_open)
PARAM_SPECS: dict[str, tuple[str, str, str, float, float, bool]] = {
    "spin": ("verge", "angular_frequency", "spin rate of the fuze body (stored in rad/s)", 0.0, math.inf, True),
    "mu": ("verge", "dimensionless", "friction coefficient of gear teeth, gear pivots and escape-wheel pivot",
           0.0, 1.0, False),
    "mu1": ("verge", "dimensionless", "friction coefficient of the verge faces and the verge pivot", 0.0, 1.0, False),
    "restitution": ("verge", "dimensionless", "coefficient of restitution of tooth/verge impacts", 0.0, 1.0, False),
    "phi_cut": ("verge", "angle", "cumulative escape-wheel angle at which the rotor leaves the train, rad",
                0.0, math.inf, True),
    "phi_start": ("verge", "angle", "escape-wheel angle at the start (entrance face), rad", -math.inf, math.inf,
                  False),
    "rotor_start": ("verge", "angle", "rotor angle at the start (PHI1C), rad", -math.inf, math.inf, False),
    "a": ("escapement", "length", "distance verge pivot - escape-wheel pivot, m", 0.0, math.inf, True),
    "b": ("escapement", "length", "escape-wheel tip radius, m", 0.0, math.inf, True),
    "c": ("escapement", "length", "verge radius to the face tips, m", 0.0, math.inf, True),
    "alpha_en": ("escapement", "angle", "entrance face angle, rad", -math.pi, math.pi, False),
    "alpha_ex": ("escapement", "angle", "exit face angle, rad", -math.pi, math.pi, False),
    "lambda": ("escapement", "angle", "angle between the entrance and exit verge radii, rad", 0.0, 2 * math.pi,
               True),
    "m1": ("bodies", "mass", "mass of the rotor, kg", 0.0, math.inf, True),
    "m2": ("bodies", "mass", "mass of gear and pinion 2, kg", 0.0, math.inf, True),
    "m3": ("bodies", "mass", "mass of escape wheel and pinion 3, kg", 0.0, math.inf, True),
    "mp": ("bodies", "mass", "mass of the verge, kg", 0.0, math.inf, True),
    "i1": ("bodies", "inertia", "moment of inertia of the rotor about its pivot, kg*m^2", 0.0, math.inf, True),
    "i2": ("bodies", "inertia", "moment of inertia of gear and pinion 2, kg*m^2", 0.0, math.inf, True),
    "i3": ("bodies", "inertia", "moment of inertia of escape wheel and pinion 3, kg*m^2", 0.0, math.inf, True),
    "ip": ("bodies", "inertia", "moment of inertia of the verge about its pivot, kg*m^2", 0.0, math.inf, True),
    "rc1": ("bodies", "length", "rotor centre-of-mass offset from its pivot, m", 0.0, math.inf, False),
    "rcp": ("bodies", "length", "verge centre-of-mass offset from its pivot, m", 0.0, math.inf, False),
    "psi_c": ("bodies", "angle", "verge eccentricity angle (centre of mass from the entrance radius), rad",
              -math.inf, math.inf, False),
    "rho_p": ("bodies", "length", "verge pivot radius, m", 0.0, math.inf, False),
    "rho1": ("bodies", "length", "rotor pivot radius, m", 0.0, math.inf, False),
    "rho2": ("bodies", "length", "pivot radius of gear set 2, m", 0.0, math.inf, False),
    "rho3": ("bodies", "length", "escape-wheel pivot radius, m", 0.0, math.inf, False),
    "r1": ("fuze", "length", "rotor pivot distance from the spin axis, m", 0.0, math.inf, True),
    "r2": ("fuze", "length", "gear-set-2 pivot distance from the spin axis, m", 0.0, math.inf, True),
    "r3": ("fuze", "length", "escape-wheel pivot distance from the spin axis, m", 0.0, math.inf, True),
    "r4": ("fuze", "length", "verge pivot distance from the spin axis, m", 0.0, math.inf, True),
    "caprp1": ("gears", "length", "operating pitch radius of the rotor (gear 1), m", 0.0, math.inf, True),
    "caprp2": ("gears", "length", "operating pitch radius of gear 2, m", 0.0, math.inf, True),
    "rp2": ("gears", "length", "operating pitch radius of pinion 2, m", 0.0, math.inf, True),
    "rp3": ("gears", "length", "operating pitch radius of pinion 3 (escape wheel), m", 0.0, math.inf, True),
    "theta1": ("gears", "angle", "operating pressure angle of mesh 1, rad", 0.0, math.pi / 2, True),
    "theta2": ("gears", "angle", "operating pressure angle of mesh 2, rad", 0.0, math.pi / 2, True),
    "caprb1": ("gears", "length", "base radius of gear 1, m", 0.0, math.inf, True),
    "caprb2": ("gears", "length", "base radius of gear 2, m", 0.0, math.inf, True),
    "rb2": ("gears", "length", "base radius of pinion 2, m", 0.0, math.inf, True),
    "rb3": ("gears", "length", "base radius of pinion 3, m", 0.0, math.inf, True),
    "capro1": ("gears", "length", "outside radius of gear 1, m", 0.0, math.inf, True),
    "capro2": ("gears", "length", "outside radius of gear 2, m", 0.0, math.inf, True),
    "ro2": ("gears", "length", "outside radius of pinion 2, m", 0.0, math.inf, True),
    "ro3": ("gears", "length", "outside radius of pinion 3, m", 0.0, math.inf, True),
    "j1": ("gears", "dimensionless", "initial contact phase of mesh 1 (0 earliest, 1 latest)", 0.0, 1.0, False),
    "j2": ("gears", "dimensionless", "initial contact phase of mesh 2 (0 earliest, 1 latest)", 0.0, 1.0, False),
}

# name in the compiled model's vocabulary (geometry.build_constants) for each scene key
_MODEL_NAME = {"alpha_en": "alphen", "alpha_ex": "alphex", "psi_c": "psicc", "rho_p": "rhop",
               "rotor_start": "phi1c"}

INT_SPECS: dict[str, tuple[str, str, int, int]] = {
    "configuration": ("verge", "fuze-body configuration", 1, 2),
    "teeth": ("escapement", "number of escape-wheel teeth", 3, 1000),
    "teeth_spanned": ("escapement", "escape-wheel teeth spanned by the verge", 1, 999),
    "ng1": ("gears", "teeth of the rotor (gear 1)", 3, 10000),
    "ng2": ("gears", "teeth of gear 2", 3, 10000),
    "np2": ("gears", "teeth of pinion 2", 3, 10000),
    "np3": ("gears", "teeth of pinion 3", 3, 10000),
}

TABLES = ("escapement", "bodies", "fuze", "gears")
TOP_KEYS = {"model", "title", "verge", "observation", "fit"}
VERGE_KEYS = {"configuration", "spin", "mu", "mu1", "restitution", "phi_cut", "phi_start", "rotor_start",
              "capture_speed", *TABLES}
DEFAULT_CAPTURE_SPEED = 2.0 * INCH  # m/s, the report program's threshold of 2 in/s


@dataclass(frozen=True)
class VergeScene:
    """A rotor-driven S&A mechanism with a verge runaway escapement at one operating point.

    Attributes
    ----------
    params : ParamSet
        All physical values in SI (see :data:`PARAM_SPECS`); ``verge.spin`` in rad/s.
        ``verge.mu1`` may be tied to ``verge.mu`` (the report's "system coefficient").
    configuration : int
        Fuze-body layout, 1 or 2.
    teeth, teeth_spanned : int
        Escape-wheel teeth ``N`` and teeth spanned by the verge ``NT``.
    ng1, ng2, np2, np3 : int
        Tooth counts of rotor, gear 2, pinion 2 and pinion 3.
    capture_speed : float
        Relative normal speed after an impact below which the tooth stays on the face
        (m/s); only matters when ``restitution > 0``.
    text, where, title : str
        TOML source, file name and title.
    extra : Mapping
        ``observation`` and ``fit`` tables, kept verbatim for the fitting layer.
    """

    params: ParamSet
    configuration: int
    teeth: int
    teeth_spanned: int
    ng1: int
    ng2: int
    np2: int
    np3: int
    capture_speed: float
    text: str
    where: str
    title: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)
    model: str = "verge"

    @property
    def spin_rpm(self) -> float:
        """Spin rate in revolutions per minute."""
        return self.params["verge.spin"].value * 60.0 / (2 * math.pi)

    def with_values(self, values: Mapping[str, float]) -> "VergeScene":
        """A copy whose parameters take the given values (SI; spin in rad/s)."""
        return replace(self, params=self.params.with_values(values))

    def constants(self, values: Mapping[str, float] | None = None) -> Constants:
        """The compiled model's constants (report units) for these or overridden values."""
        vals = self.params.values()
        if values:
            for name, x in values.items():
                key = name.removeprefix("verge.")
                if name not in self.params:
                    raise SceneError(f"unknown parameter {name!r}", self.where)
                _table, _kind, meaning, lower, upper, lower_open = PARAM_SPECS[key]
                if not (math.isfinite(x) and (x > lower if lower_open else x >= lower) and x <= upper):
                    raise SceneError(f"{name} = {x!r} is outside the physical range of the {meaning}", self.where)
            vals.update(values)
            for p in self.params:
                if p.tie is not None and p.name not in values:
                    vals[p.name] = p.tie[1] * vals[p.tie[0]]
        return _constants(self, vals)

    def phi_start(self) -> float:
        """Starting escape-wheel angle (rad)."""
        return self.params["verge.phi_start"].value


def to_report_units(key: str, value: float) -> float:
    """Convert an SI scene value of parameter ``key`` to the model's inch-lbf-s units."""
    return value * _TO_REPORT[PARAM_SPECS[key][1]]


def _constants(scene: VergeScene, vals: Mapping[str, float]) -> Constants:
    v = {_MODEL_NAME.get(key, key): to_report_units(key, vals[f"verge.{key}"]) for key in PARAM_SPECS}
    v["capture_speed"] = scene.capture_speed / INCH
    ints = {"n": scene.teeth, "nt": scene.teeth_spanned, "configuration": scene.configuration,
            "ng1": scene.ng1, "ng2": scene.ng2, "np2": scene.np2, "np3": scene.np3}
    return build_constants(v, ints, scene.where)


def _read_int(table: Mapping[str, Any], key: str, where: str) -> int:
    _tab, meaning, lo, hi = INT_SPECS[key]
    raw = table[key]
    if isinstance(raw, bool) or not isinstance(raw, int) or not lo <= raw <= hi:
        raise SceneError(f"{meaning} must be a whole number in [{lo}, {hi}], got {raw!r}", where)
    return raw


def _spin_raw(raw: Any, where: str) -> Any:
    """Insist on a unit for the spin rate (read by :func:`escfit.core.units.angular_frequency`:
    ``"500 Hz"`` is 500 turns per second, 30000 rpm)."""
    value = raw.get("value") if isinstance(raw, Mapping) else raw
    if not isinstance(value, str):
        raise UnitError(f"give the spin rate with its unit, e.g. '30000 rpm', got {value!r}", where)
    return raw


def _speed(raw: Any, where: str) -> float:
    if isinstance(raw, bool) or not isinstance(raw, (int, float, str)):
        raise UnitError(f"expected a speed such as '2 in/s', got {raw!r}", where)
    try:
        q = registry().Quantity(raw) if isinstance(raw, str) else registry().Quantity(float(raw), "m/s")
        value = float(q.to("m/s").magnitude)
    except (pint.DimensionalityError, pint.UndefinedUnitError, ValueError, AttributeError) as exc:
        raise UnitError(f"cannot read {raw!r} as a speed ({exc})", where) from None
    if not (value >= 0 and math.isfinite(value)):
        raise SceneError(f"must be a non-negative speed, got {raw!r}", where)
    return value


def parse(doc: Mapping[str, Any], *, where: str, text: str) -> VergeScene:
    """Validate a verge scene document.

    Parameters
    ----------
    doc
        The parsed TOML document (``model = "verge"``).
    where
        File name used in messages.
    text
        The TOML source, kept for provenance.

    Returns
    -------
    VergeScene

    Raises
    ------
    SceneError
        Unknown or missing keys, values outside their physical range, wrong units, a
        configuration other than 1 or 2, pivot distances that cannot form the fuze-body
        triangles, pitch radii inconsistent with the tooth counts, base or outside radii
        inconsistent with the pitch radii, or a starting angle at which the tooth cannot
        touch the entrance face.  The message names the file, the key and the value.
    """
    check_keys(doc, TOP_KEYS, where, {"model", "verge"})
    vw = f"{where} [verge]"
    top = doc["verge"]
    check_keys(top, VERGE_KEYS, vw, {"configuration", "spin", "mu", "mu1", "phi_cut", "phi_start", "rotor_start",
                                     *TABLES})
    tables: dict[str, Mapping[str, Any]] = {"verge": top}
    for name in TABLES:
        keys = {k for k, spec in PARAM_SPECS.items() if spec[0] == name} | {
            k for k, spec in INT_SPECS.items() if spec[0] == name}
        optional = {"rcp", "psi_c", "j1", "j2"}
        check_keys(top[name], keys, f"{where} [verge.{name}]", keys - optional)
        tables[name] = top[name]

    def loc(table: str, key: str) -> str:
        return f"{where} [verge.{key}]" if table == "verge" else f"{where} [verge.{table}.{key}]"

    defaults = {"restitution": 0.0, "rcp": 0.0, "psi_c": 0.0, "j1": 0.0, "j2": 0.0}
    params = ParamSet()
    mu1_tied = False
    for key, (table, kind, meaning, lower, upper, lower_open) in PARAM_SPECS.items():
        raw = tables[table].get(key, defaults.get(key))
        w = loc(table, key)
        if key == "mu1" and raw == "mu":
            mu1_tied = True
            continue
        if key == "spin":
            raw = _spin_raw(raw, w)
        params.add(read_param(raw, name=f"verge.{key}", kind=kind, meaning=meaning, where=w, lower=lower,
                              upper=upper, lower_open=lower_open))
    if mu1_tied:
        mu = params["verge.mu"]
        params.add(Param("verge.mu1", mu.value, "", PARAM_SPECS["mu1"][2] + " (tied to verge.mu)", False, mu.min,
                         mu.max, None, ("verge.mu", 1.0)))
    ints = {key: _read_int(tables[table], key, loc(table, key)) for key, (table, *_r) in INT_SPECS.items()}
    if ints["teeth_spanned"] >= ints["teeth"]:
        raise SceneError(f"the verge cannot span {ints['teeth_spanned']} of {ints['teeth']} teeth",
                         loc("escapement", "teeth_spanned"))
    capture = _speed(top.get("capture_speed", "2 in/s"), loc("verge", "capture_speed"))
    scene = VergeScene(params, ints["configuration"], ints["teeth"], ints["teeth_spanned"], ints["ng1"], ints["ng2"],
                       ints["np2"], ints["np3"], capture, text, where, str(doc.get("title", "")),
                       {k: doc[k] for k in ("observation", "fit") if k in doc})
    _check_gears(scene, tables, loc)
    _check_start(scene, tables, loc)
    return scene


def _check_gears(scene: VergeScene, tables, loc) -> None:
    p = {key: scene.params[f"verge.{key}"].value for key in PARAM_SPECS if f"verge.{key}" in scene.params}
    meshes = (("caprp1", "rp2", scene.ng1, scene.np2, "ng1/np2"), ("caprp2", "rp3", scene.ng2, scene.np3, "ng2/np3"))
    for big, small, nb, ns, ratio in meshes:
        r = p[big] / p[small]
        if abs(r / (nb / ns) - 1.0) > 0.005:
            raw = tables["gears"][small]
            raise SceneError(f"pitch radii {big}/{small} = {r:.4f} do not match the tooth ratio {ratio} = "
                             f"{nb / ns:.4f} ({small} = {raw!r})", loc("gears", small))
    pairs = (("caprb1", "caprp1", "capro1", "theta1"), ("caprb2", "caprp2", "capro2", "theta2"),
             ("rb2", "rp2", "ro2", "theta1"), ("rb3", "rp3", "ro3", "theta2"))
    for base, pitch, outside, theta in pairs:
        expect = p[pitch] * math.cos(p[theta])
        if abs(p[base] / expect - 1.0) > 0.005:
            raise SceneError(f"base radius {tables['gears'][base]!r} should equal {pitch} * cos({theta}) = "
                             f"{expect / INCH:.5f} in", loc("gears", base))
        if not p[outside] > p[pitch]:
            raise SceneError(f"outside radius {tables['gears'][outside]!r} must exceed the pitch radius {pitch}",
                             loc("gears", outside))


def _check_start(scene: VergeScene, tables, loc) -> None:
    k = scene.constants()  # also checks the fuze-body triangles
    phi0 = scene.phi_start()
    psi, g, *_ = coupled_kinematics(k.a, k.b, k.c, k.alpha_en, phi0)
    if not (math.isfinite(psi) and g > 0.0):
        raise SceneError(f"at phi_start = {tables['verge']['phi_start']!r} the tooth does not rest on the entrance "
                         f"face (contact position g = {g:.4g} in; it must be positive)", loc("verge", "phi_start"))
