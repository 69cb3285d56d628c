"""The one prior grammar (escfit.likelihood.priors), checked against independent references.

References: scipy.stats.truncnorm for the truncated normal, half-normal (a normal with mean 0
truncated to x >= 0) and lognormal (log x a truncated normal, density divided by x); closed
forms for uniform and loguniform; scipy.integrate.quad for normalisation; closed-form moments
of the (truncated) lognormal; Kolmogorov-Smirnov tests of the draws.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import pytest
from scipy import integrate, stats

from escfit.core.errors import SceneError
from escfit.core.params import Param
from escfit.likelihood.priors import (Prior, flat, halfnormal, lognormal, loguniform, normal, parse_prior, prior_of,
                                      uniform)

GF = 0.00980665  # N
INCH = 0.0254  # m


def parse(spec, unit="", lower=-math.inf, upper=math.inf):
    return parse_prior(spec, unit=unit, where="s.toml [x].prior", lower=lower, upper=upper)


def truncnorm(mu, sd, lo, hi):
    return stats.truncnorm((lo - mu) / sd, (hi - mu) / sd, loc=mu, scale=sd)


# (spec, lower, upper, reference logpdf on the support)
def _ref_uniform(x, a, b):
    return np.full_like(x, -math.log(b - a))


CASES = {
    "uniform": ("uniform(-1, 3)", 0.0, 10.0, lambda x: _ref_uniform(x, 0.0, 3.0)),
    "loguniform": ("loguniform(1e-3, 10)", 0.01, 1.0, lambda x: -np.log(x * math.log(1.0 / 0.01))),
    "normal": ("normal(0.3, 0.5)", 0.0, 1.0, lambda x: truncnorm(0.3, 0.5, 0.0, 1.0).logpdf(x)),
    "normal_open": ("normal(0.3, 0.5)", -math.inf, math.inf, lambda x: stats.norm(0.3, 0.5).logpdf(x)),
    "normal_half_open": ("normal(2, 1)", 1.5, math.inf, lambda x: truncnorm(2.0, 1.0, 1.5, math.inf).logpdf(x)),
    "halfnormal": ("halfnormal(2)", -5.0, 3.0, lambda x: truncnorm(0.0, 2.0, 0.0, 3.0).logpdf(x)),
    "halfnormal_open": ("halfnormal(2)", -math.inf, math.inf, lambda x: stats.halfnorm(0, 2).logpdf(x)),
    "lognormal": ("lognormal(0.5, 0.8)", 0.5, 4.0,
                  lambda x: truncnorm(0.5, 0.8, math.log(0.5), math.log(4.0)).logpdf(np.log(x)) - np.log(x)),
    "lognormal_open": ("lognormal(-1, 0.3)", -math.inf, math.inf,
                       lambda x: stats.norm(-1, 0.3).logpdf(np.log(x)) - np.log(x)),
    "normal_upper_tail": ("normal(0, 1)", 5.0, 6.0, lambda x: truncnorm(0.0, 1.0, 5.0, 6.0).logpdf(x)),
    "normal_lower_tail": ("normal(0, 1)", -6.0, -5.0, lambda x: truncnorm(0.0, 1.0, -6.0, -5.0).logpdf(x)),
}


def _grid(p: Prior):
    lo, hi = p.lo, p.hi
    a = lo if math.isfinite(lo) else -20.0
    b = hi if math.isfinite(hi) else 20.0
    if p.kind in ("lognormal", "loguniform", "halfnormal"):
        a = max(a, 1e-3)
    return np.linspace(a, b, 41)


@pytest.mark.parametrize("name", sorted(CASES))
def test_logpdf_equals_the_truncated_reference_density(name):
    spec, lower, upper, ref = CASES[name]
    p = parse(spec, lower=lower, upper=upper)
    x = _grid(p)
    np.testing.assert_allclose(p.logpdf(x), ref(x), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(p.pdf(x), np.exp(ref(x)), rtol=1e-9, atol=1e-300)
    # scalar in, float out; outside the support -inf
    assert isinstance(p.logpdf(float(x[3])), float)
    assert p.logpdf(float(x[3])) == pytest.approx(float(ref(x[3:4])[0]), rel=1e-9, abs=1e-9)
    outside = [v for v in (p.lo - 1.0, p.hi + 1.0) if math.isfinite(v)]
    assert all(p.logpdf(v) == -math.inf for v in outside)
    assert p.logpdf(np.array(outside)).shape == (len(outside),)


@pytest.mark.parametrize("name", sorted(CASES))
def test_density_integrates_to_one_over_the_bounds(name):
    spec, lower, upper, _ = CASES[name]
    p = parse(spec, lower=lower, upper=upper)
    lo, hi = p.lo, p.hi
    if p.kind in ("normal", "halfnormal", "lognormal") and not (math.isfinite(lo) and math.isfinite(hi)):
        # split at the mode so quad sees the peak
        if p.kind == "lognormal":
            mode = math.exp(p.args[0] - p.args[1] ** 2)
        else:
            mode = p.args[0] if p.kind == "normal" else 0.0
        mode = min(max(mode, lo), hi)
        pieces = [(lo, mode), (mode, hi)]
    else:
        pieces = [(lo, hi)]
    total = sum(integrate.quad(p.pdf, a, b, epsabs=1e-13, epsrel=1e-12, limit=200)[0] for a, b in pieces if a < b)
    assert total == pytest.approx(1.0, abs=1e-8)


def test_renormalisation_doubles_a_normal_cut_at_its_mean():
    p = normal(0.0, 2.0, 0.0, math.inf)
    assert p.pdf(0.0) == pytest.approx(2 * stats.norm.pdf(0, 0, 2.0), rel=1e-12)
    assert p.log_mass == pytest.approx(math.log(0.5), rel=1e-12)


@pytest.mark.parametrize("name", sorted(CASES))
def test_draws_lie_inside_the_bounds_and_follow_the_truncated_cdf(name):
    spec, lower, upper, ref = CASES[name]
    p = parse(spec, lower=lower, upper=upper)
    x = p.sample(np.random.default_rng(20240611), 4000)
    assert x.shape == (4000,)
    assert np.all((x >= p.lo) & (x <= p.hi))
    # the reference cdf, by integrating the reference density (independent of the prior's cdf)
    a = p.lo if math.isfinite(p.lo) else -math.inf

    def ref_cdf(values):
        return np.array([integrate.quad(lambda t: math.exp(ref(np.array([t]))[0]), a, v, limit=200)[0]
                         if v > a else 0.0 for v in np.atleast_1d(values)])

    if p.kind == "normal":
        cdf = truncnorm(p.args[0], p.args[1], p.lo, p.hi).cdf
    elif p.kind == "halfnormal":
        cdf = truncnorm(0.0, p.args[0], p.lo, p.hi).cdf
    elif p.kind == "lognormal":
        def cdf(v):
            return truncnorm(p.args[0], p.args[1], math.log(p.lo) if p.lo > 0 else -math.inf,
                             math.log(p.hi)).cdf(np.log(v))
    else:
        cdf = ref_cdf
    assert stats.kstest(x, cdf).pvalue > 0.01
    # the prior's own cdf agrees with the reference
    probe = np.quantile(x, [0.1, 0.5, 0.9])
    np.testing.assert_allclose(p.cdf(probe), cdf(probe), atol=1e-8)


def test_sampling_is_reproducible_with_a_seed():
    p = parse("lognormal(0, 1)", lower=0.1, upper=10)
    a = p.sample(np.random.default_rng(5), 100)
    b = p.sample(np.random.default_rng(5), 100)
    np.testing.assert_array_equal(a, b)


def test_lognormal_sample_mean_matches_the_closed_form():
    mu, s = 0.2, 0.5
    rng = np.random.default_rng(7)
    n = 200_000
    # untruncated: E[x] = exp(mu + s^2/2)
    x = parse(f"lognormal({mu}, {s})", lower=0.0).sample(rng, n)
    mean = math.exp(mu + s * s / 2)
    se = math.sqrt((math.exp(s * s) - 1) * math.exp(2 * mu + s * s) / n)
    assert abs(x.mean() - mean) < 5 * se
    # truncated to [a, b]: E = exp(mu + s^2/2) [Phi((ln b - mu - s^2)/s) - Phi((ln a - mu - s^2)/s)] / mass
    lo, hi = 0.8, 2.5
    y = parse(f"lognormal({mu}, {s})", lower=lo, upper=hi).sample(rng, n)
    phi = stats.norm.cdf
    la, lb = math.log(lo), math.log(hi)
    mass = phi((lb - mu) / s) - phi((la - mu) / s)
    tmean = mean * (phi((lb - mu - s * s) / s) - phi((la - mu - s * s) / s)) / mass
    assert abs(y.mean() - tmean) < 5 * y.std() / math.sqrt(n)
    assert np.all((y >= lo) & (y <= hi))


def test_arguments_with_units_are_converted_to_the_canonical_unit():
    p = parse("normal(0, 0.02 / gf)", unit="1/N")
    assert p.args == pytest.approx((0.0, 0.02 / GF), rel=1e-12)
    assert parse("normal(0, 0.005 s/ft)", unit="s/m").args[1] == pytest.approx(0.005 / 0.3048, rel=1e-12)
    assert parse("loguniform(1 gf, 5 gf)", unit="N").args == pytest.approx((GF, 5 * GF), rel=1e-12)
    assert parse("uniform(1 inch, 2 ft)", unit="m").args == pytest.approx((INCH, 0.6096), rel=1e-12)
    assert parse("normal(300 deg, 2 deg)", unit="rad").args == pytest.approx((math.radians(300), math.radians(2)))
    assert parse("halfnormal(1e-3 N*m)", unit="N*m").args == pytest.approx((1e-3,))
    assert parse("normal(1, 0.1 lbf*inch)", unit="N*m").args[1] == pytest.approx(0.1 * 4.4482216152605 * INCH)
    # bare numbers are canonical; bounds truncate in the canonical unit
    p = parse("normal(0, 0.02 / gf)", unit="1/N", lower=-1.0, upper=1.0)
    assert (p.lo, p.hi) == (-1.0, 1.0)
    assert p.logpdf(0.5) == pytest.approx(float(truncnorm(0, 0.02 / GF, -1, 1).logpdf(0.5)), rel=1e-12)


@pytest.mark.parametrize(
    "spec, unit, lower, upper, words",
    [
        ("uniform(2, 1)", "", -math.inf, math.inf, ["a < b"]),
        ("loguniform(0, 1)", "", -math.inf, math.inf, ["positive lower end"]),
        ("normal(0, 0)", "", -math.inf, math.inf, ["spread", "positive"]),
        ("halfnormal(-1)", "", -math.inf, math.inf, ["spread", "positive"]),
        ("lognormal(0, -2)", "", -math.inf, math.inf, ["spread", "positive"]),
        ("lognormal(800, 1)", "", -math.inf, math.inf, ["lognormal mu"]),
        ("normal(0, nan)", "", -math.inf, math.inf, ["'nan'", "not finite"]),
        ("normal(NaN, 1)", "", -math.inf, math.inf, ["'NaN'", "not finite"]),
        ("uniform(0, inf)", "", -math.inf, math.inf, ["'inf'", "not finite"]),
        ("uniform(-inf, 0)", "", -math.inf, math.inf, ["'-inf'", "not finite"]),
        ("normal(0, 1e999)", "", -math.inf, math.inf, ["'1e999'", "not finite"]),
        ("normal(50, 1)", "", -1.0, 1.0, ["no mass inside the bounds [-1, 1]"]),
        ("uniform(2, 3)", "", 0.0, 1.0, ["no mass inside the bounds [0, 1]"]),
        ("loguniform(1, 2)", "N", 3.0, 4.0, ["no mass inside the bounds [3, 4]", "(N)"]),
        ("halfnormal(1)", "", -2.0, 0.0, ["no mass"]),
        ("lognormal(0, 1)", "", -3.0, -1.0, ["no mass"]),
        ("cauchy(0, 1)", "", -math.inf, math.inf, ["cannot read prior 'cauchy(0, 1)'", "lognormal(mu, sigma)"]),
        ("normal 0, 1", "", -math.inf, math.inf, ["cannot read prior"]),
        ("normal(0, 1, 2)", "", -math.inf, math.inf, ["takes 2 argument(s), got 3"]),
        ("halfnormal()", "", -math.inf, math.inf, ["takes 1 argument(s), got 0"]),
        ("normal(0, abc)", "", -math.inf, math.inf, ["cannot read argument 'abc'"]),
        ("normal(0, 0.1 s)", "1/N", -math.inf, math.inf, ["'0.1 s'", "1/N"]),
        ("normal(0, 1 parsec_of_fog)", "m", -math.inf, math.inf, ["unknown unit"]),
        ("lognormal(0, 1 m)", "m", -math.inf, math.inf, ["plain numbers", "'1 m'"]),
        ("normal(0, 1 m**999)", "m", -math.inf, math.inf, ["cannot read argument"]),
        ("normal(0, 1 (m**99)**99)", "m", -math.inf, math.inf, ["cannot read argument"]),
        ("normal(0, 2 m2)", "m", -math.inf, math.inf, ["cannot read argument"]),
    ],
)
def test_refusals_name_the_prior_and_say_why(spec, unit, lower, upper, words):
    with pytest.raises(SceneError) as info:
        parse(spec, unit=unit, lower=lower, upper=upper)
    assert info.value.where == "s.toml [x].prior"
    for w in words:
        assert w in info.value.message, (w, info.value.message)


@pytest.mark.parametrize("spec", ["normal(0, 9**9**9)", "normal(9**9**9, 1)", "uniform(0, 1 m**9**9**9)",
                                  "normal(0, 2 ** 9 ** 9 ** 9)", "normal(0, (9**99)**99)",
                                  "normal(0, 1 " + "m*" * 200 + "m)"])
def test_power_towers_are_refused_quickly(spec):
    t = time.perf_counter()
    with pytest.raises(SceneError, match="cannot read argument|longer than"):
        parse(spec, unit="m")
    # a hang guard, not a speed check: evaluating any of these towers would take hours
    assert time.perf_counter() - t < 10.0


def test_bounds_and_prior_arguments_must_be_numbers():
    with pytest.raises(SceneError, match="NaN"):
        parse("normal(0, 1)", lower=math.nan)
    with pytest.raises(SceneError, match="finite"):
        normal(0.0, math.inf)
    with pytest.raises(SceneError, match="finite"):
        uniform(0.0, math.nan)


def test_prior_of_a_parameter():
    p = Param("viscous.C", 0.5, "1/s", vary=True, min=0.0, max=5.0)
    pr = prior_of(p, "s.toml [viscous.C]")
    assert (pr.kind, pr.args, pr.lo, pr.hi) == ("uniform", (0.0, 5.0), 0.0, 5.0)
    assert pr.logpdf(1.0) == pytest.approx(-math.log(5.0))
    # a prior string is read in the parameter's unit and truncated to its bounds
    q = prior_of(replace(p, prior="normal(1, 60 / min)"), "s.toml [viscous.C]")
    assert q.args == pytest.approx((1.0, 1.0)) and (q.lo, q.hi) == (0.0, 5.0)
    assert q.logpdf(2.0) == pytest.approx(float(truncnorm(1, 1, 0, 5).logpdf(2.0)), rel=1e-12)
    with pytest.raises(SceneError) as info:
        prior_of(replace(p, prior="normal(50, 1)"), "s.toml [viscous.C]")
    assert info.value.where == "s.toml [viscous.C]" and "no mass" in info.value.message


def test_open_range_without_prior_is_refused_unless_an_improper_flat_prior_is_allowed():
    p = Param("fit.kappa", 0.0, "", vary=True)
    with pytest.raises(SceneError) as info:
        prior_of(p, "s.toml [fit.kappa]")
    assert info.value.where == "s.toml [fit.kappa]"
    for w in ("fit.kappa", "no prior", "open", "min and max", "proper prior"):
        assert w in info.value.message
    half = replace(p, min=0.0)
    with pytest.raises(SceneError, match="open"):
        prior_of(half)
    f = prior_of(half, "s.toml [fit.kappa]", allow_improper=True)
    assert f.kind == "flat" and not f.proper and (f.lo, f.hi) == (0.0, math.inf)
    assert f.logpdf(3.0) == 0.0 and f.logpdf(-1.0) == -math.inf
    np.testing.assert_array_equal(f.logpdf(np.array([-1.0, 0.0, 1e300])), [-math.inf, 0.0, 0.0])
    assert "improper" in f.describe()
    with pytest.raises(SceneError, match="improper"):
        f.sample(np.random.default_rng(0), 3)
    # with a proper prior string an open range is fine
    g = prior_of(replace(p, prior="normal(0, 1)"), "s.toml [fit.kappa]")
    assert g.proper and g.sample(np.random.default_rng(0), 5).shape == (5,)


def test_constructors_describe_and_friction_aliases():
    assert uniform(0.0, 1.0) == parse("uniform(0, 1)", lower=0.0, upper=1.0)
    assert loguniform(1e-8, 1.0).kind == "loguniform"
    assert halfnormal(0.5).lo == 0.0
    assert lognormal(0.0, 1.0).hi == math.inf
    assert flat(-math.inf, math.inf).logpdf(1e300) == 0.0
    p = normal(0.0, 0.01, -1.0, 1.0)
    assert p.family == p.kind == "normal" and p.support == (p.lo, p.hi) == (-1.0, 1.0)
    assert p.describe() == "normal(0, 0.01) on [-1, 1]"
    assert parse("halfnormal(2)").describe() == "halfnormal(2) on [0, inf]"
    # replace() re-validates and re-normalises (friction scales geometry sds this way)
    wide = replace(normal(0.0, 1.0, 0.0, math.inf), args=(0.0, 2.0))
    assert wide.pdf(0.0) == pytest.approx(2 * stats.norm.pdf(0, 0, 2.0))
    with pytest.raises(SceneError):
        replace(p, args=(0.0, -1.0))
    assert hash(p) == hash(normal(0.0, 0.01, -1.0, 1.0))
