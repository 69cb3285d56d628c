"""How balance parameters change with the fixture load in a joint fit of several curves.

A ``[fit.loads]`` table in the scene says it:

``reference``
    The load at which the scene gives the escapement magnitudes (e.g. ``"100 g"``); the
    magnitudes scale in proportion to the load (the fixture's gain).
``friction``
    - ``"free"``: one ``coulomb.R[load=...]`` per load;
    - ``"shared"``: one ``coulomb.R`` for all loads;
    - ``"linear"``: ``R = coulomb.R + fit.kappa * (load - reference)``, kappa in rad/s^2 per
      load unit of the data;
    - ``"mu"``: ``R = coulomb.R + fit.mu * lever * (N - N_ref) / inertia`` with the normal force
      ``N`` from the load (a mass load is weighed at standard gravity), ``lever`` the friction
      radius and ``inertia`` the balance's moment of inertia.  ``mu_prior`` may name a friction
      rig results file: its ``friction.mu`` posterior becomes mu's (normal) prior, so rig and
      decay curves inform mu together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

from .. import BalanceScene
from ...core.errors import SceneError
from ...core.params import ParamSet, read_param
from ...analysis.recordings import UnitCurve
from ...core.scene import check_keys
from ...core.units import COMMON_UNITS, STANDARD_GRAVITY, common_convert, registry, to_canonical

__all__ = ["LoadRule"]

_KEYS = {"reference", "friction", "kappa", "mu", "lever", "inertia", "mu_prior"}


@dataclass
class LoadRule:
    """The load dependence of one joint fit (see the module docstring)."""

    reference: float = math.nan
    friction: str = "none"
    r_names: dict = field(default_factory=dict)
    windows: tuple = ()
    newton_per_unit: float = math.nan  # normal force per load unit of the data
    lever_over_inertia: float = math.nan  # 1/(kg*m)

    @classmethod
    def read(cls, table, scene: BalanceScene, data: UnitCurve, curves, params: ParamSet) -> "LoadRule":
        loads = [c.load for c in curves]
        if table is None:
            if len(curves) > 1:
                raise SceneError(f"the recording has {len(curves)} curves (loads {loads}); say how parameters depend "
                                 "on the load in a [fit.loads] table", scene.where)
            return cls()
        where = f"{scene.where} [fit.loads]"
        check_keys(table, _KEYS, where, {"reference"})
        if data.load is None:
            raise SceneError("[fit.loads] needs a load column (e.g. load_g) in the data", where)
        ref = table["reference"]
        ref_q = _load_in(ref, data.load_unit, f"{where}.reference") if isinstance(ref, str) else to_canonical(
            ref, "dimensionless", f"{where}.reference")
        friction = table.get("friction", "free")
        if friction not in ("free", "linear", "shared", "mu"):
            raise SceneError(f"friction must be 'free', 'shared', 'linear' or 'mu', got {friction!r}",
                             f"{where}.friction")
        rule = cls(ref_q, friction)
        esc = scene.effect("escapement")
        rule.windows = tuple(w.name for w in esc.windows) if esc else ()
        if "coulomb.R" not in params and friction != "shared":
            raise SceneError(f"friction = {friction!r} needs [effects.coulomb]", where)
        if friction == "free":
            base = params["coulomb.R"]
            del params.params["coulomb.R"]
            for ld in loads:
                name = f"coulomb.R[load={ld:g}]"
                rule.r_names[ld] = name
                params.add(replace(base, name=name, meaning=f"{base.meaning} at load {ld:g} {data.load_unit}"))
        elif friction == "linear":
            params.add(read_param(table.get("kappa", {"value": 0.0, "vary": True}), name="fit.kappa",
                                  kind="dimensionless", where=f"{where}.kappa",
                                  meaning=f"change of R per {data.load_unit or 'load unit'} of load (rad/s^2)"))
        elif friction == "mu":
            for key in ("lever", "inertia"):
                if key not in table:
                    raise SceneError(f"friction = 'mu' needs '{key}'", where)
            lever = to_canonical(table["lever"], "length", f"{where}.lever")
            inertia = to_canonical(table["inertia"], "inertia", f"{where}.inertia")
            if not (lever > 0 and inertia > 0):
                raise SceneError(f"lever and inertia must be positive, got {table['lever']!r}, {table['inertia']!r}", where)
            rule.lever_over_inertia = lever / inertia
            rule.newton_per_unit = _newton_per_unit(data.load_unit, where)
            mu = read_param(table.get("mu", {"value": 0.1, "vary": True, "min": 0.0, "max": 2.0}), name="fit.mu",
                            kind="dimensionless", lower=0.0, where=f"{where}.mu",
                            meaning="friction coefficient linking R to the normal force")
            if "mu_prior" in table:
                mu = replace(mu, prior=_rig_prior(table["mu_prior"], scene.where, f"{where}.mu_prior"))
            params.add(mu)
        return rule

    def apply(self, vals: Mapping[str, float], load: float) -> Mapping[str, float]:
        """Parameter values for one curve at ``load`` (in the data's load unit)."""
        if self.friction == "none" or math.isnan(load):
            return vals
        out = dict(vals)
        for name in self.windows:
            out[name] = vals[name] * load / self.reference
        if self.friction == "free":
            out["coulomb.R"] = vals[self.r_names[load]]
        elif self.friction == "linear":
            out["coulomb.R"] = vals["coulomb.R"] + vals["fit.kappa"] * (load - self.reference)
        elif self.friction == "mu":
            dn = (load - self.reference) * self.newton_per_unit
            out["coulomb.R"] = vals["coulomb.R"] + vals["fit.mu"] * self.lever_over_inertia * dn
        return out


def _load_in(text: str, unit: str, where: str) -> float:
    if (value := common_convert(text, unit or "g")) is not None:
        return value
    try:
        return float(registry().Quantity(text).to(unit or "g").magnitude)
    except Exception as exc:
        raise SceneError(f"cannot read {text!r} as a load in {unit or 'g'} ({exc})", where) from None


def _newton_per_unit(unit: str, where: str) -> float:
    kind, factor = COMMON_UNITS.get(unit or "g", (None, math.nan))
    if kind in ("mass", "force"):  # grams, kilograms, newtons: no pint
        return factor * STANDARD_GRAVITY if kind == "mass" else factor
    q = registry().Quantity(1.0, unit or "g")
    try:
        return float(q.to("N").magnitude)
    except Exception:  # a mass load: its weight at standard gravity
        try:
            return float((q * registry().Quantity(1.0, "standard_gravity")).to("N").magnitude)
        except Exception:
            raise SceneError(f"load unit {unit!r} is neither a mass nor a force", where) from None


def _rig_prior(path: str, scene_where: str, where: str) -> str:
    from pathlib import Path

    from ...results import load_fit

    p = Path(path)
    if not p.is_absolute():
        p = Path(scene_where).parent / p
    res = load_fit(p)
    post = res.group("posterior")
    if post is None or "friction.mu" not in post:
        raise SceneError(f"{p} holds no posterior of friction.mu (fit the rig with --method emcee)", where)
    x = post["friction.mu"].values.ravel()
    return f"normal({float(np.mean(x))!r}, {float(np.std(x, ddof=1))!r})"
