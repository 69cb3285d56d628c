"""Batch fits: every unit of a fleet fitted independently, in parallel on dask.distributed.

Each unit is one task.  A task carries the scene text and the unit's readings (not file
names), so workers need no shared file system; it returns the results file as bytes and the
client writes ``<out>/<unit>.h5`` atomically.  A unit that fails returns its error message
instead; the others go on.  Units whose results file exists and loads are skipped, so an
interrupted batch is finished by running it again.  On the local machine an interrupted
emcee run also resumes from its checkpoint (``<unit>.h5.emcee``).

The combined summary ``<out>/summary.nc`` (xarray, h5netcdf) has a ``unit`` dimension: the
posterior (or least-squares) median and 68 %/95 % intervals of every parameter, R-hat and
ESS, the reading scatter, the fit's warnings, status, error message and run time.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
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
from ..core.errors import DataError, EscfitError, FitError, ResultsError
from ..balance.recordings import UnitCurve, read_unit_curve
from ..results import SCHEMA_VERSION, FitResult, clean_attrs, dependency_versions

__all__ = ["UnitTask", "BatchResult", "discover_units", "fit_many", "fit_fleet", "summarize", "load_summary",
           "SUMMARY_SCHEMA", "unit_seed", "LazyClient", "local_cluster"]

SUMMARY_SCHEMA = "escfit-fleet-summary/1"
SUMMARY_FILE = "summary.nc"
STATS = ("median", "lo68", "hi68", "lo95", "hi95", "mean", "sd", "rhat", "ess_bulk")


@dataclass(frozen=True)
class UnitTask:
    """One unit to fit: its name, readings, source file and results file."""

    unit: str
    curve: UnitCurve
    data_file: str
    results_file: Path


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
        Wall time of the batch (s).
    """

    summary: xr.Dataset
    out_dir: Path
    fitted: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    elapsed: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.failed


