"""The faster exact kernels against the per-segment computation they replace.

``run_phase`` now iterates one affine map per half cycle; ``run_angle`` skips the closed form
at a turning point that cannot end the half swing.  Both are checked against slow pure-Python
references written out here -- the per-segment algorithms as they stood before (escfit
2e7e582), driving the same closed-form functions of :mod:`escfit.balance.segment` -- over
random parameter sets, and the phase kernel also against closed forms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import System, exact, regions
from escfit.balance.batch import solve_batch
from escfit.balance.kernel_records import blank, half_swings, run_options
from escfit.balance.segment import CREEP_OVERSHOOT, cross_time, propagate, turn_time
from escfit.balance.solvers import solve_system
from escfit.balance.walker import drift_factor

from .conftest import DATASETS


# -- references: the previous per-segment kernels, in plain Python -----------------------------

def reference_phase(theta0, c0, r, w2, w_lo, w_hi, w_x, w_dir, dr_th, dr_rate, n_swings):
    """Monday's phase switching, segment by segment (the kernel as of escfit 2e7e582)."""
    out = {k: [] for k in ("amplitude", "theta_turn", "half_period", "time")}
    s = 1.0 if theta0 < 0.0 else -1.0
    x, v, c, t, int_c = s * theta0, 0.0, c0, 0.0, 0.0
    status = n_seg = n_done = 0
    drift = any(rate != 0.0 for rate in dr_rate)
    while n_done < n_swings:
        h = 0.5 * c
        w1 = math.sqrt(w2 - h * h)
        on = [k for k in range(len(w_lo)) if w_dir[k] == 0 or w_dir[k] == s]
        pts = sorted([0.0, math.pi] + [math.pi / 2 + w_lo[k] for k in on] + [math.pi / 2 + w_hi[k] for k in on])
        for a, b in zip(pts[:-1], pts[1:]):
            if b <= a:
                continue
            mid = 0.5 * (a + b) - math.pi / 2
            force = -r + sum(w_x[k] for k in on if w_lo[k] <= mid < w_hi[k])
            xc, tau = force / w2, (b - a) / w1
            y, v = propagate(x - xc, v, tau, h, w2)
            x = xc + y
            t += tau
            int_c += c * tau
            n_seg += 1
        for key, value in zip(out, (abs(x), s * x, math.pi / w1, t)):
            out[key].append(value)
        n_done += 1
        if x <= 0.0:
            status = 4
        if drift and n_done % 2 == 0:
            c *= drift_factor(int_c, dr_th, dr_rate)
            if c >= 2.0 * math.sqrt(w2):
                status = 4
                break
        s, x, v = -s, -x, -v
    return out, n_done, status, n_seg, (t, s * x, s * v)


