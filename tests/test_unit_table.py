"""The units escfit reads without pint (:data:`escfit.core.units.COMMON_UNITS`,
:data:`~escfit.core.units.COMMON_RATES`, the parameters' time powers) against pint itself, and
the readers' answers with and without the table."""

import math

import pytest

from escfit.balance.problems import period
from escfit.core import units
from escfit.core.errors import UnitError


def _canonical(kind):
    return {"angle": "rad", "time": "s", "mass": "kg", "force": "N"}[kind]


@pytest.mark.parametrize("text", sorted(units.COMMON_UNITS))
def test_common_units_are_pints_factors(text):
    kind, factor = units.COMMON_UNITS[text]
    q = units.registry().Quantity(1.0, text)
    assert q.dimensionality == units.registry().Quantity(1.0, _canonical(kind)).dimensionality
    assert factor == pytest.approx(float(q.to(_canonical(kind)).magnitude), rel=1e-15)


@pytest.mark.parametrize("text,kind", sorted(units.COMMON_RATES))
def test_common_rates_follow_the_rule_for_rates(text, kind):
    """The factor is what pint's path of :func:`to_canonical` gives for the same text."""
    q = units._parse(f"1 {text}", "test")
    assert units.COMMON_RATES[(text, kind)] == pytest.approx(units._per_time(q, f"1 {text}", kind, "test"), rel=1e-15)


def test_standard_gravity_is_pints():
    assert units.STANDARD_GRAVITY == float(units.registry().Quantity(1.0, "standard_gravity").to("m/s**2").magnitude)


@pytest.mark.parametrize("unit", sorted(period.TIME_POWERS))
def test_time_powers_are_pints(unit):
    expected = float(units.registry().Quantity(1.0, unit).dimensionality.get("[time]", 0.0)) if unit else 0.0
    assert period.TIME_POWERS[unit] == expected


@pytest.mark.parametrize("value,kind", [("300 deg", "angle"), ("-2.5e-1 rad", "angle"), ("0.75 s", "time"),
                                        ("40 ms", "time"), ("2 min", "time"), ("1000 Hz", "frequency"),
                                        ("2.5 Hz", "angular_frequency"), ("15.7 1/s", "angular_frequency"),
                                        ("0.05 1/s", "rate_per_s"), ("1.2 kHz", "frequency"), ("25 g", "mass"),
                                        ("3 rad/s", "angular_frequency")])
def test_to_canonical_is_the_same_with_and_without_the_table(value, kind, monkeypatch):
    fast = units.to_canonical(value, kind, "test")
    monkeypatch.setattr(units, "COMMON_UNITS", {})
    monkeypatch.setattr(units, "COMMON_RATES", {})
    assert fast == pytest.approx(units.to_canonical(value, kind, "test"), rel=1e-15)


@pytest.mark.parametrize("value,kind", [("300 deg", "time"), ("2 Hz", "rate_per_s"), ("3 rad/s", "frequency"),
                                        ("inf deg", "angle"), ("1e999 deg", "angle"), ("5 s", "angle")])
def test_what_the_table_does_not_hold_is_refused_as_before(value, kind):
    with pytest.raises(UnitError):
        units.to_canonical(value, kind, "test")


def test_common_convert_matches_pint():
    assert units.common_convert("25 g", "kg") == pytest.approx(0.025, rel=1e-15)
    assert units.common_convert("25 g", "N") is None  # a mass is not a force: pint's path decides
    assert units.common_convert("2 min", "s") == 120.0
    assert units.common_convert("heavy", "g") is None
    assert math.isclose(units.common_convert("90 deg", "rad"), math.pi / 2, rel_tol=1e-15)
