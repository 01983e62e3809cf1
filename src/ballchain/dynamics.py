"""Equations of motion: O(N) hinge forces (DERIVATION.md section B), numba kernels.

Everything here is nondimensional: m = b = g = 1 (mass m, length b, time sqrt(b/g)).

Indexing (0-based, from the top):
  * segment ``i = 0..N-1`` has unit axis ``e[i]`` (lower end -> upper end), angular
    velocity ``w[i]`` (kept perpendicular to ``e[i]``);
  * point ``j = 0..N``: point ``j`` is the upper end of segment ``j`` and the lower end
    of segment ``j-1``; point 0 is the free top, point N the original pivot (origin);
  * hinge ``k = 0..N-2`` sits at point ``k+1`` between segments ``k`` and ``k+1``.
Status arrays (uint8): ``anchored[N+1]`` (point held by the floor; 2 while the impact
that makes the anchor is being solved), ``locked[N-1]``.
A segment is *landed* when both its end points are anchored; it is then frozen.

Each segment has six velocity coordinates (centre velocity v, angular velocity w) and
inverse mass W = diag(1, 1, 1, 3, 3, 3) (rods: m, m b^2/3), or W = 0 once landed.
Constraints are gathered per point j in up to 7 rows, each row acting on the segment
above the point (``a = j-1``, columns 0:6) and the one below (``c = j``, columns 6:12):

  kind 0  hinge (3 rows):      lower end of a - upper end of c = 0
  kind 1  anchor, lower (3):   lower end of a = 0          (point j anchored)
  kind 2  anchor, upper (3):   upper end of c = 0          (point j anchored)
  kind 3  lock (1 row):        d/dt (e_a . e_c) = w_a.(e_a x e_c) + w_c.(e_c x e_a) = 0

The velocity of the lower end of segment i is v_i + e_i x w_i, of its upper end
v_i - e_i x w_i.  The multipliers of the system (J W J^T) x = rhs are the forces
(kind 0-2: force on segment a from below, equal to minus the force on c from above) and
the lock multipliers lambda (couple lambda e_a x e_c on a).  J W J^T is block
tridiagonal (blocks of the points, coupled through the shared segment) and symmetric
positive (semi)definite: one block Cholesky (block Thomas) sweep costs O(N).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MAXR = 7  # rows per point at most: 3 + 3 + 1
ROW_HINGE, ROW_ANCHOR_LOWER, ROW_ANCHOR_UPPER, ROW_LOCK = 0, 1, 2, 3
W_V, W_W = 1.0, 3.0  # inverse mass and inverse moment of inertia, nondimensional
DROP_RTOL = 1e-11  # relative pivot below which a constraint row is treated as redundant


class Workspace:
    """Preallocated arrays for the O(N) kernels (no allocation in the hot loop)."""

    def __init__(self, n: int):
        p = n + 1
        self.n = n
        self.J = np.zeros((p, MAXR, 12))
        self.kind = np.zeros((p, MAXR), dtype=np.int8)
        self.nrow = np.zeros(p, dtype=np.int64)
        self.S = np.zeros((p, MAXR, MAXR))
        self.G = np.zeros((p, MAXR, MAXR))
        self.drop = np.zeros((p, MAXR), dtype=np.uint8)
        self.rhs = np.zeros((p, MAXR))
        self.x = np.zeros((p, MAXR))
        self.gf = np.zeros((n, 6))
        self.vel = np.zeros((n, 3))  # centre velocities
        self.pts = np.zeros((p, 3))  # point positions or velocities

    def arrays(self):
        return (self.J, self.kind, self.nrow, self.S, self.G, self.drop, self.rhs, self.x, self.gf)


# --------------------------------------------------------------------------- rows


@njit(cache=True, inline="always")
def _is_landed(anchored, i):
    """Both ends anchored (an anchor marked 2 is being made in the current impact:
    the segments next to it still move until the impulse has stopped them)."""
    return anchored[i] == 1 and anchored[i + 1] == 1


@njit(cache=True, inline="always")
def _landed_or_landing(anchored, i):
    return anchored[i] != 0 and anchored[i + 1] != 0


@njit(cache=True, inline="always")
def lock_active(anchored, k, cone):
    """Is the limit of hinge k in force?  Between two segments that have not landed,
    always; between a landed (or landing in the current impact) and an airborne
    segment only with ``anchor_cone``."""
    la = _landed_or_landing(anchored, k)
    lc = _landed_or_landing(anchored, k + 1)
    if not la and not lc:
        return True
    return cone and (la != lc)


@njit(cache=True, inline="always")
def _end_rows(J, j, r0, col, e, i, sv, sw):
    """Rows r0..r0+2 of point j, columns col..col+5: sv * v_i + sw * (e_i x w_i)."""
    ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
    for r in range(3):
        for q in range(6):
            J[j, r0 + r, col + q] = 0.0
        J[j, r0 + r, col + r] = sv
    J[j, r0 + 0, col + 4] = -ez * sw
    J[j, r0 + 0, col + 5] = ey * sw
    J[j, r0 + 1, col + 3] = ez * sw
    J[j, r0 + 1, col + 5] = -ex * sw
    J[j, r0 + 2, col + 3] = -ey * sw
    J[j, r0 + 2, col + 4] = ex * sw


@njit(cache=True, inline="always")
def _zero_cols(J, j, r0, nr, col):
    for r in range(r0, r0 + nr):
        for q in range(6):
            J[j, r, col + q] = 0.0


@njit(cache=True)
def build_rows(e, w, anchored, locked, cone, J, kind, nrow, rhs, with_acc_rhs):
    """Fill the constraint rows of every point; if ``with_acc_rhs``, also the
    acceleration right-hand side rhs = -(J W f_gravity + velocity-product terms)."""
    n = e.shape[0]
    for j in range(n + 1):
        a = j - 1
        c = j
        a_air = a >= 0 and not _is_landed(anchored, a)
        c_air = c < n and not _is_landed(anchored, c)
        r = 0
        if anchored[j] == 0:
            if a_air and c_air:
                _end_rows(J, j, 0, 0, e, a, 1.0, 1.0)
                _end_rows(J, j, 0, 6, e, c, -1.0, 1.0)
                for q in range(3):
                    kind[j, q] = ROW_HINGE
                if with_acc_rhs:
                    wa2 = w[a, 0] ** 2 + w[a, 1] ** 2 + w[a, 2] ** 2
                    wc2 = w[c, 0] ** 2 + w[c, 1] ** 2 + w[c, 2] ** 2
                    for q in range(3):
                        rhs[j, q] = -(wa2 * e[a, q] + wc2 * e[c, q])
                r = 3
        else:
            if a_air:
                _end_rows(J, j, 0, 0, e, a, 1.0, 1.0)
                _zero_cols(J, j, 0, 3, 6)
                for q in range(3):
                    kind[j, q] = ROW_ANCHOR_LOWER
                if with_acc_rhs:
                    wa2 = w[a, 0] ** 2 + w[a, 1] ** 2 + w[a, 2] ** 2
                    for q in range(3):
                        rhs[j, q] = -wa2 * e[a, q]
                    rhs[j, 2] += 1.0  # gravity: -(J W f) = +e_z
                r = 3
            if c_air:
                _end_rows(J, j, r, 6, e, c, 1.0, -1.0)
                _zero_cols(J, j, r, 3, 0)
                for q in range(3):
                    kind[j, r + q] = ROW_ANCHOR_UPPER
                if with_acc_rhs:
                    wc2 = w[c, 0] ** 2 + w[c, 1] ** 2 + w[c, 2] ** 2
                    for q in range(3):
                        rhs[j, r + q] = wc2 * e[c, q]
                    rhs[j, r + 2] += 1.0
                r += 3
        # lock row of hinge k = j - 1 (between segments a and c)
        if a >= 0 and c < n and locked[a] != 0 and lock_active(anchored, a, cone):
            x0, x1, x2 = e[a, 0], e[a, 1], e[a, 2]
            y0, y1, y2 = e[c, 0], e[c, 1], e[c, 2]
            cx = x1 * y2 - x2 * y1
            cy = x2 * y0 - x0 * y2
            cz = x0 * y1 - x1 * y0
            for q in range(12):
                J[j, r, q] = 0.0
            if a_air:
                J[j, r, 3] = cx
                J[j, r, 4] = cy
                J[j, r, 5] = cz
            if c_air:
                J[j, r, 9] = -cx
                J[j, r, 10] = -cy
                J[j, r, 11] = -cz
            kind[j, r] = ROW_LOCK
            if with_acc_rhs:
                # d2g/dt2 = J acc - (|w_a|^2 + |w_c|^2) (e_a.e_c) + 2 de_a . de_c
                dax = w[a, 1] * x2 - w[a, 2] * x1
                day = w[a, 2] * x0 - w[a, 0] * x2
                daz = w[a, 0] * x1 - w[a, 1] * x0
                dcx = w[c, 1] * y2 - w[c, 2] * y1
                dcy = w[c, 2] * y0 - w[c, 0] * y2
                dcz = w[c, 0] * y1 - w[c, 1] * y0
                wa2 = w[a, 0] ** 2 + w[a, 1] ** 2 + w[a, 2] ** 2
                wc2 = w[c, 0] ** 2 + w[c, 1] ** 2 + w[c, 2] ** 2
                cdot = x0 * y0 + x1 * y1 + x2 * y2
                rhs[j, r] = (wa2 + wc2) * cdot - 2.0 * (dax * dcx + day * dcy + daz * dcz)
            r += 1
        nrow[j] = r


# ------------------------------------------------------------- block Cholesky


@njit(cache=True)
def _chol_inplace(S, j, nr, drop):
    """Cholesky of the nr x nr block S[j] (lower triangle), dropping redundant rows
    (pivot below DROP_RTOL of the original diagonal): their unknowns are set to 0."""
    for k in range(nr):
        dk0 = S[j, k, k]
        d = dk0
        for p in range(k):
            d -= S[j, k, p] * S[j, k, p]
        if d <= DROP_RTOL * max(abs(dk0), 1e-300):
            drop[j, k] = 1
            for i in range(k, nr):
                S[j, i, k] = 0.0
            S[j, k, k] = 1.0
            continue
        drop[j, k] = 0
        lkk = math.sqrt(d)
        S[j, k, k] = lkk
        for i in range(k + 1, nr):
            s = S[j, i, k]
            for p in range(k):
                s -= S[j, i, p] * S[j, k, p]
            S[j, i, k] = s / lkk


@njit(cache=True)
def _chol_solve(S, j, nr, drop, b):
    """Solve S[j] x = b in place (b has length >= nr), dropped unknowns = 0."""
    for k in range(nr):
        if drop[j, k]:
            b[k] = 0.0
            continue
        s = b[k]
        for p in range(k):
            s -= S[j, k, p] * b[p]
        b[k] = s / S[j, k, k]
    for k in range(nr - 1, -1, -1):
        if drop[j, k]:
            b[k] = 0.0
            continue
        s = b[k]
        for p in range(k + 1, nr):
            s -= S[j, p, k] * b[p]
        b[k] = s / S[j, k, k]


@njit(cache=True, inline="always")
def _weights(anchored, i, n):
    """(1/m, 3/(m b^2)) of segment i, or (0, 0) if landed or outside the chain."""
    if i < 0 or i >= n or _is_landed(anchored, i):
        return 0.0, 0.0
    return W_V, W_W


@njit(cache=True)
def factor(anchored, J, nrow, S, G, drop):
    """Block Cholesky of J W J^T: S[j] <- chol(D_j - E_{j-1}^T S_{j-1}^{-1} E_{j-1}),
    G[j] = S_j^{-1} E_j, with D_j = J_j W J_j^T and E_j = J_j^(c) W_j J_{j+1}^(a)T
    (the coupling of points j and j+1 through their shared segment j)."""
    npts = nrow.shape[0]
    n = npts - 1
    E = np.zeros((MAXR, MAXR))  # E_j, kept for the next point's Schur complement
    col = np.empty(MAXR)
    ndrop = 0
    for j in range(npts):
        nr = nrow[j]
        av, aw = _weights(anchored, j - 1, n)
        cv, cw = _weights(anchored, j, n)
        for r in range(nr):
            for s in range(r + 1):
                acc = 0.0
                for q in range(3):
                    acc += (av * J[j, r, q] * J[j, s, q] + aw * J[j, r, 3 + q] * J[j, s, 3 + q]
                            + cv * J[j, r, 6 + q] * J[j, s, 6 + q] + cw * J[j, r, 9 + q] * J[j, s, 9 + q])
                S[j, r, s] = acc
        if j >= 1 and nr > 0:
            np_ = nrow[j - 1]
            # S_j -= E_{j-1}^T G_{j-1}  (E holds E_{j-1})
            for r in range(nr):
                for s in range(r + 1):
                    acc = 0.0
                    for p in range(np_):
                        acc += E[p, r] * G[j - 1, p, s]
                    S[j, r, s] -= acc
        _chol_inplace(S, j, nr, drop)
        for k in range(nr):
            ndrop += drop[j, k]
        if j < npts - 1:
            nn = nrow[j + 1]
            # E_j[r, s] = J[j, r, 6:] W_j J[j+1, s, :6]
            for r in range(nr):
                for s in range(nn):
                    acc = 0.0
                    for q in range(3):
                        acc += cv * J[j, r, 6 + q] * J[j + 1, s, q] + cw * J[j, r, 9 + q] * J[j + 1, s, 3 + q]
                    E[r, s] = acc
            # G_j = S_j^{-1} E_j
            for s in range(nn):
                for r in range(nr):
                    col[r] = E[r, s]
                _chol_solve(S, j, nr, drop, col)
                for r in range(nr):
                    G[j, r, s] = col[r]
    return ndrop


@njit(cache=True)
def solve(nrow, S, G, drop, rhs, x):
    """Solve (J W J^T) x = rhs with the factors from ``factor`` (block Thomas)."""
    npts = nrow.shape[0]
    for j in range(npts):
        nr = nrow[j]
        for r in range(nr):
            x[j, r] = rhs[j, r]
        if j >= 1:
            np_ = nrow[j - 1]
            for r in range(nr):
                acc = 0.0
                for p in range(np_):
                    acc += G[j - 1, p, r] * x[j - 1, p]  # G^T y: uses y_{j-1} before its solve
                x[j, r] -= acc
        # keep y_j for the next block's G^T y, then solve in a copy afterwards
    # forward pass above used y (not z); now z_j = S_j^{-1} y_j and back substitution
    for j in range(npts):
        _chol_solve(S, j, nrow[j], drop, x[j])
    for j in range(npts - 2, -1, -1):
        nr = nrow[j]
        nn = nrow[j + 1]
        for r in range(nr):
            acc = 0.0
            for s in range(nn):
                acc += G[j, r, s] * x[j + 1, s]
            x[j, r] -= acc


@njit(cache=True)
def generalized_forces(anchored, J, nrow, x, gf):
    """gf[i] = (J^T x) restricted to segment i: (force, torque) on segment i."""
    n = gf.shape[0]
    for i in range(n):
        for q in range(6):
            acc = 0.0
            for r in range(nrow[i]):
                acc += J[i, r, 6 + q] * x[i, r]
            for r in range(nrow[i + 1]):
                acc += J[i + 1, r, q] * x[i + 1, r]
            gf[i, q] = acc


# ------------------------------------------------------------ accelerations


@njit(cache=True)
def accelerations(e, w, anchored, locked, cone, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw):
    """Equations of motion between events: de/dt = w x e, dw/dt = 3 P (torque).

    Solves the hinge forces and lock multipliers (x) for the current locked set and
    anchors; returns the number of redundant rows dropped.
    """
    n = e.shape[0]
    build_rows(e, w, anchored, locked, cone, J, kind, nrow, rhs, True)
    ndrop = factor(anchored, J, nrow, S, G, drop)
    solve(nrow, S, G, drop, rhs, x)
    generalized_forces(anchored, J, nrow, x, gf)
    for i in range(n):
        if _is_landed(anchored, i):
            for q in range(3):
                de[i, q] = 0.0
                dw[i, q] = 0.0
            continue
        ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
        wx, wy, wz = w[i, 0], w[i, 1], w[i, 2]
        de[i, 0] = wy * ez - wz * ey
        de[i, 1] = wz * ex - wx * ez
        de[i, 2] = wx * ey - wy * ex
        tx, ty, tz = W_W * gf[i, 3], W_W * gf[i, 4], W_W * gf[i, 5]
        tp = tx * ex + ty * ey + tz * ez
        dw[i, 0] = tx - tp * ex
        dw[i, 1] = ty - tp * ey
        dw[i, 2] = tz - tp * ez
    return ndrop


@njit(cache=True)
def lock_multipliers(kind, nrow, x, lam):
    """lam[k] = multiplier of hinge k's lock row (0 where unlocked)."""
    for k in range(lam.shape[0]):
        lam[k] = 0.0
        j = k + 1
        for r in range(nrow[j]):
            if kind[j, r] == ROW_LOCK:
                lam[k] = x[j, r]


