"""Stage 1's Newton matrix: A = J(q+) W J(q)^T, block tridiagonal and not symmetric.

Stage 1 solves g(q_free + h W J(q)^T P) = 0 for the impulses P; its exact Newton matrix
is h J(q+) W J(q)^T.  The symmetric J(q) W J(q)^T (``dynamics.factor_general``) differs
from it by O(h |u|) but its inverse amplifies that by the condition number, which grows
with the length of a locked stretch of chain: a chord iteration on it crawls (a spectral
radius of 0.7 at N = 8), so stage 1 factors A itself (block LU, partial pivoting within
the blocks).  Rows that the symmetric factorisation found redundant (``drop``) are left
out (their impulses 0), as there.  Blocks per point j (rows of j, impulses of j or j+1):

  D_j = J1_j W J0_j^T,   U_j = J1_j^(c) W_j J0_{j+1}^(a)T,   L_j = J1_{j+1}^(a) W_j J0_j^(c)T
  D'_j = D_j - L_{j-1} X_{j-1},   X_j = D'_j^{-1} U_j
  z_j = D'_j^{-1} (b_j - L_{j-1} z_{j-1}),   x_j = z_j - X_j x_{j+1}
"""

from __future__ import annotations

from ...core.dynamics import _weights
from ...core.jit import njit

PIVOT_RTOL = 1e-12  # a pivot below this fraction of its block's largest entry: A is taken as singular


@njit(cache=True)
def _lu(D, j, nr, piv):
    """LU of D[j] (nr x nr) in place, partial pivoting (row swaps in piv[j]); False if a
    pivot is below PIVOT_RTOL of the block's largest entry (singular to round-off)."""
    scale = 0.0
    for r in range(nr):
        for c in range(nr):
            scale = max(scale, abs(D[j, r, c]))
    for k in range(nr):
        p = k
        big = abs(D[j, k, k])
        for i in range(k + 1, nr):
            if abs(D[j, i, k]) > big:
                big, p = abs(D[j, i, k]), i
        piv[j, k] = p
        if p != k:
            for s in range(nr):
                D[j, k, s], D[j, p, s] = D[j, p, s], D[j, k, s]
        d = D[j, k, k]
        if abs(d) <= PIVOT_RTOL * scale:
            return False
        for i in range(k + 1, nr):
            f = D[j, i, k] / d
            D[j, i, k] = f
            for s in range(k + 1, nr):
                D[j, i, s] -= f * D[j, k, s]
    return True


@njit(cache=True)
def _lu_solve(D, j, nr, piv, b):
    """b <- D'[j]^{-1} b with the factors of ``_lu``."""
    for k in range(nr):
        p = piv[j, k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(nr):
        s = b[i]
        for k in range(i):
            s -= D[j, i, k] * b[k]
        b[i] = s
    for i in range(nr - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, nr):
            s -= D[j, i, k] * b[k]
        b[i] = s / D[j, i, i]


@njit(cache=True, inline="always")
def _lower(J0, J1, j, r, p, wv, ww):
    """L_{j-1}[r, p]: row r of point j (its segment above, j - 1) against impulse p of point j - 1."""
    acc = 0.0
    for q in range(3):
        acc += wv * J1[j, r, q] * J0[j - 1, p, 6 + q] + ww * J1[j, r, 3 + q] * J0[j - 1, p, 9 + q]
    return acc


@njit(cache=True)
def factor_newton(anchored, ws):
    """Block LU of A = J1 W J^T (``rows.Rows``: ws.J1 the rows at q+, ws.J at q) into ws
    (D, piv, X, and the lower blocks Lb for the solves); False if A is singular to round-off (then the caller keeps to J W J^T)."""
    J0, J1, nrow, drop, D, piv, X, Lb, col = ws.J, ws.J1, ws.nrow, ws.drop, ws.D, ws.piv, ws.X, ws.Lb, ws.col
    npts = nrow.shape[0]
    n = npts - 1
    for j in range(npts):
        nr = nrow[j]
        av, aw = _weights(anchored, j - 1, n)
        cv, cw = _weights(anchored, j, n)
        for r in range(nr):
            for s in range(nr):
                acc = 0.0
                for q in range(3):
                    acc += (
                        av * J1[j, r, q] * J0[j, s, q]
                        + aw * J1[j, r, 3 + q] * J0[j, s, 3 + q]
                        + cv * J1[j, r, 6 + q] * J0[j, s, 6 + q]
                        + cw * J1[j, r, 9 + q] * J0[j, s, 9 + q]
                    )
                D[j, r, s] = acc
        if j >= 1:
            for r in range(nr):
                for p in range(nrow[j - 1]):
                    lv = 0.0 if drop[j, r] else _lower(J0, J1, j, r, p, av, aw)
                    Lb[j, r, p] = lv
                    if lv != 0.0:
                        for s in range(nr):
                            D[j, r, s] -= lv * X[j - 1, p, s]
        for r in range(nr):
            if drop[j, r]:
                for s in range(nr):
                    D[j, r, s] = 0.0
                    D[j, s, r] = 0.0
                D[j, r, r] = 1.0
        if not _lu(D, j, nr, piv):
            return False
        if j < npts - 1:
            for s in range(nrow[j + 1]):
                for r in range(nr):
                    acc = 0.0
                    if not (drop[j, r] or drop[j + 1, s]):
                        for q in range(3):
                            acc += cv * J1[j, r, 6 + q] * J0[j + 1, s, q] + cw * J1[j, r, 9 + q] * J0[j + 1, s, 3 + q]
                    col[r] = acc
                _lu_solve(D, j, nr, piv, col)
                for r in range(nr):
                    X[j, r, s] = col[r]
    return True


@njit(cache=True)
def solve_newton(ws, b, x):
    """x = A^{-1} b with the factors of ``factor_newton`` (dropped rows: x = 0)."""
    nrow, drop, D, piv, X, Lb, col = ws.nrow, ws.drop, ws.D, ws.piv, ws.X, ws.Lb, ws.col
    npts = nrow.shape[0]
    for j in range(npts):
        nr = nrow[j]
        for r in range(nr):
            v = 0.0 if drop[j, r] else b[j, r]
            if j >= 1 and not drop[j, r]:
                for p in range(nrow[j - 1]):
                    v -= Lb[j, r, p] * x[j - 1, p]
            col[r] = v
        _lu_solve(D, j, nr, piv, col)
        for r in range(nr):
            x[j, r] = col[r]
    for j in range(npts - 2, -1, -1):
        for r in range(nrow[j]):
            acc = 0.0
            for s in range(nrow[j + 1]):
                acc += X[j, r, s] * x[j + 1, s]
            x[j, r] -= acc
