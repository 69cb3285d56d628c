"""What a worker does for a batch (:func:`escfit.study.fit_many`): fit one unit and send back
its results file as bytes and its row of the fleet summary.

A task carries the scene text and the unit's data, never a file name of the client's: a
balance unit curve as its in-memory :class:`~escfit.analysis.recordings.UnitCurve`, any other
recording as a :class:`RecordingFile` (name and bytes) that :func:`readable` writes to a
temporary directory for the family's reader.
"""

from __future__ import annotations

import contextlib
import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import xarray as xr

from ..analysis.recordings import UnitCurve
from ..core.errors import DataError, EscfitError, ResultsError
from ..core.h5write import netcdf_image
from ..results import FitResult

__all__ = ["RecordingFile", "readable", "fit_task", "results_image", "summary_row"]


@dataclass(frozen=True)
class RecordingFile:
    """A recording file as a task carries it: the file's name (no directory) and its bytes."""

    name: str
    content: bytes = field(repr=False)

    @classmethod
    def read(cls, path: str | Path) -> "RecordingFile":
        p = Path(path)
        try:
            return cls(p.name, p.read_bytes())
        except FileNotFoundError:
            raise DataError("recording file not found", str(path)) from None
        except OSError as exc:
            raise DataError(f"cannot read the recording file ({exc.strerror or exc})", str(path)) from None


def summary_row(res: FitResult) -> dict[str, Any]:
    """One unit's row of the fleet summary, from a fit in memory (or read back with the groups
    :data:`escfit.study.batch.SUMMARY_GROUPS`): per-parameter statistics, reading scatter and its unit, number of
    readings, warnings."""
    lsq = res.group("least_squares")
    attrs = lsq.attrs if lsq is not None else {}
    units = lsq["expected"].attrs.get("units", "") if lsq is not None and "expected" in lsq else ""
    return {"parameters": res.summary(), "sigma_hat": float(attrs.get("sigma_hat", math.nan)),
            "n_data": int(attrs.get("n_data", -1)), "reading_units": str(units), "warnings": res.warnings}


@contextlib.contextmanager
def readable(data: UnitCurve | RecordingFile | str | Path) -> Iterator[UnitCurve | Path | str]:
    """What :func:`escfit.inference.fit` reads: a unit curve as it is, a recording file's bytes
    written under its own name to a temporary directory (removed afterwards)."""
    if not isinstance(data, RecordingFile):
        yield data
        return
    with tempfile.TemporaryDirectory(prefix="escfit-unit-") as d:
        path = Path(d) / (Path(data.name).name or "recording")
        path.write_bytes(data.content)
        yield path


def fit_task(scene_text: str, scene_where: str, data: UnitCurve | RecordingFile, options: dict) -> dict[str, Any]:
    """Worker side: fit one unit; never raises (a failure comes back as a message).

    Returns the results file's bytes (``payload``) and the unit's summary row (``row``)."""
    started = time.perf_counter()
    try:
        from ..inference import fit
        from ..core.scene import load_scene

        scene = load_scene(scene_where, text=scene_text)
        opts = dict(options)
        checkpoint = opts.pop("checkpoint", None)
        source = opts.pop("source", None)
        note = ""
        with readable(data) as local:
            if checkpoint is not None and Path(checkpoint).exists() and opts.get("method") == "emcee":
                try:
                    res = fit(scene, local, checkpoint=checkpoint, resume=True, **opts)
                except (ResultsError, OSError) as exc:  # damaged, foreign or of other settings: start afresh
                    why = exc.message if isinstance(exc, ResultsError) else f"{type(exc).__name__}: {exc}"
                    note = f"checkpoint {Path(checkpoint).name} not resumable ({why}); started afresh"
                    Path(checkpoint).unlink(missing_ok=True)
                    res = fit(scene, local, checkpoint=checkpoint, force=True, **opts)
            else:
                res = fit(scene, local, checkpoint=checkpoint, force=True, **opts)
        if isinstance(data, RecordingFile) and source and "data_file" in res.tree.attrs:
            res.tree.attrs["data_file"] = source  # the client's file, not the worker's temporary copy
        payload = results_image(res)
        return {"status": "ok", "payload": payload, "row": summary_row(res), "note": note,
                "seconds": time.perf_counter() - started}
    except Exception as exc:  # noqa: BLE001 - one unit's failure must not stop the batch
        msg = str(exc) if isinstance(exc, EscfitError) else f"{type(exc).__name__}: {exc}"
        return {"status": "failed", "error": msg or type(exc).__name__, "seconds": time.perf_counter() - started}


def results_image(obj: FitResult | xr.Dataset) -> bytes:
    """A results file's (or the summary's) bytes, written in memory with checksums (as
    :func:`escfit.results.write_fit` writes them)."""
    tree = obj.tree if isinstance(obj, FitResult) else obj
    try:
        import dask
    except ImportError:  # pragma: no cover - in-process runs without dask
        return netcdf_image(tree)
    # under a dask client (a worker, or the client of a batch) xarray would take a cluster-wide lock
    # named after the buffer, which the scheduler does not know; the write is local, so no lock is needed
    with dask.config.set(scheduler="synchronous"):
        return netcdf_image(tree)
