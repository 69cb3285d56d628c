"""Write Monday's charts (see :mod:`escfit.balance.monday.charts`) as CSV tables and PNG figures."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Sequence

import numpy as np

from ...core.atomic import atomic_path
from .charts import REFERENCE_POWER_ANGLE, amplitude_factor, equivalent_r, graph_factor, unit_curve

__all__ = ["write_charts", "APPENDIX_C_RATIOS"]

APPENDIX_C_RATIOS = (0.040, 0.045, 0.050, 0.055, 0.060, 0.065, 0.080, 0.090, 0.100, 0.105, 0.110, 0.120,
                     0.130, 0.140, 0.150)
X2_WINDOWS = ((0.2, 0.4), (0.2, 0.5), (0.3, 0.5), (0.3, 0.6), (0.3, 0.7), (0.4, 0.8))  # (alpha, eps)
X3_WINDOWS = ((0.0, 0.25), (0.0, 0.3), (0.2, 0.2), (0.25, 0.25), (0.2787, 0.2787), (0.3, 0.3))  # (alpha, beta)


def _write_csv(path: Path, header: Sequence[str], rows, force: bool) -> None:
    with atomic_path(path, force=force) as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            w.writerows(rows)


def write_charts(out_dir: str | Path, *, c_over_w0: float = 0.05, ks: Sequence[float] = (0.05, 0.1, 0.2, 0.3, 0.45, 0.6),
                 cycles: int = 40, force: bool = False, png: bool = True) -> list[Path]:
    """Regenerate the charts into ``out_dir``; returns the files written.

    Parameters
    ----------
    c_over_w0
        Damping ratio at which the conversion charts are drawn.
    ks
        K values of the computed unit curves (one figure per Appendix C ratio).
    png
        Also draw PNG figures (needs matplotlib).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    rows = [(c, k, n, a) for c in APPENDIX_C_RATIOS for k in ks for n, a in enumerate(unit_curve(c, k, cycles=cycles))]
    _write_csv(out / "unit_curves.csv", ["c_over_omega0", "K", "cycle", "amplitude_rad"], rows, force)
    x2 = np.linspace(0.0, 1.0, 21)
    rows = [(a, e, x, equivalent_r(c_over_w0, x, -e, -a)) for a, e in X2_WINDOWS for x in x2]
    _write_csv(out / "conversion_x2.csv", ["alpha", "epsilon", "X2_over_omega0sq", "R_X2_over_omega0sq"], rows, force)
    x3 = np.linspace(0.0, 6.0, 25)
    rows = [(a, b, x, equivalent_r(c_over_w0, x, -a, b)) for a, b in X3_WINDOWS for x in x3]
    _write_csv(out / "conversion_x3.csv", ["alpha", "beta", "X3_over_omega0sq", "R_X3_over_omega0sq"], rows, force)
    cs = np.round(np.arange(0.005, 0.2001, 0.005), 3)
    rows = [(c, graph_factor(c), amplitude_factor(c)) for c in cs]
    _write_csv(out / "factors.csv", ["c_over_omega0", "graph_factor", "amplitude_factor_ref_0.05"], rows, force)
    files += [out / n for n in ("unit_curves.csv", "conversion_x2.csv", "conversion_x3.csv", "factors.csv")]
    if png:
        files += _plots(out, c_over_w0, ks, cycles, x2, x3, cs, force)
    return files


def _plots(out: Path, c0, ks, cycles, x2, x3, cs, force) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []

    def save(fig, name):
        with atomic_path(out / name, force=force) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
        plt.close(fig)
        written.append(out / name)

    fig, axes = plt.subplots(3, 5, figsize=(16, 9), sharex=True, sharey=True)
    for ax, c in zip(axes.flat, APPENDIX_C_RATIOS):
        for k in ks:
            ax.plot(unit_curve(c, k, cycles=cycles), label=f"K={k:g}")
        ax.set_title(f"C/omega0 = {c:.3f}", fontsize=9)
    axes[0, 0].legend(fontsize=7)
    fig.supxlabel("cycles from release")
    fig.supylabel("amplitude (rad)")
    fig.suptitle(f"Computed unit curves (phase switching, reference power angle +-{REFERENCE_POWER_ANGLE} rad)")
    save(fig, "unit_curves.png")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    for a, e in X2_WINDOWS:
        a1.plot(x2, [equivalent_r(c0, x, -e, -a) for x in x2], label=f"({a:g}, 0, {e:g})")
    a1.set_xlabel("X2/omega0^2")
    a1.set_ylabel("R_X2/omega0^2")
    a1.set_title(f"Unlock -> Coulomb (alpha, beta, eps), C/omega0={c0:g}")
    a1.legend(fontsize=8)
    for a, b in X3_WINDOWS:
        a2.plot(x3, [equivalent_r(c0, x, -a, b) for x in x3], label=f"({a:g}, {b:g})")
    a2.set_xlabel("X3/omega0^2")
    a2.set_ylabel("R_X3/omega0^2")
    a2.set_title("Impulse -> Coulomb (alpha, beta)")
    a2.legend(fontsize=8)
    save(fig, "conversion_charts.png")
    fig, (b1, b2) = plt.subplots(1, 2, figsize=(11, 4))
    b1.plot(cs, [graph_factor(c) for c in cs])
    b1.set_xlabel("C/omega0")
    b1.set_ylabel("graph factor K/K_R")
    b2.plot(cs, [amplitude_factor(c) for c in cs])
    b2.set_xlabel("C/omega0")
    b2.set_ylabel("amplitude factor (1 at C/omega0 = 0.05)")
    save(fig, "factors.png")
    return written
