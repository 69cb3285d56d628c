"""emcee, imported without the statistics package its KDE move alone needs.

emcee's ``moves`` package imports ``scipy.stats`` at import time for one class, ``KDEMove``
(a kernel density estimate of the complementary walkers), which escfit does not use: about
0.3 CPU s of every sampler run, more than a quick fit's least squares.  Here emcee is imported
with ``scipy.stats`` marked as not installed for that moment only, and the KDE move is then
given a stand-in for ``gaussian_kde`` that imports scipy.stats on its first call, so that
``emcee.moves.KDEMove`` works as before for anyone who uses it in the same process.

Where emcee or scipy.stats is imported already, nothing is changed.
"""

from __future__ import annotations

import sys

__all__ = ["emcee"]


def _gaussian_kde(*args, **kwargs):
    """``scipy.stats.gaussian_kde``, imported on first use."""
    from scipy.stats import gaussian_kde

    return gaussian_kde(*args, **kwargs)


def _import_emcee():
    if "emcee" in sys.modules or "scipy.stats" in sys.modules:
        import emcee

        return emcee
    sys.modules["scipy.stats"] = None  # type: ignore[assignment]  # makes its import fail: emcee does without
    try:
        import emcee
        import emcee.moves.kde as kde
    finally:
        if sys.modules.get("scipy.stats", 0) is None:
            del sys.modules["scipy.stats"]
    if getattr(kde, "gaussian_kde", 0) is None:
        kde.gaussian_kde = _gaussian_kde
    return emcee


emcee = _import_emcee()
