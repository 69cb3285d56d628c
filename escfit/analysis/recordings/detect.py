"""Recording formats: detection from a file's content and the format -> reader dispatch.

This module sits above the readers: it imports them, none of them imports it.

Detection looks at the content, never only at the name: the first bytes (a zip, XML, JSON), the
first lines (``LabVIEW Measurement``, CASSY's ``DEF=``, a timegrapher program's header) and the
header's names (escfit's own columns, run labels, phyphox's quoted header).  When the content
fits several formats the file is refused with the candidates listed and the key that settles it
(``[recording] format``); it is never silently read as one of them.
"""

from __future__ import annotations

import re
from pathlib import Path

from ...core.csvtable import refuses_unreadable
from ...core.errors import DataError
from ...core.textfile import refuse_binary
from ...core.tabletext import decode_lenient, numbered_lines, split_fields
from .cassy import read_cassy_labx, read_cassy_text, sniff_cassy_text
from .foreign import cassy_member, refuse_foreign, zip_names
from .formats_list import ESCFIT_FORMATS, FORMAT_NAMES, TIMEGRAPHER_FORMATS, TIMESERIES_FORMATS
from .labfiles import read_arduino_log, read_cmbl, read_run_csv, sniff_arduino_log, sniff_run_csv
from .lvm import read_lvm, sniff_lvm
from .phyphox import read_phyphox, sniff_phyphox_csv
from .pulses import read_pulses
from .rawseries import read_raw_series
from .recording_spec import RecordingSpec
from .sniff import did_you_mean, file_kind, match_header, refuse_unless_csv
from .tg_applog import read_tg_applog, sniff_tg_applog
from .tg_logs import read_tgcli, read_timegrapher_net, sniff_tg_logs
from .timegrapher import TimegrapherRecording, read_tg_json, read_timegrapher_csv
from .timeseries import read_timeseries
from .tracker import read_tracker_table, read_trk, sniff_tracker_table
from .unit_curve import read_unit_curve

__all__ = ["FORMATS", "detect_format", "read_recording", "read_timegrapher", "read_with_spec", "candidates"]

FORMATS = ESCFIT_FORMATS
_HEAD = 65536


def _text_head(path: Path) -> str:
    raw = path.read_bytes()[:_HEAD]
    return decode_lenient(raw, str(path), []) if raw.strip() else ""


def _xml_format(head: str) -> str | None:
    if "<cassylab" in head[:600]:
        return "cassy"
    if "org.opensourcephysics.cabrillo.tracker" in head[:2000]:
        return "tracker-trk"
    if re.search(r"<Document[\s>]", head[:2000]) and "<DataSet" in head:
        return "vernier-cmbl"
    return None


def candidates(path: str | Path) -> list[str]:
    """Every format whose signature the file's content carries, most specific first."""
    p = Path(path)
    kind = file_kind(p)
    if kind == "empty":
        raise DataError("empty file (no header and no rows)", str(path))
    raw = p.read_bytes()[:8]
    refuse_foreign(p)  # workbooks, compressed or zipped instrument files, audio, unknown binaries
    if raw.startswith(b"PK\x03\x04"):  # a zip that passed: a compressed CASSY file or phyphox's CSV files
        return ["cassy"] if cassy_member(zip_names(p), p.suffix.lower()) is not None else ["phyphox"]
    if raw.startswith(b"MATLAB") or p.suffix.lower() == ".mat":
        return ["raw"]
    if kind == "binary" and not raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        refuse_binary(p.read_bytes()[:512], str(path), "a recording")
    head = _text_head(p)
    stripped = head.lstrip("\ufeff \t\r\n")
    if stripped.startswith("<"):
        found = _xml_format(stripped)
        return [found] if found else []
    logs = sniff_tg_logs(stripped)
    if logs:
        return [logs]
    if stripped.startswith(("{", "[")):
        return ["timegrapher"]
    if sniff_lvm(stripped):
        return ["lvm"]
    if sniff_cassy_text(stripped):
        return ["cassy-text"]
    found = []
    header = _first_header(stripped)
    cols = set(match_header(header))
    if "kind" in cols and any(c.startswith("time_") for c in cols):
        found.append("pulses")
    if cols & {"swing", "cycle"}:
        found.append("unit-curve")
    if "amplitude_deg" in cols and cols & {"rate_s_per_day", "beat_error_ms"}:
        found.append("timegrapher")
    if any(c.startswith("theta_") for c in cols):
        found.append("timeseries")
    if sniff_tg_applog(path) and "timegrapher" not in found:
        found.append("tg-applog")
    runs = sniff_run_csv(_header_above_numbers(stripped))
    if runs:
        found.append(runs)
    if sniff_phyphox_csv(stripped):
        found.append("phyphox")
    if sniff_tracker_table(stripped):
        found.append("tracker")
    if sniff_arduino_log(stripped):
        found.append("arduino-log")
    return found


def _fields(line: str) -> list[str]:
    s = line.strip()
    delim = max((",", ";", "\t"), key=s.count) if any(d in s for d in ",;\t") else None
    if delim is None and len(s) > 1 and s[0] == s[-1] == '"':  # one quoted name: a one-column table's header
        return [s[1:-1]]
    return split_fields(s, delim)


