"""Multistart points: the Latin hypercube's strata, and the same points as scipy's generator."""

import numpy as np
import pytest

from escfit.inference.starts import latin_hypercube, multistart_points


@pytest.mark.parametrize("n,d", [(1, 1), (7, 4), (15, 9), (40, 2)])
def test_one_point_per_stratum(n, d):
    u = latin_hypercube(n, d, seed=3)
    assert u.shape == (n, d)
    assert np.all((u >= 0) & (u < 1))
    for axis in range(d):
        assert sorted(np.floor(u[:, axis] * n).astype(int)) == list(range(n))


@pytest.mark.parametrize("seed", [0, 1, 2**32 - 1])
def test_same_points_as_scipy(seed):
    # scipy's scrambled Latin hypercube is the reference the fits used before
    qmc = pytest.importorskip("scipy.stats.qmc")
    np.testing.assert_allclose(latin_hypercube(7, 5, seed), qmc.LatinHypercube(d=5, seed=seed).random(7),
                               rtol=0, atol=1e-15)


def test_points_span_the_bounds():
    class Flat:
        kind = "uniform"

    x0 = np.array([1.0, 2.0])
    pts = multistart_points([Flat(), Flat()], x0, np.array([0.0, -np.inf]), np.array([4.0, np.inf]), 9, seed=0)
    assert len(pts) == 9 and np.array_equal(pts[0], x0)
    rest = np.array(pts[1:])
    assert np.all((rest[:, 0] >= 0) & (rest[:, 0] < 4))
    assert np.all((rest[:, 1] >= 1.0 - 1e-12) & (rest[:, 1] < 3.0 + 1e-12))  # x0 +- 50 % where unbounded
