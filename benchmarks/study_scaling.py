"""Scaling of a batch fit: the same 200-unit fleet fitted by least squares on 1 and 2 workers.

A 200-unit fleet (angle switching, Monday's rig: 27 notch readings per unit at three loads) is
generated into a temporary directory and fitted with ``escfit.study.fit_many`` (least
squares, 8 start points per unit) on a LocalCluster of N worker processes, started as
fit-many starts it (``escfit.study.cluster.local_cluster``: one task at a time per worker,
compiled kernels limited to a share of the cores).  The cluster is started, and each worker
has imported escfit and loaded the cached kernels, before the clock starts; the clock then
runs over the whole of ``fit_many``, the combined summary (built from the rows the tasks
return, and written) included.  With ``--scheduler ADDRESS`` the batch also runs on that
existing cluster.

The repeats alternate between the worker counts (1, 2, 1, 2 ...) so that a change in the
machine's load falls on both; min and median over the repeats are printed, and the ratio
t(1 worker) / t(2 workers) of both.  The summary step is also timed alone: as fit-many builds
it (from memory) and the old way, reading every unit's results file back (the two summaries
are checked to be identical).

Usage (from the repository root)::

    python benchmarks/study_scaling.py [--units 200] [--workers 1 2] [--repeat 3]
        [--scheduler tcp://host:8786] [--json out.json] [--png scaling.png]

The machine's load average (1, 5, 15 min) is printed before and after each run: other
processes on the same cores inflate the times and deflate the ratio.  So is, at the start and
at the end, :func:`parallel_capacity`: how much faster two processes of a plain Python loop
run than one, the ceiling of the ratio at that moment.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import tempfile
import time
from pathlib import Path


def _load() -> list[float]:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return []


def _spin(n: int) -> float:
    t0 = time.perf_counter()
    x = 0
    for i in range(n):
        x += i
    return time.perf_counter() - t0


def parallel_capacity(n: int = 5_000_000) -> float:
    """How much faster two CPU-bound processes get through two equal loops than one process
    through one, now: 2.0 on two free cores, 1.0 when the machine gives the two no more than
    one.  The ceiling of the ratio t(1 worker) / t(2 workers) at this moment."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(2) as ex:
        list(ex.map(_spin, [1000, 1000]))  # both processes started
        one = ex.submit(_spin, n).result()
        two = max(ex.map(_spin, [n, n]))
    return round(2 * one / two, 2)


def _warm(data: str, scene: str, unit: str) -> None:
    from escfit.inference import fit

    fit(scene, data, unit=unit, n_starts=1)


def summary_read_back(res, data, out: Path) -> float:
    """Seconds to build and write the batch's summary the old way, reading every unit's results
    file back; the summary must equal the one fit-many built from memory."""
    import xarray as xr

    from escfit.study import discover_units
    from escfit.study.batch import summarize

    s = res.summary
    t0 = time.perf_counter()
    tasks = discover_units([data], out)
    status = {u: {"status": str(s["status"].values[i]), "error": str(s["error"].values[i]),
                  "seconds": float(s["seconds"].values[i])} for i, u in enumerate(s["unit"].values)}
    reread = summarize(tasks, status, attrs=dict(s.attrs))
    reread.to_netcdf(out / "summary-read-back.nc", engine="h5netcdf")
    seconds = time.perf_counter() - t0
    xr.testing.assert_identical(reread, s)
    return seconds


def _start(target):
    """A client (and its cluster, or None) on ``target``: a worker count or an address."""
    from distributed import Client

    from escfit.study.cluster import local_cluster

    if isinstance(target, int):
        cluster = local_cluster(target)
        client = Client(cluster)
        client.wait_for_workers(target)
        return cluster, client
    return None, Client(target)


