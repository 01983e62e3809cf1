"""The floor's rows as complementarity candidates beside the hinges' (``core.unilateral``):
the impact and the acceleration-level LCP of a planar chain whose points the floor may push
and never pulls, against an independent derivation.

The truth: Lagrange's equations in generalised coordinates q = (x_N, z_N, theta_0..theta_{N-1})
(the bottom end's position and the segments' angles from the vertical), the mass matrix
from the centres' Jacobians, the contacts as rows A of the points' heights and the hinges'
bends, and the LCP solved by trying every active set (numpy, dense): at the velocity level
v+ = v- + M^-1 A^T P, P >= 0, A v+ >= target, complementary; at the acceleration level
M q'' = Q - (the velocity products) + A^T lambda, lambda >= 0, A q'' + A' q' >= 0,
complementary.  Units m = b = g = 1 (segments of length 2, moment of inertia 1/3).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from ballchain.core.impacts import hinge_rates, new_impact_work
from ballchain.core.rules import SLIDING
from ballchain.core.state import new_work
from ballchain.core.unilateral import (
    dense_impact_set,
    dense_lock_set,
    floor_impact,
    floor_lock_set,
    floor_velocity_impact,
    new_floor_work,
)

I_C = 1.0 / 3.0


def _jacobians(theta):
    """Each centre's Jacobian (2 x (N + 2): x and z), each point's height row, and the
    products J' q' need (the centres' and points' accelerations at q'' = 0 per unit rate^2)."""
    n = len(theta)
    s, c = np.sin(theta), np.cos(theta)
    jc = np.zeros((n, 2, n + 2))
    for i in range(n):
        jc[i, 0, 0] = 1.0
        jc[i, 1, 1] = 1.0
        for k in range(i, n):
            f = 1.0 if k == i else 2.0
            jc[i, 0, 2 + k] = f * c[k]
            jc[i, 1, 2 + k] = -f * s[k]
    jz = np.zeros((n + 1, n + 2))
    for j in range(n + 1):
        jz[j, 1] = 1.0
        for k in range(j, n):
            jz[j, 2 + k] = -2.0 * s[k]
    return jc, jz


def _mass(theta):
    n = len(theta)
    jc, _ = _jacobians(theta)
    M = sum(jc[i].T @ jc[i] for i in range(n))
    for i in range(n):
        M[2 + i, 2 + i] += I_C
    return M


def _bend_row(theta, k):
    """d/dq of g_k = cos(theta_k - theta_{k+1}) - cos(alpha)."""
    row = np.zeros(len(theta) + 2)
    d = -math.sin(theta[k] - theta[k + 1])
    row[2 + k], row[3 + k] = d, -d
    return row


def _solve_lcp(M, A, q0):
    """The LCP z >= 0, w = M z + q0 >= 0, z . w = 0 (M = A M^-1 A^T) by trying every active
    set; returns z (the unique solution: M is positive definite here)."""
    m = len(q0)
    found = []
    for mask in itertools.product([0, 1], repeat=m):
        act = [i for i in range(m) if mask[i]]
        z = np.zeros(m)
        if act:
            z[act] = np.linalg.solve(M[np.ix_(act, act)], -q0[act])
        w = M @ z + q0
        scale = 1.0 + np.abs(q0).max()
        if (z >= -1e-12 * scale).all() and (w >= -1e-12 * scale).all():
            found.append(z)
    assert len(found) >= 1
    for z in found[1:]:
        np.testing.assert_allclose(z, found[0], atol=1e-10)
    return found[0]


def _turn(phi):
    """The rotation by phi about the vertical: the floor's physics does not see it."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _core_state(theta, rate, phi=0.0):
    """The planar chain in the x-z plane, turned by phi about the vertical (3D: every
    component of the axes and rates in play)."""
    e = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=1)
    w = np.stack([np.zeros_like(rate), rate, np.zeros_like(rate)], axis=1)
    R = _turn(phi)
    return np.ascontiguousarray(e @ R.T), np.ascontiguousarray(w @ R.T)


