"""Escapement efficiency (seed 004): printed targets, optimum, drop, work index, friction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance import efficiency as eff
from escfit.core.errors import SceneError, SolverError

deg = np.radians


def test_graham_65_degrees_matches_printed_percentages():
    # impulse face normal at 65 deg to the tooth force, pallet moving at 90 deg to it
    assert round(100 * eff.impulse_fraction(deg(65)), 1) == 42.3
    assert round(100 * eff.transmitted_fraction(deg(65), deg(90)), 1) == 38.3
    # "divide 38.3 by 50": 23.4 % below the ideal, the text's "almost 24%"
    loss = 1 - eff.transmitted_fraction(deg(65), deg(90)) / eff.max_fraction(deg(90))
    assert round(100 * loss, 1) == 23.4


def test_ideal_maximum_is_half_with_fi_half_way():
    assert eff.max_fraction(deg(90)) == pytest.approx(0.5, abs=1e-15)
    assert eff.best_impulse_angle(deg(90)) == pytest.approx(deg(45))
    assert eff.transmitted_fraction(deg(45), deg(90)) == pytest.approx(0.5, abs=1e-15)


@pytest.mark.parametrize("fe_fp_deg", [40, 60, 90, 110])
@pytest.mark.parametrize("mu", [0.0, 0.1, 0.3])
def test_optimum_found_by_brute_force(fe_fp_deg, mu):
    b = deg(fe_fp_deg)
    a = np.linspace(0, b, 200_001)
    f = eff.transmitted_fraction(a, b, mu)
    assert a[np.argmax(f)] == pytest.approx(eff.best_impulse_angle(b, mu), abs=2e-5)
    assert f.max() == pytest.approx(eff.max_fraction(b, mu), rel=1e-9)


def test_maximum_falls_as_fe_fp_grows():
    # the text's second chart: a wider FeFp angle lowers the best achievable fraction
    best = [eff.max_fraction(deg(b)) for b in (30, 60, 90, 120)]
    assert np.all(np.diff(best) < 0)
    assert best[2] == pytest.approx(math.cos(deg(45)) ** 2)


def test_one_of_six_degrees_lost_to_drop():
    assert round(eff.drop_work_index(0.5, 6.0, 1.0), 3) == 0.417
    assert eff.drop_work_index(0.5, 6.0, 0.0) == 0.5
    with pytest.raises(SceneError, match=r"drop_angle = 6\.0, impulse_angle = 6\.0"):
        eff.drop_work_index(0.5, 6.0, 6.0)
    with pytest.raises(SceneError, match=r"drop_angle = -1\.0"):
        eff.drop_work_index(0.5, 6.0, -1.0)


def test_brocot_work_index_is_pi_over_8():
    assert round(eff.brocot_work_index(parts=10_000), 4) == 0.3927
    assert eff.brocot_work_index(method="quad") == pytest.approx(math.pi / 8, rel=1e-9)
    # the text: 50 parts are "accurate to 2 decimal places"
    assert round(eff.brocot_work_index(parts=50), 2) == 0.39
    assert abs(eff.brocot_work_index(parts=50) - math.pi / 8) > abs(eff.brocot_work_index() - math.pi / 8)


def test_brocot_curve_is_the_thales_semicircle():
    t = np.linspace(0, 1, 101)
    assert np.allclose(eff.brocot_fraction(t), np.sqrt(t * (1 - t)), atol=1e-12)
    assert eff.brocot_fraction(0.5) == pytest.approx(0.5)


def test_simpson_needs_even_parts():
    with pytest.raises(SolverError, match=r"even number of parts .*parts = 7"):
        eff.work_index(lambda t: t, parts=7)
    with pytest.raises(SolverError, match="method = 'trapezoid'"):
        eff.work_index(lambda t: t, method="trapezoid")
    assert eff.work_index(lambda t: t**3, parts=2) == pytest.approx(0.25, abs=1e-15)  # exact for cubics


def test_friction_angle_lowers_the_graham_fraction():
    f0 = eff.transmitted_fraction(deg(65), deg(90))
    f1 = eff.transmitted_fraction(deg(65), deg(90), mu=0.1)
    # cos65 * cos(25 deg + atan 0.1) / cos(atan 0.1)
    rho = math.atan(0.1)
    assert f1 == pytest.approx(math.cos(deg(65)) * math.cos(deg(25) + rho) / math.cos(rho), rel=1e-14)
    assert round(f1, 3) == 0.365 and f1 < f0
    # the same as adding the friction force mu*N along the face, against the pallet's motion
    n = math.cos(deg(65))
    assert f1 == pytest.approx(n * (math.cos(deg(25)) - 0.1 * math.sin(deg(25))), rel=1e-14)


def test_friction_locks_a_steep_face():
    # b - a + rho >= 90 deg: the normal force cannot move the pallet
    assert eff.transmitted_fraction(deg(2), deg(90), mu=0.1) == 0.0
    assert eff.brocot_fraction(0.0, mu=0.1) == 0.0
    assert eff.brocot_work_index(mu=0.1) < eff.brocot_work_index()
    assert eff.brocot_work_index(mu=0.1) == pytest.approx(eff.brocot_work_index(mu=0.1, method="quad"), rel=1e-5)


def test_contact_work_efficiency_by_virtual_work():
    """Energy balance of a sliding contact, checked from kinematics and statics separately."""
    a, b, mu = deg(65), deg(90), 0.1
    # plane coordinates: face normal n along x, tangent t along y
    n, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    e = np.array([math.cos(a), -math.sin(a)])          # tooth direction, angle a from n
    p = np.array([math.cos(b - a), math.sin(b - a)])   # pallet direction, angle b - a from n
    ve = 1.0
    vp = ve * (e @ n) / (p @ n)                        # equal normal velocities
    slip = ve * e - vp * p                             # tooth relative to the face
    assert abs(slip @ n) < 1e-15
    s_dir = slip / np.linalg.norm(slip)
    # contact force on the pallet: normal plus friction along the slip; wheel supplies Fe along e
    force_per_n = n + mu * s_dir
    normal = 1.0 / (force_per_n @ e)                   # scale so the force along e is Fe = 1
    work_in = 1.0 * ve
    work_out = normal * (force_per_n @ p) * vp
    dissipated = mu * normal * np.linalg.norm(slip)
    assert work_in == pytest.approx(work_out + dissipated, rel=1e-12)
    assert eff.contact_work_efficiency(a, b, mu) == pytest.approx(work_out / work_in, rel=1e-12)
    assert eff.contact_work_efficiency(a, b, 0.0) == pytest.approx(1.0, rel=1e-14)


def test_negative_friction_refused():
    with pytest.raises(SceneError, match=r"mu = -0\.1"):
        eff.transmitted_fraction(deg(45), deg(90), mu=-0.1)
    with pytest.raises(SceneError, match="mu = nan"):
        eff.friction_angle(float("nan"))


@pytest.mark.parametrize("mu", [0.05, 0.1, 0.3])
def test_contact_efficiency_at_45_degrees(mu):
    # tan(45 deg - rho) = (1 - mu) / (1 + mu)
    assert eff.contact_work_efficiency(deg(45), deg(90), mu) == pytest.approx((1 - mu) / (1 + mu), rel=1e-12)
