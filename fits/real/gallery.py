"""Fit every shipped real recording as read raw and draw the gallery of docs/real-data.md.

Run:  python fits/real/gallery.py [--out docs/real-data]   (about a minute; least squares)

For each recipe in this folder: the recording is read raw with its scene's ``[recording]``
table, fitted by least squares, and compared with a naive log-linear envelope of its turning
points (viscous damping only: ln A falls by C/2 per second).  Prints one Markdown table row per
recording and writes one figure each (data and model against time, residuals).
"""

from __future__ import annotations

import argparse
import math
import tomllib
from pathlib import Path

import numpy as np

from escfit.inference import least_squares, make_problem
from escfit.core.scene import load_scene

HERE = Path(__file__).resolve().parent


def envelope_c(problem) -> float:
    """C (1/s) of an exponential through the turning-point amplitudes (the naive method)."""
    from escfit.balance.recordings.turning_points import reduce_series
    from escfit.balance.recordings.unit_curve import UnitCurve

    data = problem.data
    if isinstance(data, UnitCurve):
        t, a = data.time, data.value
    else:
        tp = reduce_series(data)
        t = np.r_[tp.release_time, tp.time]
        a = np.abs(np.r_[tp.release_theta, tp.theta] - (tp.offset + tp.offset_rate * (t - tp.release_time)))
    ok = a > 0
    slope = np.polyfit(t[ok], np.log(a[ok]), 1)[0]
    return -2.0 * slope


def figure(problem, res, title: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    y = problem.observed
    e = problem.expected(res.values)
    t = problem.curves[0].time if problem.curves[0].time is not None else np.arange(y.size)
    unit = getattr(problem, "reading_units", "rad")
    deg = unit == "rad" and np.nanmax(np.abs(y)) < 7
    k = 180 / math.pi if deg else 1.0
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(9, 5.2), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    style = dict(ms=3, lw=0) if y.size < 400 else dict(ms=1.2, lw=0)
    ax.plot(t, k * y, "o", color="0.45", label="recording", **style)
    ax.plot(t, k * e, "-", color="C3", lw=1.0, label="model at the best fit")
    ax.set_ylabel("angle (deg)" if deg else f"reading ({unit})")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    axr.plot(t, k * (y - e), "o", color="C0", **style)
    axr.axhline(0, color="k", lw=0.6)
    axr.set_ylabel("residual (deg)" if deg else f"residual ({unit})")
    axr.set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(HERE.parents[1] / "docs" / "real-data"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print("| recording | read as | C (1/s) | R (rad/s^2) | omega0 (rad/s) | envelope C (1/s) | reading scatter | misfit |")
    print("|---|---|---|---|---|---|---|---|")
    from escfit.inference.fit import _misfit

    for recipe in sorted(HERE.glob("*.toml")):
        doc = tomllib.loads(recipe.read_text())
        scene = load_scene((recipe.parent / doc["scene"]).resolve())
        problem = make_problem(scene, str((recipe.parent / doc["data"]).resolve()))
        res = least_squares(problem, n_starts=8)

        def fmt(name):
            if name not in res.names:
                v = res.values.get(name, math.nan)
                return f"{v:.4g} (fixed)"
            i = res.names.index(name)
            return f"{res.value[i]:.4g} +- {1.96 * res.stderr[i]:.2g}"

        _, warnings = _misfit(problem, res, problem.obs_coords())
        warnings = warnings + problem.checks_at_best_fit(res.values)[1]
        kind = "waveform" if problem.curves[0].label == "waveform" else "turning points"
        print(f"| {recipe.stem} | {kind}, {problem.n_data} readings | {fmt('viscous.C')} | {fmt('coulomb.R')} | "
              f"{fmt('oscillator.omega0')} | {envelope_c(problem):.4g} | {res.sigma_hat:.3g} | "
              f"{'; '.join(w.split(':')[0] for w in warnings) or 'clean'} |")
        figure(problem, res, doc.get("title", recipe.stem), out / f"{recipe.stem}.png")


if __name__ == "__main__":
    main()
