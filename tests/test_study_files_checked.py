"""The study's readers check a file's layout before reading it, as ``summary`` does.

``fit-many`` (when it resumes a folder), the population's draws, the decay residuals of a
comparison, the fleet summary and the population file each read files a user may have copied,
damaged or been sent.  A file whose arrays declare gigabytes it does not hold is refused (or, for
a resume, treated as not done) from its metadata alone, under a memory ceiling far below what
reading it would take.  The files are made by the fixtures of ``test_saved_files_checked`` and
damaged in copies through h5py.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import xarray as xr

from escfit.core.errors import ResultsError

from .test_fuzz_inputs import memory_ceiling
from .test_saved_files_checked import MEMORY_CEILING, damage, deleted, made, unwritten, work  # noqa: F401

HUGE_POSTERIOR = unwritten("posterior/rig.k", (10, 1_000_000_000))  # 80 GB declared, nothing written


def test_population_draws_refuse_an_inflated_results_file(work):
    from escfit.study.population import collect_draws

    damage(work / "e.h5", HUGE_POSTERIOR)
    with memory_ceiling(MEMORY_CEILING), pytest.raises(ResultsError) as info:
        collect_draws([work / "e.h5"], names=["rig.k"])
    assert "posterior/rig.k declares" in str(info.value) and "e.h5" in str(info.value)


def test_population_draws_refuse_a_results_file_missing_a_group(work):
    from escfit.study.population import collect_draws

    damage(work / "e.h5", deleted("diagnostics"))
    with pytest.raises(ResultsError, match="diagnostics group is missing"):
        collect_draws([work / "e.h5"], names=["rig.k"])


def test_a_resumed_batch_takes_an_inflated_results_file_for_not_done(work):
    """Read as a finished unit only after its layout passes: here it is never read."""
    from escfit.study.batch import _load_for_summary

    assert _load_for_summary(work / "l.h5") is not None  # the undamaged file is a finished unit
    damage(work / "e.h5", HUGE_POSTERIOR)
    with memory_ceiling(MEMORY_CEILING):
        assert _load_for_summary(work / "e.h5") is None


def test_decay_residuals_refuse_an_inflated_results_file(work):
    from escfit.study.compare import decay_residuals

    folder = work / "units"
    folder.mkdir()
    shutil.copy(work / "e.h5", folder / "unit1.h5")
    damage(folder / "unit1.h5", unwritten("posterior_predictive/expected", (10, 10, 10_000_000)))
    with memory_ceiling(MEMORY_CEILING), pytest.raises(ResultsError, match="posterior_predictive/expected declares"):
        decay_residuals(folder)


def _small_file(path, schema):
    """A netCDF-4 file of the given schema holding one short variable along ``unit``."""
    ds = xr.Dataset({"status": ("unit", np.array(["ok", "ok"]))}, coords={"unit": ["a", "b"]},
                    attrs={"schema_version": schema, "summary": "{}"})
    ds.to_netcdf(path, engine="h5netcdf")


@pytest.mark.parametrize("kind", ["fleet summary", "population file"])
def test_summary_and_population_files_are_checked_before_reading(tmp_path, kind):
    from escfit.study.batch import load_summary
    from escfit.study.names import SUMMARY_SCHEMA
    from escfit.study.population import POPULATION_SCHEMA, load_population

    schema, load = {"fleet summary": (SUMMARY_SCHEMA, load_summary),
                    "population file": (POPULATION_SCHEMA, load_population)}[kind]
    path = tmp_path / "f.nc"
    _small_file(path, schema)
    assert load(path).attrs["schema_version"] == schema  # the file as written is read
    damage(path, lambda f: f.create_dataset("values", shape=(20_000, 50_000), dtype="f8", chunks=(1000, 1000)))
    # an 8 GB array added, never written
    with memory_ceiling(MEMORY_CEILING), pytest.raises(ResultsError, match="array values declares"):
        load(path)
    (tmp_path / "text.nc").write_text("not HDF5\n")
    with pytest.raises(ResultsError, match=f"not an HDF5 file: give a {kind}"):
        load(tmp_path / "text.nc")
