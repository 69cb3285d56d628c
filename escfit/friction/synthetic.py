"""Synthetic rig sessions with known friction, geometry and reading errors.

A session is generated exactly as the rig would produce it: the *true* geometry (which
may differ from the nominal one by a known error) and the friction law give the true
``dw`` of each reading, independent normal reading errors are added, and the result is
rounded to the resolution the readings are written with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .readers import Readings
from .rig import mu_law, predicted_dw

__all__ = ["SessionSpec", "make_session"]


@dataclass(frozen=True)
class SessionSpec:
    """Everything that defines one synthetic session (SI units).

    Attributes
    ----------
    mu
        Friction coefficient at ``load_ref``, ``speed_ref``.
    loads, speeds
        Loads (N) and speeds (m/s); every load is read at every speed.
    k, d
        True geometry, m.
    reading_sd
        Standard deviation of the reading error, N.
    mu_w, mu_v, load_ref, speed_ref
        Friction law (see :func:`escfit.friction.rig.mu_law`).
    load_at
        Meaning of the load column (see :data:`escfit.friction.rig.LOAD_AT`).
    centre_noise
        Remove the mean of the per-reading friction errors, so that the plain average of
        the per-reading ``mu`` at the true geometry equals the law's average exactly.
    round_to
        Round ``dw`` to this step, N (0: no rounding).
    material
        Material label written in every row (or ``None``).
    """

    mu: float
    loads: tuple[float, ...]
    speeds: tuple[float, ...]
    k: float
    d: float
    reading_sd: float
    mu_w: float = 0.0
    mu_v: float = 0.0
    load_ref: float = 0.0
    speed_ref: float = 0.0
    load_at: str = "reading"
    centre_noise: bool = False
    round_to: float = 0.0
    material: str | None = None


def make_session(spec: SessionSpec, seed: int, *, where: str = "<synthetic>") -> Readings:
    """Draw one session from ``spec`` with a ``numpy.random.default_rng(seed)`` generator.

    Readings are ordered load-major (all speeds of the first load first).
    """
    rng = np.random.default_rng(seed)
    load = np.repeat(np.asarray(spec.loads, dtype=float), len(spec.speeds))
    speed = np.tile(np.asarray(spec.speeds, dtype=float), len(spec.loads))
    mu = mu_law(spec.mu, load, speed, mu_w=spec.mu_w, mu_v=spec.mu_v,
                load_ref=spec.load_ref, speed_ref=spec.speed_ref)
    true_dw = predicted_dw(load, mu, spec.k, spec.d, spec.load_at)
    noise = spec.reading_sd * rng.standard_normal(load.size)
    if spec.centre_noise:
        # dw is proportional to the load, so the per-reading mu error is noise / dw_per_mu;
        # removing its mean keeps the noise normal-shaped while fixing the sample mean
        per_mu = true_dw / mu
        noise = noise - per_mu * np.mean(noise / per_mu)
    dw = true_dw + noise
    if spec.round_to > 0:
        dw = np.round(dw / spec.round_to) * spec.round_to
    dw = np.maximum(dw, 0.0)
    material = None if spec.material is None else tuple([spec.material] * load.size)
    return Readings(load=load, dw=dw, speed=speed, material=material,
                    lines=tuple(range(1, load.size + 1)), where=where)
