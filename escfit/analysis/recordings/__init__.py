"""Readers for recorder data; each returns a :class:`UnitCurve` (or raises DataError)."""

from .unit_curve import UnitCurve, read_unit_curve, write_unit_curve

__all__ = ["UnitCurve", "read_unit_curve", "write_unit_curve"]
