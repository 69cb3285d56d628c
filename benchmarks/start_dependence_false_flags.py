"""False flags of the start-dependence check (:mod:`escfit.analysis.start_dependence`) on records
whose model is exactly the fitted one.

Each record is a free decay simulated by escfit's own solver (pendulum or spring; amplitude
0.1-1.5 rad, period 0.5-3 s, 8-120 periods, 15-100 samples a period, white or AR(1) noise of
0.1-3 % of the amplitude, 20-90 % of the amplitude lost, split between C and R anywhere from all
viscous to all friction, a sixth with air drag as well), fitted with the scene that made it.  A
record is flagged when the fit's losses are marked not determined by the check; the figure is
the rate, with the largest move of a loss in the fit's own standard errors.

Run (two processes, 2000 records, some 12 minutes on two cores)::

    python benchmarks/start_dependence_false_flags.py 0 2 2000 /tmp/ff.jsonl &
    python benchmarks/start_dependence_false_flags.py 1 2 2000 /tmp/ff.jsonl
    python benchmarks/start_dependence_summary.py /tmp/ff.jsonl

Record i is drawn from the seed 1000 + i; worker k handles the records with i % NWORKERS == k.
"""
import json
import math
import re
import sys
import time
import traceback

import numpy as np

from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.balance.waveform import sample_theta
from escfit.balance.solvers import default_solver
from escfit.core.scene import load_scene
from escfit.inference import make_problem
from escfit.inference.fit import fit_problem

KEY = "fitted again from one period later"
N_DRAG = 15   # records 0..N with drag (interleaved: every i with i % 6 == 3 below N_DRAG*6)
AR1_EVERY = 9  # every i % 9 == 5 has AR(1) noise


def scene_text(restoring, w0, C, R, D, drag, ar1, rho):
    """Fit scene; starts at perturbed truth-like values, generous bounds."""
    cmax = max(2.0, 10 * C)
    rmax = max(2.0, 10 * R)
    s = f'''model = "balance"
[oscillator]
restoring = "{restoring}"
omega0 = {{ value = {w0:.9g}, vary = true, min = {0.6 * w0:.9g}, max = {1.6 * w0:.9g} }}
[effects.viscous]
C = {{ value = {C:.9g}, vary = true, min = 0, max = {cmax:.9g} }}
[effects.coulomb]
R = {{ value = {R:.9g}, vary = true, min = 0, max = {rmax:.9g} }}
'''
    if drag:
        s += f'''[effects.drag]
D = {{ value = {D:.9g}, vary = true, min = 0, max = {max(5.0, 10 * D):.9g} }}
'''
    s += '[observation]\nmodel = "waveform"\n'
    if ar1:
        s += 'noise = "ar1"\n'
    return s


def draw(i):
    rng = np.random.default_rng(1000 + i)
    restoring = "pendulum" if i % 2 == 0 else "spring"
    drag = (i % 6 == 3)
    ar1 = (i % AR1_EVERY == 5)
    amp = float(np.exp(rng.uniform(math.log(0.1), math.log(1.5))))
    period = float(np.exp(rng.uniform(math.log(0.5), math.log(3.0))))
    nper = float(np.exp(rng.uniform(math.log(8), math.log(120))))
    spp = float(np.exp(rng.uniform(math.log(15), math.log(100))))
    noise = float(np.exp(rng.uniform(math.log(0.001), math.log(0.03))))
    loss = float(rng.uniform(0.2, 0.9))
    if drag:
        w = rng.dirichlet([1.0, 1.0, 1.0])
    else:
        f = float(rng.uniform(0, 1))
        # a few exact extremes: all viscous / all friction
        u = rng.uniform()
        if u < 0.1:
            f = 1.0
        elif u < 0.2:
            f = 0.0
        w = np.array([f, 1 - f, 0.0])
    rho = float(rng.uniform(0.5, 0.9)) if ar1 else 0.0
    return dict(i=i, restoring=restoring, drag=bool(drag), ar1=bool(ar1), amp=amp, period=period,
                periods=nper, spp=spp, noise_frac=noise, loss_target=loss, weights=[float(x) for x in w],
                rho=rho, seed=int(1000 + i))


BASE = '''model = "balance"
[oscillator]
restoring = "%s"
omega0 = { value = 6.0, vary = true, min = 0.1, max = 100 }
[effects.viscous]
C = { value = 0.01, vary = true, min = 0, max = 100 }
[effects.coulomb]
R = { value = 0.01, vary = true, min = 0, max = 100 }
%s[observation]
model = "waveform"
'''
DRAG = '[effects.drag]\nD = { value = 0.05, vary = true, min = 0, max = 100 }\n'


def truth_scene(r):
    return load_scene("truth.toml", text=BASE % (r["restoring"], DRAG if r["drag"] else ""))


def simulate(scene, vals, t):
    system = scene.system({**scene.params.values(), **vals})
    solver = default_solver(system)
    theta, status = sample_theta(system, t, solver)
    return np.asarray(theta), status, solver


