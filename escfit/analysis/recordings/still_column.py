"""A signal column that holds one value in every row: refused, naming the columns that move.

A tracker that writes a placeholder angle (every row 0) beside the bob's pixel position, or a
logger's unused channel, matches a column's name but holds no swing.  Its spectrum has no peak,
and "no oscillation found" would send the user looking for a fault in the motion; the message
says what the column holds instead, which other columns vary, and when they are x and y, that they
may be a tracked position (``--format tracker`` turns them into the angle; ``escfit init`` reads
the file so).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...core.errors import DataError

__all__ = ["refuse_still", "TRACK_HINT"]

#: how the refusal of a still column beside a moving x and y ends (escfit init reads the file so)
TRACK_HINT = "--format tracker turns x and y into the angle about the arc they trace"


def refuse_still(values_of: Callable[[int], np.ndarray], label_of: Callable[[int], str], a: int, others: list[int],
                 hint: str, where: str) -> None:
    """Raise :class:`~escfit.core.errors.DataError` when column ``a`` holds one value in every row.

    ``values_of(i)`` and ``label_of(i)`` give column ``i``'s numbers and name; ``others`` are the
    columns to name when they vary; ``hint`` says which key chooses another column.
    """
    def spread(i: int) -> float:
        v = values_of(i)
        finite = v[np.isfinite(v)]
        return float(np.ptp(finite)) if finite.size else 0.0

    values = values_of(a)
    if values.size < 3 or spread(a) > 0:
        return
    moving = [label_of(i) for i in others if spread(i) > 0]
    said = f"column {label_of(a)!r} holds one value ({values[0]:g}) in every row: no swing to fit"
    if {m.strip().lower().split("(")[0].strip() for m in moving} >= {"x", "y"}:
        raise DataError(f"{said}; x and y vary: a position tracked on video? {TRACK_HINT}", where)
    raise DataError(f"{said}; {', '.join(repr(m) for m in moving) or 'no other column'} vary; {hint}", where)
