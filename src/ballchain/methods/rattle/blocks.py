"""The block LU of the step's matrices: A = J1 W J0^T, block tridiagonal over the points.

Both stages solve with such a matrix.  Stage 1's Newton matrix is J(q+) W J(q)^T (not
symmetric: stage 1 solves g(q_free + h W J(q)^T P) = 0 for the impulses P); stage 2's is
the symmetric J(q+) W J(q+)^T (J1 = J0).  A symmetric factorisation of J W J^T does not
serve stage 1: it differs from A by O(h |u|), and its inverse amplifies that by the
condition number, which grows with the length of a locked stretch of chain (a chord
iteration on it crawls, at a spectral radius of 0.7 at N = 8).  So both are factored by
one block LU without pivoting (A is symmetric positive semi-definite, or within O(h |u|)
of it).  Blocks per point j (rows of j against the impulses of j - 1, j or j + 1):

  D_j = J1_j W J0_j^T,   U_j = J1_j^(c) W_j J0_{j+1}^(a)T,   L_j = J1_j^(a) W_{j-1} J0_{j-1}^(c)T
  D'_j = D_j - L_j X_{j-1} = l_j u_j (in place: l_j below the diagonal, 1 / pivots on it,
  0 for a dropped row, whose column of l is 0: its unknown comes out 0),
  X_j = D'_j^{-1} U_j,   M_j = D'_j^{-1} L_j (kept in place of L_j),
  z_j = D'_j^{-1} b_j - M_j z_{j-1},   x_j = z_j - X_j x_{j+1}

The solves' sweeps are chains, each point waiting on its neighbour: with M_j only a 4 x 4
product waits on z_{j-1} (D'_j^{-1} b_j does not), not the whole solve with D'_j.

Each block is stored packed, row by row at the stride of its own row count (D_j: nr_j x
nr_j at D[o_j + r nr_j + s]; L_j and M_j: nr_j x nr_{j-1}; X_j: nr_j x nr_{j+1}), and the
points' blocks one after the other (o_j = F.off[j], the same in D, L and X: a slot of
nr_j max(nr_{j-1}, nr_j, nr_{j+1}) entries), so that a run of free points (4 rows) fills
each array densely, 128 bytes a point: at large N the sweeps stream through memory (a
slot of RMAX^2 a point, 2 of its 8 cache lines used, made the solves 2.3 times slower at
N = 16384, ``benchmarks/factor_speed.py --rattle``).

A *dropped* row has unknown 0 and its equation left out: a row the factorisation of
J W J^T finds redundant (its pivot below DROP_RTOL of its diagonal: a chain folded
between anchors, two limits that say the same), and in stage 1 the rows dropped by the
symmetric factors it is given.  A pivot of A below PIVOT_RTOL of its diagonal that was
not dropped makes A singular to round-off: ``factor_blocks`` returns -1.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ...core.blocks import DROP_RTOL
from ...core.rows import W_V, W_W
from ...jit import njit
from .rows import K_AXIS, K_JOINT, end_signs, has_columns

_u = np.uint64  # an index cast to it: numba checks a signed index for wrapping around (a compare and
#   a select at every access of a block at a point's offset), an unsigned one not: the hot loops
#   read their blocks at D[_u(o + k)] (the free points' factorisation took 1.5 times as long without)

PIVOT_RTOL = 1e-12  # stage 1: a pivot of A below this fraction of its diagonal (not dropped): A is singular

# The factors of one matrix: D (l, u and the inverse pivots), L (the lower blocks L_j while
# factoring, then M_j = D'_j^{-1} L_j for the solves), X, each flat, point j's block at
# off[j] (module docstring), which rows are dropped, and the diagonal before the
# elimination (scratch).
Factors = namedtuple("Factors", ["D", "L", "X", "drop", "d0", "off"])


def new_factors(points: int, rmax: int) -> Factors:
    """Room for the factors of ``points`` blocks of up to rmax rows."""
    return Factors(
        np.zeros(points * rmax * rmax),
        np.zeros(points * rmax * rmax),
        np.zeros(points * rmax * rmax),
        np.zeros((points, rmax), np.uint8),
        np.zeros(rmax),
        np.zeros(points + 1, np.int64),
    )


@njit(cache=True, _nrt=True)
def factors_view(F, p):
    """The factors of the first p points: views (the blocks' arrays and ``d0`` whole: the
    offsets are the whole chain's, and a view's points come first)."""
    return Factors(F.D, F.L, F.X, F.drop[:p], F.d0, F.off[: p + 1])


@njit(cache=True, inline="always")
def _slot(nr, n_above, n_below):
    """Entries of a point's slot: nr_j max(nr_{j-1}, nr_j, nr_{j+1}) (its D, L and X blocks;
    the counts as numbers: a helper that takes an array and branches before its last use
    of it costs numba a reference count at every call)."""
    return nr * max(nr, n_above, n_below)


@njit(cache=True, inline="always")
def _pair(J1, J0, j1, r, j0, s, g1, g0, wv, ww):
    """J1[j1, r] W J0[j0, s]^T over one segment: its columns g1 in row r, g0 in row s (0: the
    segment above the point, 6: below), weights wv (centre) and ww (axis)."""
    ac, ae = 0.0, 0.0
    for q in range(3):
        ac += J1[j1, r, g1 + q] * J0[j0, s, g0 + q]
        ae += J1[j1, r, g1 + 3 + q] * J0[j0, s, g0 + 3 + q]
    return wv * ac + ww * ae


@njit(cache=True, _nrt=False)
def _entry(J1, J0, kind, j1, r, j0, s, b1, b0, wv, ww):
    """J1[j1, r] W J0[j0, s]^T over one segment: the one below point j1 if b1 (else above),
    below point j0 if b0.  An end row's gradient there is a signed unit vector (``rows``):
    its products are taken in closed form; a row with no columns there gives 0."""
    k1, k0 = kind[j1, r], kind[j0, s]
    if not (has_columns(k1, b1) and has_columns(k0, b0)):
        return 0.0
    g1, g0 = (6 if b1 else 0), (6 if b0 else 0)
    if k1 < K_AXIS:
        c1, e1 = end_signs(k1, b1)
        q = k1 % 3
        if k0 < K_AXIS:
            if k0 % 3 != q:
                return 0.0
            c0, e0 = end_signs(k0, b0)
            return wv * c1 * c0 + ww * e1 * e0
        return wv * c1 * J0[j0, s, g0 + q] + ww * e1 * J0[j0, s, g0 + 3 + q]
    if k0 < K_AXIS:
        c0, e0 = end_signs(k0, b0)
        q = k0 % 3
        return wv * c0 * J1[j1, r, g1 + q] + ww * e0 * J1[j1, r, g1 + 3 + q]
    return _pair(J1, J0, j1, r, j0, s, g1, g0, wv, ww)


@njit(cache=True, _nrt=False)
def factor_blocks(anchored, J1, J0, kind, nrow, drops, F, symmetric, j_from):
    """Block LU of J1 W J0^T into F (rows of the kinds ``kind``: ``_entry``), from point
    j_from on: F holds the factors of the points before it, whose rows (and those of point
    j_from) are the same.  ``symmetric`` (J1 is J0): rows found redundant are dropped
    (F.drop); otherwise the rows dropped in ``drops`` are.  Returns the number of dropped
    rows from j_from on, or -1 if the matrix is singular to round-off (not symmetric only)."""
    D, L, X, drop, d0, off = F.D, F.L, F.X, F.drop, F.d0, F.off
    npts = nrow.shape[0]
    n = npts - 1
    ndrop = 0
    if j_from == 0:
        off[0] = 0
    for j in range(j_from, npts):  # the blocks' places, from j_from's on (before it: the same rows)
        n_above = nrow[j - 1] if j >= 1 else 0
        n_below = nrow[j + 1] if j < n else 0
        off[j + 1] = off[j] + _slot(nrow[j], n_above, n_below)
    j = j_from
    while j < npts:
        o = off[j]
        nr = nrow[j]
        if nr == 4 and kind[j, 0] == K_JOINT:  # most points: free, without a bend or floor row
            j, nd = _factor_free_points(J1, J0, kind, nrow, j, F, symmetric, drops)
            if nd < 0:
                return -1
            ndrop += nd
            continue
        # the weights of segments j - 1 and j (``core.blocks._weights``: 0 if landed or
        # outside the chain), read here: a call a point would cost numba a reference count
        ia, ic = min(max(j - 1, 0), n - 1), min(j, n - 1)
        a_out = (j < 1) | ((anchored[ia] == 1) & (anchored[ia + 1] == 1))
        c_out = (j >= n) | ((anchored[ic] == 1) & (anchored[ic + 1] == 1))
        av, aw = (0.0, 0.0) if a_out else (W_V, W_W)
        cv, cw = (0.0, 0.0) if c_out else (W_V, W_W)
        free = kind[j, 0] == K_JOINT  # the first 4 rows in closed form (``_free_point_blocks``)
        r0 = 4 if free else 0
        npv = nrow[j - 1] if j >= 1 else 0
        op = off[j - 1] if j >= 1 else 0
        if free:
            _free_point_blocks(J1, J0, npv, nr, j, o, D, L, av, aw, cv, cw)
        for r in range(nr):
            for s in range(r0 if r < r0 else 0, nr):
                D[o + r * nr + s] = _entry(J1, J0, kind, j, r, j, s, False, False, av, aw) + _entry(
                    J1, J0, kind, j, r, j, s, True, True, cv, cw
                )
        if j >= 1 and av + aw > 0.0:
            for r in range(r0, nr):
                for p in range(npv):
                    L[o + r * npv + p] = _entry(J1, J0, kind, j, r, j - 1, p, False, True, av, aw)
            for r in range(nr):
                for s in range(nr):
                    acc = 0.0
                    for p in range(npv):
                        acc += L[o + r * npv + p] * X[op + p * nr + s]
                    D[o + r * nr + s] -= acc
        elif j >= 1:
            for r in range(nr):
                for p in range(npv):
                    L[o + r * npv + p] = 0.0
        for k in range(nr):
            d0[k] = abs(D[o + k * nr + k])
        for k in range(nr):  # LU of D'_j in place, no pivoting
            d = D[o + k * nr + k]
            if symmetric:
                out = d <= DROP_RTOL * max(d0[k], 1e-300)
            else:
                out = drops[j, k] != 0
                if not out and not abs(d) > PIVOT_RTOL * d0[k]:
                    return -1
            if out:  # its unknown 0: no multipliers, inverse pivot 0 (the solves need not ask)
                drop[j, k] = 1
                ndrop += 1
                D[o + k * nr + k] = 0.0
                for i in range(k + 1, nr):
                    D[o + i * nr + k] = 0.0
                continue
            drop[j, k] = 0
            inv = 1.0 / d
            D[o + k * nr + k] = inv
            for i in range(k + 1, nr):
                f = D[o + i * nr + k] * inv
                D[o + i * nr + k] = f
                if f != 0.0:
                    for s in range(k + 1, nr):
                        D[o + i * nr + s] -= f * D[o + k * nr + s]
        if j >= 1:
            _lu_solve_columns(D, o, nr, L, npv)  # M_j = D'_j^{-1} L_j, for the solves
        if j < n:
            nn = nrow[j + 1]
            if free:
                _free_point_coupling(J1, J0, nn, j, o, X, cv, cw)
            for r in range(r0, nr):
                for s in range(nn):
                    X[o + r * nn + s] = _entry(J1, J0, kind, j, r, j + 1, s, True, False, cv, cw)
            _lu_solve_columns(D, o, nr, X, nn)
        j += 1
    return ndrop


@njit(cache=True, _nrt=False)
def _free_point_blocks(J1, J0, npv, nr, j, o, D, L, av, aw, cv, cw):
    """D_j's first 4 x 4 and L_j's first 4 rows at a free point j: its joint rows q (on the
    segment above: +1 centre, -1 axis; below: -1, -1) and the axis row of the segment
    below (E = J[j, 3, 9:12]):  D[q, q'] = delta (av + aw + cv + cw),  D[q, 3] = -cw E0_q,
    D[3, q] = -cw E1_q,  D[3, 3] = cw E1 . E0;  L[q, p] = av J0[j-1, p, 6+q] - aw
    J0[j-1, p, 9+q] (row p of point j - 1 on its segment below), L[3, p] = 0 (packed at
    the strides nr, the rows of point j, and npv, those of point j - 1, at o = off[j])."""
    dq = av + aw + cv + cw
    e11, e12, e13 = J1[j, 3, 9], J1[j, 3, 10], J1[j, 3, 11]
    e01, e02, e03 = J0[j, 3, 9], J0[j, 3, 10], J0[j, 3, 11]
    for q in range(3):
        for s in range(3):
            D[_u(o + q * nr + s)] = dq if q == s else 0.0
    D[_u(o + 3)], D[_u(o + nr + 3)], D[_u(o + 2 * nr + 3)] = -cw * e01, -cw * e02, -cw * e03
    D[_u(o + 3 * nr)], D[_u(o + 3 * nr + 1)], D[_u(o + 3 * nr + 2)] = -cw * e11, -cw * e12, -cw * e13
    D[_u(o + 3 * nr + 3)] = cw * (e11 * e01 + e12 * e02 + e13 * e03)
    for p in range(npv):  # (npv: the rows of point j - 1, 0 at the top)
        for q in range(3):
            L[_u(o + q * npv + p)] = av * J0[j - 1, p, 6 + q] - aw * J0[j - 1, p, 9 + q]
        L[_u(o + 3 * npv + p)] = 0.0


@njit(cache=True, _nrt=False)
def _free_point_coupling(J1, J0, nn, j, o, X, cv, cw):
    """U_j's first 4 rows at a free point j (``_free_point_blocks``), against the rows s of
    point j + 1 on their segment above (J0[j+1, s, 0:6]):  U[q, s] = -cv J0[j+1, s, q] - cw
    J0[j+1, s, 3+q],  U[3, s] = cw E1 . J0[j+1, s, 3:6] (packed at the stride nn, at o = off[j])."""
    e11, e12, e13 = J1[j, 3, 9], J1[j, 3, 10], J1[j, 3, 11]
    for s in range(nn):  # (nn: the rows of point j + 1)
        for q in range(3):
            X[_u(o + q * nn + s)] = -cv * J0[j + 1, s, q] - cw * J0[j + 1, s, 3 + q]
        X[_u(o + 3 * nn + s)] = cw * (e11 * J0[j + 1, s, 3] + e12 * J0[j + 1, s, 4] + e13 * J0[j + 1, s, 5])


@njit(cache=True, _nrt=False)
def _factor_free_points(J1, J0, kind, nrow, j0, F, symmetric, drops):
    """``factor_blocks`` at the free points with their 4 rows only (joints, the axis
    below) from j0 on, as long as they last: the blocks of ``_free_point_blocks`` and
    ``_free_point_coupling``, whose structure leaves L_j X_{j-1} in the joints' 3 x 3
    (L_j's axis row is 0; X_{j-1}'s axis column is 0: the axis below j has no columns on
    the segment above it), loops of fixed length.  One call a run of such points, not one
    a point: a call that takes the arrays costs numba a reference count of each.  Returns
    (the first point after the run, the number of dropped rows), or (j, -1) where the
    matrix is singular (not symmetric)."""
    D, L, X, drop, off = F.D, F.L, F.X, F.drop, F.off
    npts = nrow.shape[0]
    n = npts - 1
    ndrop = 0
    j = j0
    wv, ww = W_V, W_W  # both segments' weights (a point with joint rows is free: neither segment at it has landed)
    while j < npts and nrow[j] == 4 and kind[j, 0] == K_JOINT:
        npv = nrow[j - 1] if j >= 1 else 0
        o, op = off[j], (off[j - 1] if j >= 1 else 0)
        _free_point_blocks(J1, J0, npv, 4, j, o, D, L, wv, ww, wv, ww)
        for r in range(3):
            for s in range(3):
                acc = 0.0
                for p in range(npv):
                    acc += L[_u(o + r * npv + p)] * X[_u(op + p * 4 + s)]
                D[_u(o + r * 4 + s)] -= acc
        d00, d11, d22, d33 = abs(D[_u(o)]), abs(D[_u(o + 5)]), abs(D[_u(o + 10)]), abs(D[_u(o + 15)])
        nd = 0
        for k in range(4):
            d = D[_u(o + k * 5)]
            dk0 = d00 if k == 0 else (d11 if k == 1 else (d22 if k == 2 else d33))
            if symmetric:
                out = d <= DROP_RTOL * max(dk0, 1e-300)
            else:
                out = drops[j, k] != 0
                if not out and not abs(d) > PIVOT_RTOL * dk0:
                    return j, -1
            if out:
                drop[j, k] = 1
                nd += 1
                D[_u(o + k * 5)] = 0.0
                for i in range(k + 1, 4):
                    D[_u(o + i * 4 + k)] = 0.0
                continue
            drop[j, k] = 0
            inv = 1.0 / d
            D[_u(o + k * 5)] = inv
            for i in range(k + 1, 4):
                f = D[_u(o + i * 4 + k)] * inv
                D[_u(o + i * 4 + k)] = f
                for c in range(k + 1, 4):
                    D[_u(o + i * 4 + c)] -= f * D[_u(o + k * 4 + c)]
        for p in range(npv):  # M_j = D'_j^{-1} L_j, for the solves
            L[_u(o + p)], L[_u(o + npv + p)], L[_u(o + 2 * npv + p)], L[_u(o + 3 * npv + p)] = _lu4_solve(
                D, o, L[_u(o + p)], L[_u(o + npv + p)], L[_u(o + 2 * npv + p)], L[_u(o + 3 * npv + p)]
            )
        if j < n:
            nn = nrow[j + 1]
            _free_point_coupling(J1, J0, nn, j, o, X, wv, ww)
            for s in range(nn):
                X[_u(o + s)], X[_u(o + nn + s)], X[_u(o + 2 * nn + s)], X[_u(o + 3 * nn + s)] = _lu4_solve(
                    D, o, X[_u(o + s)], X[_u(o + nn + s)], X[_u(o + 2 * nn + s)], X[_u(o + 3 * nn + s)]
                )
        ndrop += nd
        j += 1
    return j, ndrop


@njit(cache=True, _nrt=False)
def _lu_solve_columns(D, o, nr, X, nn):
    """The block at o of X <- D'_j^{-1} times it (D'_j's LU at o of D; nn columns; a
    dropped row comes out 0: its inverse pivot is 0 and its column of l is 0)."""
    for k in range(nr):
        for i in range(k + 1, nr):
            f = D[o + i * nr + k]
            if f != 0.0:
                for s in range(nn):
                    X[o + i * nn + s] -= f * X[o + k * nn + s]
    for k in range(nr - 1, -1, -1):
        for c in range(k + 1, nr):
            f = D[o + k * nr + c]
            if f != 0.0:
                for s in range(nn):
                    X[o + k * nn + s] -= f * X[o + c * nn + s]
        inv = D[o + k * nr + k]
        for s in range(nn):
            X[o + k * nn + s] *= inv


@njit(cache=True, _nrt=False)
def solve_blocks(nrow, F, b, x):
    """x = A^{-1} b with the factors of ``factor_blocks`` (dropped rows: x = 0):
    z_j = D'_j^{-1} b_j - M_j z_{j-1} down the chain (only the product with z_{j-1} waits
    on the point before), then x_j = z_j - X_j x_{j+1} up it."""
    D, M, X, off = F.D, F.L, F.X, F.off
    npts = nrow.shape[0]
    for j in range(npts):
        nr = nrow[j]
        o = off[j]
        npv = nrow[j - 1] if j >= 1 else 0
        if nr == 4:  # most points: loops of fixed length (written out here, not a helper's:
            # a helper taking the arrays costs numba a reference count per point)
            x0, x1, x2, x3 = _lu4_solve(D, o, b[j, 0], b[j, 1], b[j, 2], b[j, 3])
            if npv == 4:
                z0, z1, z2, z3 = x[j - 1, 0], x[j - 1, 1], x[j - 1, 2], x[j - 1, 3]
                x0 -= M[_u(o + 0)] * z0 + M[_u(o + 1)] * z1 + M[_u(o + 2)] * z2 + M[_u(o + 3)] * z3
                x1 -= M[_u(o + 4)] * z0 + M[_u(o + 5)] * z1 + M[_u(o + 6)] * z2 + M[_u(o + 7)] * z3
                x2 -= M[_u(o + 8)] * z0 + M[_u(o + 9)] * z1 + M[_u(o + 10)] * z2 + M[_u(o + 11)] * z3
                x3 -= M[_u(o + 12)] * z0 + M[_u(o + 13)] * z1 + M[_u(o + 14)] * z2 + M[_u(o + 15)] * z3
            else:
                for p in range(npv):
                    zp = x[j - 1, p]
                    x0 -= M[_u(o + p)] * zp
                    x1 -= M[_u(o + npv + p)] * zp
                    x2 -= M[_u(o + 2 * npv + p)] * zp
                    x3 -= M[_u(o + 3 * npv + p)] * zp
            x[j, 0], x[j, 1], x[j, 2], x[j, 3] = x0, x1, x2, x3
            continue
        for r in range(nr):
            x[j, r] = b[j, r]
        for k in range(nr):
            xk = x[j, k]
            for i in range(k + 1, nr):
                x[j, i] -= D[o + i * nr + k] * xk
        for k in range(nr - 1, -1, -1):
            s = x[j, k]
            for c in range(k + 1, nr):
                s -= D[o + k * nr + c] * x[j, c]
            x[j, k] = s * D[o + k * nr + k]
        for r in range(nr):
            acc = 0.0
            for p in range(npv):
                acc += M[o + r * npv + p] * x[j - 1, p]
            x[j, r] -= acc
    for j in range(npts - 2, -1, -1):
        nn = nrow[j + 1]
        o = off[j]
        if nrow[j] == 4 and nn == 4:
            for r in range(4):
                x[j, r] -= (
                    X[_u(o + 4 * r)] * x[j + 1, 0]
                    + X[_u(o + 4 * r + 1)] * x[j + 1, 1]
                    + X[_u(o + 4 * r + 2)] * x[j + 1, 2]
                    + X[_u(o + 4 * r + 3)] * x[j + 1, 3]
                )
            continue
        for r in range(nrow[j]):
            acc = 0.0
            for s in range(nn):
                acc += X[o + r * nn + s] * x[j + 1, s]
            x[j, r] -= acc


@njit(cache=True, inline="always")
def _lu4_solve(D, o, x0, x1, x2, x3):
    """D'_j^{-1} (x0, x1, x2, x3) for a point of 4 rows: l (unit lower) then u (its
    inverse pivots on the diagonal), as ``factor_blocks`` left them in D at o (packed 4 x 4)."""
    x1 -= D[_u(o + 4)] * x0
    x2 -= D[_u(o + 8)] * x0 + D[_u(o + 9)] * x1
    x3 -= D[_u(o + 12)] * x0 + D[_u(o + 13)] * x1 + D[_u(o + 14)] * x2
    x3 *= D[_u(o + 15)]
    x2 = (x2 - D[_u(o + 11)] * x3) * D[_u(o + 10)]
    x1 = (x1 - D[_u(o + 6)] * x2 - D[_u(o + 7)] * x3) * D[_u(o + 5)]
    x0 = (x0 - D[_u(o + 1)] * x1 - D[_u(o + 2)] * x2 - D[_u(o + 3)] * x3) * D[_u(o + 0)]
    return x0, x1, x2, x3
