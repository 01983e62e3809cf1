"""Impacts and the locked set (docs/model.md, section 3), numba kernels, nondimensional.

Velocity level (Moreau / Gauss): the post-impact velocity is the one closest to the
pre-impact one in the kinetic-energy metric such that every hinge stays joined, every
anchored point is at rest and every hinge at its limit has dg/dt >= 0.  With impulses
Lambda on the candidate hinges this is the LCP

    Lambda >= 0,  dg/dt+ = dg/dt- + (J W J^T Lambda)_lock >= 0,  Lambda . dg/dt+ = 0,

with the hinge and anchor rows as equalities.  Acceleration level (which locks hold):

    lambda >= 0,  d2g/dt2 >= 0,  lambda . d2g/dt2 = 0   over hinges at the limit with dg/dt = 0.

Both are solved by principal pivoting on the active set: block pivoting (flip every
violated index) while the number of violations falls, then Murty's least-index rule.
Each trial active set costs one O(N) factorisation.  Murty's rule is finite only for
P-matrices in exact arithmetic; the matrix here, M = J_L W_eff J_L^T (W_eff: the
inverse mass reduced by the equality rows), is only positive semidefinite, singular
when a lock row depends on the anchor/hinge rows (rules.limit_in_force removes the
structural case: two segments spanning two anchors) and near-singular in rare configurations.  So (i) the
complementarity tests use tolerances scaled to the size of the multipliers and
accelerations (round-off of the O(N) solve, not an absolute 1e-11), and (ii) the
pivoting remembers the sets it tried: a repeated set (cycling) or PIVOT_BUDGET trials
hand the problem to ``_lemke``, Lemke's method with lexicographic ratio test on the
dense c x c problem (M + delta I, q + tau) over the c candidates, finite for that
P-matrix; M costs one factorisation and c solves.
"""

from __future__ import annotations

import numpy as np
from .jit import entry, njit

from .dynamics import (
    ROW_ANCHOR_LOWER,
    ROW_ANCHOR_UPPER,
    ROW_LOCK,
    accelerations,
    apply_impulses,
    build_rows,
    constraint_rates4,
    constraint_rows,
    constraint_velocities,
    factor,
    solve,
    torque_jump,
    torques4,
    W_W,
)
from .rules import RATE_TOL

MULT_TOL = 1e-11  # absolute floor of the complementarity tolerances
MULT_RTOL = 1e-10  # tolerance relative to the largest multiplier / acceleration at stake
PIVOT_BUDGET = 200  # principal-pivoting trials before the dense fallback
REG_RTOL = 1e-10  # fallback: delta = REG_RTOL * max diag M (makes M + delta I positive definite)
FROZEN_RTOL = 1e-9  # fallback: M_kk below this fraction of its unconstrained value: row k is redundant
_HKEY = np.uint64(0x9E3779B97F4A7C15)


@entry
@njit(cache=True)
def hinge_gaps(e, cos_alpha, out):
    """g_k = e_k . e_{k+1} - cos(alpha)."""
    for k in range(out.shape[0]):
        out[k] = e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2] - cos_alpha


@njit(cache=True)
def hinge_rates(e, w, out):
    """dg_k/dt = (w_k x e_k) . e_{k+1} + e_k . (w_{k+1} x e_{k+1})."""
    for k in range(out.shape[0]):
        a, c = k, k + 1
        dax = w[a, 1] * e[a, 2] - w[a, 2] * e[a, 1]
        day = w[a, 2] * e[a, 0] - w[a, 0] * e[a, 2]
        daz = w[a, 0] * e[a, 1] - w[a, 1] * e[a, 0]
        dcx = w[c, 1] * e[c, 2] - w[c, 2] * e[c, 1]
        dcy = w[c, 2] * e[c, 0] - w[c, 0] * e[c, 2]
        dcz = w[c, 0] * e[c, 1] - w[c, 1] * e[c, 0]
        out[k] = dax * e[c, 0] + day * e[c, 1] + daz * e[c, 2] + e[a, 0] * dcx + e[a, 1] * dcy + e[a, 2] * dcz


@njit(cache=True)
def hinge_accels(e, w, de, dw, out):
    """d2g_k/dt2 = dde_k . e_{k+1} + 2 de_k . de_{k+1} + e_k . dde_{k+1}, dde = dw x e + w x de."""
    for k in range(out.shape[0]):
        acc = 0.0
        a, c = k, k + 1
        for q in range(3):
            q1 = (q + 1) % 3
            q2 = (q + 2) % 3
            dda = dw[a, q1] * e[a, q2] - dw[a, q2] * e[a, q1] + w[a, q1] * de[a, q2] - w[a, q2] * de[a, q1]
            ddc = dw[c, q1] * e[c, q2] - dw[c, q2] * e[c, q1] + w[c, q1] * de[c, q2] - w[c, q2] * de[c, q1]
            acc += dda * e[c, q] + 2.0 * de[a, q] * de[c, q] + e[a, q] * ddc
        out[k] = acc