def reference_angle(theta0, v0, c0, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, dr_th,
                    dr_rate, n_swings, max_seg):
    """Angle switching, segment by segment: the closed form at every turning point, then the
    bracketed crossing solve (the kernel as of escfit 2e7e582), with the creep rule of every
    solver (:func:`escfit.balance.segment.creeps_to_rest`)."""
    out = {k: [] for k in ("amplitude", "theta_turn", "half_period", "time", "banked")}
    s = (1.0 if theta0 < 0.0 else -1.0) if v0 == 0.0 else (1.0 if v0 > 0.0 else -1.0)
    x, v, c, t, t_swing, int_c = s * theta0, s * v0, c0, 0.0, 0.0, 0.0
    status = n_done = n_seg = 0
    any_bank, at_start = False, True
    drift = any(rate != 0.0 for rate in dr_rate)
    k = angle_record(theta0, v0, c0, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, dr_th,
                     dr_rate)
    edge_tab, n_edge_tab, w2_tab, xc_tab = regions.region_tables(k[0])
    d = 0 if s > 0.0 else 1
    scale = None
    while n_done < n_swings:
        if n_seg >= max_seg:
            status = 3
            break
        edges, n_edges = edge_tab[d], n_edge_tab[d]
        j = 0
        while j < n_edges and edges[j] <= x:
            j += 1
        w2, xc = w2_tab[d, j], xc_tab[d, j]
        y0, h = x - xc, 0.5 * c
        if scale is None:
            scale = math.sqrt(y0 * y0 + v * v / w2)
        xb = edges[j] if j < n_edges else math.inf
        grazed = crosses = False
        if v <= 0.0 and y0 >= 0.0:
            v = 0.0
            if at_start:
                status = 1
                break
            grazed = True
        if grazed:
            tau = 0.0
        else:
            if v <= 0.0:
                v = 0.0  # also a negative zero, which would flip atan2's branch
            tau_turn = turn_time(y0, v, h, w2)
            x_turn = xc + propagate(y0, v, tau_turn, h, w2)[0] if math.isfinite(tau_turn) else xc
            crosses = x_turn > xb
            # the creep rule (segment.creeps_to_rest): a turn overshooting its rest position by
            # less than CREEP_OVERSHOOT of the larger of the segment's motion and the release's
            creep = abs(x_turn - xc) <= CREEP_OVERSHOOT * max(math.sqrt(y0 * y0 + v * v / w2), scale)
            if crosses:
                tau, v_new = cross_time(y0, v, h, w2, xb - xc, tau_turn)
                x, v = xb, max(v_new, 0.0)
            elif math.isfinite(tau_turn) and not creep:
                tau, x, v = tau_turn, x_turn, 0.0
            else:
                n_seg += 1
                x, v, t, status = xc, 0.0, math.inf, 1
                break
        n_seg += 1
        t += tau
        t_swing += tau
        int_c += c * tau
        at_start = False
        is_bank = crosses and j == n_edges - 1 and math.isfinite(bank)
        if crosses and not is_bank:
            continue
        for key, value in zip(out, (abs(x), s * x, t_swing, t, 1 if is_bank else 0)):
            out[key].append(value)
        any_bank = any_bank or is_bank
        t_swing = 0.0
        n_done += 1
        if drift and n_done % 2 == 0:
            c *= drift_factor(int_c, dr_th, dr_rate)
        s, x = -s, -x
        v = restitution * v if is_bank else 0.0
        at_start = v == 0.0
        d = 1 - d
    if status == 0 and any_bank:
        status = 2
    return out, n_done, status, n_seg, (t, s * x, s * v)


# -- random parameter sets ----------------------------------------------------------------------

def _windows(rng, n, w0, spread=1.0):
    """``n`` windows (lo, hi, X, dir): sometimes adjacent like an unlock before an impulse."""
    lohi = np.sort(rng.uniform(-1.2 * spread, 1.2 * spread, 2 * n)).reshape(n, 2) if n else np.zeros((0, 2))
    if n > 1 and rng.random() < 0.5:
        lohi[1:, 0] = lohi[:-1, 1]
    w_x = rng.uniform(-1.0, 5.0, n) * w0**2 * rng.choice([0.1, 1.0, 10.0])
    w_dir = rng.integers(-1, 2, n).astype(np.int64)  # both swings, positive only, negative only
    return lohi[:, 0].copy(), lohi[:, 1].copy(), w_x, w_dir


def _drift(rng):
    if rng.random() < 0.4:
        return np.sort(rng.uniform(0.0, 1.0, 2))[::-1].copy(), rng.uniform(-0.1, 0.3, 3)
    return np.zeros(0), np.zeros(1)


def random_phase_args(rng):
    w0 = rng.uniform(2.0, 40.0)
    theta0 = rng.uniform(0.05, 6.5) * rng.choice([-1.0, 1.0])
    c = rng.choice([0.0, rng.uniform(0.0, 0.3 * w0), rng.uniform(0.0, 1.99 * w0)])
    r = rng.choice([0.0, rng.uniform(0.0, 0.3), rng.uniform(0.0, 3.0)]) * w0**2  # up to Coulomb-dominated
    w_lo, w_hi, w_x, w_dir = _windows(rng, int(rng.integers(0, 4)), w0)
    return (float(theta0), float(c), float(r), float(w0**2), w_lo, w_hi, w_x, w_dir, *_drift(rng))