def _safe_file_name(unit: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", unit).strip("._") or "unit"
    return name if name == unit else f"{name}-{zlib.crc32(unit.encode()):08x}"


def unit_seed(seed: int, unit: str) -> int:
    """The seed a unit is fitted with: fixed by the batch seed and the unit name, not the order."""
    return int(np.random.SeedSequence([seed, zlib.crc32(unit.encode())]).generate_state(1)[0] % (2**31 - 1))


def discover_units(data: Sequence[str | Path | UnitCurve], out_dir: str | Path, *,
                   notch_deg: float | None = None) -> list[UnitTask]:
    """The units of one or more recordings, in order of appearance.

    A file with a ``unit`` column contributes each of its units; a file without one is one
    unit named after the file (its stem).

    Raises
    ------
    DataError
        A unit name occurs in two files, or a file cannot be read.
    """
    out = Path(out_dir)
    tasks: list[UnitTask] = []
    seen: dict[str, str] = {}
    for item in data:
        curve = item if isinstance(item, UnitCurve) else read_unit_curve(item, notch_deg=notch_deg)
        source = curve.source or str(item)
        names = list(dict.fromkeys(map(str, curve.unit))) if curve.unit.size else [""]
        for name in names:
            unit = name or Path(source).stem
            if unit in seen:
                raise DataError(f"unit {unit!r} appears in {seen[unit]} and again here; unit names must be unique",
                                source)
            seen[unit] = source
            rows = np.flatnonzero(curve.unit == name) if curve.unit.size else np.arange(curve.swing.size)
            part = curve.select(rows)
            if name:
                part.unit = np.full(rows.size, name)
            tasks.append(UnitTask(unit, part, source, out / f"{_safe_file_name(unit)}.h5"))
    if not tasks:
        raise DataError("no units to fit: no data files given")
    return tasks


SUMMARY_GROUPS = ("posterior", "least_squares", "diagnostics")


def _load_for_summary(path: Path) -> FitResult | None:
    """Root attributes and the groups a summary needs (reading every group costs several times more),
    or None when the file is missing or unreadable.  h5py checks the file afresh first: xarray
    might hand back a cached handle of a file that has since been replaced."""
    import h5py

    if not path.is_file() or not h5py.is_hdf5(path):
        return None
    try:
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


def _fit_task(scene_text: str, scene_where: str, curve: UnitCurve, options: dict) -> dict[str, Any]:
    """Worker side: fit one unit; never raises (a failure comes back as a message)."""
    started = time.perf_counter()
    try:
        from ..inference import fit
        from ..core.scene import load_scene

        scene = load_scene(scene_where, text=scene_text)
        opts = dict(options)
        checkpoint = opts.pop("checkpoint", None)
        if checkpoint is not None and Path(checkpoint).exists() and opts.get("method") == "emcee":
            try:
                res = fit(scene, curve, checkpoint=checkpoint, resume=True, **opts)
            except ResultsError:  # an unusable checkpoint: start afresh
                Path(checkpoint).unlink(missing_ok=True)
                res = fit(scene, curve, checkpoint=checkpoint, **opts)
        else:
            res = fit(scene, curve, checkpoint=checkpoint, force=True, **opts)
        payload = _to_bytes(res)
        return {"status": "ok", "payload": payload, "seconds": time.perf_counter() - started}
    except Exception as exc:  # noqa: BLE001 - one unit's failure must not stop the batch
        msg = str(exc) if isinstance(exc, EscfitError) else f"{type(exc).__name__}: {exc}"
        return {"status": "failed", "error": msg or type(exc).__name__, "seconds": time.perf_counter() - started}


def _to_bytes(res: FitResult) -> bytes:
    """The results file's bytes, written in memory."""
    try:
        import dask
    except ImportError:  # pragma: no cover - in-process runs without dask
        return bytes(res.tree.to_netcdf(engine="h5netcdf"))
    # inside a dask worker xarray would take a cluster-wide lock named after the buffer, which the
    # scheduler does not know; the write is local, so no lock is needed
    with dask.config.set(scheduler="synchronous"):
        return bytes(res.tree.to_netcdf(engine="h5netcdf"))


class _Runner:
    """Runs tasks on a dask client (local cluster or given address) or in this process."""

    def __init__(self, scheduler, workers: int | None):
        self.client = None
        self._cluster = None
        self._lazy = scheduler if isinstance(scheduler, LazyClient) else None
        self.local_fs = True
        if workers == 0 and scheduler is None:
            return
        from distributed import Client

        if scheduler is None:
            self._cluster = local_cluster(workers or _cpu_count())
            self.client = Client(self._cluster)
        elif isinstance(scheduler, str):
            self.client = Client(scheduler)
            self.local_fs = False
        elif isinstance(scheduler, Client):
            self.client = scheduler
            self.local_fs = False
        elif callable(scheduler):  # a factory, e.g. LazyClient: called only when there is work
            self.client = scheduler()
            self.local_fs = isinstance(scheduler, LazyClient) and not scheduler.address
        else:
            raise FitError(f"scheduler must be an address, a distributed.Client or a factory, got {scheduler!r}")

    @property
    def description(self) -> str:
        if self.client is None:
            return "in-process"
        cluster = self._cluster if self._cluster is not None else getattr(self._lazy, "_cluster", None)
        if cluster is not None:
            return f"LocalCluster({len(cluster.workers)} processes x 1 thread)"
        return f"scheduler {self.client.scheduler.address}"

    def run(self, fn: Callable, jobs: list[tuple], on_done: Callable[[int, dict], None]) -> None:
        if self.client is None:
            for i, args in enumerate(jobs):
                on_done(i, fn(*args))
            return
        from distributed import as_completed

        futures = [self.client.submit(fn, *args, pure=False, key=f"escfit-fit-{i}-{os.urandom(4).hex()}")
                   for i, args in enumerate(jobs)]
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                out = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker, a killed task ...
                out = {"status": "failed", "error": f"{type(exc).__name__}: {exc}", "seconds": math.nan}
            on_done(i, out)
            fut.release()

    def close(self) -> None:
        if self._cluster is not None:
            self.client.close()
            self._cluster.close()


def local_cluster(n_workers: int):
    """A LocalCluster of ``n_workers`` single-threaded processes, as batches use it."""
    import dask
    from distributed import LocalCluster

    # the statistical profiler samples every task's stack every 10 ms: pure overhead here
    with dask.config.set({"distributed.worker.profile.enabled": False}):
        return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None,
                            silence_logs=40)


class LazyClient:
    """A dask Client started on first use and shared by the batches it is passed to.

    Pass it as ``scheduler`` to :func:`fit_many` (or :func:`fit_fleet`): a batch with nothing
    left to fit never starts a cluster.  ``address`` selects a running scheduler; otherwise a
    LocalCluster of ``workers`` processes is started.  Call :meth:`close` at the end.
    """

    def __init__(self, address: str | None = None, workers: int | None = None):
        self.address, self.workers = address, workers
        self._client = None
        self._cluster = None

    def __call__(self):
        if self._client is None:
            from distributed import Client

            if self.address:
                self._client = Client(self.address)
            else:
                self._cluster = local_cluster(self.workers or _cpu_count())
                self._client = Client(self._cluster)
        return self._client

    @property
    def started(self) -> bool:
        return self._client is not None

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()
        self._client = self._cluster = None


