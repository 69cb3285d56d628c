"""Synthetic recordings of balance scenes: what each recorder would write, with known truth."""

from .instruments import RECORDERS, record, record_pulses, record_timegrapher, record_timeseries
from .unit_curves import record_unit_curve

__all__ = ["RECORDERS", "record", "record_pulses", "record_timegrapher", "record_timeseries", "record_unit_curve"]
