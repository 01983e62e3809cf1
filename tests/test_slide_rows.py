"""The core's rows for a point sliding on a frictionless floor (``rules.SLIDING``: one height
row, ``rows.ROW_SLIDE_*``): the O(N) equations of motion against independent derivations.

* a rod on its sliding foot: thetaddot = 3 sin(theta) (1 - cos(theta) thetadot^2) /
  (1 + 3 sin^2 theta) and the floor's push N = 1 - sin(theta) thetaddot - cos(theta) thetadot^2
  (its centre falls on a vertical line), m = b = g = 1;
* a planar chain on its sliding bottom end, with a point in the middle also held at its
  height: Lagrange's equations in generalised coordinates (the bottom end's x and the
  segments' angles), the height row as a multiplier, solved densely by numpy;
* a chain in 3D on a sliding bottom end: nothing horizontal acts, so the centres'
  horizontal accelerations sum to zero.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballchain.core.dynamics import accelerations, anchor_force_total
from ballchain.core.rules import SLIDING
from ballchain.core.state import new_work

I_C = 1.0 / 3.0  # a segment's moment of inertia about its centre (m b^2; length 2 b)


def _accelerations(e, w, anchored):
    n = e.shape[0]
    ws = new_work(n)
    de, dw = np.zeros((n, 3)), np.zeros((n, 3))
    accelerations(e, w, anchored, np.zeros(max(n - 1, 0), np.uint8), ws, de, dw)
    force = np.zeros(3)
    anchor_force_total(ws.kind, ws.nrow, ws.x, force)
    return de, dw, ws, force


def _planar(theta, rate):
    """Axes e_i = (sin, 0, cos) theta_i and rates w_i = (0, thetadot_i, 0) (de/dt = w x e)."""
    theta, rate = np.asarray(theta, float), np.asarray(rate, float)
    e = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=1)
    w = np.stack([np.zeros_like(rate), rate, np.zeros_like(rate)], axis=1)
    return e, w


@pytest.mark.parametrize("theta, rate", [(0.3, 0.0), (0.9, 0.7), (1.4, -1.1), (0.05, 2.0)])
def test_a_rod_on_its_sliding_foot_turns_as_its_equation_says(theta, rate):
    e, w = _planar([theta], [rate])
    anchored = np.array([0, SLIDING], np.uint8)
    _, dw, _, force = _accelerations(e, w, anchored)
    s, c = math.sin(theta), math.cos(theta)
    acc = 3.0 * s * (1.0 - c * rate**2) / (1.0 + 3.0 * s * s)
    assert dw[0, 1] == pytest.approx(acc, rel=1e-12, abs=1e-13)
    assert force == pytest.approx([0.0, 0.0, 1.0 - s * acc - c * rate**2], abs=1e-12)


def _lagrange(theta, rate, held):
    """thetaddot of a planar chain whose bottom end (point N) slides on the floor, with the
    points in ``held`` kept at their height too: generalised coordinates q = (x_N,
    theta_0..theta_{N-1}), centres c_i = (x_N + sum_{k>i} 2 sin theta_k + sin theta_i,
    sum_{k>i} 2 cos theta_k + cos theta_i), M q'' = Q - sum_i J_i^T h_i + A^T lambda,
    A q'' = -a' (the held heights' accelerations), dense."""
    n = len(theta)
    s, c = np.sin(theta), np.cos(theta)
    M = np.zeros((n + 1, n + 1))
    rhs = np.zeros(n + 1)
    for i in range(n):
        jx, jz = np.zeros(n + 1), np.zeros(n + 1)
        jx[0] = 1.0
        hx = hz = 0.0
        for k in range(i, n):
            f = 1.0 if k == i else 2.0
            jx[1 + k] = f * c[k]
            jz[1 + k] = -f * s[k]
            hx -= f * s[k] * rate[k] ** 2
            hz -= f * c[k] * rate[k] ** 2
        M += np.outer(jx, jx) + np.outer(jz, jz)
        M[1 + i, 1 + i] += I_C
        rhs += -jz - jx * hx - jz * hz  # gravity (0, -1) and the velocity products
    A = np.zeros((len(held), n + 1))
    b = np.zeros(len(held))
    for r, j in enumerate(held):  # z_j = sum_{k>=j} 2 cos theta_k
        for k in range(j, n):
            A[r, 1 + k] = -2.0 * s[k]
            b[r] += 2.0 * c[k] * rate[k] ** 2  # -(d/dt A) q'
    m = len(held)
    kkt = np.block([[M, -A.T], [A, np.zeros((m, m))]])
    sol = np.linalg.solve(kkt, np.concatenate([rhs, b]))
    return sol[1 : n + 1]


@pytest.mark.parametrize("held", [[], [3], [2, 4]])
def test_a_planar_chain_on_a_sliding_end_follows_lagranges_equations(held):
    rng = np.random.default_rng(7)
    n = 6
    theta = rng.uniform(-1.2, 1.2, n)
    rate = rng.uniform(-1.0, 1.0, n)
    e, w = _planar(theta, rate)
    anchored = np.zeros(n + 1, np.uint8)
    anchored[n] = SLIDING
    anchored[held] = SLIDING
    _, dw, _, _ = _accelerations(e, w, anchored)
    np.testing.assert_allclose(dw[:, 1], _lagrange(theta, rate, held), rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(dw[:, [0, 2]], 0.0, atol=1e-12)


def test_nothing_horizontal_acts_on_a_chain_on_a_sliding_end():
    rng = np.random.default_rng(11)
    n = 9
    e = rng.normal(size=(n, 3))
    e /= np.linalg.norm(e, axis=1)[:, None]
    w = np.cross(e, rng.normal(size=(n, 3)))  # (perpendicular to the axes)
    anchored = np.zeros(n + 1, np.uint8)
    anchored[n] = SLIDING
    _, _, ws, force = _accelerations(e, w, anchored)
    assert abs(ws.gf[:, 0].sum()) < 1e-12 and abs(ws.gf[:, 1].sum()) < 1e-12  # the centres' horizontal forces
    assert force[0] == force[1] == 0.0
    assert ws.gf[:, 2].sum() == pytest.approx(force[2], abs=1e-12)  # the floor's push, the only vertical force