def _cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def fit_many(data: str | Path | UnitCurve | Iterable[str | Path | UnitCurve], scene: str | Path, out_dir: str | Path,
             *, method: str = "leastsq", scheduler: Any = None, workers: int | None = None, seed: int = 0,
             walkers: int = 32, steps: int = 2000, burn: int | None = None, n_starts: int = 8,
             solver: str = "exact", units: Sequence[str] | None = None, notch_deg: float | None = None,
             progress: bool | Callable[[str], None] = False, predictive_draws: int = 400) -> BatchResult:
    """Fit every unit of the recordings independently and summarise the fleet.

    Parameters
    ----------
    data
        Unit-curve CSV file(s) or :class:`~escfit.balance.recordings.UnitCurve` objects; units come
        from the ``unit`` column, or one unit per file without one.
    scene
        Scene file (TOML) with the free parameters, the same for every unit.
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
    walkers, steps, burn, n_starts, solver
        Passed to :func:`escfit.inference.fit`.
    units
        Fit only these units (default: all).
    notch_deg
        Notch angle for files without a ``# notch_deg:`` line.
    progress
        ``True`` prints one line per unit to stderr; a callable receives those lines.
    predictive_draws
        Thinned posterior draws whose pointwise log-likelihood each results file keeps (more
        lowers the Pareto k of PSIS-LOO; see :func:`escfit.inference.fit`).

    Returns
    -------
    BatchResult
        Its ``failed`` maps unit -> error message; failures are also printed to stderr.
    """
    from ..core.scene import load_scene

    if method not in ("leastsq", "emcee"):
        raise FitError(f"method must be 'leastsq' or 'emcee', got {method!r}")
    if workers is not None and workers < 0:
        raise FitError(f"workers must be >= 0, got {workers}")
    if workers == 0 and scheduler is not None:
        raise FitError("workers = 0 (in-process) and a scheduler address exclude each other")
    sc = load_scene(scene)
    items = [data] if isinstance(data, (str, Path, UnitCurve)) else list(data)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tasks = discover_units(items, out, notch_deg=notch_deg)
    if units is not None:
        known = {t.unit for t in tasks}
        missing = [u for u in units if u not in known]
        if missing:
            raise DataError(f"no readings of unit(s) {missing}; units in the data: {sorted(known)}")
        tasks = [t for t in tasks if t.unit in set(units)]
    say = progress if callable(progress) else ((lambda s: print(s, file=sys.stderr)) if progress else (lambda s: None))
    started = time.perf_counter()
    status: dict[str, dict] = {}
    loaded: dict[str, FitResult] = {}
    todo = []
    other: list[str] = []
    for t in tasks:
        done_before = _load_for_summary(t.results_file)
        if done_before is not None and (done_before.attrs.get("scene") != sc.text
                                        or done_before.attrs.get("method") != method):
            other.append(t.unit)
        elif done_before is not None:
            loaded[t.unit] = done_before
            status[t.unit] = {"status": "skipped", "seconds": math.nan}
            say(f"{t.unit}: done before ({t.results_file.name}), skipped")
        else:
            todo.append(t)
    if other:
        raise ResultsError(f"units {other} were fitted here with another scene or method; use another output "
                           "directory or remove their results files", str(out))
    options = {"method": method, "walkers": walkers, "steps": steps, "burn": burn, "n_starts": n_starts,
               "solver": solver, "predictive_draws": predictive_draws}
    runner = _Runner(scheduler, workers) if todo else _Runner(None, 0)  # no cluster when nothing is left
    where = runner.description if todo else "nothing to fit"
    jobs = []
    for t in todo:
        opts = {**options, "seed": unit_seed(seed, t.unit)}
        if runner.local_fs and method == "emcee":
            opts["checkpoint"] = str(t.results_file) + ".emcee"
        jobs.append((sc.text, str(scene), t.curve, opts))

    def done(i: int, res: dict) -> None:
        t = todo[i]
        if res["status"] == "ok":
            try:
                with atomic_path(t.results_file, force=True) as tmp:
                    tmp.write_bytes(res.pop("payload"))
                ck = Path(str(t.results_file) + ".emcee")
                if ck.exists():
                    ck.unlink()
                say(f"{t.unit}: fitted in {res['seconds']:.1f} s -> {t.results_file.name}")
            except OSError as exc:
                res = {"status": "failed", "error": f"cannot write the results file ({exc})", "seconds": res["seconds"]}
        if res["status"] == "failed":
            print(f"escfit fit-many: unit {t.unit} failed: {res['error']}", file=sys.stderr)
        status[t.unit] = res

    try:
        if jobs:
            say(f"fitting {len(jobs)} unit(s) ({method}) on {where}; {len(tasks) - len(jobs)} done before")
            runner.run(_fit_task, jobs, done)
    finally:
        runner.close()
    elapsed = time.perf_counter() - started
    summary = summarize(tasks, status, loaded=loaded, attrs={
        "method": method, "seed": seed, "scene": sc.text, "scene_file": str(scene), "runner": where,
        "elapsed_s": elapsed, "settings": {k: v for k, v in options.items() if v is not None}})
    with atomic_path(out / SUMMARY_FILE, force=True) as tmp:
        summary.to_netcdf(tmp, engine="h5netcdf")
    return BatchResult(summary, out, [u for u, s in status.items() if s["status"] == "ok"],
                       [u for u, s in status.items() if s["status"] == "skipped"],
                       {u: s["error"] for u, s in status.items() if s["status"] == "failed"}, elapsed)