def _chain(seed, n, bends):
    """A planar chain's angles with the hinges ``bends`` at their limit alpha (bending
    either way), its rates and its bottom end's velocity, from a seed."""
    rng = np.random.default_rng(seed)
    alpha = math.pi / 4
    theta = np.empty(n)
    theta[0] = rng.uniform(-2.0, 2.0)
    for k in range(n - 1):
        theta[k + 1] = theta[k] + (alpha * rng.choice([-1.0, 1.0]) if k in bends else rng.uniform(-0.7, 0.7))
    rate = rng.normal(size=n)
    base = rng.normal(size=2)
    base[1] = -abs(base[1]) - 0.5  # (the bottom end comes down: contacts approach)
    return theta, rate, base, alpha


CASES = [  # (seed, N, the points the floor may hold, the hinges at their limit)
    (2, 5, [5, 3, 0], [1]),
    (2, 6, [6, 4, 2, 1], [0, 3]),
    (2, 4, [4, 3, 2, 1, 0], []),
    (4, 6, [6, 5, 0], [1, 2, 4]),
    (5, 3, [3, 0], [0, 1]),
]


def _from_dense_set(fw, active, anchored):
    """The dense problem's solution set (fw.active) as the pivoting's initial guess."""
    nh = active.shape[0]
    active[:] = fw.active[:nh]
    anchored[:] = np.where(fw.active[nh:] != 0, SLIDING, 0)


@pytest.mark.parametrize("seed, n, points, hinges", CASES)
@pytest.mark.parametrize("restitution, phi", [(0.0, 0.0), (0.5, 0.0), (0.5, 2.2)])
@pytest.mark.parametrize("dense", [False, True], ids=["pivoting", "dense"])
def test_an_impact_with_a_floor_that_never_pulls_is_the_lcp_of_lagranges_equations(
    seed, n, points, hinges, restitution, phi, dense
):
    """Pivoting, or the dense problem (its fallback where pivoting cycles: its solution set
    then taken by the pivoting at its first trial, nothing left to change)."""
    theta, rate, base, alpha = _chain(seed, n, hinges)
    M = _mass(theta)
    jc, jz = _jacobians(theta)
    q1 = np.concatenate([base, rate])
    A = np.array([jz[j] for j in points] + [_bend_row(theta, k) for k in hinges])
    before = A @ q1
    target = np.array([restitution * max(-v, 0.0) for v in before[: len(points)]] + [0.0] * len(hinges))
    Minv = np.linalg.inv(M)
    P = _solve_lcp(A @ Minv @ A.T, A, before - target)
    q2 = q1 + Minv @ A.T @ P
    assert P.max() > 0.0 and (P == 0.0).any()  # (a real choice: some contacts act, some do not)

    R = _turn(phi)
    e, w = _core_state(theta, rate, phi)
    ws, iw, fw = new_work(n), new_impact_work(n), new_floor_work(n)
    iw.dv[:] = R @ [base[0], 0.0, base[1]]  # (the bottom end's velocity: point N is not at rest)
    for j, v in zip(points, before[: len(points)]):
        iw.rebound[j] = restitution * max(-v, 0.0)
    anchored = np.zeros(n + 1, np.uint8)
    fcand = np.zeros(n + 1, np.uint8)
    fcand[points] = SLIDING
    cand, forced, active = (np.zeros(max(n - 1, 0), np.uint8) for _ in range(3))
    cand[hinges] = 1
    if dense:
        assert dense_impact_set(e, w, anchored, cand, forced, active, fcand, 0.0, ws, iw, fw) >= 0
        _from_dense_set(fw, active, anchored)
    trials = floor_impact(e, w, anchored, cand, forced, active, fcand, 0.0, ws, iw, fw)
    assert trials == 0 if dense else trials >= 0
    w = w @ R  # (turned back into the x-z plane)
    np.testing.assert_allclose(w, np.stack([0.0 * q2[2:], q2[2:], 0.0 * q2[2:]], axis=1), atol=1e-10)
    np.testing.assert_allclose(fw.vz[points], (A @ q2)[: len(points)], atol=1e-10)
    np.testing.assert_allclose(fw.pz[points], P[: len(points)], atol=1e-10)
    held = [j for j, p in zip(points, P) if p > 1e-9]
    assert [j for j in range(n + 1) if anchored[j]] == sorted(held)
    assert all(anchored[j] == SLIDING for j in held)
    assert [k for k in range(n - 1) if active[k]] == [k for k, p in zip(hinges, P[len(points) :]) if p > 1e-9]
    # frictionless: the centres' horizontal momentum kept; and every centre's velocity as Lagrange's
    vc = np.array([jc[i] @ q2 for i in range(n)])
    np.testing.assert_allclose((fw.vc @ R)[:, [0, 2]], vc, atol=1e-10)
    np.testing.assert_allclose((fw.vc @ R)[:, 1], 0.0, atol=1e-10)
    assert vc[:, 0].sum() == pytest.approx(sum(jc[i][0] @ q1 for i in range(n)), abs=1e-10)


