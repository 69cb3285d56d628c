"""Rig readings CSV: units in headers, metadata, and every refusal with file:line [column]."""

from __future__ import annotations

import numpy as np
import pytest

from escfit.core.errors import DataError
from escfit.friction import parse_readings, read_readings, write_readings

GF = 0.00980665

GOOD = """\
# source: test
# material: ruby on steel
# source: second line
load_g,dw_g,speed_ft_s,material
2.2,0.127,3,steel

1.0,0.06,10,steel
"""


def test_reads_units_metadata_and_rows():
    r = parse_readings(GOOD, where="rig.csv")
    assert len(r) == 2
    assert np.allclose(r.load, [2.2 * GF, 1.0 * GF])
    assert np.allclose(r.dw, [0.127 * GF, 0.06 * GF])
    assert np.allclose(r.speed, [0.9144, 3.048])
    assert r.material == ("steel", "steel")
    assert r.lines == (5, 7)
    assert r.metadata == {"source": "test second line", "material": "ruby on steel"}


def test_force_units_and_optional_columns():
    r = parse_readings("load_mN,dw_N\n20,0.001\n", where="x.csv")
    assert np.allclose(r.load, [0.02]) and np.allclose(r.dw, [0.001])
    assert r.speed is None and r.material is None


def test_round_trip(tmp_path):
    r = parse_readings(GOOD, where="rig.csv")
    path = tmp_path / "out.csv"
    write_readings(r, path, comments=["source: round trip"])
    back = read_readings(path)
    assert np.allclose(back.load, r.load) and np.allclose(back.dw, r.dw) and np.allclose(back.speed, r.speed)
    assert back.metadata["source"] == "round trip"


@pytest.mark.parametrize(
    "text,where,words",
    [
        ("", "rig.csv", ["empty file"]),
        ("# only a comment\n\n", "rig.csv", ["empty file"]),
        ("load_g,dw_g\n", "rig.csv:1", ["no readings"]),
        ("load_g,speed_ft_s\n1,3\n", "rig.csv:1", ["missing column dw_<unit>"]),
        ("dw_g\n1\n", "rig.csv:1", ["missing column load_<unit>"]),
        ("load_g,dw_g\n2.2,abc\n", "rig.csv:2 [dw_g]", ["'abc'", "not a number"]),
        ("load_g,dw_g\n2.2,\n", "rig.csv:2 [dw_g]", ["(empty)", "not a number"]),
        ("load_g,dw_g\nnan,0.1\n", "rig.csv:2 [load_g]", ["'nan'", "not finite"]),
        ("load_g,dw_g\n2.2,inf\n", "rig.csv:2 [dw_g]", ["'inf'", "not finite"]),
        ("load_g,dw_g\n2.2,0.1\n0,0.1\n", "rig.csv:3 [load_g]", ["load must be positive", "'0'"]),
        ("load_g,dw_g\n-1.5,0.1\n", "rig.csv:2 [load_g]", ["load must be positive", "'-1.5'"]),
        ("load_g,dw_g\n2.2,-0.02\n", "rig.csv:2 [dw_g]", ["dw must be zero or positive", "'-0.02'"]),
        ("load_g,dw_g,speed_ft_s\n2.2,0.1,-3\n", "rig.csv:2 [speed_ft_s]", ["speed", "'-3'"]),
        ("load_furlongs,dw_g\n1,1\n", "rig.csv:1 [load_furlongs]", ["unit 'furlongs'"]),
        ("load_zz,dw_g\n1,1\n", "rig.csv:1 [load_zz]", ["unknown unit 'zz'"]),
        ("load_g,dw_s\n1,1\n", "rig.csv:1 [dw_s]", ["unit 's' is not a force or a mass"]),
        ("load_g,dw_g,speed_g\n1,1,1\n", "rig.csv:1 [speed_g]", ["not a speed"]),
        ("load,dw_g\n1,1\n", "rig.csv:1 [load]", ["has no unit", "load_g"]),
        ("load_g,dw_g,temp_C\n1,1,1\n", "rig.csv:1 [temp_C]", ["unknown column 'temp_C'"]),
        ("load_g,load_N,dw_g\n1,1,1\n", "rig.csv:1", ["appears twice"]),
        ("load_g,dw_g\n1,0.1,5\n", "rig.csv:2", ["expected 2 fields"]),
    ],
)
def test_refusals_name_file_line_column_and_value(text, where, words):
    with pytest.raises(DataError) as info:
        parse_readings(text, where="rig.csv")
    assert info.value.where == where
    for w in words:
        assert w in info.value.message


def test_byte_order_mark_tolerated(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("load_g,dw_g\n2.2,0.1\n".encode("utf-8-sig"))
    assert len(read_readings(path)) == 1


def test_missing_file(tmp_path):
    with pytest.raises(DataError, match="not found"):
        read_readings(tmp_path / "nope.csv")


def test_data_error_is_a_value_error():
    with pytest.raises(ValueError):
        parse_readings("load_g,dw_g\n0,0\n", where="x.csv")


def test_select_one_material():
    r = parse_readings("load_g,dw_g,material\n1,0.1,steel\n2,0.2,alu\n3,0.3,steel\n", where="m.csv")
    assert r.materials() == ["steel", "alu"]
    s = r.only("steel")
    assert len(s) == 2 and s.lines == (2, 4)
    with pytest.raises(DataError, match="'brass'"):
        r.only("brass")
