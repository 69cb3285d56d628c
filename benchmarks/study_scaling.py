"""Scaling of a batch fit: the same 200-unit fleet fitted by least squares on 1 and 2 workers.

A 200-unit fleet (angle switching, Monday's rig: 27 notch readings per unit at three loads) is
generated into a temporary directory and fitted with ``escfit.study.fit_many`` (least
squares, 8 start points per unit) on a LocalCluster of N single-threaded worker processes.
The cluster is started before the clock starts, so the times are those of the batch itself;
the start-up of a cluster is reported separately.  With ``--scheduler ADDRESS`` the batch
also runs on that existing cluster.

Usage (from the repository root)::

    python benchmarks/study_scaling.py [--units 200] [--workers 1 2] [--repeat 1]
        [--scheduler tcp://host:8786] [--json out.json] [--png scaling.png]

The machine's load average is printed before and after: other processes on the same cores
inflate the times (and deflate the ratio).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import tempfile
import time
from pathlib import Path


def _load() -> list[float]:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return []


def _warm(data: str, scene: str, unit: str) -> None:
    from escfit.inference import fit

    fit(scene, data, unit=unit, n_starts=1)


def run(units: int, workers: list[int], repeat: int, scheduler: str | None) -> dict:
    import dask
    from distributed import Client, LocalCluster

    from escfit.study import fit_many, generate_fleet, preset

    tmp = Path(tempfile.mkdtemp(prefix="escfit-scaling-"))
    try:
        fleet = generate_fleet(preset("angle", n_units=units, seed=2024), tmp / "fleet")
        scene = tmp / "angle.toml"
        from escfit.study import Rig, fit_scene

        scene.write_text(fit_scene(Rig(), "angle"))
        # compile and cache the numba kernels once, outside the clock
        fit_many(fleet.recordings, scene, tmp / "warm", workers=0, units=fleet.units[:1])
        rows = []
        targets: list[tuple[str, object]] = [(str(n), n) for n in workers]
        if scheduler:
            targets.append((f"scheduler {scheduler}", scheduler))
        for label, target in targets:
            for rep in range(repeat):
                t0 = time.perf_counter()
                if isinstance(target, int):
                    with dask.config.set({"distributed.worker.profile.enabled": False}):
                        cluster = LocalCluster(n_workers=target, threads_per_worker=1, processes=True,
                                               dashboard_address=None, silence_logs=40)
                    client = Client(cluster)
                    client.wait_for_workers(target)
                else:
                    cluster, client = None, Client(target)
                # each worker imports escfit and loads the cached kernels before the clock starts
                client.run(_warm, str(fleet.recordings), str(scene), fleet.units[0])
                startup = time.perf_counter() - t0
                out = tmp / f"fits-{label.replace(' ', '_').replace('/', '_')}-{rep}"
                load_before = _load()
                res = fit_many(fleet.recordings, scene, out, scheduler=client)
                n_workers = len(client.scheduler_info()["workers"])
                client.close()
                if cluster is not None:
                    cluster.close()
                assert res.ok, res.failed
                seconds = float(res.elapsed)
                per_unit = res.summary["seconds"].values.astype(float)
                rows.append({"target": label, "workers": n_workers, "repeat": rep, "seconds": round(seconds, 2),
                             "startup_s": round(startup, 2), "units": units,
                             "unit_s_mean": round(float(per_unit[per_unit == per_unit].mean()), 3),
                             "load_before": load_before, "load_after": _load()})
                print(json.dumps(rows[-1]), flush=True)
        base = min(r["seconds"] for r in rows if r["target"] == str(workers[0]))
        for r in rows:
            r["speedup_vs_first"] = round(base / r["seconds"], 2)
        return {"benchmark": "study_scaling", "method": "leastsq", "n_starts": 8, "cpus": os.cpu_count(),
                "python": platform.python_version(), "machine": platform.machine(), "rows": rows}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=200)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--scheduler", default=None, help="also run on this existing dask scheduler")
    ap.add_argument("--json", dest="json_out", default=None, help="write the results as JSON")
    ap.add_argument("--png", default=None, help="write a bar chart (matplotlib)")
    args = ap.parse_args()
    result = run(args.units, args.workers, args.repeat, args.scheduler)
    best: dict[str, dict] = {}
    for r in result["rows"]:
        if r["target"] not in best or r["seconds"] < best[r["target"]]["seconds"]:
            best[r["target"]] = r
    print("\n| workers | batch wall time (s) | speed-up | cluster start (s) | load before |")
    print("|---|---:|---:|---:|---|")
    for label, r in best.items():
        print(f"| {label} ({r['workers']} workers) | {r['seconds']:.1f} | {r['speedup_vs_first']:.2f} | "
              f"{r['startup_s']:.1f} | {r['load_before']} |")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(result, indent=1))
    if args.png:
        from escfit.study.plots import plot_scaling

        rows = [{"workers": r["workers"], "seconds": r["seconds"]} for k, r in best.items() if not k.startswith("scheduler")]
        plot_scaling(rows, title=f"{args.units} units, least squares").savefig(args.png, dpi=110)


if __name__ == "__main__":
    main()
