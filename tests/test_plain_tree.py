"""Results held as plain arrays (:mod:`escfit.core.plain_tree`) are the xarray tree they stand for.

The reference is xarray itself: the same groups built as ``xarray.Dataset`` s and written by
xarray's own ``to_netcdf`` must read back identical to the plain tree's file, and a fit's result
must give the same table before and after its DataTree is made.
"""

from __future__ import annotations

import io

import numpy as np
import pytest
import xarray as xr

from escfit.core.h5direct import image
from escfit.core.h5write import xarray_image
from escfit.core.plain_tree import Group, Tree
from escfit.results import FitResult, clean_attrs


def _groups(cls):
    names = ["a.x", "b.y"]
    obs = {"obs": np.arange(5), "time": ("obs", np.linspace(0, 1, 5), {"units": "s"}),
           "curve": ("obs", np.array(["p", "p", "q", "q", "q"]))}
    lsq = cls({"value": ("parameter", np.array([1.5, -2.0])), "stderr": ("parameter", np.array([0.1, np.nan])),
               "correlation": (("parameter", "parameter_b"), np.array([[1.0, 0.3], [0.3, 1.0]])),
               "at_bound": ("parameter", np.array([0, -1], np.int8)),
               "ok": ("parameter", np.array([True, False])),
               "expected": ("obs", np.arange(5.0) ** 2, {"units": "deg", "long_name": "expected"})},
              coords={"parameter": names, "parameter_b": names, **obs}, attrs={"chisqr": 2.5, "note": "text"})
    post = cls({"a.x": (("chain", "draw"), np.arange(12.0).reshape(3, 4), {"units": "1/s"})},
               coords={"chain": np.arange(3), "draw": np.arange(4)})
    return {"least_squares": lsq, "posterior": post}


ATTRS = clean_attrs({"parameters": ["a.x", "b.y"], "model": "balance", "warnings": ["w"], "seed": 3})


def _read(data: bytes) -> xr.DataTree:
    with xr.open_datatree(io.BytesIO(data), engine="h5netcdf") as t:
        return t.load()


def test_plain_tree_file_reads_back_as_xarrays_own_file():
    plain = Tree(ATTRS, _groups(Group))
    ref = xr.DataTree(dataset=xr.Dataset(attrs=ATTRS))
    for name, ds in _groups(xr.Dataset).items():
        ref[name] = xr.DataTree(dataset=ds)
    got, want = _read(image(plain)), _read(xarray_image(ref))
    assert dict(got.attrs) == dict(want.attrs)
    assert set(got.children) == set(want.children) == {"least_squares", "posterior"}
    for name in want.children:
        xr.testing.assert_identical(got[name].to_dataset(), want[name].to_dataset())
    # and the DataTree made from the plain tree in memory is the one xarray builds
    for name in want.children:
        xr.testing.assert_identical(plain.to_xarray()[name].to_dataset(), ref[name].to_dataset())


def test_a_dimension_of_two_lengths_is_refused():
    with pytest.raises(ValueError, match="'b'.*dimension 'obs' of length 3, 2 elsewhere"):
        Group({"a": ("obs", np.zeros(2)), "b": ("obs", np.zeros(3))})
    with pytest.raises(ValueError, match="2-d values given dimensions"):
        Group({"a": ("obs", np.zeros((2, 2)))})


def test_summary_is_the_same_before_and_after_the_datatree_is_made():
    lsq = _groups(Group)["least_squares"]
    lsq.data_vars.pop("ok")
    for key, (lo, hi) in {"68": (-1, 1), "95": (-2, 2)}.items():
        lsq.data_vars[f"lo{key}"] = Group({"v": ("parameter", np.array([1.5 + 0.1 * lo, -2.0]))})["v"]
        lsq.data_vars[f"hi{key}"] = Group({"v": ("parameter", np.array([1.5 + 0.1 * hi, -1.0]))})["v"]
    res = FitResult(Tree(ATTRS, {"least_squares": lsq}))
    before = res.summary()
    assert "xarray" not in type(res.contents()).__module__
    tree = res.tree  # made now
    assert isinstance(tree, xr.DataTree) and res.contents() is tree
    after = res.summary()
    assert set(before) == {"a.x", "b.y"}
    for name in before:
        for key, value in before[name].items():
            assert after[name][key] == value or (value != value and after[name][key] != after[name][key]), (name, key)
    assert before["a.x"]["estimate"] == 1.5 and before["a.x"]["lo95"] == pytest.approx(1.3)
    assert before["b.y"]["at_bound"] == "min" and before["a.x"]["at_bound"] is None
