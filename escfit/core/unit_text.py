"""The grammar of unit text escfit lets pint evaluate: a number, then names, ``* / ( )`` and small powers.

Kept apart from :mod:`escfit.core.units` (the conversions) and
:mod:`escfit.core.unit_registry` (pint's registry, which checks every text it parses against
this grammar), so that both read it without importing each other.
"""

from __future__ import annotations

import re

__all__ = ["MAX_UNIT_TEXT", "safe_unit_text"]

MAX_UNIT_TEXT = 40
_UNIT_TOKEN = re.compile(r"(?P<name>[A-Za-z_°µΩ²³]+(?:_\d{1,2})?(?![\w])|%)|(?P<pow>(?:\*\*|\^)\s*-?\d{1,2})(?![\d.])"
                         r"|(?P<op>[*/])|(?P<paren>[()])|(?P<space>\s+)")
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
# A leading number, or a short product or quotient of numbers and pi ("pi/2 rad", "1/4 turn"):
# at most four factors and no powers, so nothing pint computes from it can grow.
_PREFIX = re.compile(rf"\s*(?:{_NUM}|pi)(?:\s*[*/]\s*(?:{_NUM}|pi)(?![A-Za-z_])){{0,3}}(?![\d.eE])")
_PREFIX_NUMBER = re.compile(_NUM)


def safe_unit_text(text: str) -> bool:
    """Whether ``text`` (what follows an argument's number) is a unit pint may evaluate safely.

    Tokens: unit names (ASCII letters, ``_``, ``°``, ``µ``, ``Ω``, optionally ending in ``_``
    and one or two digits such as ``g_0``), ``%``, ``*``, ``/``, parentheses (depth at most 2),
    spaces and a power ``**n`` / ``^n`` (``n`` one or two digits, optionally negative) directly
    after a name.  No other numbers, so nothing pint evaluates can grow: ``9**9**9`` is refused.
    """
    if len(text) > MAX_UNIT_TEXT:
        return False
    pos, prev, depth = 0, "start", 0
    while pos < len(text):
        m = _UNIT_TOKEN.match(text, pos)
        if not m:
            return False
        pos = m.end()
        tok = m.lastgroup
        if tok == "space":
            continue
        if tok == "pow" and prev != "name":
            return False
        if tok == "op" and prev == "op":
            return False
        if tok == "paren":
            depth += 1 if m.group() == "(" else -1
            if not 0 <= depth <= 2:
                return False
            tok = m.group()
        prev = tok
    return depth == 0 and prev not in ("op", "(")
