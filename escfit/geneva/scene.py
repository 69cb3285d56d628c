"""Geneva scenes: reading and validating ``model = "geneva"`` TOML documents.

Example::

    model = "geneva"
    [geneva]
    slots = 4                              # 3, 4 or 6 (pins m = 2n/(n - 2))
    driver_inertia = "3e-6 lbf*inch*s^2"
    follower_inertia = "50e-6 lbf*inch*s^2"
    torque = "0.08 lbf*inch"               # constant driving torque K
    mu = 0.20                              # pin-slot friction coefficient
    compat = "none"                        # or "meyer1973"
    [run]
    duration = "0.2 s"
    sample_interval = "0.1 ms"

Numbers without a unit are SI.  Any of the four physical values may be a free parameter
table ``{ value = ..., vary = true, min = ..., max = ..., prior = "..." }``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

from ..core.errors import SceneError
from ..core.params import ParamSet, read_param
from ..core.scene import check_keys
from ..core.units import to_canonical
from .geometry import ALLOWED_SLOTS, COMPAT_MODES, Geometry

__all__ = ["GenevaScene", "parse", "PARAM_NAMES"]

TOP_KEYS = {"model", "title", "geneva", "run", "observation", "fit"}
GENEVA_KEYS = {"slots", "driver_inertia", "follower_inertia", "torque", "mu", "compat"}
RUN_KEYS = {"duration", "sample_interval"}

PARAM_NAMES = ("geneva.driver_inertia", "geneva.follower_inertia", "geneva.torque", "geneva.mu")


@dataclass(frozen=True)
class GenevaScene:
    """A Geneva escapement driven by a constant torque from rest.

    Attributes
    ----------
    geometry
        Slots and engagement convention (structure only).
    params
        ``geneva.driver_inertia`` (kg*m^2), ``geneva.follower_inertia`` (kg*m^2),
        ``geneva.torque`` (N*m, positive in the driving sense) and ``geneva.mu``.
    duration
        Simulated time from rest, s.
    sample_interval
        Spacing of the output time grid, s.
    text, where
        Source TOML text and file name.
    extra
        Tables other layers read (``observation``, ``fit``), kept verbatim.
    """

    geometry: Geometry
    params: ParamSet
    duration: float
    sample_interval: float
    text: str
    where: str
    title: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)
    model: str = "geneva"

    @property
    def slots(self) -> int:
        """Number of follower slots."""
        return self.geometry.slots

    @property
    def compat(self) -> str:
        """Engagement convention (``"none"`` or ``"meyer1973"``)."""
        return self.geometry.compat

    def with_values(self, values: Mapping[str, float]) -> "GenevaScene":
        """A copy whose parameters take the given values (SI)."""
        return replace(self, params=self.params.with_values(values))


def parse(doc: Mapping[str, Any], *, where: str, text: str) -> GenevaScene:
    """Validate a Geneva scene document.

    Parameters
    ----------
    doc
        The parsed TOML document (``model = "geneva"``).
    where
        File name used in messages.
    text
        The TOML source, kept for provenance.

    Raises
    ------
    SceneError
        Unknown or missing keys, slots not 3, 4 or 6, non-positive inertia or torque,
        negative friction, an unknown ``compat``, or values with the wrong unit; the
        message names the file, key and value.
    """
    check_keys(doc, TOP_KEYS, where, {"model", "geneva"})
    gw = f"{where} [geneva]"
    g = doc["geneva"]
    check_keys(g, GENEVA_KEYS, gw, {"slots", "driver_inertia", "follower_inertia", "torque", "mu"})
    slots = g["slots"]
    if isinstance(slots, bool) or not isinstance(slots, int) or slots not in ALLOWED_SLOTS:
        raise SceneError(f"slots must be 3, 4 or 6 (pins 6, 4, 3: m = 2n/(n-2) must be whole), got {slots!r}",
                         f"{gw}.slots")
    compat = g.get("compat", "none")
    if compat not in COMPAT_MODES:
        raise SceneError(f"compat must be one of {list(COMPAT_MODES)}, got {compat!r}", f"{gw}.compat")
    params = ParamSet()
    params.add(read_param(g["driver_inertia"], name="geneva.driver_inertia", kind="inertia", lower=0.0,
                          lower_open=True, meaning="moment of inertia of the pin wheel (driver), kg*m^2",
                          where=f"{gw}.driver_inertia"))
    params.add(read_param(g["follower_inertia"], name="geneva.follower_inertia", kind="inertia", lower=0.0,
                          lower_open=True, meaning="moment of inertia of the slotted wheel (follower), kg*m^2",
                          where=f"{gw}.follower_inertia"))
    params.add(read_param(g["torque"], name="geneva.torque", kind="torque", lower=0.0, lower_open=True,
                          meaning="constant driving torque K on the driver, N*m, positive in the driving sense",
                          where=f"{gw}.torque"))
    params.add(read_param(g["mu"], name="geneva.mu", kind="dimensionless", lower=0.0,
                          meaning="pin-slot (Coulomb) friction coefficient", where=f"{gw}.mu"))
    run = doc.get("run", {})
    rw = f"{where} [run]"
    check_keys(run, RUN_KEYS, rw)
    duration = _positive_time(run.get("duration", 0.2), f"{rw}.duration")
    interval = _positive_time(run.get("sample_interval", 1e-4), f"{rw}.sample_interval")
    if interval > duration:
        raise SceneError(f"sample_interval {run.get('sample_interval')!r} is longer than the duration "
                         f"{run.get('duration', 0.2)!r}", f"{rw}.sample_interval")
    title = doc.get("title", "")
    extra = {k: doc[k] for k in ("observation", "fit") if k in doc}
    return GenevaScene(Geometry(slots, compat), params, duration, interval, text, where, str(title), extra)


def _positive_time(raw: Any, where: str) -> float:
    value = to_canonical(raw, "time", where)
    if not (value > 0 and math.isfinite(value)):
        raise SceneError(f"must be a positive time, got {raw!r}", where)
    return value