@njit(cache=True)
def anchor_forces(kind, nrow, x, out):
    """out[j] = force of the anchor at point j on the non-landed chain."""
    for j in range(out.shape[0]):
        out[j, 0] = 0.0
        out[j, 1] = 0.0
        out[j, 2] = 0.0
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_ANCHOR_LOWER or k == ROW_ANCHOR_UPPER:
                out[j, r % 3] += x[j, r]


# ------------------------------------------------------------ kinematics


@njit(cache=True)
def point_positions(e, out):
    """Positions of points 0..N: point N at the origin, point j = 2 sum_{i>=j} e_i."""
    n = e.shape[0]
    out[n, 0] = 0.0
    out[n, 1] = 0.0
    out[n, 2] = 0.0
    for j in range(n - 1, -1, -1):
        for q in range(3):
            out[j, q] = out[j + 1, q] + 2.0 * e[j, q]


@njit(cache=True)
def velocities(e, w, pv, vel):
    """Point velocities pv (N+1, 3) and centre velocities vel (N, 3) from w:
    d/dt point_j = 2 sum_{i>=j} w_i x e_i, v_i = pv_{i+1} + w_i x e_i."""
    n = e.shape[0]
    pv[n, 0] = 0.0
    pv[n, 1] = 0.0
    pv[n, 2] = 0.0
    for i in range(n - 1, -1, -1):
        dx = w[i, 1] * e[i, 2] - w[i, 2] * e[i, 1]
        dy = w[i, 2] * e[i, 0] - w[i, 0] * e[i, 2]
        dz = w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0]
        vel[i, 0] = pv[i + 1, 0] + dx
        vel[i, 1] = pv[i + 1, 1] + dy
        vel[i, 2] = pv[i + 1, 2] + dz
        pv[i, 0] = pv[i + 1, 0] + 2.0 * dx
        pv[i, 1] = pv[i + 1, 1] + 2.0 * dy
        pv[i, 2] = pv[i + 1, 2] + 2.0 * dz


