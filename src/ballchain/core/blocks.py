"""The block factorisation of J W J^T and its solves (docs/model.md, section 2), numba
kernels, nondimensional.

The multipliers of (J W J^T) x = rhs (the rows: ``rows``) are the forces (hinge and anchor
rows: force on segment a from below, equal to minus the force on c from above) and the
lock multipliers lambda (couple lambda e_a x e_c on a).  J W J^T is block tridiagonal
(blocks of the points, coupled through the shared segment) and symmetric positive
(semi)definite: one block factorisation (block Thomas) sweep costs O(N).  In general
(``factor_general``: block Cholesky, up to 7 rows a point) or, when every point has at
most 4 rows, in closed form with fixed-size loops (``factor4``); ``factor`` and
``solve`` pick the one that fits, ``generalized_forces`` / ``torques4`` / ``forces4``
turn the multipliers into the segments' generalised forces.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from .rows import ROW_ANCHOR_LOWER, ROW_ANCHOR_UPPER, ROW_HINGE, ROW_LOCK, W_V, W_W
from .rules import is_landed as _is_landed
from .state import MAXR

# factor4's restart record: rows MAXR .. MAXR+2 of S[j] (below the factors) hold what
# point j's block was computed from: the Schur complement carried into it (10 values),
# the rows dropped above it, its row count, first row kind and anchor flag, and the axis
# of segment j; S[0, REC_E, REC_VALID] = 1 while S, G, drop hold factor4's factors of
# those inputs (factor_general clears it).  A refactorisation restarts at the first
# point whose inputs changed: the trials of an impact or a lock set, the projection and
# the first evaluation after an event share the axes and differ only in a few rows.
# The record is kept only while S[0, REC_E, REC_ON] = 1 (``reuse_factors``: during an
# event instant); between events every evaluation has new axes and records nothing.
REC_U, REC_P, REC_E = MAXR, MAXR + 1, MAXR + 2
REC_VALID, REC_NDROP, REC_ON = 3, 4, 5
DROP_RTOL = 1e-11  # relative pivot below which a constraint row is treated as redundant


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def _weights(anchored, i, n):
    """(1/m, 3/(m b^2)) of segment i, or (0, 0) if landed or outside the chain.  Its ends'
    marks are read before any branch (clamped into the chain): numba then takes no
    reference count of ``anchored`` at each call in a loop."""
    k = min(max(i, 0), n - 1)
    landed = _is_landed(anchored, k)
    if i < 0 or i >= n or landed:
        return 0.0, 0.0
    return W_V, W_W


@njit(cache=True, _nrt=True)
def factor_general(anchored, J, nrow, S, G, drop):
    """Block Cholesky of J W J^T for any row count per point (up to MAXR), products
    taken from the rows J: S[j] <- chol(D_j - E_{j-1}^T S_{j-1}^{-1} E_{j-1}),
    G[j] = S_j^{-1} E_j, with D_j = J_j W J_j^T and E_j = J_j^(c) W_j J_{j+1}^(a)T
    (the coupling of points j and j+1 through their shared segment j)."""
    npts = nrow.shape[0]
    n = npts - 1
    S[0, REC_E, REC_VALID] = 0.0  # S, G, drop no longer hold factor4's factors
    mr = J.shape[1]  # rows per point at most (MAXR here; a method may lay out more)
    E = np.zeros((mr, mr))  # E_j, kept for the next point's Schur complement
    col = np.empty(mr)
    ndrop = 0
    for j in range(npts):
        nr = nrow[j]
        av, aw = _weights(anchored, j - 1, n)
        cv, cw = _weights(anchored, j, n)
        for r in range(nr):
            for s in range(r + 1):
                acc = 0.0
                for q in range(3):
                    acc += (
                        av * J[j, r, q] * J[j, s, q]
                        + aw * J[j, r, 3 + q] * J[j, s, 3 + q]
                        + cv * J[j, r, 6 + q] * J[j, s, 6 + q]
                        + cw * J[j, r, 9 + q] * J[j, s, 9 + q]
                    )
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


@njit(cache=True, _nrt=False)
def solve_general(nrow, S, G, drop, rhs, x):
    """Solve (J W J^T) x = rhs with the factors from ``factor_general`` (block Thomas)."""
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


# ---------------------------------------------- fixed-size path (<= 4 rows per point)
#
# Every point has at most one group of three end rows (hinge, or one anchor) and one
# lock row unless it is an anchored point between two airborne segments.  Then each
# block is padded to 4 x 4 (an unused row has diagonal 1 and no coupling, so its
# unknown is 0) and J W J^T is formed in closed form from the segment axes, with the
# row coefficients of an end row on a segment written (A, B): A v + B (e x w), and a
# lock row L n . w, n = e_a x e_c:
#   end . end   = wv A1 A2 delta + ww B1 B2 (|e|^2 delta - e e^T)
# (|e|^2, not 1: the Runge-Kutta stages evaluate off |e| = 1, and near a redundant
# configuration, e.g. two segments folded flat between anchors, the smallest eigenvalue
# of J W J^T is ~1e-7, so an O(|e|^2 - 1) mismatch with the rows makes the matrix
# inconsistent or indefinite and the right-hand side discontinuous)
#   end . lock  = ww B L (e x n)_q          lock . lock = ww L1 L2 n1 . n2
# Hinge row: a (1, 1), c (-1, 1); anchor, lower: a (1, 1); anchor, upper: c (1, -1);
# lock row: a L = 1, c L = -1.  The factor is the block L P L^T (L_j unit lower,
# P_j diagonal: no square roots), with F_j = L_j^{-1} E_j and H_j = P_j^{-1} F_j:
#   L_j P_j L_j^T = D_j - F_{j-1}^T H_{j-1},   u_j = L_j^{-1} (b_j - H_{j-1}^T u_{j-1}),
#   x_j = L_j^{-T} (P_j^{-1} u_j - H_j x_{j+1});
# S holds L_j below its diagonal and 1/p_k on it (0 for a dropped or padding row: its
# column of L and its row of H are then 0, so its unknown comes out 0), G holds H_j.
# A point without rows (landed segments on both sides, or a free end) has E = 0 on
# both sides: its unknowns are 0 and it is skipped.


@njit(cache=True, inline="always")
def _end_coeffs(kind0, nr):
    """(A_a, B_a, A_c, B_c) of the end rows of a point whose first row kind is kind0."""
    if nr < 3:
        return 0.0, 0.0, 0.0, 0.0
    if kind0 == ROW_HINGE:
        return 1.0, 1.0, -1.0, 1.0
    if kind0 == ROW_ANCHOR_LOWER:
        return 1.0, 1.0, 0.0, 0.0
    if kind0 == ROW_ANCHOR_UPPER:
        return 0.0, 0.0, 1.0, -1.0
    return 0.0, 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def _lock_vector(e, j, nr):
    """n = e_a x e_c of point j's lock row (0 if the point has none)."""
    if nr != 4:
        return 0.0, 0.0, 0.0
    a = j - 1
    c = j
    return (
        e[a, 1] * e[c, 2] - e[a, 2] * e[c, 1],
        e[a, 2] * e[c, 0] - e[a, 0] * e[c, 2],
        e[a, 0] * e[c, 1] - e[a, 1] * e[c, 0],
    )


