"""A fit's answer in plain sentences, for a physics class or a watchmaker's bench.

The sentences open every report, ``escfit fit`` and ``escfit summary``; the technical tables
follow them.  Each number is the median over the fit's draws (the posterior's, or the
least-squares normal approximation's, :func:`escfit.report.quantities.parameter_draws`) with its
95 % interval in words, "between 1.1 and 1.3 % (95 %)" (:mod:`escfit.core.plainwords`).

The fit's model family writes them (:meth:`escfit.core.family.Family.plain`): a balance wheel
or pendulum the share of its amplitude lost each period and where it goes, Q, the halving time,
or for an escapement-driven balance the share of the impulse friction takes
(:mod:`escfit.balance.plain`); the other families their friction coefficients in words.
"""

from __future__ import annotations

from ..core.errors import SceneError
from ..core.family import get_family
from ..core.plainwords import coefficient_sentences, sig
from .quantities import parameter_draws

__all__ = ["plain_summary", "window_sentences", "mode_sentences", "MOST"]

MOST = 0.75  # a fit over less than this share of the record says where its numbers come from


def plain_summary(res) -> list[str]:
    """A few sentences saying what the fit found, in everyday words and units.

    Parameters
    ----------
    res : escfit.results.FitResult

    Returns
    -------
    list of str
        Sentences (empty when the fit's family has nothing to say in words).
    """
    if res.verdict == "not determined":
        return ["The fit did not determine the parameters, so there is no plain answer yet: the first warning below "
                "says which edit of the scene to make."]
    draws = parameter_draws(res)
    try:
        family = get_family(str(res.attrs.get("model", "balance")))
    except SceneError:  # a family not registered in this installation
        return coefficient_sentences(draws)
    plain = getattr(family, "plain", None)
    if plain is None:
        return coefficient_sentences(draws) + window_sentences(res.attrs) + mode_sentences(res.attrs)
    return plain(draws, res.attrs, res.arrays("observed_data")) + window_sentences(res.attrs) + mode_sentences(res.attrs)


def mode_sentences(attrs) -> list[str]:
    """A weak second oscillation the record holds beside the swing, which the fit leaves out.

    From the results' ``second_mode_period_s`` and ``second_mode_share`` (the share of the
    swing's spectral power): a structure or a second pendulum that rings along, so that a
    teacher knows the numbers above are the main swing's alone.
    """
    try:
        period, share = float(attrs["second_mode_period_s"]), float(attrs["second_mode_share"])
    except (KeyError, TypeError, ValueError):
        return []
    return [f"The record also holds a weaker second oscillation, of period {sig(period, 3)} s ({sig(100 * share, 2)} % "
            "of the main swing's power); the numbers above are the main swing's, and the second stays in the "
            "residuals."]


def window_sentences(attrs) -> list[str]:
    """Where in the record the numbers come from, when the fit used less than :data:`MOST` of it.

    From the results' ``record_first_s``, ``record_last_s`` (the file's first and last sample)
    and ``fit_first_s``, ``fit_last_s`` (the first and last instant fitted), on the file's clock;
    the sentence counts time from the first sample, as the notes do.  ``window_keys`` names the
    scene's ``[recording]`` keys that set the window, when they did.
    """
    try:
        first, last, a, b = (float(attrs[k]) for k in ("record_first_s", "record_last_s", "fit_first_s", "fit_last_s"))
    except (KeyError, TypeError, ValueError):
        return []
    span = last - first
    if not (span > 0 and b > a) or (b - a) >= MOST * span:
        return []
    keys = [k for k in str(attrs.get("window_keys", "")).split(", ") if k]
    why = (f"the scene's [recording] {' and '.join(keys)} left the rest out (the scene's comments say why)" if keys
           else "the rest was left out, and the notes and warnings below say why")
    return [f"These numbers come from the part of the record from t = {sig(a - first, 3)} to {sig(b - first, 3)} s "
            f"({100 * (b - a) / span:.0f} % of its {sig(span, 3)} s); {why}."]