@njit(cache=True)
def kinetic_energy(e, w, pv, vel):
    """T = sum 1/2 |v_i|^2 + 1/2 (1/3) |w_i|^2 (units m g b)."""
    velocities(e, w, pv, vel)
    t = 0.0
    for i in range(e.shape[0]):
        t += 0.5 * (vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2)
        t += (w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2) / 6.0
    return t


@njit(cache=True)
def potential_energy(e):
    """U = sum z_centre_i = sum_i (e_iz + 2 sum_{k>i} e_kz) (units m g b)."""
    n = e.shape[0]
    u = 0.0
    below = 0.0
    for i in range(n - 1, -1, -1):
        u += below + e[i, 2]
        below += 2.0 * e[i, 2]
    return u


@njit(cache=True)
def constraint_velocities(e, w, J, nrow, pv, vel, out):
    """out[j, r] = J_row (v, w): the rate of every constraint row."""
    velocities(e, w, pv, vel)
    n = e.shape[0]
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            acc = 0.0
            if j >= 1:
                for q in range(3):
                    acc += J[j, r, q] * vel[j - 1, q] + J[j, r, 3 + q] * w[j - 1, q]
            if j < n:
                for q in range(3):
                    acc += J[j, r, 6 + q] * vel[j, q] + J[j, r, 9 + q] * w[j, q]
            out[j, r] = acc