@njit(cache=True, _nrt=False)
def fits4(kind, nrow):
    """Every point has 0, 3 or 4 rows (one end group and at most one lock row), or 6
    (an anchor between two airborne segments, without a lock row); a sliding point's
    height row (``rows.ROW_SLIDE_*``) needs the general path."""
    for j in range(nrow.shape[0]):
        r = nrow[j]
        if r != 0 and r != 3 and r != 4 and r != 6:
            return False
        if r == 4 and kind[j, 3] != ROW_LOCK:
            return False
    return True


@njit(cache=True, inline="always")
def _inverse_pivot(p, dkk, k, nr, drop, j, r):
    """(1/p, 0) for the pivot p of row k of a block with nr rows, its flag drop[j, r]
    cleared; (0, 1) with the flag set if the row is redundant (p below DROP_RTOL of its
    diagonal dkk); (0, 0) for a padding row (k >= nr)."""
    if k >= nr:
        return 0.0, 0
    if p <= DROP_RTOL * max(abs(dkk), 1e-300):
        drop[j, r] = 1
        return 0.0, 1
    drop[j, r] = 0
    return 1.0 / p, 0


@njit(cache=True, inline="always")
def _ldl3(s00, s10, s11, s20, s21, s22, d00, d11, d22, drop, j, r0):
    """L P L^T of a 3 x 3 block (lower triangle s), dropping redundant rows (pivot below
    DROP_RTOL of the diagonal d_kk; flags at drop[j, r0 + k]).  Returns (1/p0, L10, L20,
    1/p1, L21, 1/p2, rows dropped)."""
    nd = 0
    i0, dk = _inverse_pivot(s00, d00, 0, 3, drop, j, r0)
    nd += dk
    l10 = s10 * i0
    l20 = s20 * i0
    p = s11 - l10 * s10
    w21 = s21 - l20 * s10
    i1, dk = _inverse_pivot(p, d11, 1, 3, drop, j, r0 + 1)
    nd += dk
    l21 = w21 * i1
    p = s22 - l20 * s20 - l21 * w21
    i2, dk = _inverse_pivot(p, d22, 2, 3, drop, j, r0 + 2)
    nd += dk
    return i0, l10, l20, i1, l21, i2, nd