def random_angle_args(rng):
    w0 = rng.uniform(5.0, 30.0)
    theta0 = rng.uniform(0.2, 6.0) * rng.choice([-1.0, 1.0])
    c = rng.choice([0.0, rng.uniform(0.0, 0.6 * w0), rng.uniform(0.0, 3.0 * w0)])
    r = rng.choice([0.0, rng.uniform(0.0, 0.2) * w0**2])
    w_lo, w_hi, w_x, w_dir = _windows(rng, int(rng.integers(0, 3)), w0, spread=0.8)
    w_x *= 0.3
    n_bp = int(rng.integers(0, 3))
    sp_bp = np.sort(rng.uniform(-2.0, 2.0, n_bp))
    sp_w2 = rng.uniform(0.7, 1.3, n_bp + 1) * w0**2
    sp_off = np.zeros(n_bp + 1)
    for i, b in enumerate(sp_bp):  # a continuous restoring torque
        sp_off[i + 1] = sp_w2[i] * b + sp_off[i] - sp_w2[i + 1] * b
    bank = float(rng.choice([math.inf, abs(theta0) * rng.uniform(0.9, 1.5)]))
    return (float(theta0), 0.0, float(c), float(r), sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank,
            float(rng.uniform(0.0, 1.0)), *_drift(rng))


def angle_record(theta0, v0, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, dr_th, dr_rate):
    """The coefficient record of the previous kernels' positional arguments."""
    k = blank(1)
    k["theta0"], k["v0"], k["c"], k["r"], k["r_static"] = theta0, v0, c, r, r
    n = len(sp_w2)
    k["n_pieces"] = n
    k["sp_bp"][0, :n - 1], k["sp_w2"][0, :n], k["sp_off"][0, :n] = sp_bp, sp_w2, sp_off
    k["omega0"] = math.sqrt(sp_w2[0])
    m = len(w_lo)
    k["n_windows"] = m
    k["w_lo"][0, :m], k["w_hi"][0, :m], k["w_x"][0, :m], k["w_dir"][0, :m] = w_lo, w_hi, w_x, w_dir
    k["bank"], k["restitution"] = bank, restitution
    k["n_bands"] = len(dr_th)
    k["drift_th"][0, :len(dr_th)], k["drift_rate"][0, :len(dr_rate)] = dr_th, dr_rate
    return k


def phase_record(theta0, c, r, w2, w_lo, w_hi, w_x, w_dir, dr_th, dr_rate):
    return angle_record(theta0, 0.0, c, r, np.zeros(0), np.array([w2]), np.zeros(1), w_lo, w_hi, w_x, w_dir,
                        math.inf, 0.0, dr_th, dr_rate)


def positional(system):
    """The previous kernels' positional arguments of a system (for the references)."""
    f = system.field
    return (f("theta0"), f("v0"), f("c"), f("r"), f("sp_bp"), f("sp_w2"), f("sp_off"), f("w_lo"), f("w_hi"),
            f("w_x"), f("w_dir"), f("bank"), f("restitution"), f("drift_th"), f("drift_rate"))


def _kernel_run(kernel, k, n_swings, max_seg=0, log_rows=0):
    out = half_swings(n_swings, nan=True)
    run = run_options(n_swings, max_segments=max_seg, dense=log_rows > 0)
    log = np.zeros((log_rows, 9))
    res = kernel(k, run, out, log)
    n = res.n_done
    fields = {f: out[f][:n] for f in ("amplitude", "theta_turn", "half_period", "time", "banked")}
    return fields, res.n_done, res.status, res.n_seg, (res.t, res.theta, res.omega), log[:res.rows]