@njit(cache=True)
def apply_impulses(e, w, anchored, J, nrow, x, gf, sign):
    """w_i += sign * 3 P_i (torque of J^T x on segment i): a velocity jump."""
    generalized_forces(anchored, J, nrow, x, gf)
    for i in range(e.shape[0]):
        if _is_landed(anchored, i):
            w[i, 0] = 0.0
            w[i, 1] = 0.0
            w[i, 2] = 0.0
            continue
        tx, ty, tz = W_W * gf[i, 3], W_W * gf[i, 4], W_W * gf[i, 5]
        tp = tx * e[i, 0] + ty * e[i, 1] + tz * e[i, 2]
        w[i, 0] += sign * (tx - tp * e[i, 0])
        w[i, 1] += sign * (ty - tp * e[i, 1])
        w[i, 2] += sign * (tz - tp * e[i, 2])


@njit(cache=True)
def normalize_state(e, w, anchored):
    """|e_i| = 1, w_i perpendicular to e_i, w = 0 on landed segments."""
    for i in range(e.shape[0]):
        nrm = math.sqrt(e[i, 0] ** 2 + e[i, 1] ** 2 + e[i, 2] ** 2)
        e[i, 0] /= nrm
        e[i, 1] /= nrm
        e[i, 2] /= nrm
        if _is_landed(anchored, i):
            w[i, 0] = 0.0
            w[i, 1] = 0.0
            w[i, 2] = 0.0
        else:
            p = w[i, 0] * e[i, 0] + w[i, 1] * e[i, 1] + w[i, 2] * e[i, 2]
            w[i, 0] -= p * e[i, 0]
            w[i, 1] -= p * e[i, 1]
            w[i, 2] -= p * e[i, 2]


