"""Which of several columns that could hold the signal is the measured one, by what the table says.

Used by :mod:`escfit.analysis.recordings.columns` before the columns' shapes are compared
(:func:`escfit.analysis.channel.choose_channel`): a column with fewer readings than the table's
longest, or named as a spectrum, is no candidate; of the rest, a plainly named measured quantity
is preferred over derived ones, except among the axes of one sensor, which only their shapes tell
apart.  ``cols`` is a :class:`~escfit.analysis.recordings.columns.Columns` table.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["measured_candidates", "TEXT_KINDS"]

TEXT_KINDS = ("text", "flag", "date")  # column kinds that hold no readings
_SPECTRUM_WORDS = ("fft", "fourier", "spektrum", "spectrum", "spectra", "psd", "frequenz", "frequency", "periodogram")
_DERIVED_WORDS = ("mittel", "mean", "average", "avg", "smooth", "glätt", "glaett", "filter", "fit", "model", "theor",
                  "energie", "energy", "ableitung", "derivative", "diff", "delta", "integral", "berechnet", "calc",
                  "residu", "error", "fehler", "sigma", "std")
_MEASURED_WORDS = {"weg", "s", "x", "y", "winkel", "alpha", "α", "phi", "φ", "theta", "θ", "angle", "position", "pos",
                   "displacement", "auslenkung", "elongation", "encoder"}


def measured_candidates(cols, hits: list[int]) -> list[int]:
    """Of several columns that could hold the signal, those that are the measured one (a note says why
    the others were passed over): a column with fewer readings than the table's longest (an FFT's
    axis or spectrum, a derivative's or a fit's column padded with empty cells) or named as a
    spectrum is no candidate; of the rest, a plainly named measured quantity (CASSY's ``Winkel``,
    ``Weg``, ``s``, ``x``, ``alpha``) is preferred over derived ones (a mean, a fit, an energy)."""
    counts = {i: _readings(cols, i) for i in range(cols.ncols) if cols.kind(i) not in TEXT_KINDS}
    longest = max(counts.values(), default=0)
    passed = []
    kept = []
    for i in hits:
        low = cols.label(i).lower()
        if any(w in low for w in _SPECTRUM_WORDS):
            passed.append(f"{cols.label(i)!r} (a spectrum)")
        elif counts.get(i, 0) < 0.95 * longest - 2:
            passed.append(f"{cols.label(i)!r} ({counts.get(i, 0)} readings of {longest})")
        else:
            kept.append(i)
    if len(kept) > 1 and not _axes_of_one_sensor(cols, kept):  # x, y, z of one sensor: the shapes decide
        words = {i: set(re.findall(r"[^\W\d_]+", re.sub(r"\s*[(\[/].*$", "", cols.label(i).lower()))) for i in kept}
        plain = [i for i in kept if words[i] & _MEASURED_WORDS and not any(d in w for w in words[i] for d in _DERIVED_WORDS)]
        if len(plain) == 1:
            passed += [f"{cols.label(i)!r} (derived)" for i in kept if i != plain[0]]
            kept = plain
    if len(kept) == 1 and passed:
        cols.notes.append(f"column {cols.label(kept[0])!r} is the measured one, passing over {', '.join(passed)} "
                          "([recording] angle_column, velocity_column or displacement_column chooses another)")
    return kept or hits


def _axes_of_one_sensor(cols, columns: list[int]) -> bool:
    """Whether the columns' labels differ only in an axis letter (``Gyroscope x``, ``y``, ``z``)."""
    from ...analysis.channel import axis_base

    bases = [axis_base(cols.label(i)) for i in columns]
    return all(b is not None for b in bases) and len({b[0] for b in bases}) == 1


def _readings(cols, i: int) -> int:
    """How many cells of column i hold a reading (not empty, not NaN)."""
    if i in cols.values:
        return int(np.isfinite(np.asarray(cols.values[i], dtype=float)).sum())
    if i >= len(cols.cells):
        return 0
    return sum(1 for c in cols.cells[i] if c.strip() and c.strip().strip('"').lower() not in ("nan", "-nan", "na"))
