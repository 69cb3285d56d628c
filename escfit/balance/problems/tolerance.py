"""The integrator's tolerance of a waveform fit, from the readings' noise and the Jacobian's steps.

An adaptive integrator's error is systematic: it shifts the model's curve, and the fit follows.
For residuals standardised by a noise scale ``sigma``, a model error of at most ``e`` at every
one of ``n`` samples moves an estimate by at most ``e * sqrt(n) / sigma`` of its standard
error (Cauchy-Schwarz on the normal equations).  :func:`noise_allowed_rtol` keeps that below
:data:`ERROR_SE` of a standard error: ``e <= ERROR_SE * sigma / sqrt(n)``.  The global error of
DOP853 on a decaying swing grows with the periods integrated: measured on the 116 s string
pendulum record (70 periods, 37 deg) it is 0.28 ``rtol`` times the amplitude per period; the
budget takes a full ``rtol`` times the amplitude per period, so
``rtol = ERROR_SE * sigma / (sqrt(n) * amplitude * periods)``.

The noise is not the only reader of the model when least squares differentiates it by forward
differences: with steps of ``sqrt(eps)`` (1.5e-8) relative, an integrator error of ``e`` puts an
error of about ``e / step`` into the Jacobian.  Along a ridge (the string pendulum with air drag:
C, R and D correlated beyond 0.99, principal spreads 350-fold) that moved the optimum by 2.3
standard errors at the 1.9e-8 its noise allows, and the standard errors by up to a third.  So
for a scene whose Jacobian comes from forward differences :func:`noise_rtol` never goes looser
than :data:`JACOBIAN_RTOL`.  A scene whose Jacobian comes from the integrator's own
sensitivities (:mod:`escfit.balance.problems.waveform_jacobian`) carries no such floor: its
columns are the derivatives of the computed motion at any tolerance, and the same ridge fitted at
2e-8 lands within 0.001 standard error of the forward-difference fit at 1e-10.  It takes what the
noise allows, up to :data:`LOOSEST`, where the error budget above was measured.
"""

from __future__ import annotations

import math

__all__ = ["noise_rtol", "noise_allowed_rtol", "ERROR_SE", "JACOBIAN_RTOL", "TIGHTEST", "LOOSEST"]

#: the largest shift of an estimate, in standard errors, the integrator's error may cause
ERROR_SE = 0.01

#: the loosest tolerance at which a forward-difference Jacobian (steps sqrt(eps)) keeps fits unchanged
JACOBIAN_RTOL = 1e-10

#: the loosest tolerance chosen (with a Jacobian from sensitivities): DOP853's error is still in its asymptotic
#: range there, where the budget's proportionality was measured
LOOSEST = 1e-7

#: the tightest tolerance chosen (DOP853 refuses below 1e-15; round-off dominates before that)
TIGHTEST = 1e-13


def noise_allowed_rtol(sigma: float, amplitude: float, n: int, periods: float) -> float:
    """The loosest relative tolerance the readings' noise allows (nan when an argument is not
    positive and finite).

    Parameters
    ----------
    sigma
        The readings' noise scale (their unit: rad, rad/s or m), from the record itself.
    amplitude
        The largest swing in the record (same unit).
    n
        Samples fitted.
    periods
        Periods of the motion the model integrates (at least one is budgeted).
    """
    args = (sigma, amplitude, float(n), periods)
    if not all(math.isfinite(a) and a > 0 for a in args):
        return math.nan
    return ERROR_SE * sigma / (math.sqrt(n) * amplitude * max(periods, 1.0))


def noise_rtol(sigma: float, amplitude: float, n: int, periods: float, *,
               sensitivities: bool = False) -> tuple[float, str]:
    """The integrator's relative tolerance for a waveform fit, and why, in words.

    What :func:`noise_allowed_rtol` allows, kept between :data:`TIGHTEST` and :data:`LOOSEST`, and
    no looser than :data:`JACOBIAN_RTOL` unless the Jacobian comes from the integrator's
    sensitivities (the other arguments are :func:`noise_allowed_rtol`'s).

    Parameters
    ----------
    sensitivities
        Least squares differentiates the model by its forward sensitivities, not by forward
        differences.

    Returns
    -------
    rtol : float
    basis : str
        The choice stated for the results' attributes.
    """
    allowed = noise_allowed_rtol(sigma, amplitude, n, periods)
    loosest = LOOSEST if sensitivities else JACOBIAN_RTOL
    if not math.isfinite(allowed):
        return JACOBIAN_RTOL, f"rtol = {JACOBIAN_RTOL:.2g}: the record gives no noise scale to match"
    rtol = max(min(allowed, loosest), TIGHTEST)
    why = (f"the readings' noise {sigma:.3g} allows rtol = {allowed:.2g} (an integrator error below "
           f"{ERROR_SE:g} standard error over {n} samples and {periods:.0f} periods)")
    if allowed > loosest and not sensitivities:
        return rtol, (f"rtol = {rtol:.2g}: {why}, but the forward-difference Jacobian needs {JACOBIAN_RTOL:.2g} "
                      "to leave the fit unchanged")
    if allowed > loosest:
        return rtol, f"rtol = {rtol:.2g}: {why}, kept at {LOOSEST:.2g}, the loosest used"
    if sensitivities:
        return rtol, f"rtol = {rtol:.2g}: {why}; least squares differentiates by the integrator's sensitivities"
    return rtol, f"rtol = {rtol:.2g}: {why}"