@njit(cache=True, inline="always")
def _unit_lower_solve4(l10, l20, l21, l30, l31, l32, b0, b1, b2, b3):
    """x = L^{-1} b for the 4 x 4 unit lower triangular L (forward substitution)."""
    x0 = b0
    x1 = b1 - l10 * x0
    x2 = b2 - l20 * x0 - l21 * x1
    x3 = b3 - l30 * x0 - l31 * x1 - l32 * x2
    return x0, x1, x2, x3


@njit(cache=True, _nrt=False)
def factor4(e, anchored, kind, nrow, S, G, drop):
    """L P L^T factor of J W J^T in 4 x 4 blocks formed in closed form (see above), every
    block held in scalars (one line per entry).  Returns the number of redundant rows
    dropped."""
    npts = nrow.shape[0]
    n = npts - 1
    rec = S[0, REC_E, REC_ON] == 1.0
    j0 = _restart_point(e, anchored, kind, nrow, S) if rec else 0
    if j0 == npts:  # the same inputs as the factors held
        return np.int64(S[0, REC_E, REC_NDROP])
    S[0, REC_E, REC_VALID] = 0.0
    # u = F_{j-1}^T H_{j-1}, the previous point's part of the Schur complement
    u00 = u10 = u11 = u20 = u21 = u22 = u30 = u31 = u32 = u33 = 0.0
    ndrop = 0
    if j0 > 0:
        u00, u10, u11, u20 = S[j0, REC_U, 0], S[j0, REC_U, 1], S[j0, REC_U, 2], S[j0, REC_U, 3]
        u21, u22, u30 = S[j0, REC_U, 4], S[j0, REC_U, 5], S[j0, REC_U, 6]
        u31, u32, u33 = S[j0, REC_P, 0], S[j0, REC_P, 1], S[j0, REC_P, 2]
        ndrop = np.int64(S[j0, REC_P, 3])
    nr = nrow[j0]
    Aa, Ba, Ac, Bc = _end_coeffs(kind[j0, 0], nr)
    nx, ny, nz = _lock_vector(e, j0, nr)
    for j in range(j0, npts):
        if rec:  # the restart record of point j (what its block is computed from)
            S[j, REC_U, 0] = u00
            S[j, REC_U, 1] = u10
            S[j, REC_U, 2] = u11
            S[j, REC_U, 3] = u20
            S[j, REC_U, 4] = u21
            S[j, REC_U, 5] = u22
            S[j, REC_U, 6] = u30
            S[j, REC_P, 0] = u31
            S[j, REC_P, 1] = u32
            S[j, REC_P, 2] = u33
            S[j, REC_P, 3] = ndrop
            S[j, REC_P, 4] = nr
            S[j, REC_P, 5] = kind[j, 0]
            S[j, REC_P, 6] = anchored[j]
            if j < n:
                S[j, REC_E, 0] = e[j, 0]
                S[j, REC_E, 1] = e[j, 1]
                S[j, REC_E, 2] = e[j, 2]
        if nr == 0:  # no rows: E_{j-1} = E_j = 0
            u00 = u10 = u11 = u20 = u21 = u22 = u30 = u31 = u32 = u33 = 0.0
            if j == n:
                break
            nr = nrow[j + 1]
            Aa, Ba, Ac, Bc = _end_coeffs(kind[j + 1, 0], nr)
            nx, ny, nz = _lock_vector(e, j + 1, nr)
            continue
        av, aw = _weights(anchored, j - 1, n)
        cv, cw = _weights(anchored, j, n)
        ea0 = ea1 = ea2 = ec0 = ec1 = ec2 = 0.0
        if j >= 1:
            ea0, ea1, ea2 = e[j - 1, 0], e[j - 1, 1], e[j - 1, 2]
        if j < n:
            ec0, ec1, ec2 = e[j, 0], e[j, 1], e[j, 2]
        qa = aw * Ba * Ba
        qc = cw * Bc * Bc
        na2 = ea0 * ea0 + ea1 * ea1 + ea2 * ea2  # |e|^2: 1 only on the constraint manifold
        nc2 = ec0 * ec0 + ec1 * ec1 + ec2 * ec2
        if nr == 6:
            # an anchor between two airborne segments: its lower rows (segment a) end
            # the sweep so far, its upper rows (segment c) start a new one (S[j, 4:7, 4:7])
            t = aw * na2
            d00 = av + t - aw * ea0 * ea0
            d10 = -aw * ea1 * ea0
            d11 = av + t - aw * ea1 * ea1
            d20 = -aw * ea2 * ea0
            d21 = -aw * ea2 * ea1
            d22 = av + t - aw * ea2 * ea2
            i0, l10, l20, i1, l21, i2, nd = _ldl3(
                d00 - u00, d10 - u10, d11 - u11, d20 - u20, d21 - u21, d22 - u22, d00, d11, d22, drop, j, 0
            )
            ndrop += nd
            S[j, 0, 0] = i0
            S[j, 1, 0] = l10
            S[j, 1, 1] = i1
            S[j, 2, 0] = l20
            S[j, 2, 1] = l21
            S[j, 2, 2] = i2
            S[j, 3, 0] = 0.0
            S[j, 3, 1] = 0.0
            S[j, 3, 2] = 0.0
            S[j, 3, 3] = 0.0
            t = cw * nc2
            d00 = cv + t - cw * ec0 * ec0
            d10 = -cw * ec1 * ec0
            d11 = cv + t - cw * ec1 * ec1
            d20 = -cw * ec2 * ec0
            d21 = -cw * ec2 * ec1
            d22 = cv + t - cw * ec2 * ec2
            i0, l10, l20, i1, l21, i2, nd = _ldl3(d00, d10, d11, d20, d21, d22, d00, d11, d22, drop, j, 3)
            ndrop += nd
            S[j, 4, 4] = i0
            S[j, 5, 4] = l10
            S[j, 5, 5] = i1
            S[j, 6, 4] = l20
            S[j, 6, 5] = l21
            S[j, 6, 6] = i2
            i3 = 0.0
            l30 = l31 = l32 = 0.0
            Ac, Bc = 1.0, -1.0  # the upper rows act on segment c as an upper anchor
        else:
            base = av * Aa * Aa + qa * na2 + cv * Ac * Ac + qc * nc2
            d00 = base - qa * ea0 * ea0 - qc * ec0 * ec0
            d10 = -qa * ea1 * ea0 - qc * ec1 * ec0
            d11 = base - qa * ea1 * ea1 - qc * ec1 * ec1
            d20 = -qa * ea2 * ea0 - qc * ec2 * ec0
            d21 = -qa * ea2 * ea1 - qc * ec2 * ec1
            d22 = base - qa * ea2 * ea2 - qc * ec2 * ec2
            if nr == 4:
                la = aw * Ba
                lc = cw * Bc
                d30 = la * (ea1 * nz - ea2 * ny) - lc * (ec1 * nz - ec2 * ny)
                d31 = la * (ea2 * nx - ea0 * nz) - lc * (ec2 * nx - ec0 * nz)
                d32 = la * (ea0 * ny - ea1 * nx) - lc * (ec0 * ny - ec1 * nx)
                d33 = (aw + cw) * (nx * nx + ny * ny + nz * nz)
            else:
                d30 = d31 = d32 = 0.0
                d33 = 1.0
            # Schur complement D_j - F_{j-1}^T H_{j-1}
            s00 = d00 - u00
            s10 = d10 - u10
            s11 = d11 - u11
            s20 = d20 - u20
            s21 = d21 - u21
            s22 = d22 - u22
            s30 = d30 - u30
            s31 = d31 - u31
            s32 = d32 - u32
            s33 = d33 - u33
            # L P L^T of the block, dropping redundant rows (and padding rows k >= nr):
            # i_k = 1/p_k, or 0 for a dropped row; w_ik = L_ik p_k
            p = s00
            i0, nd = _inverse_pivot(p, d00, 0, nr, drop, j, 0)
            ndrop += nd
            l10 = s10 * i0
            l20 = s20 * i0
            l30 = s30 * i0
            p = s11 - l10 * s10
            w21 = s21 - l20 * s10
            w31 = s31 - l30 * s10
            i1, nd = _inverse_pivot(p, d11, 1, nr, drop, j, 1)
            ndrop += nd
            l21 = w21 * i1
            l31 = w31 * i1
            p = s22 - l20 * s20 - l21 * w21
            w32 = s32 - l30 * s20 - l31 * w21
            i2, nd = _inverse_pivot(p, d22, 2, nr, drop, j, 2)
            ndrop += nd
            l32 = w32 * i2
            p = s33 - l30 * s30 - l31 * w31 - l32 * w32
            i3, nd = _inverse_pivot(p, d33, 3, nr, drop, j, 3)
            ndrop += nd
            S[j, 0, 0] = i0
            S[j, 1, 0] = l10
            S[j, 1, 1] = i1
            S[j, 2, 0] = l20
            S[j, 2, 1] = l21
            S[j, 2, 2] = i2
            S[j, 3, 0] = l30
            S[j, 3, 1] = l31
            S[j, 3, 2] = l32
            S[j, 3, 3] = i3
        if j == n:
            break
        # E_j: rows of point j (side c, segment j) x rows of point j+1 (side a, segment j)
        nr1 = nrow[j + 1]
        Aa1, Ba1, Ac1, Bc1 = _end_coeffs(kind[j + 1, 0], nr1)
        mx, my, mz = _lock_vector(e, j + 1, nr1)
        pv = cv * Ac * Aa1
        pw = cw * Bc * Ba1
        pe = pw * nc2
        g00 = pv + pe - pw * ec0 * ec0
        g01 = -pw * ec0 * ec1
        g02 = -pw * ec0 * ec2
        g10 = -pw * ec1 * ec0
        g11 = pv + pe - pw * ec1 * ec1
        g12 = -pw * ec1 * ec2
        g20 = -pw * ec2 * ec0
        g21 = -pw * ec2 * ec1
        g22 = pv + pe - pw * ec2 * ec2
        lc = cw * Bc
        g03 = lc * (ec1 * mz - ec2 * my)
        g13 = lc * (ec2 * mx - ec0 * mz)
        g23 = lc * (ec0 * my - ec1 * mx)
        la = -cw * Ba1
        g30 = la * (ec1 * nz - ec2 * ny)
        g31 = la * (ec2 * nx - ec0 * nz)
        g32 = la * (ec0 * ny - ec1 * nx)
        g33 = -cw * (nx * mx + ny * my + nz * mz)
        # F_j = L_j^{-1} E_j (L_j unit lower), column by column; H_j = P_j^{-1} F_j
        f00, f10, f20, f30 = _unit_lower_solve4(l10, l20, l21, l30, l31, l32, g00, g10, g20, g30)
        f01, f11, f21, f31 = _unit_lower_solve4(l10, l20, l21, l30, l31, l32, g01, g11, g21, g31)
        f02, f12, f22, f32 = _unit_lower_solve4(l10, l20, l21, l30, l31, l32, g02, g12, g22, g32)
        f03, f13, f23, f33 = _unit_lower_solve4(l10, l20, l21, l30, l31, l32, g03, g13, g23, g33)
        h00 = f00 * i0
        h01 = f01 * i0
        h02 = f02 * i0
        h03 = f03 * i0
        h10 = f10 * i1
        h11 = f11 * i1
        h12 = f12 * i1
        h13 = f13 * i1
        h20 = f20 * i2
        h21 = f21 * i2
        h22 = f22 * i2
        h23 = f23 * i2
        h30 = f30 * i3
        h31 = f31 * i3
        h32 = f32 * i3
        h33 = f33 * i3
        G[j, 0, 0] = h00
        G[j, 0, 1] = h01
        G[j, 0, 2] = h02
        G[j, 0, 3] = h03
        G[j, 1, 0] = h10
        G[j, 1, 1] = h11
        G[j, 1, 2] = h12
        G[j, 1, 3] = h13
        G[j, 2, 0] = h20
        G[j, 2, 1] = h21
        G[j, 2, 2] = h22
        G[j, 2, 3] = h23
        G[j, 3, 0] = h30
        G[j, 3, 1] = h31
        G[j, 3, 2] = h32
        G[j, 3, 3] = h33
        u00 = f00 * h00 + f10 * h10 + f20 * h20 + f30 * h30
        u10 = f01 * h00 + f11 * h10 + f21 * h20 + f31 * h30
        u11 = f01 * h01 + f11 * h11 + f21 * h21 + f31 * h31
        u20 = f02 * h00 + f12 * h10 + f22 * h20 + f32 * h30
        u21 = f02 * h01 + f12 * h11 + f22 * h21 + f32 * h31
        u22 = f02 * h02 + f12 * h12 + f22 * h22 + f32 * h32
        u30 = f03 * h00 + f13 * h10 + f23 * h20 + f33 * h30
        u31 = f03 * h01 + f13 * h11 + f23 * h21 + f33 * h31
        u32 = f03 * h02 + f13 * h12 + f23 * h22 + f33 * h32
        u33 = f03 * h03 + f13 * h13 + f23 * h23 + f33 * h33
        nr = nr1
        Aa, Ba, Ac, Bc = Aa1, Ba1, Ac1, Bc1
        nx, ny, nz = mx, my, mz
    if rec:
        S[0, REC_E, REC_NDROP] = ndrop
        S[0, REC_E, REC_VALID] = 1.0
    return ndrop