def _first_header(text: str) -> list[str]:
    for _, line in numbered_lines(text):
        s = line.strip()
        if s and not s.startswith("#"):
            return _fields(s)
    return []


_NUMBER = re.compile(r"^[-+]?(\d+[.,]?\d*|[.,]\d+)([eE][-+]?\d+)?$")


def _header_above_numbers(text: str) -> list[str]:
    """The line right above the first line that starts with a number (a table's header; a
    title line above it, such as DataStudio's ``Output Voltage, Run #16``, is not one)."""
    previous = None
    for _, line in numbered_lines(text):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        fields = _fields(s)
        if fields and _NUMBER.match(fields[0].strip()):
            return _fields(previous) if previous is not None else []
        previous = s
    return _first_header(text)


@refuses_unreadable
def detect_format(path: str | Path) -> str:
    """Which format a recording file holds, from its content (one of
    :data:`~escfit.analysis.recordings.formats_list.FORMAT_NAMES`).

    Raises
    ------
    DataError
        Binary or empty files; files matching no format (naming the columns close to a known
        one); files matching several (naming them and ``[recording] format``).
    """
    found = candidates(path)
    if len(found) == 1:
        return found[0]
    if len(found) > 1:
        raise DataError(f"the content fits several formats ({', '.join(found)}); set [recording] format (or --format) "
                        "to the one it is", str(path))
    header = _first_header(_text_head(Path(path))) if file_kind(path) == "text" else []
    raise DataError(f"cannot tell the recording format from the header {header}{did_you_mean(header)}; give "
                    f"the format explicitly (one of {', '.join(FORMATS)})", str(path))


def read_timegrapher(path: str | Path) -> TimegrapherRecording:
    """Read a tg JSON dump, a per-beat CSV or an app's log (told apart by content)."""
    if file_kind(path) == "json":
        return read_tg_json(path)
    return read_tg_applog(path) if sniff_tg_applog(path) else read_timegrapher_csv(path)


_SERIES_READERS = {"raw": read_raw_series, "phyphox": read_phyphox, "cassy": read_cassy_labx,
                   "cassy-text": read_cassy_text, "lvm": read_lvm, "picoscope": read_raw_series,
                   "vernier-cmbl": read_cmbl, "vernier-csv": lambda p, s: read_run_csv(p, s, program="Vernier"),
                   "pasco-csv": lambda p, s: read_run_csv(p, s, program="PASCO Capstone"),
                   "tracker": read_tracker_table, "tracker-trk": read_trk, "arduino-log": read_arduino_log}
_TG_READERS = {"timegrapher-net": read_timegrapher_net, **{f: read_tgcli for f in TIMEGRAPHER_FORMATS if
                                                           f.startswith("tgcli")}}


@refuses_unreadable
def read_with_spec(path: str | Path, spec: RecordingSpec | None, fmt: str | None = None):
    """Read an instrument's or program's file with the ``[recording]`` options.

    The format is ``fmt``, else ``spec.format``, else detected (:func:`detect_format`); a text
    table that matches no signature is read as a raw table.  escfit's own formats are read by
    :func:`read_recording`.
    """
    fmt = fmt or (spec.format if spec is not None else None)
    if fmt is None:
        try:
            fmt = detect_format(path)
        except DataError as exc:
            if "cannot tell the recording format" not in exc.message:
                raise
            fmt = "raw"
        if fmt in ("unit-curve", "pulses", "timeseries"):  # with [recording] options escfit's tables read raw
            fmt = "raw"
    if fmt in _SERIES_READERS:
        return _SERIES_READERS[fmt](path, spec)
    if fmt in _TG_READERS:
        return _TG_READERS[fmt](path, spec)
    if fmt in ESCFIT_FORMATS:
        return read_recording(path, fmt)
    raise DataError(f"unknown format {fmt!r}; choose one of {', '.join(FORMAT_NAMES)}", str(path))


@refuses_unreadable
def read_recording(path: str | Path, fmt: str | None = None, **options):
    """Read any recording format (detected unless ``fmt`` is given).

    Parameters
    ----------
    path
        The file.
    fmt
        One of :data:`~escfit.analysis.recordings.formats_list.FORMAT_NAMES`, or ``None`` to detect it.
    **options
        Passed to the format's reader (e.g. ``notch_deg`` for unit curves).

    Returns
    -------
    UnitCurve, PulseTrain, TimegrapherRecording or TimeSeries
    """
    fmt = fmt or detect_format(path)
    if fmt == "unit-curve":
        refuse_unless_csv(path, "a unit curve")
        return read_unit_curve(path, **options)
    if fmt == "pulses":
        return read_pulses(path, **options)
    if fmt == "timegrapher":
        return read_timegrapher(path, **options)
    if fmt == "timeseries":
        return read_timeseries(path, **options)
    if fmt == "tg-applog":
        return read_tg_applog(path, **options)
    if fmt in TIMESERIES_FORMATS or fmt in TIMEGRAPHER_FORMATS:
        return read_with_spec(path, options.pop("spec", None), fmt)
    raise DataError(f"unknown format {fmt!r}; choose one of {', '.join(FORMAT_NAMES)}", str(path))