def summarize(tasks: Sequence[UnitTask], status: dict[str, dict] | None = None, *,
              loaded: dict[str, FitResult] | None = None, attrs: dict | None = None) -> xr.Dataset:
    """The combined summary of a batch from its results files (dimension ``unit``).

    Variables: ``<stat>`` (unit, parameter) for the statistics in :data:`STATS`;
    ``status``, ``error``, ``seconds``, ``results_file``, ``data_file``, ``n_data``,
    ``sigma_hat`` (least-squares reading scatter, rad), ``warnings`` (JSON list) per unit.
    ``loaded`` holds results already read (by unit), which are not read again.
    """
    status = status or {}
    loaded = loaded or {}
    rows: list[dict[str, dict]] = []
    params: list[str] = []
    per_unit: dict[str, list] = {k: [] for k in ("status", "error", "seconds", "results_file", "data_file", "n_data",
                                                  "sigma_hat", "warnings")}
    for t in tasks:
        st = status.get(t.unit, {"status": "skipped"})
        res = None
        if st["status"] != "failed":
            res = loaded.get(t.unit) or _load_for_summary(t.results_file)
        s = res.summary() if res is not None else {}
        for name in s:
            if name not in params:
                params.append(name)
        rows.append(s)
        lsq = res.group("least_squares") if res is not None else None
        if st["status"] != "failed" and res is None:
            st = {"status": "failed", "error": "results file missing or unreadable after the fit"}
        per_unit["status"].append(st["status"])
        per_unit["error"].append(st.get("error", ""))
        per_unit["seconds"].append(float(st.get("seconds", math.nan)))
        per_unit["results_file"].append(t.results_file.name)
        per_unit["data_file"].append(t.data_file)
        per_unit["n_data"].append(int(t.curve.swing.size))
        per_unit["sigma_hat"].append(float(lsq.attrs.get("sigma_hat", math.nan)) if lsq is not None else math.nan)
        per_unit["warnings"].append(json.dumps(res.warnings if res is not None else []))
    data = {}
    for stat in STATS:
        arr = np.full((len(tasks), len(params)), np.nan)
        for i, s in enumerate(rows):
            for j, p in enumerate(params):
                if p in s and stat in s[p]:
                    arr[i, j] = s[p][stat]
        data[stat] = (("unit", "parameter"), arr)
    for k, v in per_unit.items():
        data[k] = ("unit", np.array(v, dtype=object if isinstance(v[0] if v else "", str) else None))
    ds = xr.Dataset(data, coords={"unit": np.array([t.unit for t in tasks], dtype=object),
                                  "parameter": np.array(params, dtype=object)})
    ds["seconds"].attrs["units"] = "s"
    ds["sigma_hat"].attrs["units"] = "rad"
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
    ds = xr.open_dataset(p, engine="h5netcdf").load()
    if ds.attrs.get("schema_version") != SUMMARY_SCHEMA:
        raise ResultsError(f"not a fleet summary of schema {SUMMARY_SCHEMA!r}", str(p))
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
    if not scene.is_file() or scene.read_text() != text:
        with atomic_path(scene, force=True) as tmp:
            tmp.write_text(text)
    return fit_many(fl.recordings, scene, out, method=method, walkers=walkers, steps=steps, seed=seed,
                    scheduler=scheduler, workers=workers, units=units, progress=progress)