@njit(cache=True, _nrt=False)
def reuse_factors(S, on):
    """Keep factor4's restart record (on: during an event instant, where J W J^T is
    factored many times for the same axes) or stop keeping it (off: between events,
    where every evaluation has new axes; the record is dropped)."""
    S[0, REC_E, REC_ON] = 1.0 if on else 0.0
    if not on:
        S[0, REC_E, REC_VALID] = 0.0


@njit(cache=True, _nrt=False)
def _restart_point(e, anchored, kind, nrow, S):
    """The first point whose block factor4 must recompute: npts if S holds the factors
    of these very inputs, else one above the first segment or point whose inputs
    differ from the restart record (point j's block reads segments j-1..j+1 and the
    rows and anchor flags of points j-1..j+1), 0 if there is no valid record."""
    npts = nrow.shape[0]
    n = npts - 1
    if S[0, REC_E, REC_VALID] != 1.0:
        return 0
    first = npts
    for i in range(n):
        if e[i, 0] != S[i, REC_E, 0] or e[i, 1] != S[i, REC_E, 1] or e[i, 2] != S[i, REC_E, 2]:
            first = i
            break
    for j in range(first if first < npts else npts):
        if nrow[j] != S[j, REC_P, 4] or kind[j, 0] != S[j, REC_P, 5] or anchored[j] != S[j, REC_P, 6]:
            first = j
            break
    if first == npts:
        return npts
    return max(first - 1, 0)