def _velocity_products(theta, rate):
    """The centres' accelerations and the points' height accelerations at q'' = 0."""
    n = len(theta)
    s, c = np.sin(theta), np.cos(theta)
    ac = np.zeros((n, 2))
    for i in range(n):
        for k in range(i, n):
            f = 1.0 if k == i else 2.0
            ac[i] += f * np.array([-s[k], -c[k]]) * rate[k] ** 2
    az = np.array([sum(-2.0 * c[k] * rate[k] ** 2 for k in range(j, n)) for j in range(n + 1)])
    return ac, az


@pytest.mark.parametrize("seed, n, points, hinges", CASES)
@pytest.mark.parametrize("dense", [False, True], ids=["pivoting", "dense"])
def test_which_points_the_floor_holds_is_the_acceleration_lcp_of_lagranges_equations(seed, n, points, hinges, dense):
    theta, rate, _, alpha = _chain(seed, n, hinges)
    for k in hinges:  # (a hinge at its limit and at rest there: the same rate on both sides)
        rate[k + 1] = rate[k]
    rate *= 0.5
    M = _mass(theta)
    jc, jz = _jacobians(theta)
    ac, az = _velocity_products(theta, rate)
    Q = sum(jc[i].T @ (np.array([0.0, -1.0]) - ac[i]) for i in range(n))
    A = np.array([jz[j] for j in points] + [_bend_row(theta, k) for k in hinges])
    # the rows' accelerations at q'' = 0: the heights' products, and a bend's,
    # d2/dt2 cos(theta_k - theta_{k+1}) = -cos(d) d'^2 - sin(d) d'' (d' = 0 at rest on the limit)
    a0 = np.concatenate([az[points], np.zeros(len(hinges))])
    Minv = np.linalg.inv(M)
    lam = _solve_lcp(A @ Minv @ A.T, A, A @ Minv @ Q + a0)
    qdd = Minv @ (Q + A.T @ lam)

    e, w = _core_state(theta, rate)
    ws, fw = new_work(n), new_floor_work(n)
    de, dw = np.zeros((n, 3)), np.zeros((n, 3))
    ddg, lm = np.zeros(max(n - 1, 0)), np.zeros(max(n - 1, 0))
    anchored = np.zeros(n + 1, np.uint8)
    fcand = np.zeros(n + 1, np.uint8)
    fcand[points] = SLIDING
    cand, active = np.zeros(max(n - 1, 0), np.uint8), np.zeros(max(n - 1, 0), np.uint8)
    cand[hinges] = 1
    if dense:
        assert dense_lock_set(e, w, anchored, cand, active, fcand, ws, de, dw, ddg, 1e-10, fw) >= 0
        _from_dense_set(fw, active, anchored)
    trials = floor_lock_set(e, w, anchored, cand, active, fcand, ws, de, dw, ddg, lm, fw)
    assert trials == 0 if dense else trials >= 0
    np.testing.assert_allclose(dw[:, 1], qdd[2:], atol=1e-9)
    np.testing.assert_allclose(fw.pz[points], lam[: len(points)], atol=1e-9)
    np.testing.assert_allclose(fw.vz[points], (A @ qdd + a0)[: len(points)], atol=1e-9)
    held = [j for j, p in zip(points, lam) if p > 1e-9]
    assert [j for j in range(n + 1) if anchored[j]] == sorted(held)
    assert [k for k in range(n - 1) if active[k]] == [k for k, p in zip(hinges, lam[len(points) :]) if p > 1e-9]
    ca = np.array([jc[i] @ qdd + ac[i] for i in range(n)])
    np.testing.assert_allclose(fw.vc[:, [0, 2]], ca, atol=1e-9)


