"""Linear complementarity problems: the pivoting driver both impact problems use, and
Lemke's method for the dense fallback (numba).

The LCP  w = q + M z >= 0, z >= 0, w . z = 0  over the hinges at their limit is solved by
principal pivoting on the active set (``next_active_set``): block pivoting (flip every
violated index) while the number of violations falls, then Murty's least-index rule.
Each trial active set costs the caller one O(N) factorisation.  Murty's rule is finite
only for P-matrices in exact arithmetic; the matrices here are only positive
semidefinite, so the driver remembers the sets it tried: a repeated set (cycling) or
PIVOT_BUDGET trials hand the problem to the caller's dense fallback, ``dense_lcp``
(Lemke's method with lexicographic ratio test on a regularised dense problem, finite for
that P-matrix).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..jit import njit

PIVOT_BUDGET = 200  # principal-pivoting trials before the dense fallback
REG_RTOL = 1e-10  # fallback: delta = REG_RTOL * max diag M (makes M + delta I positive definite)
FROZEN_RTOL = 1e-9  # fallback: M_kk below this fraction of its unconstrained value: row k is redundant
PIVOT_NEXT, PIVOT_FALLBACK = 0, 1
_HKEY = np.uint64(0x9E3779B97F4A7C15)

# The principal-pivoting driver's memory: the violated indices of the last trial, the
# fingerprints of the sets tried, and its progress counters (1-element arrays).
Pivoting = namedtuple("Pivoting", ["viol", "hist", "nhist", "best", "stall", "murty"])


@njit(cache=True, _nrt=True)
def new_pivoting(nh):
    """A fresh driver for an LCP over nh indices."""
    return Pivoting(
        np.zeros(max(nh, 1), dtype=np.uint8),
        np.zeros(PIVOT_BUDGET + 1, dtype=np.uint64),
        np.zeros(1, np.int64),
        np.full(1, 1 << 60, np.int64),
        np.zeros(1, np.int64),
        np.zeros(1, np.uint8),
    )


@njit(cache=True, _nrt=False)
def _pivot_update(active, viol, use_murty):
    """Flip violated indices: all of them (block pivoting) or the least one (Murty)."""
    if use_murty:
        for k in range(viol.shape[0]):
            if viol[k]:
                active[k] = 1 - active[k]
                return
    else:
        for k in range(viol.shape[0]):
            if viol[k]:
                active[k] = 1 - active[k]


@njit(cache=True, _nrt=False)
def _set_hash(active, nh):
    """64-bit fingerprint of the active set (a collision only calls the fallback early)."""
    h = np.uint64(1469598103934665603)
    for k in range(nh):
        if active[k]:
            h = (h ^ np.uint64(k + 1)) * _HKEY
            h ^= h >> np.uint64(29)
    return h


@njit(cache=True, _nrt=False)
def _seen(hist, nhist, h):
    for i in range(nhist):
        if hist[i] == h:
            return True
    return False


@njit(cache=True, _nrt=False)
def next_active_set(piv, active, nh, nviol):
    """After a trial of ``active`` with ``nviol`` violations (marked in ``piv.viol``):
    PIVOT_FALLBACK if the set was tried before (cycling) or the budget is spent, else
    flip the violated indices (block pivoting; Murty's least index once the count of
    violations has not fallen for three trials) and return PIVOT_NEXT."""
    h = _set_hash(active, nh)
    if piv.nhist[0] >= PIVOT_BUDGET or _seen(piv.hist, piv.nhist[0], h):
        return PIVOT_FALLBACK
    piv.hist[piv.nhist[0]] = h
    piv.nhist[0] += 1
    if nviol < piv.best[0]:
        piv.best[0] = nviol
        piv.stall[0] = 0
    else:
        piv.stall[0] += 1
        if piv.stall[0] >= 3:
            piv.murty[0] = 1
    _pivot_update(active, piv.viol, piv.murty[0] != 0)
    return PIVOT_NEXT


@njit(cache=True, _nrt=False)
def candidates(cand, forced, idx):
    """idx[:c] = the candidate indices that are not held (``forced``); returns c."""
    c = 0
    for k in range(cand.shape[0]):
        if cand[k] and not forced[k]:
            idx[c] = k
            c += 1
    return c


@njit(cache=True, _nrt=False)
def symmetrise(M, c):
    """M[:c, :c] <- (M + M^T) / 2: a Delassus matrix built column by column, its round-off
    made symmetric."""
    for ii in range(c):
        for jj in range(ii):
            m = 0.5 * (M[ii, jj] + M[jj, ii])
            M[ii, jj] = m
            M[jj, ii] = m


@njit(cache=True, _nrt=True)
def _lemke(M, q, c, z):
    """Solve the LCP  w = q + M z >= 0, z >= 0, w.z = 0  (c x c, M a P-matrix) by
    Lemke's complementary pivoting with the lexicographic ratio test (no cycling:
    finite in exact arithmetic, at most one visit per basis).  z[:c] gets the
    solution.  Returns the number of pivots, -1 on ray termination (not for a
    P-matrix) or when the (generous) iteration cap is hit."""
    for i in range(c):
        z[i] = 0.0
    imin = -1
    qmin = 0.0
    for i in range(c):
        if q[i] < qmin:
            qmin = q[i]
            imin = i
    if imin < 0:
        return 0  # z = 0 solves it
    # tableau [I | -M | -1 | q]: columns 0..c-1 w, c..2c-1 z, 2c z0, 2c+1 rhs
    nc = 2 * c + 2
    T = np.zeros((c, nc))
    basis = np.empty(c, dtype=np.int64)
    for i in range(c):
        T[i, i] = 1.0
        for j in range(c):
            T[i, c + j] = -M[i, j]
        T[i, 2 * c] = -1.0
        T[i, 2 * c + 1] = q[i]
        basis[i] = i
    scale = 0.0
    for i in range(c):
        for j in range(c):
            scale = max(scale, abs(M[i, j]))
    piv_tol = 1e-13 * max(scale, 1.0)
    entering = 2 * c
    # lexicographically most negative row for the artificial variable z0
    r = imin
    for i in range(c):
        if i != r and q[i] <= q[r]:
            better = q[i] < q[r]
            if not better:  # tie: lexicographic on the rows of B^{-1} = I: the larger index
                better = i > r
            if better:
                r = i
    max_it = 50 * (c + 1) * (c + 1)
    for it in range(max_it):
        # pivot on (r, entering)
        p = T[r, entering]
        for j in range(nc):
            T[r, j] /= p
        for i in range(c):
            if i != r:
                f = T[i, entering]
                if f != 0.0:
                    for j in range(nc):
                        T[i, j] -= f * T[r, j]
        leaving = basis[r]
        basis[r] = entering
        if leaving == 2 * c:
            for i in range(c):
                if basis[i] >= c and basis[i] < 2 * c:
                    z[basis[i] - c] = max(T[i, 2 * c + 1], 0.0)
            return it + 1
        entering = leaving + c if leaving < c else leaving - c
        # lexicographic minimum ratio test over rows with a positive pivot entry
        r = -1
        for i in range(c):
            if T[i, entering] > piv_tol:
                if r < 0:
                    r = i
                    continue
                a = T[i, entering]
                b = T[r, entering]
                d = T[i, 2 * c + 1] / a - T[r, 2 * c + 1] / b
                if d == 0.0:
                    if basis[i] == 2 * c:  # z0 leaves as soon as it can
                        r = i
                        continue
                    if basis[r] == 2 * c:
                        continue
                    for j in range(c):
                        d = T[i, j] / a - T[r, j] / b
                        if d != 0.0:
                            break
                if d < 0.0:
                    r = i
        if r < 0:
            return -1  # secondary ray
    return -1


@njit(cache=True, _nrt=True)
def dense_lcp(M, q, c, idx, active, tol, dref):
    """Fallback: active[idx] <- the solution set of LCP(M + delta I, q + tol) over the
    rows that are not redundant, a positive definite problem (delta = REG_RTOL max
    diag M).  A row with M_kk <= FROZEN_RTOL dref_k is a combination of the equality
    rows (M PSD: its whole row and column vanish): no multiplier can move g_k, so
    lambda_k = 0 and the hinge stays unlocked (g_k'' = q_k, round-off).  The shift tol
    (the acceptance tolerance) absorbs the round-off of q.  Returns Lemke's pivot
    count (-1: failure)."""
    keep = np.empty(c, dtype=np.int64)
    m = np.int64(0)
    dmax = 0.0
    for i in range(c):
        active[idx[i]] = 0
        if M[i, i] > FROZEN_RTOL * dref[i]:
            keep[m] = i
            m += 1
            dmax = max(dmax, M[i, i])
    delta = REG_RTOL * max(dmax, 1.0)
    Mr = np.empty((m, m))
    qr = np.empty(m)
    for i in range(m):
        for j in range(m):
            Mr[i, j] = M[keep[i], keep[j]]
        Mr[i, i] += delta
        qr[i] = q[keep[i]] + tol
    z = np.zeros(m)
    piv = _lemke(Mr, qr, m, z)
    if piv < 0:
        return -1
    for i in range(m):
        active[idx[keep[i]]] = 1 if z[i] > 0.0 else 0
    return piv