@njit(cache=True, _nrt=False)
def solve4(nrow, S, G, rhs, x):
    """Solve (J W J^T) x = rhs with the factors from ``factor4`` (u, x carried in
    scalars; a point without rows is skipped: its unknowns are 0)."""
    npts = nrow.shape[0]
    u0 = u1 = u2 = u3 = 0.0
    for j in range(npts):
        nr = nrow[j]
        if nr == 0:
            u0 = u1 = u2 = u3 = 0.0
            x[j, 0] = 0.0
            x[j, 1] = 0.0
            x[j, 2] = 0.0
            x[j, 3] = 0.0
            continue
        b0, b1, b2 = rhs[j, 0], rhs[j, 1], rhs[j, 2]
        b3 = rhs[j, 3] if nr == 4 else 0.0  # (nr == 6: rhs[j, 3:6] are the upper rows)
        if j >= 1 and nrow[j - 1] != 0:
            b0 -= G[j - 1, 0, 0] * u0 + G[j - 1, 1, 0] * u1 + G[j - 1, 2, 0] * u2 + G[j - 1, 3, 0] * u3
            b1 -= G[j - 1, 0, 1] * u0 + G[j - 1, 1, 1] * u1 + G[j - 1, 2, 1] * u2 + G[j - 1, 3, 1] * u3
            b2 -= G[j - 1, 0, 2] * u0 + G[j - 1, 1, 2] * u1 + G[j - 1, 2, 2] * u2 + G[j - 1, 3, 2] * u3
            b3 -= G[j - 1, 0, 3] * u0 + G[j - 1, 1, 3] * u1 + G[j - 1, 2, 3] * u2 + G[j - 1, 3, 3] * u3
        u0, u1, u2, u3 = _unit_lower_solve4(
            S[j, 1, 0], S[j, 2, 0], S[j, 2, 1], S[j, 3, 0], S[j, 3, 1], S[j, 3, 2], b0, b1, b2, b3
        )
        x[j, 0] = u0
        x[j, 1] = u1
        x[j, 2] = u2
        x[j, 3] = u3
        if nr == 6:  # the upper rows of a split anchor start afresh (factors in S[j, 4:7, 4:7])
            u0 = rhs[j, 3]
            u1 = rhs[j, 4] - S[j, 5, 4] * u0
            u2 = rhs[j, 5] - S[j, 6, 4] * u0 - S[j, 6, 5] * u1
            u3 = 0.0
            x[j, 3] = u0
            x[j, 4] = u1
            x[j, 5] = u2
    z0 = z1 = z2 = z3 = 0.0
    for j in range(npts - 1, -1, -1):
        nr = nrow[j]
        if nr == 0:
            z0 = z1 = z2 = z3 = 0.0
            continue
        # H_j x_{j+1}: the coupling to the next point (of the upper rows of a split anchor)
        c0 = c1 = c2 = c3 = 0.0
        if j < npts - 1:
            c0 = G[j, 0, 0] * z0 + G[j, 0, 1] * z1 + G[j, 0, 2] * z2 + G[j, 0, 3] * z3
            c1 = G[j, 1, 0] * z0 + G[j, 1, 1] * z1 + G[j, 1, 2] * z2 + G[j, 1, 3] * z3
            c2 = G[j, 2, 0] * z0 + G[j, 2, 1] * z1 + G[j, 2, 2] * z2 + G[j, 2, 3] * z3
            c3 = G[j, 3, 0] * z0 + G[j, 3, 1] * z1 + G[j, 3, 2] * z2 + G[j, 3, 3] * z3
        if nr == 6:  # upper rows (coupled to j + 1), then the lower rows (to j - 1)
            b2 = x[j, 5] * S[j, 6, 6] - c2
            b1 = x[j, 4] * S[j, 5, 5] - c1
            b0 = x[j, 3] * S[j, 4, 4] - c0
            z2 = b2
            z1 = b1 - S[j, 6, 5] * z2
            z0 = b0 - S[j, 5, 4] * z1 - S[j, 6, 4] * z2
            x[j, 3] = z0
            x[j, 4] = z1
            x[j, 5] = z2
            z2 = x[j, 2] * S[j, 2, 2]
            z1 = x[j, 1] * S[j, 1, 1] - S[j, 2, 1] * z2
            z0 = x[j, 0] * S[j, 0, 0] - S[j, 1, 0] * z1 - S[j, 2, 0] * z2
            z3 = 0.0
            x[j, 0] = z0
            x[j, 1] = z1
            x[j, 2] = z2
            continue
        z3 = x[j, 3] * S[j, 3, 3] - c3
        z2 = x[j, 2] * S[j, 2, 2] - c2 - S[j, 3, 2] * z3
        z1 = x[j, 1] * S[j, 1, 1] - c1 - S[j, 2, 1] * z2 - S[j, 3, 1] * z3
        z0 = x[j, 0] * S[j, 0, 0] - c0 - S[j, 1, 0] * z1 - S[j, 2, 0] * z2 - S[j, 3, 0] * z3
        x[j, 0] = z0
        x[j, 1] = z1
        x[j, 2] = z2
        x[j, 3] = z3


