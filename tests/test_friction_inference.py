"""Rig sessions on the one inference layer (least squares and emcee of :mod:`escfit.inference`):
recovery of known friction with shared geometry errors, interval widths, coverage, the
posterior's structure, and Savage-Dickey evidence against a closed form."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import stats

from escfit.core.errors import FitError
from escfit.friction import compare_laws, json_summary
from escfit.friction.family import FAMILY
from escfit.friction.readers import Readings
from escfit.friction.rig import lever_ratio
from escfit.friction.synthetic import SessionSpec, make_session
from escfit.core.scene import load_scene
from escfit.inference import fit_problem, least_squares
from escfit.results import load_fit

GF = 0.00980665
IN = 0.0254
FT_S = 0.3048
LOADS = tuple(np.array([1.2, 1.7, 2.2, 2.7, 3.2]) * GF)
SPEEDS = tuple(np.array([3.0, 5.0, 7.5, 10.0]) * FT_S)
SD = 0.0074 * GF  # reading sd of the assumed rig, N


def rig_scene(*, geom_sd="0.01 inch", reading=f'sigma = "{0.0074} gf"', friction="", load_at="reading"):
    geometry = (f'k = {{ value = "2.0 inch", sd = "{geom_sd}" }}\nd = {{ value = "1.0 inch", sd = "{geom_sd}" }}\n'
                if geom_sd else 'k = "2.0 inch"\nd = "1.0 inch"\n')
    text = (f'model = "friction_rig"\n[rig]\n{geometry}load_at = "{load_at}"\n[friction]\n'
            f'mu = {{ value = 0.1, vary = true, min = 0.0, max = 1.0 }}\n{friction}')
    if reading:
        text += f"[observation]\n{reading}\n"
    return load_scene("rig.toml", text=text)


def session(mu=0.1, k=2.0 * IN, d=1.0 * IN, seed=0, sd=SD, **kw):
    return make_session(SessionSpec(mu=mu, loads=LOADS, speeds=SPEEDS, k=k, d=d, reading_sd=sd, **kw), seed)


def lsq_fit(scene, readings, **kw):
    """The one least-squares driver on a rig session (multistart over the priors)."""
    return least_squares(FAMILY.problem(scene, readings), **kw)


def interval(fit, name, level=0.95):
    """Normal-approximation interval of a least-squares estimate."""
    i = fit.names.index(name)
    z = stats.norm.ppf(0.5 + level / 2)
    return fit.value[i] - z * fit.stderr[i], fit.value[i] + z * fit.stderr[i]


def value(fit, name):
    return fit.value[fit.names.index(name)]


def stderr(fit, name):
    return fit.stderr[fit.names.index(name)]


def posterior_fit(scene, readings, *, nwalkers=64, nsteps=1200, burn=300, seed=0):
    """Least squares then emcee through :func:`escfit.inference.fit_problem` (a FitResult).

    The log posterior is vectorised over the ensemble, so a step costs about the same for 16
    or 64 walkers: many walkers and few steps (here about 30 autocorrelation times kept per
    walker, 57 600 draws) buy the same precision as the old 32 x 3000 run at a third of the cost.
    """
    return fit_problem(FAMILY.problem(scene, readings), method="emcee", walkers=nwalkers, steps=nsteps, burn=burn,
                       seed=seed, predictive_draws=nwalkers)


def draws(result, name):
    return result.group("posterior")[name].values


def ci95(result, name):
    return np.quantile(draws(result, name).ravel(), [0.025, 0.975])


def geometry_rel_sd(k, d, sd):
    """Linearised sd of ln(a/d) for independent errors sd in k and d."""
    dk = k / (k * k - d * d)
    dd = -d / (k * k - d * d) - 1 / d
    return sd * math.hypot(dk, dd)


def reading_rel_sd(mu, k, d, sd, n_speeds=len(SPEEDS)):
    """Relative sd of mu from reading errors alone: dw = mu w / r, least squares through 0."""
    w = np.repeat(LOADS, n_speeds)
    return lever_ratio(k, d) * sd / math.sqrt(np.sum(w**2)) / mu


def test_fixed_geometry_least_squares_is_the_closed_form():
    s = rig_scene(geom_sd=None)
    r = session(seed=3)
    fit = lsq_fit(s, r)
    ratio = lever_ratio(2 * IN, 1 * IN)
    mu_hat = ratio * np.sum(r.load * r.dw) / np.sum(r.load**2)
    assert value(fit, "friction.mu") == pytest.approx(mu_hat, rel=1e-7)
    assert stderr(fit, "friction.mu") == pytest.approx(ratio * SD / math.sqrt(np.sum(r.load**2)), rel=1e-6)
    assert fit.names == ["friction.mu"] and not fit.profiled  # the stated noise is known: no rescaling
    assert fit.sigma_hat == pytest.approx(SD)


def test_known_geometry_error_recovered_within_95_percent():
    # the session's stylus is 1 sd longer and its wire 1 sd lower than measured
    k_true, d_true = 2.01 * IN, 0.99 * IN
    s = rig_scene()
    r = session(mu=0.125, k=k_true, d=d_true, seed=11)
    res = posterior_fit(s, r, seed=5)
    lo, hi = ci95(res, "friction.mu")
    assert lo < 0.125 < hi
    # the data cannot see the geometry error: the estimate moves by the ratio of lever ratios
    expected = 0.125 * lever_ratio(2 * IN, 1 * IN) / lever_ratio(k_true, d_true)
    post = draws(res, "friction.mu")
    rel = math.hypot(geometry_rel_sd(2 * IN, 1 * IN, 0.01 * IN), reading_rel_sd(0.125, 2 * IN, 1 * IN, SD))
    assert abs(post.mean() - expected) < 1.5 * rel * 0.125
    assert post.std() == pytest.approx(rel * 0.125, rel=0.1)


def test_ignoring_geometry_uncertainty_misses_a_three_sd_geometry_error():
    k_true, d_true = 2.03 * IN, 0.97 * IN
    r = session(mu=0.125, k=k_true, d=d_true, seed=11)
    honest = interval(lsq_fit(rig_scene(geom_sd="0.01 inch"), r), "friction.mu")
    blind = interval(lsq_fit(rig_scene(geom_sd=None), r), "friction.mu")
    assert not blind[0] < 0.125 < blind[1]
    assert (honest[1] - honest[0]) > 1.5 * (blind[1] - blind[0])


def test_interval_widens_with_geometry_uncertainty():
    r = session(mu=0.1, seed=21)
    sharp = posterior_fit(rig_scene(geom_sd="0.01 inch"), r, seed=1)
    vague = posterior_fit(rig_scene(geom_sd="0.03 inch"), r, seed=1)
    w1 = np.diff(ci95(sharp, "friction.mu"))[0]
    w3 = np.diff(ci95(vague, "friction.mu"))[0]
    g = geometry_rel_sd(2 * IN, 1 * IN, 0.01 * IN)
    e = reading_rel_sd(0.1, 2 * IN, 1 * IN, SD)
    predicted = math.hypot(3 * g, e) / math.hypot(g, e)
    assert predicted == pytest.approx(2.39, abs=0.01)
    assert w3 / w1 == pytest.approx(predicted, rel=0.1)
    # the Laplace approximation of the least-squares fit tells the same story
    ls1 = stderr(lsq_fit(rig_scene(geom_sd="0.01 inch"), r), "friction.mu")
    ls3 = stderr(lsq_fit(rig_scene(geom_sd="0.03 inch"), r), "friction.mu")
    assert ls3 / ls1 == pytest.approx(predicted, rel=0.03)


def test_least_squares_intervals_cover_when_geometry_is_drawn_from_its_prior():
    rng = np.random.default_rng(2024)
    s = rig_scene()
    hits, n = 0, 200
    for i in range(n):
        k = 2 * IN + 0.01 * IN * rng.standard_normal()
        d = 1 * IN + 0.01 * IN * rng.standard_normal()
        lo, hi = interval(lsq_fit(s, session(mu=0.16, k=k, d=d, seed=1000 + i), n_starts=1), "friction.mu")
        hits += lo < 0.16 < hi
    # 95 % nominal; the binomial sd over 200 sessions is 1.5 %
    assert 0.90 <= hits / n <= 0.99


def test_reading_noise_estimated_when_not_given():
    s = rig_scene(reading=None)
    r = session(mu=0.1, seed=8)
    problem = FAMILY.problem(s, r)
    assert problem.noise_names == ("observation.sigma",)
    fit = least_squares(problem)
    assert fit.profiled and "observation.sigma" not in fit.names
    assert fit.sigma_hat == pytest.approx(SD, rel=0.35)
    # the profiled scale is the rms reading residual over readings - 1 degrees of freedom (mu is free,
    # k and d are pinned by their normal priors)
    resid = r.dw - problem.expected(fit.values)
    assert fit.sigma_hat == pytest.approx(math.sqrt(resid @ resid / (len(r) - 1)), rel=1e-8)
    res = posterior_fit(s, r, seed=2)
    lo, hi = ci95(res, "observation.sigma")
    assert lo < SD < hi
    lo, hi = ci95(res, "friction.mu")
    assert lo < 0.1 < hi


def test_calibration_load_convention_recovered():
    s = rig_scene(load_at="calibration")
    r = session(mu=0.3, seed=4, load_at="calibration")
    lo, hi = interval(lsq_fit(s, r), "friction.mu")
    assert lo < 0.3 < hi
    # read with the other convention the same numbers overstate mu by the factor r / (r - mu)
    ratio = lever_ratio(2 * IN, 1 * IN)
    lo2, hi2 = interval(lsq_fit(rig_scene(), r), "friction.mu")
    assert lo2 < 0.3 * ratio / (ratio - 0.3) < hi2 and lo2 > hi


def test_posterior_structure_and_reproducibility(tmp_path):
    s = rig_scene()
    r = session(seed=1)
    a = posterior_fit(s, r, nwalkers=12, nsteps=300, burn=100, seed=7)
    b = posterior_fit(s, r, nwalkers=12, nsteps=300, burn=100, seed=7)
    c = posterior_fit(s, r, nwalkers=12, nsteps=300, burn=100, seed=8)
    post = a.group("posterior")
    assert post["friction.mu"].dims == ("chain", "draw")
    assert post.sizes["chain"] == 12 and post.sizes["draw"] == 200
    assert set(post.data_vars) == {"rig.k", "rig.d", "friction.mu", "rig.lever_ratio"}
    assert post["rig.k"].attrs["units"] == "m"
    # the derived lever ratio is a/d of each draw
    assert np.allclose(post["rig.lever_ratio"].values, lever_ratio(post["rig.k"].values, post["rig.d"].values),
                       rtol=1e-14)
    assert "normal" in json.loads(a.attrs["priors"])["rig.k"]
    assert a.group("log_likelihood")["reading"].dims == ("chain", "draw", "obs")
    assert a.group("observed_data")["reading"].shape == (len(r),)
    assert a.attrs["seed"] == 7 and a.attrs["model"] == "friction_rig"
    assert np.array_equal(post["friction.mu"].values, b.group("posterior")["friction.mu"].values)
    assert not np.array_equal(post["friction.mu"].values, c.group("posterior")["friction.mu"].values)
    summary = json_summary(a)
    assert summary["kind"] == "posterior" and "friction.mu" in summary["params"]
    path = tmp_path / "post.h5"
    a.tree.to_netcdf(path, engine="h5netcdf")
    back = load_fit(path)
    assert np.array_equal(back.group("posterior")["friction.mu"].values, post["friction.mu"].values)


def test_least_squares_dataset_summary():
    res = fit_problem(FAMILY.problem(rig_scene(), session(seed=2)), method="leastsq")
    summary = json_summary(res)
    mu = summary["params"]["friction.mu"]
    assert summary["kind"] == "least_squares"
    assert mu["ci95"][0] < mu["value"] < mu["ci95"][1]
    assert json_summary(res.group("least_squares"))["params"]["friction.mu"] == mu


def exact_bf01(r, scene, prior_sd):
    """Bayes factor of mu_v = 0 for the linear-Gaussian case, from the two evidences.

    Fixed geometry and reading sd make dw = X beta + e linear in beta = (mu0, mu_v); mu0 has
    a flat prior of unit density (uniform on [0, 1], its posterior far from the ends), mu_v
    a normal prior.  Both marginal likelihoods are Gaussian integrals.
    """
    ratio = lever_ratio(2 * IN, 1 * IN)
    X = np.column_stack([r.load / ratio, r.load / ratio * (r.speed - scene.speed_ref)])
    y, s2 = r.dw, SD**2

    def log_evidence(X, prior_prec):
        A = X.T @ X / s2 + np.diag(prior_prec)
        b = X.T @ y / s2
        beta = np.linalg.solve(A, b)
        q = np.sum((y - X @ beta) ** 2) / s2 + beta @ np.diag(prior_prec) @ beta
        k = X.shape[1]
        lognorm_prior = sum(0.5 * math.log(p / (2 * math.pi)) for p in prior_prec if p > 0)
        return (-0.5 * q - 0.5 * np.linalg.slogdet(A)[1] + 0.5 * k * math.log(2 * math.pi)
                - 0.5 * len(y) * math.log(2 * math.pi * s2) + lognorm_prior)

    log_h1 = log_evidence(X, np.array([0.0, 1 / prior_sd**2]))
    log_h0 = log_evidence(X[:, :1], np.array([0.0]))
    return math.exp(log_h0 - log_h1)


@pytest.mark.parametrize("mu_v_true,seed", [(0.0, 31), (0.0016 / FT_S, 32)])
def test_savage_dickey_matches_exact_evidence_ratio(mu_v_true, seed):
    prior_sd = 0.005 / FT_S
    s = rig_scene(geom_sd=None, friction='mu_v = { value = 0.0, vary = true, prior = "normal(0, 0.005 s/ft)" }\n'
                                         'speed_ref = "6.5 ft/s"\n')
    r = session(mu=0.1, seed=seed, mu_v=mu_v_true, speed_ref=6.5 * FT_S)
    res = posterior_fit(s, r, seed=3)
    ev = compare_laws(res, s)["friction.mu_v"]
    exact = exact_bf01(r, s, prior_sd)
    assert ev.prior_density == pytest.approx(stats.norm.pdf(0, 0, prior_sd))
    assert ev.method == "conditional"
    assert math.log(ev.bf01) == pytest.approx(math.log(exact), abs=0.05)
    if mu_v_true == 0:
        assert ev.bf01 > 3 and "null" in ev.verdict
    else:
        assert ev.bf01 < 1 / 20 and "law" in ev.verdict


def test_kernel_density_fallback_near_zero():
    # with the calibration-load convention dw is not linear in mu_v: the draws' density is used
    law = 'mu_v = { value = 0.0, vary = true, prior = "normal(0, 0.005 s/ft)" }\nspeed_ref = "6.5 ft/s"\n'
    s_cal = rig_scene(geom_sd=None, load_at="calibration", friction=law)
    s_lin = rig_scene(geom_sd=None, friction=law)
    r_cal = session(mu=0.1, seed=31, load_at="calibration", speed_ref=6.5 * FT_S)
    r_lin = session(mu=0.1, seed=31, speed_ref=6.5 * FT_S)
    ev = compare_laws(posterior_fit(s_cal, r_cal, seed=3), s_cal)["friction.mu_v"]
    lin = compare_laws(posterior_fit(s_lin, r_lin, seed=3), s_lin)["friction.mu_v"]
    assert ev.method == "kde" and lin.method == "conditional"
    assert ev.bf01 > 3
    # same noise draws, nearly the same information about mu_v: nearly the same evidence
    assert math.log(ev.bf01) == pytest.approx(math.log(lin.bf01), abs=0.3)


def test_refusals():
    s = rig_scene()
    r = session(seed=1)
    mixed = Readings(load=r.load, dw=r.dw, speed=r.speed, material=tuple(["a", "b"] * (len(r) // 2)), where="m.csv")
    with pytest.raises(FitError, match=r"2 materials \['a', 'b'\]"):
        lsq_fit(s, mixed)
    law = rig_scene(friction='mu_v = { value = 0.0, vary = true, prior = "normal(0, 0.005 s/ft)" }\n')
    with pytest.raises(FitError, match="speed_<unit>"):
        lsq_fit(law, Readings(load=r.load, dw=r.dw, where="nospeed.csv"))
    with pytest.raises(FitError, match="at least 6 walkers"):
        posterior_fit(s, r, nwalkers=4)
    with pytest.raises(FitError, match="burn must lie in"):
        posterior_fit(s, r, nsteps=10, burn=10)
    one = Readings(load=r.load[:1], dw=r.dw[:1], where="one.csv")
    with pytest.raises(FitError, match=r"one.csv: 1 reading\(s\) cannot determine 3 free parameters"):
        lsq_fit(rig_scene(reading=None), one)
    fixed = load_scene("fixed.toml", text='model = "friction_rig"\n[rig]\nk = "2 inch"\nd = "1 inch"\n'
                                          '[friction]\nmu = 0.1\n')
    with pytest.raises(FitError, match="no structural parameter"):
        lsq_fit(fixed, r)
    with pytest.raises(FitError, match="nothing to fit"):
        lsq_fit(load_scene("fixed.toml", text='model = "friction_rig"\n[rig]\nk = "2 inch"\n'
                                     'd = "1 inch"\n[friction]\nmu = 0.1\n[observation]\nsigma = "0.01 gf"\n'), r)
    with pytest.raises(FitError, match="was not sampled"):
        from escfit.friction import savage_dickey

        savage_dickey(posterior_fit(s, r, nwalkers=8, nsteps=50, burn=10), s, "friction.mu_v")
    with pytest.raises(FitError, match="no posterior"):
        compare_laws(fit_problem(FAMILY.problem(s, r)), s)