def calibrate(r):
    """C, R, D (scaled weights of each mechanism's 'alone' value) giving the target loss."""
    scene = truth_scene(r)
    A0, P, T, L = r["amp"], r["period"], r["periods"] * r["period"], r["loss_target"]
    w0 = 2 * math.pi / P
    C1 = -2 * math.log(1 - L) / T
    R1 = L * A0 * w0 ** 2 / (4 * r["periods"])
    D1 = (1 / (A0 * (1 - L)) - 1 / A0) * 3 * P / (8 * T)
    wc, wr, wd = r["weights"]
    tt = np.linspace(max(T - 1.2 * P, 0.0), T, 600)

    def vals(s):
        v = {"oscillator.omega0": w0, "viscous.C": s * wc * C1, "coulomb.R": s * wr * R1,
             "oscillator.theta0": A0}
        if r["drag"]:
            v["drag.D"] = s * wd * D1
        return v

    def lossof(s):
        th, status, _ = simulate(scene, vals(s), tt)
        return 1 - np.max(np.abs(th[tt >= T - P])) / A0

    lo, hi = 0.2, 5.0
    for _ in range(30):
        mid = math.sqrt(lo * hi)
        if lossof(mid) < L:
            lo = mid
        else:
            hi = mid
        if hi / lo < 1.002:
            break
    s = math.sqrt(lo * hi)
    return vals(s), lossof(s)


def parse_move(res):
    for n in res.notes:
        if KEY in n:
            m = re.search(r"the losses move by ([0-9.eE+-]+|nan|inf) of their standard errors", n)
            if m:
                return float(m.group(1)), n
    for w in res.warnings:
        if KEY in w:
            zs = [float(x) for x in re.findall(r"([0-9.eE+-]+) of its standard errors", w)]
            return (max(zs) if zs else math.nan), w
    return math.nan, None


def run(r):
    t0 = time.time()
    truth, loss_actual = calibrate(r)
    r["truth"] = truth
    r["loss_actual"] = float(loss_actual)
    scene = truth_scene(r)
    P, T = r["period"], r["periods"] * r["period"]
    t = np.arange(0.0, T, P / r["spp"])
    theta, status, solver = simulate(scene, truth, t)
    r["sim_status"], r["sim_solver"], r["n"] = status, solver, int(t.size)
    rng = np.random.default_rng(r["seed"])
    sigma = r["noise_frac"] * r["amp"]
    r["sigma"] = sigma
    e = rng.standard_normal(t.size)
    if r["ar1"]:
        rho, s = r["rho"], math.sqrt(1 - r["rho"] ** 2)
        e[0] = e[0]
        for k in range(1, e.size):
            e[k] = rho * e[k - 1] + s * e[k]
    y = theta + sigma * e
    # starts: truth perturbed (omega0 by ~2 %, losses by 0.6..1.5x, zero losses started at a small value)
    p = np.random.default_rng(r["seed"] + 77)
    w0 = truth["oscillator.omega0"] * (1 + 0.02 * p.uniform(-1, 1))

    def st(x, alone):
        return x * float(np.exp(p.uniform(math.log(0.6), math.log(1.5)))) if x > 0 else 0.1 * alone
    C = st(truth["viscous.C"], -2 * math.log(1 - r["loss_target"]) / T)
    R = st(truth["coulomb.R"], r["loss_target"] * r["amp"] * (2 * math.pi / P) ** 2 / (4 * r["periods"]))
    D = st(truth.get("drag.D", 0.0), 0.05) if r["drag"] else 0.0
    text = scene_text(r["restoring"], w0, C, R, D, r["drag"], r["ar1"], r["rho"])
    r["fit_scene"] = text
    t1 = time.time()
    res = fit_problem(make_problem(load_scene("fit.toml", text=text), TimeSeries(t, y, source=f"ff-{r['i']}")),
                      n_starts=1)
    r["fit_seconds"] = time.time() - t1
    r["verdict"] = res.verdict
    r["flagged"] = any(KEY in w for w in res.warnings)
    r["move_sigmas"], r["check_text"] = parse_move(res)
    r["warnings"] = list(res.warnings)
    r["notes"] = list(res.notes)
    r["undetermined"] = list(getattr(res, "undetermined", []) or [])
    try:
        rows = res.summary()
        r["estimates"] = {k: {kk: (float(vv) if isinstance(vv, (int, float)) else str(vv))
                              for kk, vv in rows[k].items()} for k in rows}
    except Exception as exc:  # noqa
        r["estimates_error"] = repr(exc)
    r["seconds"] = time.time() - t0
    return r


def main():
    k, nw, nrec, out = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    first = int(sys.argv[5]) if len(sys.argv) > 5 else 0
    for i in range(first, nrec):
        if i % nw != k:
            continue
        r = draw(i)
        try:
            r = run(r)
        except Exception as exc:
            r["error"] = repr(exc)
            r["traceback"] = traceback.format_exc()
        with open(out, "a") as fh:
            fh.write(json.dumps(r, default=str) + "\n")
        print(i, r.get("verdict"), r.get("flagged"), r.get("move_sigmas"), r.get("error"),
              round(r.get("seconds", 0), 1), flush=True)


if __name__ == "__main__":
    main()
