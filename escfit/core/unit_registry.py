"""pint's unit registry as escfit uses it: guarded against arithmetic, cached between processes.

Importing pint and building its registry costs about 0.2 s of CPU, so :mod:`escfit.core.units`
loads this module only when a text unit has to be read that its table of exact factors does
not hold (:func:`escfit.core.units.registry`); a command whose scene and record name only
radians, degrees and seconds never imports pint.
"""

from __future__ import annotations

import math
import os

import pint

from .unit_text import _PREFIX, _PREFIX_NUMBER, safe_unit_text

__all__ = ["ureg", "UnsafeUnitText"]


class UnsafeUnitText(pint.errors.PintError, ValueError):
    """Text pint was asked to parse that is not a number and a unit of :func:`safe_unit_text`'s grammar."""


class _GuardedRegistry(pint.UnitRegistry):
    """pint's registry, refusing to evaluate text outside a bounded grammar once it is built.

    pint parses a unit string as arithmetic, so ``"9**9**9 rad"`` (in a scene) or a column
    header ``load_g**9**9**9`` would compute a number with hundreds of millions of digits: the
    process hangs in one C call that no signal interrupts.  Every parse of text (``Quantity(str)``,
    ``Unit(str)``, ``parse_units``, ``parse_expression``) comes through these two methods, so
    after construction they accept only an optional number followed by a unit of names,
    ``* / ( )`` and small integer powers (:func:`safe_unit_text`), and raise
    :class:`UnsafeUnitText` otherwise (callers already report pint's errors as one line).
    """

    _guarded = False

    def _check(self, text):
        if not self._guarded or not isinstance(text, str):
            return
        m = _PREFIX.match(text)
        rest = text[m.end():].strip() if m else text.strip()
        numbers = _PREFIX_NUMBER.findall(m.group(0)) if m else []
        if (rest and not safe_unit_text(rest)) or not all(math.isfinite(float(x)) for x in numbers):
            raise UnsafeUnitText(f"{text[:60]!r} is not a number and a unit (a number or a fraction such as pi/2, "
                                 "then names, * / ( ) and powers up to two digits)")

    def parse_expression(self, input_string, *args, **kwargs):
        self._check(input_string)
        return super().parse_expression(input_string, *args, **kwargs)

    __call__ = parse_expression  # ureg("...") is parse_expression; the base class binds its own

    def parse_units(self, input_string, *args, **kwargs):
        self._check(input_string)
        return super().parse_units(input_string, *args, **kwargs)

    def parse_units_as_container(self, input_string, *args, **kwargs):
        # what Unit(str), Quantity.to(str) and m_as(str) evaluate text with
        self._check(input_string)
        return super().parse_units_as_container(input_string, *args, **kwargs)


def _registry() -> _GuardedRegistry:
    """pint's registry, its parsed definitions kept in pint's cache folder between processes.

    Parsing pint's definition files takes about 0.2 s of every command's start; pint keeps the
    parsed result in the user's cache folder (``platformdirs``' cache path for "pint") and reuses
    it while the definition files are unchanged.  ``ESCFIT_UNIT_CACHE=0`` turns that off; a
    cache that cannot be read or written (a read-only home, a file another process is still
    writing) falls back to parsing, with the same registry.
    """
    if os.environ.get("ESCFIT_UNIT_CACHE", "1") != "0":
        try:
            return _GuardedRegistry(cache_folder=":auto:")
        except Exception:  # noqa: BLE001 - any failure of the cache: parse the definitions instead
            pass
    return _GuardedRegistry()


ureg = _registry()
ureg.define("gf = gram * g_0 = gram_force")  # gram-force, as in Monday's fixture data
# A watch's beat is half a period of its balance: f = bph / 7200 Hz (18000 bph = 2.5 Hz)
ureg.define("beats_per_hour = turn / 7200 / second = bph = vph")

ureg._guarded = True  # after the module's own definitions (see _GuardedRegistry)