@njit(cache=True, _nrt=False)
def factor(e, anchored, J, kind, nrow, S, G, drop):
    """Factor J W J^T (the fixed-size path when every point has <= 4 rows, else the
    general one); returns the number of redundant rows dropped.  ``solve`` picks the
    same path."""
    if fits4(kind, nrow):
        return factor4(e, anchored, kind, nrow, S, G, drop)
    return factor_general(anchored, J, nrow, S, G, drop)


@njit(cache=True, _nrt=False)
def solve(kind, nrow, S, G, drop, rhs, x):
    """Solve (J W J^T) x = rhs with the factors from ``factor`` (of the same rows)."""
    if fits4(kind, nrow):
        solve4(nrow, S, G, rhs, x)
    else:
        solve_general(nrow, S, G, drop, rhs, x)


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def torques4(e, kind, nrow, x, gf):
    """gf[i, 3:6] = torque of the multipliers x on segment i (fixed-size layout):
    an end group with multiplier f and w-coefficient B gives B f x e_i, a lock row
    L lambda n (``generalized_forces`` computes the same from J; forces are not needed)."""
    n = e.shape[0]
    for i in range(n):
        ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for side in range(2):
            j = i + side  # point i: segment i is its side c; point i+1: its side a
            nr = nrow[j]
            Aa, Ba, Ac, Bc = _end_coeffs(kind[j, 0], nr)
            B = Ba if side == 1 else Bc
            r0 = 0
            if nr == 6 and side == 0:  # the upper rows of a split anchor
                B = -1.0
                r0 = 3
            if B != 0.0:
                fx, fy, fz = x[j, r0], x[j, r0 + 1], x[j, r0 + 2]
                tx += B * (fy * ez - fz * ey)
                ty += B * (fz * ex - fx * ez)
                tz += B * (fx * ey - fy * ex)
            if nr == 4:
                nx, ny, nz = _lock_vector(e, j, nr)
                lam = x[j, 3] if side == 1 else -x[j, 3]
                tx += lam * nx
                ty += lam * ny
                tz += lam * nz
        gf[i, 3] = tx
        gf[i, 4] = ty
        gf[i, 5] = tz


@njit(cache=True, _nrt=False)
def forces4(kind, nrow, x, gf):
    """gf[i, 0:3] = force of the multipliers x on segment i (fixed-size layout): an end
    group with multiplier f and v-coefficient A gives A f (``torques4``'s twin)."""
    for i in range(gf.shape[0]):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for side in range(2):
            j = i + side  # point i: segment i is its side c; point i+1: its side a
            nr = nrow[j]
            Aa, Ba, Ac, Bc = _end_coeffs(kind[j, 0], nr)
            A = Aa if side == 1 else Ac
            r0 = 0
            if nr == 6 and side == 0:  # the upper rows of a split anchor
                A = 1.0
                r0 = 3
            if A != 0.0:
                fx += A * x[j, r0]
                fy += A * x[j, r0 + 1]
                fz += A * x[j, r0 + 2]
        gf[i, 0] = fx
        gf[i, 1] = fy
        gf[i, 2] = fz