def run(units: int, workers: list[int], repeat: int, scheduler: str | None) -> dict:
    from escfit.study import Rig, fit_many, fit_scene, generate_fleet, preset

    tmp = Path(tempfile.mkdtemp(prefix="escfit-scaling-"))
    try:
        fleet = generate_fleet(preset("angle", n_units=units, seed=2024), tmp / "fleet")
        scene = tmp / "angle.toml"
        scene.write_text(fit_scene(Rig(), "angle"))
        # compile and cache the numba kernels once, outside the clock
        fit_many(fleet.recordings, scene, tmp / "warm", workers=0, units=fleet.units[:1])
        targets: list[tuple[str, object]] = [(str(n), n) for n in workers]
        if scheduler:
            targets.append((f"scheduler {scheduler}", scheduler))
        rows = []
        for rep in range(repeat):
            for label, target in targets:
                t0 = time.perf_counter()
                cluster, client = _start(target)
                # each worker imports escfit and loads the cached kernels before the clock starts
                warmed = client.run(_warm, str(fleet.recordings), str(scene), fleet.units[0])
                startup = time.perf_counter() - t0
                n_workers = len(warmed)
                out = tmp / f"fits-{label.replace(' ', '_').replace('/', '_')}-{rep}"
                load_before = _load()
                t0 = time.perf_counter()
                res = fit_many(fleet.recordings, scene, out, scheduler=client)
                seconds = time.perf_counter() - t0
                load_after = _load()
                client.close()
                if cluster is not None:
                    cluster.close()
                assert res.ok, res.failed
                per_unit = res.summary["seconds"].values.astype(float)
                rows.append({"target": label, "workers": n_workers, "repeat": rep, "seconds": round(seconds, 2),
                             "fits_s": round(res.elapsed, 2), "summary_s": round(res.summary_seconds, 3),
                             "summary_read_back_s": round(summary_read_back(res, fleet.recordings, out), 3),
                             "startup_s": round(startup, 2), "units": units,
                             "unit_s_mean": round(float(per_unit[per_unit == per_unit].mean()), 3),
                             "load_before": load_before, "load_after": load_after})
                print(json.dumps(rows[-1]), flush=True)
                shutil.rmtree(out, ignore_errors=True)
        return {"benchmark": "study_scaling", "method": "leastsq", "n_starts": 8, "cpus": os.cpu_count(),
                "python": platform.python_version(), "machine": platform.machine(), "rows": rows,
                "stats": _stats(rows)}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _stats(rows: list[dict]) -> dict[str, dict]:
    """Per target: min and median of the batch time and of the summary step, and the ratio of
    the first target's times to this one's (min to min, median to median)."""
    out: dict[str, dict] = {}
    for r in rows:
        d = out.setdefault(r["target"], {"workers": r["workers"], "seconds": [], "summary_s": [],
                                         "summary_read_back_s": [], "startup_s": []})
        for k in ("seconds", "summary_s", "summary_read_back_s", "startup_s"):
            d[k].append(r[k])
    first = next(iter(out.values()), None)
    for d in out.values():
        for k in ("seconds", "summary_s", "summary_read_back_s", "startup_s"):
            d[f"{k}_min"], d[f"{k}_median"] = min(d[k]), statistics.median(d[k])
        d["ratio_min"] = round(first["seconds_min"] / d["seconds_min"], 2)
        d["ratio_median"] = round(first["seconds_median"] / d["seconds_median"], 2)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=200)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scheduler", default=None, help="also run on this existing dask scheduler")
    ap.add_argument("--json", dest="json_out", default=None, help="write the results as JSON")
    ap.add_argument("--png", default=None, help="write a bar chart (matplotlib)")
    ap.add_argument("--force", action="store_true", help="replace existing output files")
    args = ap.parse_args()
    for out in (args.json_out, args.png):  # refused before the run, not after it
        if out and Path(out).exists() and not args.force:
            ap.error(f"{out} exists; pass --force to replace it")
    load_start, capacity_start = _load(), parallel_capacity()
    result = run(args.units, args.workers, args.repeat, args.scheduler)
    result["load_start"], result["load_end"] = load_start, _load()
    result["capacity_start"], result["capacity_end"] = capacity_start, parallel_capacity()
    stats = result["stats"]
    first = next(iter(stats))
    print(f"\n{args.units} units, least squares, {args.repeat} repeat(s), {os.cpu_count()} CPUs; "
          f"load average {result['load_start']} at the start, {result['load_end']} at the end; two CPU-bound "
          f"processes ran {result['capacity_start']} / {result['capacity_end']} times as fast as one "
          "(start / end; 2.0 on two free cores)")
    print("| workers | batch incl. summary, min / median (s) | t(first) / t, min / median | "
          "summary from memory (s) | summary read back (s) | cluster start (s) |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, d in stats.items():
        print(f"| {label} ({d['workers']} workers) | {d['seconds_min']:.1f} / {d['seconds_median']:.1f} | "
              f"{d['ratio_min']:.2f} / {d['ratio_median']:.2f} | {d['summary_s_median']:.2f} | "
              f"{d['summary_read_back_s_median']:.2f} | {d['startup_s_median']:.1f} |")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(result, indent=1))
    if args.png:
        from escfit.study.plots import plot_scaling

        rows = [{"workers": d["workers"], "seconds": d["seconds_min"]} for k, d in stats.items()
                if not k.startswith("scheduler")]
        plot_scaling(rows, title=f"{args.units} units, least squares").savefig(args.png, dpi=110)


if __name__ == "__main__":
    main()
