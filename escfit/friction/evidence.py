"""Evidence for or against the optional friction laws (Savage-Dickey Bayes factors).

Monday reports two findings from his rig: no appreciable variation of mu with sliding
speed between 3 and 10 ft/s, and a slight change of mu with normal load.  Each is a point
hypothesis nested in a larger model: ``mu_v = 0`` inside ``mu = mu0 + mu_v (v - v_ref)`` and
``mu_w = 0`` inside ``mu = mu0 + mu_w (w - w_ref)``.  For such nested hypotheses, when the
prior of the coefficient is independent of the other parameters, the Bayes factor of the
null against the law is the Savage-Dickey ratio

    BF01 = p(coefficient = 0 | data, law) / p(coefficient = 0 | law),

the posterior density at zero over the prior density at zero.  It needs one posterior run
of the larger model, and unlike information criteria it charges the law for the prior
range it spreads its coefficient over (a vague prior favours the null), which is exactly
the question "is there appreciable variation?".  The prior of the coefficient must
therefore be proper and stated (a normal or a bounded uniform prior in the scene).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import xarray as xr
from scipy import stats

from ..core.errors import FitError
from .readers import Readings
from .rig import lever_ratio
from .scene import SIGMA, RigScene

__all__ = ["LawEvidence", "savage_dickey", "compare_laws", "HYPOTHESES"]

#: law parameter -> the null hypothesis it tests
HYPOTHESES = {
    "friction.mu_v": "no appreciable variation of mu with sliding speed",
    "friction.mu_w": "no change of mu with normal load",
}


@dataclass(frozen=True)
class LawEvidence:
    """Savage-Dickey Bayes factor of one null hypothesis.

    Attributes
    ----------
    parameter
        The law coefficient set to zero by the null (``friction.mu_v`` or ``friction.mu_w``).
    hypothesis
        The null hypothesis in words.
    bf01
        Bayes factor of the null against the law (> 1 favours the null).
    posterior_density, prior_density
        Densities of the coefficient at zero, in its canonical unit's inverse.
    method
        How the posterior density at zero was estimated: ``"conditional"`` (average over
        the draws of the exact conditional density of the coefficient given all other
        parameters; the default, valid because ``dw`` is linear in the law coefficients
        when the load column is the normal force), else ``"kde"`` (kernel density of the
        draws, when zero lies within 2 sd of the mean) or ``"normal"`` (normal
        approximation of the marginal, further out, where kernel densities are noise).
    mean, sd, ci95
        Posterior summary of the coefficient (canonical units).
    verdict
        Kass-Raftery wording of the strength of the evidence.
    """

    parameter: str
    hypothesis: str
    bf01: float
    posterior_density: float
    prior_density: float
    method: str
    mean: float
    sd: float
    ci95: tuple[float, float]
    verdict: str

    @property
    def log10_bf01(self) -> float:
        return math.log10(self.bf01) if self.bf01 > 0 else -math.inf


def _posterior(fit):
    """The posterior Dataset (dims chain, draw) of a FitResult, or the Dataset itself."""
    if hasattr(fit, "group") and hasattr(fit, "tree"):
        post = fit.group("posterior")
        if post is None:
            raise FitError("the fit has no posterior: fit with method = 'emcee'", getattr(fit, "path", "") or None)
        return post
    if isinstance(fit, xr.Dataset):
        return fit
    raise FitError(f"expected a FitResult or a posterior Dataset, got {type(fit).__name__}")


def _scene_of(fit, scene: RigScene | None) -> RigScene:
    if scene is not None:
        return scene
    text = fit.attrs.get("scene", "") if hasattr(fit, "attrs") else ""
    if not text:
        raise FitError("give the scene: the posterior carries no scene text")
    from ..core.scene import load_scene

    return load_scene(fit.attrs.get("scene_file") or "<fit scene>", text=text)


def _readings_of(fit, readings: Readings | None) -> Readings | None:
    """The session's readings: given, or from a FitResult's ``observed_data`` (dw, load, speed)."""
    if readings is not None or not hasattr(fit, "group"):
        return readings
    obs = fit.group("observed_data")
    if obs is None or "reading" not in obs or "x" not in obs.coords:
        return None
    speed = obs["speed"].values.astype(float) if "speed" in obs.coords else None
    return Readings(load=obs["x"].values.astype(float), dw=obs["reading"].values.astype(float), speed=speed,
                    where=str(fit.attrs.get("data_file", "<fit>")))


def savage_dickey(fit, scene: RigScene | None, parameter: str, *, readings: Readings | None = None) -> LawEvidence:
    """Bayes factor of ``parameter = 0`` from a posterior of the model that contains it.

    Parameters
    ----------
    fit
        A :class:`~escfit.results.FitResult` of an emcee fit of ``scene`` (``escfit fit
        --method emcee``, :func:`escfit.inference.fit`), or its ``posterior`` Dataset (dims
        ``chain, draw``).
    scene
        The scene sampled (supplies the coefficient's prior); ``None`` reads it from the
        FitResult's provenance.
    parameter
        ``"friction.mu_v"`` or ``"friction.mu_w"``.
    readings
        The session's readings, for the exact conditional density at zero; read from the
        FitResult's ``observed_data`` when omitted.  Without them (a bare posterior Dataset)
        the kernel-density or normal estimate is used.

    Raises
    ------
    FitError
        No posterior, the coefficient was not sampled, or its prior has no density at zero.
    """
    post = _posterior(fit)
    scene = _scene_of(fit, scene)
    if parameter not in post:
        raise FitError(f"{parameter} was not sampled; declare it with vary = true and a proper prior", scene.where)
    prior = scene.priors[parameter]
    prior_density = float(prior.pdf(0.0))
    if not prior_density > 0:
        raise FitError(f"the prior of {parameter} ({prior.describe()}) has no density at 0", scene.where)
    x = np.asarray(post[parameter].values, dtype=float).ravel()
    mean, sd = float(np.mean(x)), float(np.std(x))
    lo, hi = np.quantile(x, [0.025, 0.975])
    readings = _readings_of(fit, readings)
    conditional = None if readings is None else _conditional_density_at_zero(post, readings, scene, parameter)
    if conditional is not None:
        post_density, method = conditional, "conditional"
    elif sd > 0 and abs(mean) / sd <= 2.0:
        post_density, method = float(stats.gaussian_kde(x)(0.0)[0]), "kde"
    else:
        post_density, method = float(stats.norm.pdf(0.0, mean, sd)), "normal"
    bf01 = post_density / prior_density
    return LawEvidence(parameter, HYPOTHESES.get(parameter, f"{parameter} = 0"), bf01, post_density,
                       prior_density, method, mean, sd, (float(lo), float(hi)), _verdict(bf01))


def _conditional_density_at_zero(post, readings: Readings, scene: RigScene, parameter: str) -> float | None:
    """Rao-Blackwellised posterior density of a law coefficient at zero, or ``None``.

    Given every other parameter, ``dw`` is linear in the coefficient ``c``:
    ``dw_i = base_i + c * x_i``.  With normal reading errors and a normal (or flat) prior
    the conditional posterior of ``c`` is a normal truncated to the prior's support, whose
    density at zero is exact; averaging it over the posterior draws of the other
    parameters estimates the marginal density at zero with far less noise than a kernel
    density in the tail.  (The constraint ``mu >= 0`` at every reading is ignored here; it
    only matters when a reading's mu is within a few sd of zero.)
    """
    prior = scene.priors[parameter]
    if scene.load_at != "reading" or prior.kind not in ("normal", "uniform", "halfnormal"):
        return None
    if parameter == "friction.mu_v" and readings.speed is None:
        return None
    from .likelihood import build_model

    model = build_model(scene, readings)
    if any(n not in post for n in model.names):
        return None
    theta = np.column_stack([np.asarray(post[n].values, dtype=float).ravel() for n in model.names])
    values = model.unpack(theta)
    values[parameter] = np.zeros_like(values[parameter])
    per_mu = readings.load[None, :] / lever_ratio(values["rig.k"], values["rig.d"])[:, None]
    base = per_mu * model.mu(values)
    if parameter == "friction.mu_w":
        x = per_mu * (readings.load - scene.load_ref)[None, :]
    else:
        x = per_mu * (readings.speed - scene.speed_ref)[None, :]
    sd = values[SIGMA][:, None]
    prec = np.sum((x / sd) ** 2, axis=1)
    num = np.sum(x * (readings.dw[None, :] - base) / sd**2, axis=1)
    if prior.kind in ("normal", "halfnormal"):
        m0, s0 = (prior.args[0], prior.args[1]) if prior.kind == "normal" else (0.0, prior.args[0])
        prec, num = prec + 1.0 / s0**2, num + m0 / s0**2
    if not np.all(np.isfinite(num)) or not np.all(prec > 0):
        return None
    mean, scale = num / prec, 1.0 / np.sqrt(prec)
    lo, hi = prior.lo, prior.hi
    mass = stats.norm.cdf((hi - mean) / scale) - stats.norm.cdf((lo - mean) / scale)
    if not lo <= 0.0 <= hi:
        return 0.0
    return float(np.mean(stats.norm.pdf(0.0, mean, scale) / mass))


def compare_laws(fit, scene: RigScene | None = None, *, readings: Readings | None = None) -> dict[str, LawEvidence]:
    """Savage-Dickey evidence for every law coefficient the posterior sampled (see :func:`savage_dickey`)."""
    post = _posterior(fit)
    return {name: savage_dickey(fit, scene, name, readings=readings) for name in HYPOTHESES if name in post}


def _verdict(bf01: float) -> str:
    """Kass and Raftery (1995) scale on 2 ln B for whichever hypothesis is favoured."""
    if not bf01 > 0:
        return "decisive for the law"
    two_ln = 2.0 * abs(math.log(bf01))
    side = "the null" if bf01 >= 1 else "the law"
    if two_ln < 2:
        return f"not worth more than a bare mention (leans to {side})"
    if two_ln < 6:
        return f"positive for {side}"
    if two_ln < 10:
        return f"strong for {side}"
    return f"very strong for {side}"
