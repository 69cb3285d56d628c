"""The scipy way: a hand-written least-squares fit of the 116 s string pendulum record.

What a physicist writes without escfit: ``scipy.integrate.solve_ivp`` (LSODA, rtol 1e-6) of
``theta'' = -omega0**2 sin(theta) - C theta' - R sgn(theta')`` released at rest from ``theta0``
at ``t_release``, the samples ``y = theta(t - t_release) + c0 + c1 t``, and
``scipy.optimize.least_squares`` from one start.  No escfit import.
Run:  python benchmarks/lsq_peer.py   (prints JSON: seconds, evaluations, estimates)
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

DATA = Path(__file__).resolve().parents[1] / "datasets/real/string_pendulum_video/lab1_data.txt"
NAMES = ["omega0", "theta0", "C", "R", "c0", "c1", "t_release"]


def fit(path: Path = DATA) -> dict:
    t, y = np.loadtxt(path, usecols=(0, 1), unpack=True)
    theta_start = y[0]  # the record starts at a turning point, the release
    keep = t >= 0.2  # after it, as a careful user would
    t, y = t[keep], y[keep]
    calls = [0]

    def model(p):
        w0, th0, c, r, c0, c1, t0 = p
        calls[0] += 1
        rhs = lambda _, s: [s[1], -w0 * w0 * np.sin(s[0]) - c * s[1] - r * np.sign(s[1])]  # noqa: E731
        sol = solve_ivp(rhs, (0.0, t[-1] - t0), [th0, 0.0], method="LSODA", t_eval=t - t0, rtol=1e-6, atol=1e-9)
        theta = sol.y[0] if sol.success and sol.y.shape[1] == t.size else np.full(t.size, 1e3)
        return theta + c0 + c1 * t - y

    x0 = np.array([3.85, theta_start, 0.02, 0.001, 0.0, 0.0, 0.0])
    lo = [3.0, 0.0, 0.0, 0.0, -0.5, -0.1, -0.2]
    hi = [4.5, 1.5, 1.0, 1.0, 0.5, 0.1, 0.2]
    clock, cpu = time.perf_counter(), time.process_time()
    res = least_squares(model, x0, bounds=(lo, hi), method="trf")
    seconds, cpu = time.perf_counter() - clock, time.process_time() - cpu
    jac = res.jac
    cov = np.linalg.pinv(jac.T @ jac) * float(res.fun @ res.fun) / (t.size - len(x0))
    return {"seconds": seconds, "cpu_seconds": cpu, "rms_rad": float(np.sqrt(np.mean(res.fun**2))),
            "evaluations": calls[0], "samples": int(t.size), "names": NAMES,
            "value": res.x.tolist(), "stderr": np.sqrt(np.abs(np.diag(cov))).tolist(), "message": res.message}


if __name__ == "__main__":
    print(json.dumps(fit()))