@njit(cache=True)
def position_residuals(e, anchored, locked, cone, lock_cos, anchor_pos, kind, nrow, pts, out):
    """Residual of every row at the position level: anchors (point - anchor), locks
    (e_a . e_c - lock_cos: the cosine at which the hinge locked, cos(alpha) to within the
    event tolerance), hinges 0 (positions are built from e).  Returns max |.|."""
    point_positions(e, pts)
    worst = 0.0
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_HINGE:
                out[j, r] = 0.0
            elif k == ROW_LOCK:
                a = j - 1
                out[j, r] = e[a, 0] * e[j, 0] + e[a, 1] * e[j, 1] + e[a, 2] * e[j, 2] - lock_cos[a]
            else:
                out[j, r] = pts[j, r % 3] - anchor_pos[j, r % 3]
            worst = max(worst, abs(out[j, r]))
    return worst


@njit(cache=True)
def rotate_by(e, anchored, gf, sign):
    """e_i <- normalize(e_i + sign * 3 P_i tau_i x e_i) (a small rotation)."""
    for i in range(e.shape[0]):
        if _is_landed(anchored, i):
            continue
        tx, ty, tz = sign * W_W * gf[i, 3], sign * W_W * gf[i, 4], sign * W_W * gf[i, 5]
        ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
        nx = ex + (ty * ez - tz * ey)
        ny = ey + (tz * ex - tx * ez)
        nz = ez + (tx * ey - ty * ex)
        nrm = math.sqrt(nx * nx + ny * ny + nz * nz)
        e[i, 0] = nx / nrm
        e[i, 1] = ny / nrm
        e[i, 2] = nz / nrm


