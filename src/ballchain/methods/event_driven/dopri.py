"""Dormand-Prince 5(4) over the chain's equations of motion (numba, nondimensional):
the tableau, one step's stages and its error, the dense output, and the state at an
event instant (a quintic through the step's ends and two interior nodes, Hermite-Birkhoff),
with the floor's impulse over a step or part of one.  ``integrator`` drives the steps;
``locate`` finds the events on the dense output."""

from __future__ import annotations

import math
from fractions import Fraction as Fr

import numpy as np

from ...core.dynamics import accelerations, anchor_force_total
from ...jit import njit

# Dormand-Prince 5(4) (Hairer's DOPRI5; the coefficients of scipy's RK45)
C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
A = np.array(
    [
        [0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    ]
)
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
P = np.array(
    [
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ]
)


def _hermite_birkhoff_inverse(sa, sb):
    """Exact inverse of the 4 x 4 system for the coefficients a_2..a_5 of the quintic
    p(s) = y0 + s h f0 + sum_m a_m s^m with p(1) = y1, p'(1) = h f1, p'(sa) = h fa,
    p'(sb) = h fb (rows in that order)."""
    m = [
        [Fr(1)] * 4,
        [Fr(2), Fr(3), Fr(4), Fr(5)],
        [2 * sa, 3 * sa**2, 4 * sa**3, 5 * sa**4],
        [2 * sb, 3 * sb**2, 4 * sb**3, 5 * sb**4],
    ]
    inv = [[Fr(int(i == j)) for j in range(4)] for i in range(4)]
    for col in range(4):  # Gauss-Jordan in exact rationals
        piv = next(r for r in range(col, 4) if m[r][col] != 0)
        m[col], m[piv] = m[piv], m[col]
        inv[col], inv[piv] = inv[piv], inv[col]
        d = m[col][col]
        m[col] = [v / d for v in m[col]]
        inv[col] = [v / d for v in inv[col]]
        for r in range(4):
            if r != col and m[r][col] != 0:
                fac = m[r][col]
                m[r] = [a - fac * b for a, b in zip(m[r], m[col])]
                inv[r] = [a - fac * b for a, b in zip(inv[r], inv[col])]
    return np.array([[float(v) for v in row] for row in inv])


# the state at an event: a quintic through the step's ends and f at the 4th-order dense
# output at these nodes (``event_state``)
HB_NODES = np.array([1 / 3, 2 / 3])
HB_MINV = _hermite_birkhoff_inverse(Fr(1, 3), Fr(2, 3))


@njit(cache=True, _nrt=False)
def chain_rhs(Y, anchored, locked, ws, dY):
    return accelerations(Y[0], Y[1], anchored, locked, ws, dY[0], dY[1])


@njit(cache=True, inline="always")
def dense_weights(h, theta, b):
    """b_s = h sum_p P[s, p] theta^(p+1): y(t0 + theta h) = y0 + sum_s b_s K_s."""
    for s in range(7):
        acc = 0.0
        tp = theta
        for p in range(4):
            acc += P[s, p] * tp
            tp *= theta
        b[s] = acc * h


@njit(cache=True, _nrt=True)
def dense_state(Y0, K, h, theta, out):
    """Continuous extension of the step (4th order) at t0 + theta h, whole state."""
    b = np.empty(7)
    dense_weights(h, theta, b)
    n = Y0.shape[1]
    for a in range(2):
        for i in range(n):
            for q in range(3):
                v = Y0[a, i, q]
                for s in range(7):
                    v += b[s] * K[s, a, i, q]
                out[a, i, q] = v


@njit(cache=True, inline="always")
def dense_e(Y0, K, b, i, q):
    """One component e[i, q] of the dense output, weights b from dense_weights."""
    v = Y0[0, i, q]
    for s in range(7):
        v += b[s] * K[s, 0, i, q]
    return v


@njit(cache=True, _nrt=False)
def stage_rhs(Y, anchored, locked, ws, dY, F):
    """dY = f(Y); F[0:3] = the anchors' total force on the chain at Y, F[3] = the power
    the smooth laws remove there (``core.forces``: both integrated as extra states)."""
    chain_rhs(Y, anchored, locked, ws, dY)
    anchor_force_total(ws.kind, ws.nrow, ws.x, F)
    F[3] = ws.power[0]


@njit(cache=True, _nrt=False)
def rk_stages(Y, h, sg, anchored, locked, ws):
    """Stages 2..7 of a Dormand-Prince step of size h from Y (sg.K[0] = f(Y), sg.F[0]
    given); sg.Y1 = the 5th-order solution, sg.K[6] = f(Y1); sg.F[s] the anchors' force
    at stage s."""
    K, Ytmp, Y1, F = sg.K, sg.Ytmp, sg.Y1, sg.F
    n = Y.shape[1]
    for s in range(1, 7):
        for a in range(2):
            for i in range(n):
                for q in range(3):
                    v = Y[a, i, q]
                    if s < 6:
                        for r in range(s):
                            v += h * A[s, r] * K[r, a, i, q]
                    else:
                        for r in range(6):
                            v += h * B[r] * K[r, a, i, q]
                    Ytmp[a, i, q] = v
        if s < 6:
            stage_rhs(Ytmp, anchored, locked, ws, K[s], F[s])
        else:
            for a in range(2):
                for i in range(n):
                    for q in range(3):
                        Y1[a, i, q] = Ytmp[a, i, q]
            stage_rhs(Y1, anchored, locked, ws, K[6], F[6])


@njit(cache=True, _nrt=False)
def event_state(Y, sg, hb, h, theta, anchored, locked, ws, n_landed, fint, lost):
    """Y <- the state at t0 + theta h of the step from Y (stages sg.K, sg.F; sg.Y1 its
    5th-order end, K[6] = f(Y1)), fint (the floor's impulse) and lost (the smooth laws'
    loss) advanced to that time.  The quintic p(s), s in
    [0, 1], with p(0) = y0, p'(0) = h f0, p(1) = y1, p'(1) = h f(y1) and p'(s_r) = h
    f(y(s_r)) at the nodes s_r = 1/3, 2/3, y(s_r) from the 4th-order continuous
    extension: two evaluations (K2[1:3], F2[1:3]), against five for a new step to
    t0 + theta h, and a local error of the step's own order, O(h^6) (the data's errors
    enter times h), a few times the full step's (tests/test_event_state.py).
    With c = M^-T (theta^2 .. theta^5) (``HB_MINV``):
      p(theta) = y0 + theta h f0 + c0 (y1 - y0 - h f0) + c1 h (f1 - f0)
                 + c2 h (f(y(1/3)) - f0) + c3 h (f(y(2/3)) - f0).
    The floor's impulse and the smooth laws' loss, the integrals of F (extra states
    J' = F[0:3], L' = F[3]), the same way."""
    K, K2, F, F2, Y1, Ytmp = sg.K, hb.K2, sg.F, hb.F2, sg.Y1, sg.Ytmp
    n = Y.shape[1]
    for r in range(2):
        dense_state(Y, K, h, HB_NODES[r], Ytmp)
        stage_rhs(Ytmp, anchored, locked, ws, K2[1 + r], F2[1 + r])
    c0 = c1 = c2 = c3 = 0.0
    tp = theta * theta
    for m in range(4):
        c0 += HB_MINV[m, 0] * tp
        c1 += HB_MINV[m, 1] * tp
        c2 += HB_MINV[m, 2] * tp
        c3 += HB_MINV[m, 3] * tp
        tp *= theta
    for a in range(2):
        for i in range(n):
            for q in range(3):
                y0 = Y[a, i, q]
                k0 = h * K[0, a, i, q]
                Y[a, i, q] = (
                    y0
                    + theta * k0
                    + c0 * (Y1[a, i, q] - y0 - k0)
                    + c1 * (h * K[6, a, i, q] - k0)
                    + c2 * (h * K2[1, a, i, q] - k0)
                    + c3 * (h * K2[2, a, i, q] - k0)
                )
    for q in range(4):
        acc = 0.0
        for s in range(6):
            acc += B[s] * F[s, q]
        k0 = h * F[0, q]
        part = (
            theta * k0
            + c0 * (h * acc - k0)
            + c1 * (h * F[6, q] - k0)
            + c2 * (h * F2[1, q] - k0)
            + c3 * (h * F2[2, q] - k0)
        )
        if q < 3:
            fint[q] += part
        else:
            lost[0] += part
    fint[2] += theta * h * n_landed


@njit(cache=True, _nrt=False)
def floor_impulse_step(h, F, n_landed, out):
    """out += int_0^h (F(t) + n_landed m g e_z) dt by the step's own quadrature,
    h sum_s b_s F_s (the weights of the 5th-order solution): the floor's continuous
    impulse on the airborne chain plus its support of the landed segments (at rest)."""
    for q in range(3):
        acc = 0.0
        for s in range(6):
            acc += B[s] * F[s, q]
        out[q] += h * acc
    out[2] += h * n_landed


@njit(cache=True, _nrt=False)
def smooth_loss_step(h, F, lost):
    """lost += int_0^h F[3] dt, the power the smooth laws remove, by the step's own
    quadrature (as ``floor_impulse_step``)."""
    acc = 0.0
    for s in range(6):
        acc += B[s] * F[s, 3]
    lost[0] += h * acc


@njit(cache=True, _nrt=True)
def floor_impulse_dense(h, theta, F, n_landed, out):
    """out[0:3] = int_0^(theta h) (F + n_landed m g e_z) dt and out[3] the smooth laws'
    loss over the same time, from the continuous extension (the quadrature dense output
    gives for an extra state dJ/dt = F)."""
    b = np.empty(7)
    dense_weights(h, theta, b)
    for q in range(4):
        acc = 0.0
        for s in range(7):
            acc += b[s] * F[s, q]
        out[q] = acc
    out[2] += theta * h * n_landed


@njit(cache=True, _nrt=False)
def copy_state(dst, src):
    """dst[...] = src for (2, N, 3) states (an explicit loop: cheaper than a slice copy)."""
    for a in range(2):
        for i in range(src.shape[1]):
            for q in range(3):
                dst[a, i, q] = src[a, i, q]


@njit(cache=True, _nrt=False)
def nonfinite(Y):
    for a in range(2):
        for i in range(Y.shape[1]):
            for q in range(3):
                if not math.isfinite(Y[a, i, q]):
                    return True
    return False


@njit(cache=True, _nrt=False)
def dense_axes(Y0, K, b, out):
    """The axes e of the dense output (weights b from dense_weights) into out."""
    for i in range(Y0.shape[1]):
        for q in range(3):
            out[i, q] = dense_e(Y0, K, b, i, q)


@njit(cache=True, _nrt=False)
def step_error(Y, Y1, K, h, rtol, atol):
    """Largest component error of the step, in units of its tolerance (max norm)."""
    n = Y.shape[1]
    err = 0.0
    for a in range(2):
        for i in range(n):
            for q in range(3):
                ev = 0.0
                for s in range(7):
                    ev += E[s] * K[s, a, i, q]
                sc = atol + rtol * max(abs(Y[a, i, q]), abs(Y1[a, i, q]))
                r = abs(ev * h) / sc
                if r > err or not math.isfinite(r):
                    err = r
    return err
