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
from ..core.plainwords import coefficient_sentences
from .quantities import parameter_draws

__all__ = ["plain_summary"]


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
        return coefficient_sentences(draws)
    return plain(draws, res.attrs, res.group("observed_data"))
