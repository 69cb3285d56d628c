"""Bounded reading of XML files and zip members: memory set by what escfit can use, never by a
size a file declares or a compression ratio.

Zip members are read in chunks and counted as they unpack, after their declared size is checked
against the caller's cap: a member claiming or unpacking to more is refused before (or as soon
as) the cap is passed.  A damaged member (a bad CRC, an unknown compression method, an encrypted
member, a stream cut short) is refused in one line naming the member.

XML goes through defusedxml's parser, which refuses a document type, entity declarations and
external references from expat's own events, so the guard holds whatever the file's encoding
(UTF-8, UTF-16 with or without a byte-order mark, an ``encoding=`` declaration).
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any, Iterator

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import DefusedXMLParser, ParseError

from ...core.errors import DataError

__all__ = ["XML_MAX_BYTES", "CHUNK", "parse_xml", "feed_xml", "read_member", "read_head", "member_chunks", "read_capped"]

# bytes of XML a reader parses at most: 10^6 samples of four CASSY channels take some 100 MB;
# 256 MB is past any lab recording and parses in well under a minute
XML_MAX_BYTES = 256 << 20
CHUNK = 1 << 20


def _megabytes(n: float) -> str:
    return f"{n / 1e6:.0f} MB" if n >= 1e6 else f"{n:.0f} bytes"


def read_capped(path: str | Path, limit: int, what: str) -> bytes:
    """A file's bytes, refused in one line when it is larger than ``limit`` bytes."""
    size = Path(path).stat().st_size
    if size > limit:
        raise DataError(f"{_megabytes(size)} is more than escfit reads of {what} ({_megabytes(limit)})", str(path))
    with open(path, "rb") as fh:
        raw = fh.read(limit + 1)
    if len(raw) > limit:
        raise DataError(f"more than {_megabytes(limit)}: more than escfit reads of {what}", str(path))
    return raw


def member_chunks(zf: zipfile.ZipFile, name: str, limit: int, where: str, what: str) -> Iterator[bytes]:
    """The bytes of zip member ``name`` in chunks, at most ``limit`` of them in all.

    Raises
    ------
    DataError
        A member declaring or unpacking to more than ``limit`` bytes, or a damaged, encrypted or
        unsupported member.
    """
    info = zf.getinfo(name)
    if info.file_size > limit:
        raise DataError(f"{name} in the zip unpacks to {_megabytes(info.file_size)}, more than escfit reads of "
                        f"{what} ({_megabytes(limit)})", where)
    if info.flag_bits & 0x1:
        raise DataError(f"{name} in the zip is encrypted: extract it with its password and read the file", where)
    total = 0
    try:
        with zf.open(info) as fh:
            while chunk := fh.read(CHUNK):
                total += len(chunk)
                if total > limit:
                    raise DataError(f"{name} in the zip unpacks to more than {_megabytes(limit)}: more than escfit "
                                    f"reads of {what}", where)
                yield chunk
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, RuntimeError, EOFError, OSError,
            ValueError) as exc:
        text = str(exc).strip().rstrip(".") or type(exc).__name__
        raise DataError(f"cannot unpack {name} from the zip ({text}): the archive is damaged or uses a method "
                        "escfit cannot read; extract it with an archive program and read the file", where) from None


def read_head(zf: zipfile.ZipFile, name: str, size: int, where: str) -> bytes:
    """The first ``size`` bytes of zip member ``name`` (damage refused as by :func:`member_chunks`)."""
    out = b""
    for chunk in member_chunks(zf, name, max(zf.getinfo(name).file_size, size), where, "a data file"):
        out += chunk[:size - len(out)]
        if len(out) >= size:
            break
    return out


def read_member(zf: zipfile.ZipFile, name: str, limit: int, where: str, what: str) -> bytes:
    """All of zip member ``name`` (see :func:`member_chunks` for the limit and refusals)."""
    return b"".join(member_chunks(zf, name, limit, where, what))


def _xml_error(exc: Exception, where: str) -> DataError:
    if isinstance(exc, DefusedXmlException):
        return DataError("XML with a document type or entity declaration: not an instrument's data file", where)
    line, col = getattr(exc, "position", (None, None))
    return DataError(f"invalid XML ({str(exc).split(':')[0]}, column {col}); the file is cut short or damaged",
                     f"{where}:{line}" if line else where)


def feed_xml(chunks: Iterator[bytes] | list[bytes], where: str, target: Any = None) -> Any:
    """Parse XML given as chunks of bytes with defusedxml's parser and ``target`` (an
    :class:`xml.etree.ElementTree.TreeBuilder` by default); the target's ``close()`` value."""
    parser = DefusedXMLParser(target=target, forbid_dtd=True)
    try:
        for chunk in chunks:
            parser.feed(chunk)
        return parser.close()
    except (ParseError, DefusedXmlException) as exc:
        raise _xml_error(exc, where) from None


def parse_xml(raw: bytes, where: str) -> Any:
    """Parse an instrument's XML file (its root element); a document type, entity declaration or
    external reference is refused (no instrument writes one, and entities can expand without
    bound), whatever the encoding."""
    if len(raw) > XML_MAX_BYTES:
        raise DataError(f"{_megabytes(len(raw))} of XML is more than escfit reads ({_megabytes(XML_MAX_BYTES)})",
                        where)
    return feed_xml([raw], where)

