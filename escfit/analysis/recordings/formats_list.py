"""The names of the recording formats escfit reads (a leaf: the scene's ``[recording] format`` key
is checked against it without importing the readers).

See :mod:`escfit.analysis.recordings.detect` for what each holds and which reader reads it.
"""

from __future__ import annotations

__all__ = ["FORMAT_NAMES", "ESCFIT_FORMATS", "TIMESERIES_FORMATS", "TIMEGRAPHER_FORMATS"]

#: escfit's own CSV and JSON formats (and the generic app log)
ESCFIT_FORMATS = ("unit-curve", "pulses", "timegrapher", "timeseries", "tg-applog")
#: instruments' and programs' files read into a TimeSeries
TIMESERIES_FORMATS = ("raw", "phyphox", "cassy", "cassy-text", "lvm", "picoscope", "vernier-cmbl", "vernier-csv",
                      "pasco-csv", "tracker", "tracker-trk", "arduino-log")
#: timegrapher programs' files read into a TimegrapherRecording
TIMEGRAPHER_FORMATS = ("timegrapher-net", "tgcli-beats", "tgcli-windows", "tgcli-slices", "tgcli-amplitude",
                       "tgcli-json")
FORMAT_NAMES = ESCFIT_FORMATS + TIMESERIES_FORMATS + TIMEGRAPHER_FORMATS