# -- the phase kernel ---------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(4))
def test_phase_kernel_matches_the_per_segment_reference(seed):
    """rtol 1e-12; where a value passes near zero (a Coulomb-dominated run whose amplitude changes
    sign, a small boundary velocity) both computations carry the rounding of the run's largest
    terms, so the absolute floor is 1e-13 of those (angles: the largest |theta| or centre of the
    run; velocities: that times omega0)."""
    rng = np.random.default_rng(seed)
    seen = set()
    for _ in range(150):
        args = random_phase_args(rng)
        ref, n_ref, status_ref, nseg_ref, final_ref = reference_phase(*args, 40)
        got, n_done, status, n_seg, final, _ = _kernel_run(exact.run_phase_one, phase_record(*args), 40)
        assert (n_done, status, n_seg) == (n_ref, status_ref, nseg_ref), args
        theta0, c, r, w2, w_lo, w_hi, w_x = args[:7]
        scale = max([abs(theta0), (r + np.abs(w_x).sum()) / w2] + ref["amplitude"])
        for key in ("amplitude", "theta_turn"):
            np.testing.assert_allclose(got[key], ref[key], rtol=1e-12, atol=1e-13 * scale, err_msg=key)
        for key in ("half_period", "time"):
            np.testing.assert_allclose(got[key], ref[key], rtol=1e-12, atol=0, err_msg=key)
        assert not got["banked"].any()
        np.testing.assert_allclose(final, final_ref, rtol=1e-12, atol=1e-13 * scale * max(1.0, math.sqrt(w2)))
        seen.add(status)
        if status == 4 and not args[-1].any():
            seen.add("negative amplitude")  # a half cycle ended on the side it started
        if args[-1].any():
            seen.add("drift")
        if len(args[7]) and (args[7] != 0).any():
            seen.add("one-sided window")
    assert {0, 4, "negative amplitude", "drift", "one-sided window"} <= seen


def test_phase_kernel_closed_forms():
    """Viscous + Coulomb: A' = q*(A - r) - r per half cycle with q = exp(-pi*C/(2*omega1)) and
    r = R/omega0**2, continued past zero (Monday's convention breaks down: status 4)."""
    w0, th0 = 10.0, 3.0
    for c, big_r in [(0.0, 0.0), (0.8, 0.0), (0.0, 40.0), (1.7, 50.0), (0.3, 400.0)]:
        args = (th0, c, big_r, w0**2, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, np.int64), np.zeros(0),
                np.zeros(1))
        got, n_done, status, n_seg, final, _ = _kernel_run(exact.run_phase_one, phase_record(*args), 60)
        r = big_r / w0**2
        w1 = math.sqrt(w0**2 - c**2 / 4)
        q = math.exp(-math.pi * c / (2 * w1))
        a, expected = th0, []
        for _ in range(60):
            a = q * (a - r) - r
            expected.append(a)
        np.testing.assert_allclose(got["amplitude"], np.abs(expected), rtol=1e-12, atol=1e-13 * th0)
        np.testing.assert_allclose(got["half_period"], math.pi / w1, rtol=1e-14)
        np.testing.assert_allclose(got["time"], math.pi / w1 * np.arange(1, 61), rtol=1e-13)
        assert n_done == 60 and n_seg == 60
        assert status == (4 if min(expected) <= 0 else 0)


def test_phase_log_does_not_change_the_results_and_chains_the_segments():
    rng = np.random.default_rng(7)
    for _ in range(30):
        args = random_phase_args(rng)
        plain = _kernel_run(exact.run_phase_one, phase_record(*args), 30)
        logged = _kernel_run(exact.run_phase_one, phase_record(*args), 30, log_rows=30 * 8)
        for key in plain[0]:
            np.testing.assert_array_equal(plain[0][key], logged[0][key])
        assert plain[1:5] == logged[1:5]
        log, n_seg = logged[5], logged[3]
        # each half cycle's last segment, swept on with the closed form, ends where the kernel says
        w2 = args[3]
        for k in range(logged[1]):
            row = log[:n_seg][log[:n_seg, 8] == k][-1]
            t0, tau, s, x0, v0, xc, _, h = row[:8]
            y, _ = propagate(x0 - xc, v0, tau, h, w2)
            scale = max(abs(args[0]), abs(xc), abs(x0))
            assert abs(s * (xc + y) - logged[0]["theta_turn"][k]) <= 1e-12 * scale
            assert t0 + tau == pytest.approx(logged[0]["time"][k], rel=1e-13)


