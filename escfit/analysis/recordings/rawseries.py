"""Raw recordings read into a TimeSeries: the entry point.

:func:`read_raw_series` dispatches on content: MATLAB files (a ``MATLAB`` header, HDF5 v7.3 or
a ``.mat`` name) go to :mod:`escfit.analysis.recordings.matfile`, everything else to the text-table
reader :mod:`escfit.analysis.recordings.rawtable`.  Both hand their converted columns (time s, angle
rad) to :func:`~escfit.analysis.recordings.rawsteps.build_series`, which repairs the time base
(:mod:`escfit.analysis.timebase`), applies the ``start``/``stop`` window and checks what is left.  The shared steps live in :mod:`escfit.analysis.recordings.rawsteps`
(so the readers need not import this module) and are re-exported here.

Metadata convention
-------------------
Readers fill :attr:`TimeSeries.meta` with strings only (so it survives
:func:`~escfit.analysis.recordings.timeseries.write_timeseries` and HDF5 attributes):
``source_format``, ``time_column``, ``angle_column``, ``angle_unit``, ``window``, ``notes`` and
``warnings``, each one string of sentences joined by ``"; "``
(:func:`~escfit.analysis.recordings.rawsteps.notes_of` splits it), next to the file's own ``# key: value`` metadata (a file key that collides is kept as
``file_<key>``).
"""

from __future__ import annotations

from pathlib import Path

from ...core.errors import DataError
from .foreign import refuse_foreign
from .matfile import read_mat_series
from .rawsteps import FILE_OPTIONS, MIN_SAMPLES, build_series, file_options, merge_file_meta, notes_of, warnings_of
from .rawtable import read_raw_table
from .recording_spec import RecordingSpec
from .series import TimeSeries

__all__ = ["read_raw_series", "build_series", "notes_of", "warnings_of", "merge_file_meta", "file_options",
           "FILE_OPTIONS", "MIN_SAMPLES"]

_HDF5 = b"\x89HDF\r\n\x1a\n"


def read_raw_series(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a raw recording (text table or MATLAB file) into a TimeSeries.

    Parameters
    ----------
    path
        The file.  MATLAB files are recognised by their header (or a ``.mat`` name).
    spec
        Reading options (``None``: detect everything); see
        :mod:`escfit.analysis.recordings.recording_spec`, and :mod:`~escfit.analysis.recordings.rawtable` and
        :mod:`~escfit.analysis.recordings.matfile` for the file shapes understood.

    Returns
    -------
    TimeSeries
        Time (s, in the file's clock) and angle (rad); ``meta`` records how the file was read.

    Raises
    ------
    DataError
        Missing, empty, binary or JSON files; anything the reader cannot decide or parse,
        naming ``file:line [column]`` (or ``file [variable]``) and the option that would
        settle it.
    """
    p = Path(path)
    if not p.is_file():
        raise DataError("data file not found", str(path))
    with open(p, "rb") as fh:
        head = fh.read(520)
    if head.startswith(b"MATLAB") or p.suffix.lower() == ".mat":
        return read_mat_series(p, spec)
    if head.startswith(_HDF5) or head[512:520] == _HDF5:
        raise DataError("an HDF5 file, not a text table (a MATLAB v7.3 file needs its .mat suffix)", str(path))
    refuse_foreign(p)
    return read_raw_table(p, spec)