@njit(cache=True)
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


@njit(cache=True)
def _set_hash(active, nh):
    """64-bit fingerprint of the active set (a collision only calls the fallback early)."""
    h = np.uint64(1469598103934665603)
    for k in range(nh):
        if active[k]:
            h = (h ^ np.uint64(k + 1)) * _HKEY
            h ^= h >> np.uint64(29)
    return h


@njit(cache=True)
def _seen(hist, nhist, h):
    for i in range(nhist):
        if hist[i] == h:
            return True
    return False


@njit(cache=True)
def _candidates(cand, forced, idx):
    """idx[:c] = the candidate hinges (limits in force) that are not held; returns c."""
    c = 0
    for k in range(cand.shape[0]):
        if cand[k] and not forced[k]:
            idx[c] = k
            c += 1
    return c


@njit(cache=True)
def _delassus(e, w, anchored, base, idx, c, J, kind, nrow, S, G, drop, rhs, x, gf, wt, col, M, dref):
    """M[:c, :c] = J_L W_eff J_L^T over the hinges idx[:c]: column j = the hinge rates
    that a unit lock impulse on hinge idx[j] produces once the equality rows (hinges,
    anchors, and the locks ``base`` held whatever their sign) have reacted.  One
    factorisation, c O(N) solves; symmetrised.  dref[j] = J_L W J_L^T for row j alone
    (before the equality rows react)."""
    n = e.shape[0]
    build_rows(e, w, anchored, base, J, kind, nrow, rhs, np.bool_(False))
    factor(e, anchored, J, kind, nrow, S, G, drop)
    for jj in range(c):
        k = idx[jj]
        for i in range(n):
            for q in range(3):
                wt[i, q] = 0.0
        nx = e[k, 1] * e[k + 1, 2] - e[k, 2] * e[k + 1, 1]
        ny = e[k, 2] * e[k + 1, 0] - e[k, 0] * e[k + 1, 2]
        nz = e[k, 0] * e[k + 1, 1] - e[k, 1] * e[k + 1, 0]
        dref[jj] = 0.0
        if not (anchored[k] != 0 and anchored[k + 1] != 0):
            dref[jj] += W_W * (nx * nx + ny * ny + nz * nz)
            wt[k, 0] = W_W * nx
            wt[k, 1] = W_W * ny
            wt[k, 2] = W_W * nz
        if not (anchored[k + 1] != 0 and anchored[k + 2] != 0):
            dref[jj] += W_W * (nx * nx + ny * ny + nz * nz)
            wt[k + 1, 0] = -W_W * nx
            wt[k + 1, 1] = -W_W * ny
            wt[k + 1, 2] = -W_W * nz
        # rates of the equality rows under this (v = 0, w = wt) jump, then their reaction
        for j in range(nrow.shape[0]):
            for r in range(nrow[j]):
                acc = 0.0
                if j >= 1:
                    for q in range(3):
                        acc += J[j, r, 3 + q] * wt[j - 1, q]
                if j < n:
                    for q in range(3):
                        acc += J[j, r, 9 + q] * wt[j, q]
                rhs[j, r] = -acc
        solve(nrow, S, G, drop, rhs, x)
        apply_impulses(e, wt, anchored, J, nrow, x, gf, 1.0)
        hinge_rates(e, wt, col)
        for ii in range(c):
            M[ii, jj] = col[idx[ii]]
    for ii in range(c):
        for jj in range(ii):
            m = 0.5 * (M[ii, jj] + M[jj, ii])
            M[ii, jj] = m
            M[jj, ii] = m


@njit(cache=True)
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


@njit(cache=True)
def _dense_lcp(M, q, c, idx, active, tol, dref):
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


