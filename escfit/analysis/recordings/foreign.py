"""Files escfit cannot read, told apart by their first bytes, refused in one line that says what
the file is and what to export instead.

A spreadsheet workbook (Excel ``.xlsx`` and ``.xls``, OpenDocument ``.ods``), a compressed or
zipped instrument file (Logger Pro ``.cmbl`` saved compressed, Graphical Analysis ``.gambl``, a
zip without a single CASSY data file), a sound file, a PDF and any other binary layout (a timegrapher's or a
logger's own format) are not tables of numbers; no well-kept reader for the workbooks is
installed (openpyxl is not a dependency), so the user is told to save the data as CSV from the
program.  The signatures are the formats' own magic numbers: zip ``PK\\x03\\x04`` (with
``[Content_Types].xml`` and ``xl/`` for Office Open XML, ``mimetype`` for OpenDocument), OLE2
``D0 CF 11 E0 A1 B1 1A E1`` (Excel 97-2003), gzip ``1F 8B``, xz ``FD 37 7A 58 5A 00``, RIFF/WAVE,
``%PDF``, HDF5 ``\\x89HDF``.  MATLAB files, phyphox's zip and a compressed CASSY ``.labx`` (a zip
whose ``data.xml`` is the XML) are readable and pass.

This module imports nothing of the readers; :mod:`escfit.analysis.recordings.detect` and
:mod:`escfit.analysis.recordings.rawseries` call :func:`refuse_foreign` first.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

from ...core.errors import DataError
from ...core.textfile import UTF16_ADVICE, looks_utf16
from .packed import read_head

__all__ = ["refuse_foreign", "cassy_member", "zip_names"]

_AS_CSV = "save it as CSV (or text) from the program that wrote it and read that file"
_OLE2 = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"
_HDF5 = b"\x89HDF\r\n\x1a\n"


def refuse_foreign(path: str | Path) -> None:
    """Raise a one-line :class:`DataError` when ``path`` is a file escfit cannot read.

    Parameters
    ----------
    path
        An existing file.

    Raises
    ------
    DataError
        For the kinds in the module docstring; nothing for text, MATLAB, HDF5 v7.3 ``.mat`` files
        and zips holding CSV files (phyphox).
    """
    p = Path(path)
    with open(p, "rb") as fh:
        head = fh.read(1024)
    suffix = p.suffix.lower()
    why = None
    if head.startswith(b"PK\x03\x04") or head.startswith(b"PK\x05\x06"):
        why = _zip(p, suffix)
    elif head.startswith(_OLE2):
        why = ("an Excel 97-2003 workbook (.xls, or another OLE2 document): open it in a spreadsheet and save the "
               "sheet as CSV (phyphox: export 'CSV (Comma, decimal point)'), then read that")
    elif head.startswith(b"\x1f\x8b"):
        why = (f"a compressed Logger Pro file (.cmbl): {_LOGGER_PRO}" if suffix == ".cmbl" else
               "a gzip-compressed file: decompress it (gunzip) and read the file inside")
    elif head.startswith(b"\xfd7zXZ\x00"):
        why = ("a LabPlot project (.lml, xz-compressed): export its spreadsheet as CSV and read that" if suffix == ".lml"
               else "an xz-compressed file: decompress it (unxz) and read the file inside")
    elif head.startswith(b"RIFF") and head[8:12] == b"WAVE":
        why = ("a sound recording (WAV): escfit does not read audio; analyse it with a timegrapher program (tg's "
               "JSON dump, peterhudson/timegrapher --beats or --windows CSV) and read that")
    elif head.startswith(b"%PDF"):
        why = "a PDF document, not data: read the table it was made from (CSV or text)"
    elif (head.startswith(_HDF5) or head[512:520] == _HDF5) and suffix != ".mat" and not head.startswith(b"MATLAB"):
        why = "an HDF5 file, not a recording (a MATLAB v7.3 file needs its .mat suffix; escfit's results: escfit summary)"
    elif suffix == ".cmbl" and not head.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<"):
        why = f"a Logger Pro file (.cmbl) that is not plain XML (saved compressed?): {_LOGGER_PRO}"
    elif looks_utf16(head) and not head.startswith((b"\xff\xfe", b"\xfe\xff")):  # with a mark: read where readable
        why = UTF16_ADVICE
    elif b"\x00" in head and not head.startswith((b"\xff\xfe", b"\xfe\xff", b"MATLAB")) and suffix != ".mat":
        why = ("a binary file of unknown layout (an instrument's or a program's own format), not a table of numbers: "
               + _AS_CSV)
    elif b"<phyphox" in head:
        why = ("a phyphox experiment file (.phyphox, XML with the experiment and its buffers), not an export: in "
               "phyphox use 'Export data' with 'CSV (Comma, decimal point)' and read that")
    if why:
        raise DataError(why, str(path))


def zip_names(path: str | Path) -> list[str]:
    """The members of a zip archive (a damaged one is refused in one line)."""
    try:
        with zipfile.ZipFile(path) as zf:
            return zf.namelist()
    except (zipfile.BadZipFile, OSError):
        raise DataError("a damaged .zip file (cut short?): copy or export it again", str(path)) from None


def cassy_member(names: list[str], suffix: str) -> str | None:
    """The member of a zip holding a compressed CASSY Lab 2 ``.labx`` (its XML is ``data.xml``), or
    the zip's only ``.labx``; None when there is none or several."""
    if "data.xml" in names and suffix == ".labx":
        return "data.xml"
    labx = [n for n in names if n.lower().endswith(".labx")]
    return labx[0] if len(labx) == 1 else None


_LOGGER_PRO = "open it in Logger Pro and File > Export As > CSV (or save it uncompressed), then read that"


def _zip(p: Path, suffix: str) -> str | None:
    try:
        with zipfile.ZipFile(p) as zf:
            names = zf.namelist()
            mimetype = read_head(zf, "mimetype", 80, str(p)).decode("ascii", "replace") if "mimetype" in names else ""
    except (zipfile.BadZipFile, OSError):
        return "a damaged .zip file (cut short?): copy or export it again"
    lower = [n.lower() for n in names]
    if "[content_types].xml" in lower:
        kind = ("an Excel workbook (.xlsx)" if any(n.startswith("xl/") for n in lower) or suffix == ".xlsx"
                else "an Office document (Open XML)")
        return f"{kind}: export it as CSV (phyphox: 'CSV (Comma, decimal point)'; a spreadsheet: Save As CSV) and read that"
    if "opendocument" in mimetype:
        return "an OpenDocument file (.ods): save the sheet as CSV from the spreadsheet and read that"
    if suffix == ".gambl":
        return ("a Vernier Graphical Analysis file (.gambl): export the data from Graphical Analysis as CSV "
                "(File > Export > CSV) and read that")
    if cassy_member(names, suffix) is not None:
        return None  # a compressed .labx: read by the CASSY reader
    labx = [n for n in names if n.lower().endswith((".labx", ".lab"))]
    if labx or suffix == ".labx":
        inner = f" ({', '.join(labx[:3])})" if labx else f" ({', '.join(names[:3])})"
        return (f"a zip archive holding no single CASSY Lab data file{inner}: extract the .labx from it, or in "
                "CASSY Lab 2 export the table as text, and read that")
    if any(n.endswith(".csv") for n in lower):
        return None  # phyphox's export: read by its reader
    shown = ", ".join(names[:4]) + (", ..." if len(names) > 4 else "")
    return f"a zip archive ({shown}) with no CSV table in it: extract the data file and read that"
