"""Reproducing Meyer's (1973) Appendix E, and the experiments behind ``docs/geneva.md``.

Run ``python -m escfit.geneva.reproduce`` to print the reproduction tables in Markdown.

Rise-time definitions compared with Meyer's column (all measured on the same run):

``peaks``
    first speed peak after which every peak stays within 1% of the terminal peak (the
    definition :func:`escfit.geneva.simulate` reports);
``minima``
    the same with the speed minima;
``first_min``
    the first speed minimum after release (his text: "by the first minimum in velocity,
    the driver has achieved its steady state velocity profile").
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .geometry import Geometry, coefficients
from .simulate import forward, rise_time
from .tables import MEYER_TABLES, meyer_table

__all__ = ["appendix_e_rows", "markdown_table", "rise_time_scores", "lagged_friction_extremes", "LBF_INCH"]

LBF_INCH = 0.1129848290276167  # N*m per lbf*inch (and kg*m^2 per lbf*inch*s^2)
PRINT_DT = 0.0005  # Meyer's output interval, s
RISE_DEFINITIONS = ("peaks", "minima", "first_min")


def appendix_e_rows(duration: float = 0.2) -> list[dict[str, Any]]:
    """Every Appendix E row with our figures, as published (compat) and with correct geometry.

    Each row holds the printed values, the exact terminal extremes and period, the rise
    times under :data:`RISE_DEFINITIONS`, and ``print_peak``/``print_min``: the extremes of
    the last complete engagement before ``duration`` read on Meyer's 0.5 ms output grid.
    """
    rows = []
    for name, (_, slots, i_d, i_f, compat) in MEYER_TABLES.items():
        tab = meyer_table(name)
        for k in range(tab["mu"].size):
            row: dict[str, Any] = {"mechanism": name, "slots": slots, "mu": float(tab["mu"][k]),
                                   "K": float(tab["K"][k] / LBF_INCH)}
            for col in ("peak_speed", "min_speed", "rise_time", "period"):
                row[f"meyer_{col}"] = float(tab[col][k])
            for label, mode in (("ours", compat), ("geometric", "none")):
                if label == "geometric" and mode == compat:
                    continue
                row.update({f"{label}_{key}": v for key, v in _one(slots, mode, i_d, i_f, row["mu"], row["K"],
                                                                     duration).items()})
            rows.append(row)
    return rows


def _one(slots, compat, i_d, i_f, mu, torque, duration) -> dict[str, float]:
    values = {"geneva.driver_inertia": i_d * LBF_INCH, "geneva.follower_inertia": i_f * LBF_INCH,
              "geneva.torque": torque * LBF_INCH, "geneva.mu": mu}
    times = np.arange(int(round(duration / PRINT_DT)) + 1) * PRINT_DT
    pred = forward(Geometry(slots, compat), values, duration=duration, sample_times=times)
    tr, term = pred.trajectory, pred.terminal
    out = {"peak_speed": term.peak_speed, "min_speed": term.min_speed, "period": term.period,
           "rise_peaks": pred.rise_time,
           "rise_minima": rise_time(tr.eng_min_speed, tr.eng_min_time, term.min_speed),
           "rise_first_min": float(tr.eng_min_time[1]) if tr.eng_min_time.size > 1 else math.nan}
    if tr.eng_start.size:
        sel = (tr.time >= tr.eng_start[-1]) & (tr.time <= tr.eng_end[-1])
        out["print_peak"], out["print_min"] = float(tr.speed[sel].max()), float(tr.speed[sel].min())
    return out


def rise_time_scores(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Median and largest |relative error| of each rise-time definition against Meyer's column."""
    out = {}
    for d in RISE_DEFINITIONS:
        err = np.array([r[f"ours_rise_{d}"] / r["meyer_rise_time"] - 1 for r in rows])
        err = err[np.isfinite(err)]
        out[d] = {"median_abs": float(np.median(np.abs(err))), "max_abs": float(np.max(np.abs(err))),
                  "within_10pct": int(np.sum(np.abs(err) <= 0.10)), "n": int(err.size)}
    return out


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The reproduction table in Markdown (speeds rad/s, times s)."""
    head = ("| mechanism | mu | K in-lb | peak Meyer | peak ours | min Meyer | min ours | period Meyer | period ours "
            "| rise Meyer | rise peaks | rise minima | rise 1st min | peak, min with correct geometry |")
    lines = [head, "|" + "---|" * 14]
    for r in rows:
        geo = (f"{r['geometric_peak_speed']:.1f}, {r['geometric_min_speed']:.1f}" if "geometric_peak_speed" in r
               else "(same)")
        lines.append(
            f"| {r['mechanism'].replace('_', '-')} | {r['mu']:.2f} | {r['K']:.2f} | {r['meyer_peak_speed']:.0f} "
            f"| {r['ours_peak_speed']:.1f} | {r['meyer_min_speed']:.0f} | {r['ours_min_speed']:.2f} "
            f"| {r['meyer_period']:.3f} | {r['ours_period']:.4f} | {r['meyer_rise_time']:.3f} "
            f"| {_f(r['ours_rise_peaks'])} | {_f(r['ours_rise_minima'])} | {_f(r['ours_rise_first_min'])} | {geo} |")
    return "\n".join(lines)


def _f(v: float) -> str:
    return f"{v:.3f}" if math.isfinite(v) else "-"


def lagged_friction_extremes(slots: int, compat: str, i_d: float, i_f: float, mu: float, torque: float, *,
                             lag: float = 5e-5, step: float = 2e-6, duration: float = 0.2,
                             settle: float = 0.15) -> tuple[float, float]:
    """Peak and minimum speed when the friction sign is taken from an acceleration ``lag`` old.

    Emulates the ``OLD2DX`` card of Meyer's program (sign of ``C*w**2 + D*alpha(t - lag)``;
    his lag was ``DT/10 = 50 us``) with fixed-step RK4.  Inputs in Meyer's units (inertia
    lbf*inch*s^2, torque lbf*inch); returns the extremes after ``settle`` seconds, rad/s.
    Slow (pure Python, ``duration/step`` steps): for documentation, not for fitting.
    """
    g = Geometry(slots, compat)
    a, rho, e, span, x0 = g.a, i_d / i_f, torque / i_f, g.span, g.x_start
    n_lag = max(1, int(round(lag / step)))

    def accel(theta: float, w: float, alpha_old: float) -> float:
        big_a, big_b, big_c, big_d = coefficients((theta % span) + x0, a, rho, mu)
        s = -1.0 if big_c * w * w + big_d * alpha_old < 0 else 1.0
        return (e - (big_b + s * big_c) * w * w) / (big_a + s * big_d)

    big_a, _, _, big_d = coefficients(x0, a, rho, mu)
    history = [e / (big_a + abs(big_d))] * (n_lag + 1)  # Meyer's Appendix D start
    theta = w = t = 0.0
    hi, lo = -math.inf, math.inf
    i = 0
    while t < duration - 0.5 * step:
        old = history[i % (n_lag + 1)]
        k1 = accel(theta, w, old)
        k2 = accel(theta + 0.5 * step * w, w + 0.5 * step * k1, old)
        k3 = accel(theta + 0.5 * step * (w + 0.5 * step * k1), w + 0.5 * step * k2, old)
        k4 = accel(theta + step * (w + 0.5 * step * k2), w + step * k3, old)
        theta += step * (w + step / 6.0 * (k1 + k2 + k3))
        w += step / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += step
        i += 1
        history[i % (n_lag + 1)] = accel(theta, w, history[i % (n_lag + 1)])
        if t >= settle:
            hi, lo = max(hi, w), min(lo, w)
    return hi, lo


def main() -> None:  # pragma: no cover - documentation helper
    rows = appendix_e_rows()
    print(markdown_table(rows))
    print()
    for d, s in rise_time_scores(rows).items():
        print(f"rise time '{d}': median |error| {100 * s['median_abs']:.0f}%, largest {100 * s['max_abs']:.0f}%, "
              f"{s['within_10pct']}/{s['n']} within 10%")


if __name__ == "__main__":  # pragma: no cover
    main()
