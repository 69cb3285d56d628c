"""Text files as people save them: UTF-8 with or without a byte-order mark; other encodings named.

Spreadsheets and Windows editors often start a UTF-8 file with a byte-order mark (EF BB BF); it is
not part of the first line and is dropped.  A file in another encoding (Latin-1 / Windows-1252 from
an older logger, UTF-16 from some exports) is refused with one line that names the encoding seen,
the first byte that is not UTF-8 and its line, so that the user can re-save the file; guessing an
encoding silently could turn a degree sign or a micro prefix into another unit.
"""

from __future__ import annotations

from .errors import DataError

__all__ = ["decode_text", "looks_binary", "looks_utf16", "refuse_binary", "BOM", "UTF16_ADVICE"]

BOM = b"\xef\xbb\xbf"
UTF16_ADVICE = "UTF-16 text, not UTF-8: save the file as UTF-8 (in a spreadsheet: CSV UTF-8)"


def looks_binary(raw: bytes) -> bool:
    """Whether ``raw`` (a file's first bytes) holds NUL bytes outside a UTF-16 text."""
    return b"\x00" in raw and not raw.startswith((b"\xff\xfe", b"\xfe\xff"))


def looks_utf16(raw: bytes) -> bool:
    """Whether ``raw`` (a file's first bytes) is UTF-16 text: a UTF-16 byte-order mark, or
    (without one) a NUL in every other byte, as ASCII text in UTF-16 has."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        return True
    head = raw[:512] if len(raw) % 2 == 0 else raw[:min(len(raw) - 1, 512)]
    if len(head) < 8:
        return False
    even, odd = head[0::2], head[1::2]
    return any(half.count(0) == len(half) and other.count(0) == 0 for half, other in ((even, odd), (odd, even)))


def refuse_binary(raw: bytes, where: str, what: str) -> None:
    """Refuse a file whose first bytes ``raw`` hold NUL bytes, naming UTF-16 text as such (it is
    text in another encoding, not a binary file)."""
    if looks_utf16(raw):
        raise DataError(UTF16_ADVICE, where)
    raise DataError(f"binary file, not {what}", where)


def decode_text(raw: bytes, where: str, *, what: str = "a text file") -> str:
    """Decode a file's bytes as UTF-8, dropping a byte-order mark.

    Parameters
    ----------
    raw
        The file's bytes.
    where
        The file, for messages.
    what
        What the caller expected, for the message about binary files (``"a recording"``).

    Raises
    ------
    DataError
        A binary file, UTF-16 text, or bytes that are not UTF-8 (naming the byte, its line and
        what it reads as in Windows-1252).
    """
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise DataError("UTF-16 text (it starts with a UTF-16 byte-order mark): save the file as UTF-8", where)
    if raw.startswith(BOM):
        raw = raw[len(BOM):]
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        if looks_binary(raw[:8192]):
            raise DataError(f"a binary file, not {what}", where) from None
        line = raw[:exc.start].count(b"\n") + 1
        byte = raw[exc.start]
        seen = bytes([byte]).decode("cp1252", errors="replace")
        raise DataError(f"not UTF-8 text: byte 0x{byte:02x} on line {line} (in Latin-1 / Windows-1252 that is "
                        f"{seen!r}); save the file as UTF-8", f"{where}:{line}") from None
