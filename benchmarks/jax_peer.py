"""The string pendulum's least squares as a JAX user would write it: diffrax and scipy's trust region.

Run (any interpreter with jax and diffrax; written by ``benchmarks/jax_compare.py``)::

    python benchmarks/jax_peer.py INPUT.json OUTPUT.json

The model is the one escfit fits to the record (``fits/real/string_pendulum_lab1.toml``)::

    theta'' = -omega0**2 sin(theta) - C theta' - R sign(theta'),  theta(0) = theta0, theta'(0) = 0
    mean(t) = theta(t - t_release) - offset - offset_rate (t - t_ref)

with residuals whitened for AR(1) noise of correlation ``rho`` and divided by the noise scale
(both held at the input's values), and one residual ``(x - mu)/sd`` per Gaussian prior the input
gives (escfit's priors on the sensor's centre and drift, measured from the record).  diffrax integrates it with Dopri8 under a PID step-size controller (rtol and atol from
the input); the Jacobian is forward-mode differentiation through the solve (``jax.jacfwd`` with
``diffrax.ForwardMode``: the discretised sensitivity equations, step sizes held), the release
instant's column ``-theta'(t)``; ``scipy.optimize.least_squares`` (trust region reflective, C
and R bounded below by 0) iterates from the input's start.  The sign function has a zero
derivative, so the turning points' jump in the velocity's sensitivity is not modelled: a JAX
user's usual model, exact where the fit ends with R at 0.

The output holds the estimates, chi-square, function and Jacobian evaluations and the seconds
spent importing, compiling (the first evaluation of the jitted model and Jacobian) and fitting.
"""

from __future__ import annotations

import json
import sys
import time

T_START = time.perf_counter()

import numpy as np  # noqa: E402

try:
    import jax  # noqa: E402
    import jax.numpy as jnp  # noqa: E402
    import diffrax  # noqa: E402
except ImportError as exc:  # the caller reports the peer as skipped
    print(f"jax_peer: {exc}", file=sys.stderr)
    sys.exit(4)
from scipy.optimize import least_squares  # noqa: E402

jax.config.update("jax_enable_x64", True)
NAMES = ["oscillator.omega0", "oscillator.theta0", "viscous.C", "coulomb.R", "observation.offset",
         "observation.offset_rate", "observation.t_release"]


def _field(t, y, args):
    w0, c, r = args
    return jnp.stack([y[1], -w0 * w0 * jnp.sin(y[0]) - c * y[1] - r * jnp.sign(y[1])])


def _solve(p, ts, rtol, atol, adjoint):
    w0, th0, c, r = p[0], p[1], p[2], p[3]
    sol = diffrax.diffeqsolve(diffrax.ODETerm(_field), diffrax.Dopri8(), t0=0.0, t1=ts[-1], dt0=None,
                              y0=jnp.stack([th0, jnp.zeros_like(th0)]), args=(w0, c, r),
                              saveat=diffrax.SaveAt(ts=ts), max_steps=1_000_000, adjoint=adjoint,
                              stepsize_controller=diffrax.PIDController(rtol=rtol, atol=atol))
    return sol.ys


def main(src: str, dst: str) -> None:
    spec = json.loads(open(src).read())
    t = np.asarray(spec["time"], float)
    y = np.asarray(spec["readings"], float)
    t_ref, rho, rtol, atol = spec["t_ref"], spec["rho"], spec["rtol"], spec["atol"]
    fresh = np.asarray(spec.get("fresh", []), int)
    sigma = float(spec.get("sigma", 1.0))
    pinned = [(NAMES.index(n), mu, sd) for n, (mu, sd) in spec.get("priors", {}).items()]
    t_imported = time.perf_counter()
    motion = jax.jit(lambda p, ts: _solve(p, ts, rtol, atol, diffrax.RecursiveCheckpointAdjoint()))
    tangent = jax.jit(jax.jacfwd(lambda p, ts: _solve(p, ts, rtol, atol, diffrax.ForwardMode())[:, 0]))
    scale = np.sqrt(1.0 - rho * rho)
    counts = {"nfev": 0, "njev": 0}

    def whiten(r):
        e = r.copy()
        e[1:] = (r[1:] - rho * r[:-1]) / scale
        e[fresh] = r[fresh]
        return e / sigma

    def ts_of(x):
        return jnp.asarray(np.maximum(t - x[6], 0.0))

    def residuals(x):
        counts["nfev"] += 1
        ys = np.asarray(motion(jnp.asarray(x[:4]), ts_of(x)))
        prior = [(x[i] - mu) / sd for i, mu, sd in pinned]
        return np.concatenate([whiten(y - (ys[:, 0] - x[4] - x[5] * (t - t_ref))), prior])

    def jacobian(x):
        counts["njev"] += 1
        ts = ts_of(x)
        d = np.asarray(tangent(jnp.asarray(x[:4]), ts))
        omega = np.asarray(motion(jnp.asarray(x[:4]), ts))[:, 1]
        dmu = np.column_stack([d, -np.ones_like(t), -(t - t_ref), -omega])
        rows = np.zeros((len(pinned), x.size))
        for row, (i, _, sd) in enumerate(pinned):
            rows[row, i] = 1.0 / sd
        return np.vstack([np.column_stack([whiten(-dmu[:, j]) for j in range(dmu.shape[1])]), rows])

    x0 = np.array([spec["start"][n] for n in NAMES], float)
    lo = np.array([-np.inf, -np.inf, 0.0, 0.0, -np.inf, -np.inf, -np.inf])
    x0[2:4] = np.maximum(x0[2:4], 0.0)
    residuals(x0)
    jacobian(x0)  # compile both
    counts.update(nfev=0, njev=0)
    t_compiled = time.perf_counter()
    fit = least_squares(residuals, x0, jac=jacobian, bounds=(lo, np.inf), method="trf", x_scale="jac")
    t_done = time.perf_counter()
    out = {"values": dict(zip(NAMES, map(float, fit.x))), "chisqr": float(fit.fun @ fit.fun), "nfev": counts["nfev"],
           "njev": counts["njev"], "status": int(fit.status), "import_s": t_imported - T_START,
           "compile_s": t_compiled - t_imported, "fit_s": t_done - t_compiled, "jax": jax.__version__,
           "diffrax": diffrax.__version__}
    open(dst, "w").write(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
