"""Results written by h5netcdf directly read back as xarray's own ``to_netcdf`` files do."""

from __future__ import annotations

import io

import numpy as np
import pytest
import xarray as xr

from escfit.core.h5direct import supported
from escfit.core.h5write import netcdf_image, xarray_image


def _tree() -> xr.DataTree:
    rng = np.random.default_rng(1)
    obs = {"obs": np.arange(5), "swing": ("obs", np.array([0, 0, 1, 1, 2])),
           "curve": ("obs", np.array(["a", "b", "load 33", "é", "a"])), "load": ("obs", np.linspace(1, 2, 5)),
           "time": ("obs", np.linspace(0, 1, 5), {"units": "s"})}
    root = xr.DataTree(dataset=xr.Dataset(attrs={"schema_version": "escfit-fit/1", "seed": 3, "rate": 0.5,
                                                 "parameters": '["a", "b"]', "flags": np.array([1, 2])}))
    root["observed_data"] = xr.DataTree(dataset=xr.Dataset(
        {"reading": ("obs", rng.normal(size=5), {"units": "rad"})}, coords=obs))
    names = ["viscous.C", "coulomb.R[load=1]"]
    root["least_squares"] = xr.DataTree(dataset=xr.Dataset(
        {"value": ("parameter", [0.1, np.nan]), "at_bound": ("parameter", np.array([0, -1], np.int8)),
         "correlation": (("parameter", "parameter_b"), np.eye(2)), "fixed": ("parameter", [True, False]),
         "expected": ("obs", rng.normal(size=5), {"units": "rad", "long_name": "model"}),
         "scalar": ((), 2.5)}, coords={"parameter": names, "parameter_b": names, **obs}))
    root["posterior"] = xr.DataTree(dataset=xr.Dataset(
        {n: (("chain", "draw"), rng.normal(size=(4, 50)), {"units": "1/s"}) for n in names},
        coords={"chain": np.arange(4), "draw": np.arange(50)}))
    root["empty"] = xr.DataTree(dataset=xr.Dataset({"nothing": ("none", np.zeros(0))}))
    return root


def _read(image: bytes) -> xr.DataTree:
    with xr.open_datatree(io.BytesIO(image), engine="h5netcdf") as tree:
        return tree.load()


@pytest.mark.parametrize("checksums", [True, False])
def test_tree_reads_back_as_xarrays_own_file(checksums):
    tree = _tree()
    assert supported(tree)
    ours, theirs = _read(netcdf_image(tree, checksums=checksums)), _read(xarray_image(tree, checksums=checksums))
    xr.testing.assert_identical(ours, theirs)
    xr.testing.assert_identical(ours, tree)
    assert ours["least_squares"]["fixed"].dtype == bool


def test_checksums_and_fill_values_as_xarray_writes_them():
    import h5py

    with h5py.File(io.BytesIO(netcdf_image(_tree())), "r") as f:
        assert f["posterior/viscous.C"].fletcher32
        assert f["least_squares/at_bound"].fletcher32
        assert not f["least_squares/parameter"].fletcher32  # text takes no checksum
        assert np.isnan(f["least_squares/value"].attrs["_FillValue"])
        assert f["observed_data/reading"].attrs["coordinates"] == "curve load swing time"


def test_dataset_and_arviz_reader(tmp_path):
    ds = _tree()["posterior"].to_dataset()
    xr.testing.assert_identical(xr.open_dataset(io.BytesIO(netcdf_image(ds)), engine="h5netcdf").load(), ds)
    az = pytest.importorskip("arviz")
    path = tmp_path / "fit.h5"
    path.write_bytes(netcdf_image(_tree()))
    idata = az.from_netcdf(path)
    assert {"posterior", "observed_data"} <= set(idata.groups())
    np.testing.assert_array_equal(np.asarray(idata.posterior["viscous.C"]),
                                  _tree()["posterior"]["viscous.C"].values)


def test_unsupported_kinds_go_through_xarray():
    ds = xr.Dataset({"when": ("t", np.array(["2024-01-01", "2024-01-02"], dtype="datetime64[ns]"))})
    assert not supported(ds)
    back = xr.open_dataset(io.BytesIO(netcdf_image(ds)), engine="h5netcdf").load()
    xr.testing.assert_identical(back, ds)
