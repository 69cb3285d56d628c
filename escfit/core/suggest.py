"""'Did you mean' for misspelled scene keys and values.

A refusal of a key or value the code does not know lists every valid one and, when one of them
is close to what was written (``"wavefrom"`` for ``"waveform"``), names it first, so that the
message is the edit to make.
"""

from __future__ import annotations

import difflib
from typing import Iterable

__all__ = ["closest", "did_you_mean", "one_of"]

CUTOFF = 0.6  # difflib's similarity ratio above which a valid word is offered


def closest(word: object, valid: Iterable[str]) -> str | None:
    """The valid word closest to ``word`` (case-insensitive), or None when none is close.

    Parameters
    ----------
    word
        What was written (anything: a non-string is compared as its text).
    valid
        The words that are accepted.
    """
    choices = [str(v) for v in valid]
    lowered = {c.lower(): c for c in choices}
    found = difflib.get_close_matches(str(word).lower(), list(lowered), n=1, cutoff=CUTOFF)
    return lowered[found[0]] if found else None


def did_you_mean(word: object, valid: Iterable[str]) -> str:
    """``" (did you mean 'waveform'?)"`` for the closest valid word, or ``""``."""
    best = closest(word, valid)
    return f" (did you mean {best!r}?)" if best is not None else ""


def one_of(what: str, got: object, valid: Iterable[str]) -> str:
    """The sentence refusing ``got`` for ``what``: every valid value listed, the closest named.

    Examples
    --------
    >>> one_of("observation model", "wavefrom", ["amplitude", "waveform"])
    "observation model must be one of 'amplitude', 'waveform'; got 'wavefrom' (did you mean 'waveform'?)"
    """
    valid = list(valid)
    return f"{what} must be one of {', '.join(map(repr, valid))}; got {got!r}{did_you_mean(got, valid)}"