@pytest.mark.parametrize("seed, n, points, hinges", CASES)
@pytest.mark.parametrize("phi", [0.0, 2.2])
def test_newtons_law_at_the_limits_beside_the_floor_is_the_lcp_of_lagranges_equations(seed, n, points, hinges, phi):
    """``floor_velocity_impact`` with e_lock = 0.5: each candidate hinge's rate after the
    impact at least -e times its rate before, equal where its impulse acts (Newton's law,
    ``contacts.newton.law_rate``), the floor's rows inelastic, in one LCP.  Where no hinge
    comes out closing (a second pass would stop it: not this truth), every rate, impulse
    and held set is Lagrange's; and the impact never creates energy."""
    e_lock = 0.5
    theta, rate, base, alpha = _chain(seed, n, hinges)
    M = _mass(theta)
    jc, jz = _jacobians(theta)
    q1 = np.concatenate([base, rate])
    A = np.array([jz[j] for j in points] + [_bend_row(theta, k) for k in hinges])
    before = A @ q1
    target = np.concatenate([np.zeros(len(points)), -e_lock * before[len(points) :]])
    Minv = np.linalg.inv(M)
    P = _solve_lcp(A @ Minv @ A.T, A, before - target)
    q2 = q1 + Minv @ A.T @ P
    closing = bool(((A @ q2)[len(points) :] < -1e-9).any())

    R = _turn(phi)
    e, w = _core_state(theta, rate, phi)
    ws, iw, fw = new_work(n), new_impact_work(n), new_floor_work(n)
    iw.dv[:] = R @ [base[0], 0.0, base[1]]
    hinge_rates(e, w, iw.rates_before)
    anchored = np.zeros(n + 1, np.uint8)
    fcand = np.zeros(n + 1, np.uint8)
    fcand[points] = SLIDING
    cand, forced, active = (np.zeros(max(n - 1, 0), np.uint8) for _ in range(3))
    cand[hinges] = 1
    T0 = 0.5 * q1 @ M @ q1
    assert floor_velocity_impact(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw) >= 0
    assert iw.split[0] + iw.split[1] >= -1e-12 * T0  # (never creates energy)
    if closing:
        return
    w = w @ R
    np.testing.assert_allclose(w[:, 1], q2[2:], atol=1e-10)
    np.testing.assert_allclose(fw.vz[points], (A @ q2)[: len(points)], atol=1e-10)
    np.testing.assert_allclose(fw.pz[points], P[: len(points)], atol=1e-10)
    assert [j for j in range(n + 1) if anchored[j]] == sorted(j for j, p in zip(points, P) if p > 1e-9)
    assert [k for k in range(n - 1) if active[k]] == [k for k, p in zip(hinges, P[len(points) :]) if p > 1e-9]
    assert abs((iw.split[0] + iw.split[1]) - (T0 - 0.5 * q2 @ M @ q2)) < 1e-10 * max(T0, 1.0)


def test_some_of_newtons_cases_have_no_closing_hinge():
    """(The test above compares with Lagrange where no hinge comes out closing: most cases.)"""
    open_cases = 0
    for seed, n, points, hinges in CASES:
        theta, rate, base, _ = _chain(seed, n, hinges)
        M, (_, jz) = _mass(theta), _jacobians(theta)
        q1 = np.concatenate([base, rate])
        A = np.array([jz[j] for j in points] + [_bend_row(theta, k) for k in hinges])
        before = A @ q1
        target = np.concatenate([np.zeros(len(points)), -0.5 * before[len(points) :]])
        Minv = np.linalg.inv(M)
        q2 = q1 + Minv @ A.T @ _solve_lcp(A @ Minv @ A.T, A, before - target)
        open_cases += not ((A @ q2)[len(points) :] < -1e-9).any()
    assert open_cases >= 3