@njit(cache=True)
def _dense_fallback(e, w, anchored, base, idx, c, q_all, tol, J, kind, nrow, S, G, drop, rhs, x, gf, active):
    """The LCP over the candidates idx[:c] as one dense problem (``_delassus``, then
    ``_dense_lcp``): q = q_all[idx] (the rates or accelerations with no candidate
    active), the locks ``base`` held throughout.  Sets active[idx]; returns Lemke's pivot
    count (-1: failure)."""
    n = e.shape[0]
    q0 = np.empty(c)
    for i in range(c):
        q0[i] = q_all[idx[i]]
    M = np.empty((c, c))
    dref = np.empty(c)
    _delassus(e, w, anchored, base, idx, c, J, kind, nrow, S, G, drop, rhs, x, gf, np.empty((n, 3)),
              np.empty(max(n - 1, 1)), M, dref)
    return _dense_lcp(M, q0, c, idx, active, tol, dref)


@njit(cache=True)
def _impact_trial(e, w, anchored, active, J, kind, nrow, S, G, drop, rhs, x, gf, pv, vel, jv_minus, w_plus,
                  rates):
    """Post-impact velocity w_plus and hinge rates for the lock set ``active``: the
    impulses x solve (J W J^T) x = -J v-, and w+ = w- + W J^T x."""
    n = e.shape[0]
    for i in range(n):
        for q in range(3):
            w_plus[i, q] = w[i, q]
    fits = constraint_rows(e, w, anchored, active, J, kind, nrow, rhs)
    if fits:
        constraint_rates4(e, w, anchored, kind, nrow, pv, vel, jv_minus)
    else:
        constraint_velocities(e, w, J, nrow, pv, vel, jv_minus)
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            rhs[j, r] = -jv_minus[j, r]
    factor(e, anchored, J, kind, nrow, S, G, drop)
    solve(nrow, S, G, drop, rhs, x)
    if fits:
        torques4(e, kind, nrow, x, gf)
        torque_jump(e, w_plus, anchored, gf, 1.0)
    else:
        apply_impulses(e, w_plus, anchored, J, nrow, x, gf, 1.0)
    hinge_rates(e, w_plus, rates)


@njit(cache=True)
def velocity_impact(e, w, anchored, cand, forced, active, J, kind, nrow, S, G, drop, rhs, x, gf, pv, vel,
                    jv_minus, w_plus, rates, impulse, anchor_impulse, energy_split):
    """Moreau's inelastic impact.  ``cand[k]``: hinge k at its limit, its limit in force
    (a candidate); ``forced[k]``: a candidate held at its limit whatever the sign of its
    impulse (the accumulation rule, ``rules.must_hold``); ``active`` on entry: initial
    guess (e.g. locked or approaching hinges), on exit: the hinges that carry an
    impulse or stay at the limit.  ``anchored`` includes the points
    that just touched the floor.  On exit ``w`` holds the post-impact angular velocities,
    ``impulse[k]`` the lock impulses, ``anchor_impulse[j]`` the floor impulses,
    ``energy_split`` = (lost to locking, lost to landing): their sum is the kinetic
    energy lost (>= 0); a share alone can be negative when one impact both lands and
    locks (a hinge that was opening is held at its limit).
    Returns the number of trials (negative if the pivoting did not converge)."""
    n = e.shape[0]
    nh = n - 1
    viol = np.zeros(max(nh, 1), dtype=np.uint8)
    hist = np.zeros(PIVOT_BUDGET + 1, dtype=np.uint64)
    nhist = np.int64(0)
    best = 1 << 60
    stall = 0
    use_murty = False
    final = False  # the set came from the dense fallback: accept it
    for it in range(PIVOT_BUDGET + 3):
        _impact_trial(e, w, anchored, active, J, kind, nrow, S, G, drop, rhs, x, gf, pv, vel, jv_minus, w_plus,
                      rates)
        for k in range(nh):
            viol[k] = 0
            impulse[k] = 0.0
        lmax = 0.0
        for k in range(nh):
            if active[k]:
                lam = 0.0
                for r in range(nrow[k + 1]):
                    if kind[k + 1, r] == ROW_LOCK:
                        lam = x[k + 1, r]
                impulse[k] = lam
                lmax = max(lmax, abs(lam))
        ltol = max(MULT_TOL, MULT_RTOL * max(lmax, 1.0))
        nviol = 0
        for k in range(nh):
            if active[k]:
                if impulse[k] < -ltol and not forced[k]:
                    viol[k] = 1
                    nviol += 1
            elif cand[k] and rates[k] < -RATE_TOL:
                viol[k] = 1
                nviol += 1
        if nviol == 0 or final:
            # energy lost per constraint: -1/2 Lambda_c (J_c v- + J_c v+)
            lost_lock = 0.0
            lost_land = 0.0
            for j in range(nrow.shape[0]):
                for r in range(nrow[j]):
                    kd = kind[j, r]
                    if kd == ROW_LOCK:
                        k = j - 1
                        lost_lock += -0.5 * x[j, r] * (jv_minus[j, r] + rates[k])
                    elif kd == ROW_ANCHOR_LOWER or kd == ROW_ANCHOR_UPPER:
                        lost_land += -0.5 * x[j, r] * jv_minus[j, r]  # J_c v+ = 0 for anchors
            for j in range(anchor_impulse.shape[0]):
                for q in range(3):
                    anchor_impulse[j, q] = 0.0
                for r in range(nrow[j]):
                    kd = kind[j, r]
                    if kd == ROW_ANCHOR_LOWER or kd == ROW_ANCHOR_UPPER:
                        anchor_impulse[j, r % 3] += x[j, r]
            energy_split[0] = lost_lock
            energy_split[1] = lost_land
            for i in range(n):
                for q in range(3):
                    w[i, q] = w_plus[i, q]
            return it
        h = _set_hash(active, nh)
        if nhist >= PIVOT_BUDGET or _seen(hist, nhist, h):
            # cycling (or too long): the dense problem over the candidates, solved by Lemke
            idx = np.empty(max(nh, 1), dtype=np.int64)
            c = _candidates(cand, forced, idx)
            for k in range(nh):
                active[k] = forced[k]
            _impact_trial(e, w, anchored, active, J, kind, nrow, S, G, drop, rhs, x, gf, pv, vel, jv_minus, w_plus,
                          rates)
            if _dense_fallback(e, w, anchored, forced, idx, c, rates, RATE_TOL, J, kind, nrow, S, G, drop, rhs, x,
                               gf, active) < 0:
                return -1
            final = True
            continue
        hist[nhist] = h
        nhist += 1
        if nviol < best:
            best = nviol
            stall = 0
        else:
            stall += 1
            if stall >= 3:
                use_murty = True
        _pivot_update(active, viol, use_murty)
    return -1


