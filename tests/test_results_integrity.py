"""Results files: checksummed data (a flipped byte is refused), a full disk is one clean error."""

from __future__ import annotations

import errno
import json

import h5py
import numpy as np
import pytest
import xarray as xr

from escfit.core.errors import ResultsError
from escfit.results import SCHEMA_VERSION, FitResult, load_fit, write_fit


def _result() -> FitResult:
    rng = np.random.default_rng(3)
    draws = 1.0 + 0.01 * rng.standard_normal((4, 500))
    post = xr.Dataset({"viscous.C": (("chain", "draw"), draws)},
                      coords={"chain": np.arange(4), "draw": np.arange(500)})
    lsq = xr.Dataset({"value": ("parameter", [1.0]), "stderr": ("parameter", [0.01])},
                     coords={"parameter": ["viscous.C"]})
    tree = xr.DataTree.from_dict({"/": xr.Dataset(attrs={"schema_version": SCHEMA_VERSION,
                                                          "parameters": json.dumps(["viscous.C"]),
                                                          "units": json.dumps({"viscous.C": "1/s"})}),
                                  "posterior": post, "least_squares": lsq})
    return FitResult(tree)


def _flip_inside(path, values: np.ndarray) -> None:
    """Flip one byte in the middle of the stored bytes of ``values`` (raw, uncompressed)."""
    raw = bytearray(path.read_bytes())
    needle = values.ravel()[100:104].astype("<f8").tobytes()
    at = raw.find(needle)
    assert at > 0, "posterior bytes not found in the file"
    raw[at + 3] ^= 0x10
    path.write_bytes(bytes(raw))


def test_data_variables_carry_checksums_and_stay_readable(tmp_path):
    import arviz

    res = _result()
    out = tmp_path / "fit.h5"
    write_fit(res, out)
    with h5py.File(out, "r") as f:
        assert f["posterior/viscous.C"].fletcher32
        assert f["least_squares/value"].fletcher32
    idata = arviz.from_netcdf(out)
    np.testing.assert_array_equal(idata.posterior["viscous.C"].values, res.group("posterior")["viscous.C"].values)
    assert load_fit(out).summary()["viscous.C"]["median"] == pytest.approx(
        float(np.median(res.group("posterior")["viscous.C"].values)))


def test_a_flipped_data_byte_is_refused(tmp_path):
    res = _result()
    values = res.group("posterior")["viscous.C"].values
    out = tmp_path / "fit.h5"
    write_fit(res, out)
    _flip_inside(out, values)
    with pytest.raises(ResultsError, match="fit.h5"):
        load_fit(out)
    # the same flip in a file written without checksums goes unnoticed: the check above is what catches it
    plain = tmp_path / "plain.h5"
    res.tree.to_netcdf(plain, engine="h5netcdf")
    _flip_inside(plain, values)
    changed = load_fit(plain).group("posterior")["viscous.C"].values
    assert not np.array_equal(changed, values)


def test_a_full_disk_is_one_error_and_leaves_nothing(tmp_path, monkeypatch):
    import escfit.core.h5write as h5write

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(h5write.os, "fsync", full)
    out = tmp_path / "fit.h5"
    with pytest.raises(ResultsError, match="disk is full") as info:
        write_fit(_result(), out)
    assert "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []
    # an existing file is left as it was
    out.write_bytes(b"old")
    with pytest.raises(ResultsError, match="disk is full"):
        write_fit(_result(), out, force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fit.h5"] and out.read_bytes() == b"old"