def test_phase_batch_equals_single_set():
    scene = escfit.load_scene(DATASETS / "monday1965" / "unit3_fit.toml")
    rng = np.random.default_rng(3)
    systems = [scene.build({"viscous.C": rng.uniform(0.5, 3.0), "coulomb.R": rng.uniform(200.0, 3000.0)})
               for _ in range(12)]
    batch = solve_batch(systems, 40)
    for i, sys in enumerate(systems):
        one = solve_system(sys, 40, "exact")
        np.testing.assert_array_equal(one.amplitude, batch[i].amplitude)
        np.testing.assert_array_equal(one.time, batch[i].time)
        assert one.status == batch[i].status and one.final == batch[i].final


# -- the angle kernel ---------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(2))
def test_angle_kernel_is_bit_for_bit_the_per_segment_reference(seed):
    rng = np.random.default_rng(100 + seed)
    seen = set()
    for _ in range(60):
        args = random_angle_args(rng)
        ref, n_ref, status_ref, nseg_ref, final_ref = reference_angle(*args, 40, 64 * 40 + 1000)
        got, n_done, status, n_seg, final, _ = _kernel_run(exact.run_one, angle_record(*args), 40, 64 * 40 + 1000)
        assert (n_done, status, n_seg) == (n_ref, status_ref, nseg_ref)
        for key in ref:
            np.testing.assert_array_equal(got[key], np.array(ref[key], got[key].dtype), err_msg=key)
        assert final == final_ref
        seen.add(status)
    assert {0, 1, 2} <= seen


def test_angle_kernel_monday_case_is_bit_for_bit():
    sys = escfit.load_scene(DATASETS / "scenes" / "monday_unit_angle_fit.toml").build()
    ref, n_ref, status_ref, nseg_ref, final_ref = reference_angle(*positional(sys), 120, 64 * 120 + 1000)
    got, n_done, status, n_seg, final, _ = _kernel_run(exact.run_one, sys.k, 120, 64 * 120 + 1000)
    assert (n_done, status, n_seg, final) == (n_ref, status_ref, nseg_ref, final_ref)
    for key in ref:
        np.testing.assert_array_equal(got[key], np.array(ref[key], got[key].dtype), err_msg=key)


def test_surely_crosses_never_contradicts_the_closed_form():
    """The bound that skips the turning point must say "crosses" only when the closed form does."""
    rng = np.random.default_rng(11)
    checked = skipped = 0
    for _ in range(20000):
        w2 = rng.uniform(1.0, 400.0)
        h = rng.choice([0.0, rng.uniform(0.0, 1.2) * math.sqrt(w2)])
        y0 = rng.uniform(-5.0, 1.0)
        v0 = max(0.0, rng.choice([0.0, rng.uniform(-1.0, 10.0) * math.sqrt(w2)]))
        if v0 == 0.0 and y0 >= 0.0:
            continue
        xc = rng.uniform(-2.0, 2.0)
        tau_turn = turn_time(y0, v0, h, w2)
        if not math.isfinite(tau_turn):
            continue
        x_turn = xc + propagate(y0, v0, tau_turn, h, w2)[0]
        xb = x_turn + rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-16, 0) * max(1.0, abs(x_turn))
        if not xb > xc + y0:
            continue
        sure = exact._surely_crosses(y0, v0, h, w2, tau_turn, xc, xb)
        checked += 1
        skipped += sure
        if sure:
            assert x_turn > xb, (y0, v0, h, w2, xc, xb)
    assert checked > 5000 and skipped > 1000


# -- the batch front end ------------------------------------------------------------------------

def test_small_batches_give_the_same_numbers_on_any_thread_count():
    """A small batch runs on one thread when none is asked for; numba's setting is restored."""
    import numba

    scene = escfit.load_scene(DATASETS / "scenes" / "monday_unit_angle_fit.toml")
    stack = System.stack([scene.build({"viscous.C": 0.5 + 0.05 * i}) for i in range(3)])
    before = numba.get_num_threads()
    small = solve_batch(stack, 20)
    assert numba.get_num_threads() == before
    two = solve_batch(stack, 20, threads=2)
    for key in ("amplitude", "theta_turn", "half_period", "time"):
        np.testing.assert_array_equal(getattr(small, key), getattr(two, key))