@njit(cache=True)
def project_state(e, w, anchored, locked, cone, lock_cos, anchor_pos, J, kind, nrow, S, G, drop, rhs,
                  x, gf, pts, vel, tol, iters):
    """Remove constraint drift: normalise, then Gauss-Newton on anchor positions and
    locked angles (delta = -W J^T (J W J^T)^{-1} c), then the same on velocities.
    Returns the largest position residual before projection."""
    normalize_state(e, w, anchored)
    build_rows(e, w, anchored, locked, cone, J, kind, nrow, rhs, False)
    res0 = position_residuals(e, anchored, locked, cone, lock_cos, anchor_pos, kind, nrow, pts, rhs)
    res = res0
    it = 0
    while res > tol and it < iters:
        factor(anchored, J, nrow, S, G, drop)
        solve(nrow, S, G, drop, rhs, x)
        generalized_forces(anchored, J, nrow, x, gf)
        rotate_by(e, anchored, gf, -1.0)
        build_rows(e, w, anchored, locked, cone, J, kind, nrow, rhs, False)
        res = position_residuals(e, anchored, locked, cone, lock_cos, anchor_pos, kind, nrow, pts, rhs)
        it += 1
    normalize_state(e, w, anchored)
    # velocities
    constraint_velocities(e, w, J, nrow, pts, vel, rhs)
    vres = 0.0
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            vres = max(vres, abs(rhs[j, r]))
    if vres > tol:
        factor(anchored, J, nrow, S, G, drop)
        solve(nrow, S, G, drop, rhs, x)
        apply_impulses(e, w, anchored, J, nrow, x, gf, -1.0)
    return res0
