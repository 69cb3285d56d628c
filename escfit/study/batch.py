"""Batch fits: every unit of a fleet fitted independently, in parallel on dask.distributed.

Any model family: each unit is one :func:`escfit.inference.fit` of the batch's scene (its
``model =`` names the family) to the unit's recording.  DATA is a folder of recording files
(one unit per file, named after the file's stem), or balance unit-curve files whose ``unit``
column holds several units.

Each unit is one task.  A task carries the scene text and the unit's data (not file names),
so workers need no shared file system: a balance unit curve travels as its in-memory
:class:`~escfit.analysis.recordings.UnitCurve` (one unit of a multi-unit file), any other
recording as the file's name and bytes (:class:`RecordingFile`), which the worker writes to
a temporary directory for the family's reader.  A task returns the results file as bytes,
which the client writes to ``<out>/<unit>.h5`` atomically, and the unit's summary row.  A unit
that fails returns its error message instead; the others go on.  Units whose results file
exists and loads are skipped, so an interrupted batch is finished by running it again.  On
the local machine an interrupted emcee run also resumes from its checkpoint
(``<unit>.h5.emcee``; one that cannot be resumed, damaged for instance, is deleted and the unit
started afresh, which its progress line and its summary warnings say).  The worker's side is
:mod:`escfit.study.task`.

One batch at a time writes into a results directory: it holds the directory's lock
(:mod:`escfit.study.lock`) from before the finished units are looked at until ``summary.nc`` is
written, so a second batch is refused before it writes anything; so is a batch whose scene or
method differs from that of the directory's finished units.  Holding the lock, a batch first
deletes the hidden temporaries (``.<file>.<random>.part``) of its own files that a killed run
left behind.

The combined summary ``<out>/summary.nc`` (xarray, h5netcdf) has a ``unit`` dimension: the
posterior (or least-squares) median and 68 %/95 % intervals of every parameter, R-hat and
ESS, the reading scatter, the fit's warnings, status, error message and run time.  It is
built from the rows the tasks return; only the results files of skipped units are read.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
import sys
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np
import xarray as xr

from ..core.atomic import atomic_path
from ..core.errors import DataError, FitError, ResultsError
from ..core.h5write import write_bytes
from ..core.interrupts import deferred_interrupts
from ..balance.family import split_units
from ..analysis.recordings import UnitCurve
from ..core.provenance import dependency_versions
from ..results import SCHEMA_VERSION, FitResult, clean_attrs
from .cluster import LazyClient, Runner, local_cluster, require_distributed
from .lock import folder_lock, remove_stale_temporaries
from .task import RecordingFile, fit_task, results_image, summary_row

__all__ = ["UnitTask", "RecordingFile", "BatchResult", "discover_units", "recording_files", "fit_many",
           "fit_fleet", "summarize", "summary_row", "load_summary", "SUMMARY_SCHEMA", "unit_seed", "LazyClient",
           "local_cluster"]

from .names import SUMMARY_FILE, SUMMARY_SCHEMA  # noqa: E402 (re-exported)
STATS = ("estimate", "median", "lo68", "hi68", "lo95", "hi95", "mean", "sd", "rhat", "ess_bulk")

# Files of a DATA folder that are not recordings: scenes and recipes, notes, results, figures.
NOT_RECORDINGS = frozenset({".toml", ".md", ".rst", ".html", ".htm", ".png", ".svg", ".pdf", ".jpg", ".jpeg",
                            ".py", ".ipynb", ".h5", ".nc", ".emcee", ".part", ".yaml", ".yml"})


@dataclass(frozen=True)
class UnitTask:
    """One unit to fit: its name, data, source file and results file.

    ``data`` is a :class:`~escfit.analysis.recordings.UnitCurve` (one unit of a balance
    unit-curve file, read by the client) or a :class:`RecordingFile` (any family's recording,
    read by the family's reader on the worker).
    """

    unit: str
    data: UnitCurve | RecordingFile
    data_file: str
    results_file: Path

    @property
    def curve(self) -> UnitCurve | None:
        """The unit's balance unit curve, or None for a recording file read on the worker."""
        return self.data if isinstance(self.data, UnitCurve) else None


@dataclass
class BatchResult:
    """What a batch did.

    Attributes
    ----------
    summary
        The combined summary (also written to ``<out>/summary.nc``).
    out_dir
        Results directory.
    fitted, skipped, failed
        Unit names fitted now, skipped (already done) and failed (with their messages).
    elapsed
        Wall time of the batch up to the last unit's results file (s).
    summary_seconds
        Wall time of building and writing the combined summary afterwards (s).
    """

    summary: xr.Dataset
    out_dir: Path
    fitted: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    elapsed: float = 0.0
    summary_seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.failed


def _safe_file_name(unit: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", unit).strip("._") or "unit"
    return name if name == unit else f"{name}-{zlib.crc32(unit.encode()):08x}"


def unit_seed(seed: int, unit: str) -> int:
    """The seed a unit is fitted with: fixed by the batch seed and the unit name, not the order."""
    return int(np.random.SeedSequence([seed, zlib.crc32(unit.encode())]).generate_state(1)[0] % (2**31 - 1))


def recording_files(folder: str | Path) -> list[Path]:
    """The recording files of a DATA folder, sorted by name: its regular files except hidden ones
    and those whose suffix marks them as something else (:data:`NOT_RECORDINGS`: scenes and
    recipes, notes, results files, figures).  Subfolders are not searched.

    Raises
    ------
    DataError
        The folder holds no recording file.
    """
    d = Path(folder)
    files = sorted(p for p in d.iterdir()
                   if p.is_file() and not p.name.startswith(".") and p.suffix.lower() not in NOT_RECORDINGS)
    if not files:
        raise DataError("no recording files in this folder (scenes, notes, results files and hidden files are "
                        "not recordings)", str(d))
    return files


def _units_of(scene) -> Callable[[Path], list | None]:
    """How the client splits a recording file into units: the scene's family's ``units_of`` when it
    reads files holding several units (balance unit curves; ``scene=None``: the balance family),
    else a function saying "one unit" (None)."""
    from ..core.family import get_family

    family = get_family(scene.model if scene is not None else "balance")
    if scene is not None and not family.splits_units(scene):
        return lambda path, **_: None
    return family.units_of


def discover_units(data: Sequence[str | Path | UnitCurve], out_dir: str | Path, *,
                   notch_deg: float | None = None, scene=None) -> list[UnitTask]:
    """The units of one or more recordings or folders of recordings, in order of appearance.

    A folder contributes its recording files (:func:`recording_files`), in name order.  With
    a balance scene (or ``scene=None``), a unit-curve file with a ``unit`` column contributes
    each of its units (read here, carried as :class:`~escfit.analysis.recordings.UnitCurve`);
    any other file is one unit named after the file (its stem), carried as a
    :class:`RecordingFile` and read on the worker by the scene's family.

    Raises
    ------
    DataError
        A unit name occurs twice, a file is missing, or a unit-curve file cannot be read.
    """
    out = Path(out_dir)
    units_of = _units_of(scene)
    tasks: list[UnitTask] = []
    seen: dict[str, str] = {}

    def add(unit: str, part, source: str) -> None:
        if unit in seen:
            raise DataError(f"unit {unit!r} appears in {seen[unit]} and again here; unit names must be unique",
                            source)
        seen[unit] = source
        tasks.append(UnitTask(unit, part, source, out / f"{_safe_file_name(unit)}.h5"))

    items: list[str | Path | UnitCurve] = []
    for item in data:
        if not isinstance(item, UnitCurve) and Path(item).is_dir():
            items += recording_files(item)
        else:
            items.append(item)
    for item in items:
        parts = split_units(item, item) if isinstance(item, UnitCurve) else units_of(Path(item), notch_deg=notch_deg)
        if parts is None:
            add(Path(item).stem, RecordingFile.read(item), str(item))
            continue
        for name, part in parts:
            add(name, part, getattr(part, "source", None) or str(item))
    if not tasks:
        raise DataError("no units to fit: no data files given")
    return tasks


SUMMARY_GROUPS = ("posterior", "least_squares", "diagnostics")


def _load_for_summary(path: Path) -> FitResult | None:
    """Root attributes and the groups a summary needs (reading every group costs several times more),
    or None when the file is missing or unreadable.  h5py checks the file afresh first: xarray
    might hand back a cached handle of a file that has since been replaced."""
    import h5py

    from ..results import check_results_file

    if not path.is_file() or not h5py.is_hdf5(path):
        return None
    try:
        check_results_file(path)  # the layout, from its metadata: a damaged file is not read
        with h5py.File(path, "r") as f:
            present = [g for g in SUMMARY_GROUPS if g in f]
        parts = {}
        for g in (None, *present):
            with xr.open_dataset(path, group=g, engine="h5netcdf") as ds:
                parts["/" if g is None else g] = ds.load()
        tree = xr.DataTree.from_dict(parts)
    except Exception:  # noqa: BLE001 - unreadable: treated as not done
        return None
    if tree.attrs.get("schema_version") != SCHEMA_VERSION:
        return None
    return FitResult(tree, str(path))


def fit_many(data: str | Path | UnitCurve | Iterable[str | Path | UnitCurve], scene: str | Path, out_dir: str | Path,
             *, method: str = "leastsq", scheduler: Any = None, workers: int | None = None, seed: int = 0,
             walkers: int | None = None, steps: int | None = None, burn: int | None = None,
             n_starts: int | None = None, solver: str | None = None, units: Sequence[str] | None = None,
             notch_deg: float | None = None, progress: bool | Callable[[str], None] = False,
             predictive_draws: int | None = None) -> BatchResult:
    """Fit every unit of the recordings independently and summarise the fleet.

    Parameters
    ----------
    data
        A folder of recording files (one unit per file, named after the file's stem; any
        family the scene names), recording file(s), or
        :class:`~escfit.analysis.recordings.UnitCurve` objects.  A balance unit-curve file with a
        ``unit`` column holds several units.
    scene
        Scene file (TOML) with the free parameters, the same for every unit; its ``model =``
        names the family (see :func:`escfit.inference.fit`).
    out_dir
        Results directory (created): ``<unit>.h5`` per unit and ``summary.nc``.
    method
        ``"leastsq"`` or ``"emcee"`` (see :func:`escfit.inference.fit`).
    scheduler
        ``None``: a LocalCluster on this machine (processes, one thread each); an address
        such as ``"tcp://10.0.0.5:8786"``: that running cluster; a ``distributed.Client``; or
        a :class:`LazyClient` (a client started only when some unit is left to fit).
    workers
        Worker processes of the local cluster (default: the CPUs available); ``0`` fits in
        this process without dask (for debugging and profiling).
    seed
        Batch seed; each unit is fitted with :func:`unit_seed` (seed, unit name).
    walkers, steps, burn, n_starts, predictive_draws
        Passed to :func:`escfit.inference.fit`; ``None`` takes the family's default
        (``fit_defaults``; ``burn``: half the steps).
    solver
        The family's forward solver (balance: ``exact``, ``dop853`` ...); default: the scene's.
    units
        Fit only these units (default: all).
    notch_deg
        Notch angle of balance unit curves without a ``# notch_deg:`` line.
    progress
        ``True`` prints one line per unit to stderr; a callable receives those lines.

    Returns
    -------
    BatchResult
        Its ``failed`` maps unit -> error message; failures are also printed to stderr.

    Raises
    ------
    MissingDependency
        dask.distributed is needed (a local cluster or a scheduler address) and not installed.
    FolderBusy
        Another batch is writing into ``out_dir`` (:mod:`escfit.study.lock`); nothing was written.
    ResultsError
        Finished units of ``out_dir`` were fitted with another scene or method; nothing was written.
    """
    from ..core.family import check_options, get_family as family
    from ..core.scene import load_scene

    if method not in ("leastsq", "emcee"):
        raise FitError(f"method must be 'leastsq' or 'emcee', got {method!r}")
    if workers is not None and workers < 0:
        raise FitError(f"workers must be >= 0, got {workers}")
    if workers == 0 and scheduler is not None:
        raise FitError("workers = 0 (in-process) and a scheduler address exclude each other")
    if workers != 0 and (scheduler is None or isinstance(scheduler, str)):
        require_distributed()  # refused before any data is read
    sc = load_scene(scene)
    # an unknown family, or an option the scene's family does not take, is refused here, not once per unit
    family_options: dict[str, Any] = check_options(family(sc.model), {"solver": solver, "notch_deg": notch_deg},
                                                   {"solver": "--solver", "notch_deg": "--notch-deg"}, str(scene))
    items = [data] if isinstance(data, (str, Path, UnitCurve)) else list(data)
    out = Path(out_dir)
    # the data are read before the folder and its lock are made: a refusal leaves nothing behind
    tasks = discover_units(items, out, notch_deg=notch_deg, scene=sc)
    if units is not None:
        known = {t.unit for t in tasks}
        missing = [u for u in units if u not in known]
        if missing:
            raise DataError(f"no readings of unit(s) {missing}; units in the data: {sorted(known)}")
        tasks = [t for t in tasks if t.unit in set(units)]
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out):  # one batch at a time in a results folder
        say = progress if callable(progress) else \
            ((lambda s: print(s, file=sys.stderr)) if progress else (lambda s: None))
        started = time.perf_counter()
        status: dict[str, dict] = {}
        rows: dict[str, dict] = {}
        todo = _finished_units(tasks, out, sc.text, method, rows, status, say)
        removed = remove_stale_temporaries(out, {SUMMARY_FILE, *(t.results_file.name for t in tasks),
                                                 *(t.results_file.name + ".emcee" for t in tasks)})
        if removed:
            say(f"removed {len(removed)} temporary file(s) an interrupted run left: {', '.join(removed)}")
        options = {"method": method, "walkers": walkers, "steps": steps, "burn": burn, "n_starts": n_starts,
                   "predictive_draws": predictive_draws, **family_options}
        runner = Runner(scheduler, workers) if todo else Runner(None, 0)  # no cluster when nothing is left
        where = runner.description if todo else "nothing to fit"
        jobs = []
        for t in todo:
            opts = {**options, "seed": unit_seed(seed, t.unit), "source": t.data_file}
            if runner.local_fs and method == "emcee":
                opts["checkpoint"] = str(t.results_file) + ".emcee"
            jobs.append((sc.text, str(scene), t.data, opts))

        def done(i: int, res: dict) -> None:
            t = todo[i]
            if res["status"] == "ok":
                try:
                    write_bytes(res.pop("payload"), t.results_file, force=True)
                    Path(str(t.results_file) + ".emcee").unlink(missing_ok=True)
                    rows[t.unit] = res.pop("row")
                    if res.get("note"):  # in the summary's warnings too
                        rows[t.unit]["warnings"] = [*rows[t.unit]["warnings"], res["note"]]
                        say(f"{t.unit}: {res['note']}")
                    say(f"{t.unit}: fitted in {res['seconds']:.1f} s -> {t.results_file.name}")
                except (ResultsError, OSError) as exc:
                    res = {"status": "failed", "error": f"cannot write the results file ({exc})",
                           "seconds": res["seconds"]}
            if res["status"] == "failed":
                print(f"escfit fit-many: unit {t.unit} failed: {res['error']}", file=sys.stderr)
            status[t.unit] = res

        try:
            if jobs:
                say(f"fitting {len(jobs)} unit(s) ({method}) on {where}; {len(tasks) - len(jobs)} done before")
                runner.run(fit_task, jobs, done)
        finally:
            runner.close()
        elapsed = time.perf_counter() - started
        with deferred_interrupts():  # every unit is done: a signal now waits for the summary (a second or so)
            # from the rows the tasks returned: no results file of this run is read back
            summary = summarize(tasks, status, rows=rows, attrs={
                "method": method, "seed": seed, "model": sc.model, "scene": sc.text, "scene_file": str(scene),
                "runner": where, "elapsed_s": elapsed, "settings": {k: v for k, v in options.items() if v is not None}})
            write_bytes(results_image(summary), out / SUMMARY_FILE, force=True)
        return BatchResult(summary, out, [u for u, s in status.items() if s["status"] == "ok"],
                           [u for u, s in status.items() if s["status"] == "skipped"],
                           {u: s["error"] for u, s in status.items() if s["status"] == "failed"}, elapsed,
                           time.perf_counter() - started - elapsed)


def _finished_units(tasks: Sequence[UnitTask], out: Path, scene_text: str, method: str, rows: dict[str, dict],
                    status: dict[str, dict], say: Callable[[str], None]) -> list[UnitTask]:
    """The tasks left to fit; the finished ones get their row and status ``skipped``.

    Raises
    ------
    ResultsError
        Finished units of the folder were fitted with another scene or method: the units of
        this batch (read from their results files), or others that the folder's summary lists
        as finished by a batch of another scene or method and whose results files are still
        there.  Nothing has been written.
    """
    todo, other = [], []
    for t in tasks:
        done_before = _load_for_summary(t.results_file)
        if done_before is not None and (done_before.attrs.get("scene") != scene_text
                                        or done_before.attrs.get("method") != method):
            other.append(t.unit)
        elif done_before is not None:
            rows[t.unit] = summary_row(done_before)
            status[t.unit] = {"status": "skipped", "seconds": math.nan}
            say(f"{t.unit}: done before ({t.results_file.name}), skipped")
        else:
            todo.append(t)
    if not other:
        other = _foreign_units_of_summary(out, {t.unit for t in tasks}, scene_text, method)
    if other:
        raise ResultsError(f"units {other} were fitted here with another scene or method; use another output "
                           "directory or remove their results files", str(out))
    return todo


def _foreign_units_of_summary(out: Path, ours: set[str], scene_text: str, method: str) -> list[str]:
    """Units outside this batch that the folder's summary lists as finished by a batch of another
    scene or method, and whose results files are still in the folder."""
    from ..core.h5layout import check_file

    path = out / SUMMARY_FILE
    if not path.is_file():
        return []
    try:
        check_file(path, "fleet summary")
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            if ds.attrs.get("schema_version") != SUMMARY_SCHEMA:
                return []
            if ds.attrs.get("scene") == scene_text and ds.attrs.get("method") == method:
                return []
            listed = zip(map(str, ds["unit"].values), map(str, ds["status"].values),
                         map(str, ds["results_file"].values))
            return [u for u, st, f in listed if u not in ours and st in ("ok", "skipped") and (out / f).is_file()]
    except Exception:  # noqa: BLE001 - an unreadable summary is rebuilt, not a reason to refuse
        return []


def summarize(tasks: Sequence[UnitTask], status: dict[str, dict] | None = None, *,
              rows: dict[str, dict] | None = None, loaded: dict[str, FitResult] | None = None,
              attrs: dict | None = None) -> xr.Dataset:
    """The combined summary of a batch (dimension ``unit``).

    Variables: ``<stat>`` (unit, parameter) for the statistics in :data:`STATS` (``estimate``:
    the posterior median of an emcee fit, the best fit of a least-squares one);
    ``status``, ``error``, ``seconds``, ``results_file``, ``data_file``, ``n_data`` (readings;
    -1 when a unit failed before they were read), ``sigma_hat`` (least-squares reading scatter,
    in ``reading_units``), ``reading_units``, ``warnings`` (JSON list) per unit.

    ``rows`` holds the units' :func:`summary_row` (as the tasks return them), ``loaded``
    results already read (by unit); the results files of the other units that did not fail
    are read.
    """
    status = status or {}
    rows = dict(rows or {})
    for unit, res in (loaded or {}).items():
        rows.setdefault(unit, summary_row(res))
    params: list[str] = []
    stats_rows: list[dict[str, dict]] = []
    per_unit: dict[str, list] = {k: [] for k in ("status", "error", "seconds", "results_file", "data_file", "n_data",
                                                  "sigma_hat", "reading_units", "warnings")}
    for t in tasks:
        st = status.get(t.unit, {"status": "skipped"})
        row = None
        if st["status"] != "failed":
            row = rows.get(t.unit)
            if row is None:
                res = _load_for_summary(t.results_file)
                row = summary_row(res) if res is not None else None
            if row is None:
                st = {"status": "failed", "error": "results file missing or unreadable after the fit"}
        s = row["parameters"] if row is not None else {}
        for name in s:
            if name not in params:
                params.append(name)
        stats_rows.append(s)
        n_data = row["n_data"] if row is not None else (t.curve.swing.size if t.curve is not None else -1)
        per_unit["status"].append(st["status"])
        per_unit["error"].append(st.get("error", ""))
        per_unit["seconds"].append(float(st.get("seconds", math.nan)))
        per_unit["results_file"].append(t.results_file.name)
        per_unit["data_file"].append(t.data_file)
        per_unit["n_data"].append(int(n_data))
        per_unit["sigma_hat"].append(float(row["sigma_hat"]) if row is not None else math.nan)
        per_unit["reading_units"].append(row["reading_units"] if row is not None else "")
        per_unit["warnings"].append(json.dumps(row["warnings"] if row is not None else []))
    data = {}
    for stat in STATS:
        arr = np.full((len(tasks), len(params)), np.nan)
        for i, s in enumerate(stats_rows):
            for j, p in enumerate(params):
                if p in s and stat in s[p]:
                    arr[i, j] = s[p][stat]
                elif p in s and stat == "estimate" and "median" in s[p]:  # rows of files before "estimate"
                    arr[i, j] = s[p]["median"]
        data[stat] = (("unit", "parameter"), arr)
    for k, v in per_unit.items():
        data[k] = ("unit", np.array(v, dtype=object if isinstance(v[0] if v else "", str) else None))
    ds = xr.Dataset(data, coords={"unit": np.array([t.unit for t in tasks], dtype=object),
                                  "parameter": np.array(params, dtype=object)})
    ds["seconds"].attrs["units"] = "s"
    reading_units = {u for u in per_unit["reading_units"] if u}
    if len(reading_units) == 1:
        ds["sigma_hat"].attrs["units"] = reading_units.pop()
    meta = {"schema_version": SUMMARY_SCHEMA, "n_units": len(tasks),
            "n_failed": int(sum(s == "failed" for s in per_unit["status"])),
            "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "versions": dependency_versions(), **(attrs or {})}
    ds.attrs = clean_attrs(meta)
    return ds


def load_summary(path: str | Path) -> xr.Dataset:
    """Read ``summary.nc`` (or the directory holding it).

    Raises
    ------
    ResultsError
        Missing file or not a fleet summary.
    """
    p = Path(path)
    if p.is_dir():
        p = p / SUMMARY_FILE
    if not p.is_file():
        raise ResultsError("fleet summary not found", str(p))
    from ..core.h5layout import check_file

    if check_file(p, "fleet summary").attrs.get("schema_version") != SUMMARY_SCHEMA:
        raise ResultsError(f"not a fleet summary of schema {SUMMARY_SCHEMA!r}", str(p))
    ds = xr.open_dataset(p, engine="h5netcdf").load()
    return ds


def fit_fleet(fleet, model: str, out_dir: str | Path, *, units: Sequence[str] | None = None, method: str = "emcee",
              walkers: int = 16, steps: int = 600, seed: int = 0, scheduler: Any = None, workers: int | None = None,
              progress: bool | Callable[[str], None] = False, predictive_draws: int = 400) -> BatchResult:
    """Fit one of the study's models to a synthetic fleet (see :mod:`escfit.study.scenes`).

    The model's fit scene for the fleet's rig is written to ``<out_dir>/scene.toml``, then
    :func:`fit_many` fits the fleet's recordings (all units, or ``units``) into ``out_dir``.
    """
    from .fleet import Fleet, load_fleet
    from .scenes import fit_scene

    fl = fleet if isinstance(fleet, Fleet) else load_fleet(fleet)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    scene = out / "scene.toml"
    text = fit_scene(fl.spec.rig, model)
    with folder_lock(out):  # the scene and the fits under one lock (it is re-entrant in this thread)
        remove_stale_temporaries(out, {scene.name})
        if not scene.is_file() or scene.read_text() != text:
            with atomic_path(scene, force=True) as tmp:
                tmp.write_text(text)
        return fit_many(fl.recordings, scene, out, method=method, walkers=walkers, steps=steps, seed=seed,
                        scheduler=scheduler, workers=workers, units=units, progress=progress,
                        predictive_draws=predictive_draws)
