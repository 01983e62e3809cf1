"""Impacts and the locked set (docs/model.md, sections 2-3), numba kernels, nondimensional.

Velocity level (Moreau / Gauss): the post-impact velocity is the one closest to the
pre-impact one in the kinetic-energy metric such that every hinge stays joined, every
anchored point is at rest and every hinge at its limit has dg/dt >= 0.  With impulses
Lambda on the candidate hinges this is the LCP

    Lambda >= 0,  dg/dt+ = dg/dt- + (J W J^T Lambda)_lock >= 0,  Lambda . dg/dt+ = 0,

with the hinge and anchor rows as equalities.  Acceleration level (which locks hold):

    lambda >= 0,  d2g/dt2 >= 0,  lambda . d2g/dt2 = 0   over hinges at the limit with dg/dt = 0.

Both are solved exactly by principal pivoting on the active set: block pivoting
(flip every violated index) while the number of violations falls, then Murty's
least-index rule, which terminates for the positive-definite matrices here.  Each
trial active set costs one O(N) factorisation.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dynamics import (
    ROW_ANCHOR_LOWER,
    ROW_ANCHOR_UPPER,
    ROW_LOCK,
    accelerations,
    apply_impulses,
    build_rows,
    constraint_velocities,
    factor,
    solve,
)
from .rules import RATE_TOL

MULT_TOL = 1e-11  # multipliers/accelerations below -MULT_TOL violate complementarity
MAX_PIVOTS = 100000


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
def velocity_impact(e, w, anchored, cand, forced, active, J, kind, nrow, S, G, drop, rhs, x, gf, pv, vel,
                    jv_minus, w_plus, rates, impulse, anchor_impulse, energy_split):
    """Moreau's inelastic impact.  ``cand[k]``: hinge k at its limit (a candidate);
    ``active`` on entry: initial guess (e.g. locked or approaching hinges), on exit: the
    hinges that carry an impulse or stay at the limit.  ``anchored`` includes the points
    that just touched the floor.  On exit ``w`` holds the post-impact angular velocities,
    ``impulse[k]`` the lock impulses, ``anchor_impulse[j]`` the floor impulses,
    ``energy_split`` = (lost to locking, lost to landing): their sum is the kinetic
    energy lost (>= 0); a share alone can be negative when one impact both lands and
    locks (a hinge that was opening is held at its limit).
    Returns the number of pivots (negative if the pivoting did not converge)."""
    n = e.shape[0]
    nh = n - 1
    viol = np.zeros(max(nh, 1), dtype=np.uint8)
    best = 1 << 60
    stall = 0
    use_murty = False
    for it in range(MAX_PIVOTS):
        build_rows(e, w, anchored, active, J, kind, nrow, rhs, False)
        constraint_velocities(e, w, J, nrow, pv, vel, jv_minus)
        for j in range(nrow.shape[0]):
            for r in range(nrow[j]):
                rhs[j, r] = -jv_minus[j, r]
        factor(e, anchored, J, kind, nrow, S, G, drop)
        solve(nrow, S, G, drop, rhs, x)
        for i in range(n):
            for q in range(3):
                w_plus[i, q] = w[i, q]
        apply_impulses(e, w_plus, anchored, J, nrow, x, gf, 1.0)
        hinge_rates(e, w_plus, rates)
        nviol = 0
        for k in range(nh):
            viol[k] = 0
            impulse[k] = 0.0
        for k in range(nh):
            if active[k]:
                lam = 0.0
                for r in range(nrow[k + 1]):
                    if kind[k + 1, r] == ROW_LOCK:
                        lam = x[k + 1, r]
                impulse[k] = lam
                if lam < -MULT_TOL and not forced[k]:
                    viol[k] = 1
                    nviol += 1
            elif cand[k] and rates[k] < -RATE_TOL:
                viol[k] = 1
                nviol += 1
        if nviol == 0:
            # energy lost per constraint: -1/2 Lambda_c (J_c v- + J_c v+)
            lost_lock = 0.0
            lost_land = 0.0
            for j in range(nrow.shape[0]):
                for r in range(nrow[j]):
                    kd = kind[j, r]
                    # J_c v+ = J_c v- + (A Lambda)_c = J_c v- - rhs... computed directly below
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
    of pivots, negative if it did not converge."""
    n = e.shape[0]
    nh = n - 1
    viol = np.zeros(max(nh, 1), dtype=np.uint8)
    best = 1 << 60
    stall = 0
    use_murty = False
    for it in range(MAX_PIVOTS):
        accelerations(e, w, anchored, active, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw)
        hinge_accels(e, w, de, dw, ddg)
        nviol = 0
        for k in range(nh):
            viol[k] = 0
            lam[k] = 0.0
        for k in range(nh):
            if active[k]:
                for r in range(nrow[k + 1]):
                    if kind[k + 1, r] == ROW_LOCK:
                        lam[k] = x[k + 1, r]
                if lam[k] < -MULT_TOL:
                    viol[k] = 1
                    nviol += 1
            elif cand[k] and ddg[k] < -MULT_TOL:
                viol[k] = 1
                nviol += 1
        if nviol == 0:
            return it
        if nviol < best:
            best = nviol
            stall = 0
        else:
            stall += 1
            if stall >= 3:
                use_murty = True
        _pivot_update(active, viol, use_murty)
    return -1
