"""Fit every real recording at hand as read raw and draw the gallery of docs/real-data.md.

Run:  python fits/real/gallery.py [--out docs/real-data] [NAME ...]   (a few minutes; least squares)

For each recipe in this folder, and each free decay of the shared folder that may not be shipped
(``../shared/realdata/gpl_tests_only``, when present): the recording is read raw with its
scene's ``[recording]`` table, fitted by least squares as ``escfit fit`` does it (checked against
the record's own period, :mod:`escfit.inference.reconcile`), and compared with the source's own
value and with a naive log-linear envelope of its turning points (viscous damping only: ln A
falls by C/2 per second).  Prints one Markdown table row per recording and writes one figure
each (data and model against time, residuals).
"""

from __future__ import annotations

import argparse
import math
import tomllib
from pathlib import Path

import numpy as np

from escfit.inference import least_squares, make_problem
from escfit.inference.reconcile import reconcile, with_held_uncertainty
from escfit.core.scene import load_scene

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

#: the sources' own values, as their SOURCE.txt or their authors' code give them
SOURCE_VALUES = {
    "encoder_pendulum_jensen": ("zero-crossing period 0.65 s; compute.py: zeta = 5.462e-4 at w_n = 475 deg/s, the "
                                "first maximum falling as exp(-0.259 t), a viscous C of 0.52 1/s over the first period"),
    "gyro_torsion_radial": "period 0.422 s",
    "gyro_compound_axial": "period 1.429 s",
    "galileo_short": "period 1.16 s",
    "galileo_long": "period 1.36 s",
    "multiarm_estimation": "omega0 = 8.01 rad/s, viscous only C = 0.0668 1/s (authors' identification)",
    "multiarm_free_swing": "omega0 = 8.01 rad/s (authors' identification)",
    "pohl_amplitudes": "LabPlot: A0 exp(b t), b = -0.158 1/s (C = 0.317 1/s, viscous only)",
    "pohl_tracker": "Tracker damped sine: B = 4.610 rad/s, E = -0.288 1/s (C = 0.576 1/s, viscous only)",
    "string_pendulum_lab1": "Q ~ 140 (C ~ 0.027 1/s)",
    "string_pendulum_trial1": "released at 1.44 rad",
    "pohl_tracker_trk": "Tracker damped sine: B = 4.610 rad/s, E = -0.288 1/s (C = 0.576 1/s, viscous only)",
    "cassy_drehpendel": "period ~1.79 s; amplitude 1.81 rad -> 0.05 rad, close to linear (dry friction)",
}

#: free decays of the shared folder that are not shipped (GPL): (name, file, scene, title)
SHARED_DECAYS = [
    ("cassy_drehpendel", "gpl_tests_only/cassy_phyprakit/Drehpendel.labx", "cassy_torsion_pendulum.toml",
     "Torsion pendulum, CASSY Lab 2 .labx (PhyPraKit example)"),
    ("galileo_short", "gpl_tests_only/arduino_encoder_galileo_ferrucci/galileo_2024-07-19_09-27-13.csv",
     "galileo_encoder_pendulum.toml", "Encoder pendulum, Arduino 50 Hz, 17 s (from_galileo_to_arduino)"),
    ("galileo_long", "gpl_tests_only/arduino_encoder_galileo_ferrucci/galileo_2024-07-19_15-25-54.csv",
     "galileo_encoder_pendulum.toml", "Encoder pendulum, Arduino 50 Hz, 90 s (from_galileo_to_arduino)"),
]


def records():
    """(name, data path, scene path, title) of every recording to show."""
    for recipe in sorted(HERE.glob("*.toml")):
        doc = tomllib.loads(recipe.read_text())
        yield (recipe.stem, (recipe.parent / doc["data"]).resolve(), (recipe.parent / doc["scene"]).resolve(),
               doc.get("title", recipe.stem))
    for base in (ROOT.parent / "shared" / "realdata", ROOT.parents[1] / "shared" / "realdata"):
        if base.is_dir():
            for name, data, scene, title in SHARED_DECAYS:
                if (base / data).exists():
                    yield name, base / data, ROOT / "datasets" / "real" / "scenes" / scene, title
            break


def envelope_c(problem) -> float:
    """C (1/s) of an exponential through the turning-point amplitudes (the naive method)."""
    from escfit.analysis.recordings.turning_points import reduce_series
    from escfit.analysis.recordings.unit_curve import UnitCurve

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
    ap.add_argument("names", nargs="*", help="recordings to show (default: all)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print("| recording | read as | C (1/s) | R (rad/s^2) | omega0 (rad/s) | period (s) | the source's own value | "
          "envelope C (1/s) | reading scatter | misfit |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    from escfit.inference.fit import _misfit

    for name, data, scene_path, title in records():
        if args.names and name not in args.names:
            continue
        scene = load_scene(scene_path)
        problem = make_problem(scene, str(data))
        res, _, unresolved = reconcile(problem, least_squares(problem, n_starts=8))
        res, _ = with_held_uncertainty(problem, res)

        def fmt(key):
            if key not in res.names:
                v = res.values.get(key, math.nan)
                return "-" if math.isnan(v) else f"{v:.4g} (held)" if key in getattr(problem, "held", ()) \
                    else f"{v:.4g} (fixed)"
            i = res.names.index(key)
            return f"{res.value[i]:.4g} +- {1.96 * res.stderr[i]:.2g}"

        _, warnings = _misfit(problem, res, problem.obs_coords())
        warnings = warnings + problem.checks_at_best_fit(res.values)[1]
        if unresolved:
            warnings.insert(0, "NOT determined: the fit contradicts the measured period")
        kind = "waveform" if problem.curves[0].label == "waveform" else "turning points"
        mp = getattr(problem, "measured_period", None)
        period = f"{mp.period:.4g}" if mp is not None else "-"
        print(f"| {name} | {kind}, {problem.n_data} readings | {fmt('viscous.C')} | {fmt('coulomb.R')} | "
              f"{fmt('oscillator.omega0')} | {period} | {SOURCE_VALUES.get(name, '-')} | {envelope_c(problem):.4g} | "
              f"{res.sigma_hat:.3g} | {'; '.join(w.split(':')[0] for w in warnings) or 'clean'} |", flush=True)
        figure(problem, res, title, out / f"{name}.png")


if __name__ == "__main__":
    main()
