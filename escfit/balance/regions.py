"""Regions of a half swing in which the piecewise-linear torques are constant.

A half swing moving in direction ``s`` (+1 when theta increases) is described in the swing
frame ``x = s*theta``, in which the balance always runs from ``x = -A`` towards ``+A``.  Its
switch points -- escapement window edges, hairspring break angles and the banking angle -- cut
it into regions; inside region ``j`` the piecewise-linear part of the swing-frame acceleration
is ``-w2 * (x - xc)``: ``w2`` the stiffness of the hairspring piece there (1/s^2) and ``w2*xc``
(rad/s^2) gathers sliding Coulomb friction (``-R``), the windows acting there (an unlock window
``-X``, an impulse window ``+X``) and the hairspring piece's offset.  Every solver walks the same
regions (:func:`region_tables`, computed once per run from the coefficient record ``k``); the
exact solver solves each in closed form, the integrating solvers add the smooth torques of
:mod:`escfit.balance.acceleration`.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.kernels import kernel

__all__ = ["region_tables", "swing_edges", "region_at", "applies"]


@kernel(inline="always")
def applies(wdir, s):
    """Whether a window acting on swings ``wdir`` (0 both, +1 positive, -1 negative) acts in direction ``s``."""
    return wdir == 0 or wdir == s


@kernel
def _region_coefficients(j, s, edges, n_edges, k):
    """``(w2, xc)`` of region ``j``: between edges ``j-1`` and ``j`` of a swing in direction ``s``."""
    if j == 0:
        mid = edges[0] - 1.0 if n_edges > 0 else 0.0
    elif j == n_edges:
        mid = edges[n_edges - 1] + 1.0
    else:
        mid = 0.5 * (edges[j - 1] + edges[j])
    force = -k.r
    for i in range(k.n_windows):
        if applies(k.w_dir[i], s) and k.w_lo[i] <= mid < k.w_hi[i]:
            force += k.w_x[i]
    theta_mid = s * mid
    n_bp = k.n_pieces - 1
    i = 0
    while i < n_bp and k.sp_bp[i] <= theta_mid:
        i += 1
    w2 = k.sp_w2[i]
    xc = (force - s * k.sp_off[i]) / w2
    return w2, xc


@kernel
def swing_edges(s, k, edges):
    """Sorted distinct switch points of a swing in direction ``s`` (swing frame), banking last.

    Fills ``edges`` (length at least :func:`max_edges`) and returns how many there are.
    """
    bank = k.bank
    n = 0
    for i in range(k.n_windows):
        if applies(k.w_dir[i], s):
            edges[n] = k.w_lo[i]
            edges[n + 1] = k.w_hi[i]
            n += 2
    for i in range(k.n_pieces - 1):
        edges[n] = s * k.sp_bp[i]
        n += 1
    for i in range(1, n):  # insertion sort: a handful of values, no allocation
        v = edges[i]
        m = i - 1
        while m >= 0 and edges[m] > v:
            edges[m + 1] = edges[m]
            m -= 1
        edges[m + 1] = v
    m = 0
    for i in range(n):
        v = edges[i]
        if v < bank and (m == 0 or v > edges[m - 1]):
            edges[m] = v
            m += 1
    if math.isfinite(bank):
        edges[m] = bank
        m += 1
    return m


@kernel(inline="always")
def max_edges(k):
    """Most switch points a swing of record ``k`` can have."""
    return 2 * k.n_windows + k.n_pieces


@kernel
def region_at(x, s, edges, n_edges, k):
    """Index of the next edge above ``x`` and the coefficients ``(w2, xc)`` of the region holding ``x``."""
    j = 0
    while j < n_edges and edges[j] <= x:
        j += 1
    w2, xc = _region_coefficients(j, s, edges, n_edges, k)
    return j, w2, xc


@kernel
def region_tables(k):
    """Switch points and region coefficients of both swing directions (row 0: s = +1, row 1: s = -1).

    They are fixed for a run, so solvers tabulate them once.  Returns ``(edges, n_edges, w2, xc)``:
    the edges of each direction in order, how many, and each region's stiffness (1/s^2) and centre
    (rad, swing frame).
    """
    n_max = max_edges(k)
    edge_tab = np.empty((2, n_max))
    n_edge_tab = np.zeros(2, np.int64)
    w2_tab = np.empty((2, n_max + 1))
    xc_tab = np.empty((2, n_max + 1))
    for d in range(2):
        sd = 1.0 if d == 0 else -1.0
        n_edge_tab[d] = swing_edges(sd, k, edge_tab[d])
        for j in range(n_edge_tab[d] + 1):
            w2_tab[d, j], xc_tab[d, j] = _region_coefficients(j, sd, edge_tab[d], n_edge_tab[d], k)
    return edge_tab, n_edge_tab, w2_tab, xc_tab