@njit(cache=True)
def lock_set(e, w, anchored, cand, active, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw, ddg, lam):
    """Which hinges at their limit stay locked: the acceleration-level LCP over
    ``cand`` (hinges at the limit with dg/dt = 0).  ``active`` is the initial guess on
    entry and the locked set on exit; ``lam`` the lock multipliers.  Returns the number
    of trials, negative if it did not converge (only if Lemke fails: not expected)."""
    n = e.shape[0]
    nh = n - 1
    viol = np.zeros(max(nh, 1), dtype=np.uint8)
    hist = np.zeros(PIVOT_BUDGET + 1, dtype=np.uint64)
    nhist = np.int64(0)
    best = 1 << 60
    stall = 0
    use_murty = False
    final = False
    for it in range(PIVOT_BUDGET + 3):
        accelerations(e, w, anchored, active, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw)
        hinge_accels(e, w, de, dw, ddg)
        for k in range(nh):
            viol[k] = 0
            lam[k] = 0.0
        # tolerance: round-off of the solve, relative to the multipliers and
        # accelerations at stake (lam ~ ddg / W_W)
        scale = 1.0
        for k in range(nh):
            if active[k]:
                for r in range(nrow[k + 1]):
                    if kind[k + 1, r] == ROW_LOCK:
                        lam[k] = x[k + 1, r]
                scale = max(scale, W_W * abs(lam[k]))
            elif cand[k]:
                scale = max(scale, abs(ddg[k]))
        atol = max(MULT_TOL, MULT_RTOL * scale)
        ltol = atol / W_W
        nviol = 0
        for k in range(nh):
            if active[k]:
                if lam[k] < -ltol:
                    viol[k] = 1
                    nviol += 1
            elif cand[k] and ddg[k] < -atol:
                viol[k] = 1
                nviol += 1
        if nviol == 0 or final:
            return it
        h = _set_hash(active, nh)
        if nhist >= PIVOT_BUDGET or _seen(hist, nhist, h):
            idx = np.empty(max(nh, 1), dtype=np.int64)
            none = np.zeros(max(nh, 1), dtype=np.uint8)
            c = _candidates(cand, none, idx)
            for k in range(nh):
                active[k] = 0
            accelerations(e, w, anchored, active, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw)
            hinge_accels(e, w, de, dw, ddg)
            if _dense_fallback(e, w, anchored, none, idx, c, ddg, atol, J, kind, nrow, S, G, drop, rhs, x, gf,
                               active) < 0:
                return -1
            final = True
            continue
        hist[nhist] = h
        nhist += 1
        if nviol < best:
            best = nviol
            stall = 0
        else:
            stall += 1
            if stall >= 3:
                use_murty = True
        _pivot_update(active, viol, use_murty)
    return -1
