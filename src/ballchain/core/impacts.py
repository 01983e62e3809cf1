"""Impacts and the locked set (docs/model.md, section 3), numba kernels, nondimensional.

Velocity level (Moreau / Gauss): the post-impact velocity is the one closest to the
pre-impact one in the kinetic-energy metric such that every hinge stays joined, every
anchored point is at rest and every hinge at its limit has dg/dt >= 0.  With impulses
Lambda on the candidate hinges this is the LCP

    Lambda >= 0,  dg/dt+ = dg/dt- + (J W J^T Lambda)_lock >= 0,  Lambda . dg/dt+ = 0,

with the hinge and anchor rows as equalities.  Acceleration level (which locks hold):

    lambda >= 0,  d2g/dt2 >= 0,  lambda . d2g/dt2 = 0   over hinges at the limit with dg/dt = 0.

Both are solved by principal pivoting on the active set (the driver is ``lcp``), each
trial set costing one O(N) factorisation.  The matrix, M = J_L W_eff J_L^T (W_eff: the
inverse mass reduced by the equality rows), is only positive semidefinite, singular
when a lock row depends on the anchor/hinge rows (rules.limit_in_force removes the
structural case: two segments spanning two anchors) and near-singular in rare
configurations.  So (i) the complementarity tests use tolerances scaled to the size of
the multipliers and accelerations (round-off of the O(N) solve, not an absolute 1e-11),
and (ii) cycling or a spent budget hands the problem to the dense fallback
(``_delassus`` forms the c x c matrix M over the c candidates with one factorisation and
c solves; ``lcp.dense_lcp`` solves it by Lemke's method).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..contacts.newton import impulse_rhs, law_rate
from ..jit import entry, njit
from .blocks import factor, solve, torques4
from .dynamics import accelerations
from .kinematics import apply_impulses, constraint_rates4, constraint_velocities, kinetic_energy, torque_jump
from .lcp import PIVOT_BUDGET, PIVOT_FALLBACK, candidates, dense_lcp, new_pivoting, next_active_set, symmetrise
from .rows import (
    ROW_ANCHOR_LOWER,
    ROW_ANCHOR_UPPER,
    ROW_HINGE,
    ROW_LOCK,
    ROW_SLIDE_LOWER,
    ROW_SLIDE_UPPER,
    W_W,
    build_rows,
    constraint_rows,
)
from .rules import RATE_TOL, landed_or_landing, unit_hinge_gap
from .state import MAXR

MULT_TOL = 1e-11  # absolute floor of the complementarity tolerances
MULT_RTOL = 1e-10  # tolerance relative to the largest multiplier / acceleration at stake
ENERGY_RTOL = 1e-12  # an impact "creates" energy beyond this share of the kinetic energy (round-off)

# What an impact computes besides the new velocities: the constraint rates before it (jv),
# the post-impact w of a trial (w_plus), the hinge rates after it (rates_after), the lock
# impulses, the floor's impulse per point, and the energy lost (to locking, to landing);
# pv, vel: scratch of the point and centre velocities; dv: a velocity of the centres
# added to the one w gives before the impact (zero at an event instant; the
# time-stepping method puts there gravity's kick and the centres' velocities of the
# last step, so that the impact problem is Moreau-Jean's projection in maximal
# coordinates).
# rates_before: the hinge rates before the impact (Newton's law compares with them);
# with restitution (e_lock > 0), an impact may take a second, inelastic pass
# (``velocity_impact``): lost_hinge the energy each hinge's impulse took over both, from
# the rates at each pass's start (rates_start), and keep the first pass's outputs.
# rebound: per point, the upward velocity a landing point leaves the floor with (Newton's
# restitution at the floor, ``contacts.newton.floor_rebound``; 0: the anchor stops it),
# n_rebound[0] how many are nonzero (set by the caller: the exact method's landings).
ImpactWork = namedtuple(
    "ImpactWork",
    [
        "jv",
        "w_plus",
        "rates_after",
        "impulse",
        "anchor_impulse",
        "split",
        "pv",
        "vel",
        "dv",
        "rates_before",
        "rates_start",
        "lost_hinge",
        "keep_impulse",
        "keep_anchor",
        "w_start",
        "active_start",
        "rebound",
        "n_rebound",
    ],
)


def new_impact_work(n: int) -> ImpactWork:
    """Scratch of ``velocity_impact`` for an N-segment chain."""
    nh = max(n - 1, 0)
    return ImpactWork(
        np.zeros((n + 1, MAXR)),
        np.zeros((n, 3)),
        np.zeros(nh),
        np.zeros(nh),
        np.zeros((n + 1, 3)),
        np.zeros(2),
        np.zeros((n + 1, 3)),
        np.zeros((n, 3)),
        np.zeros((n, 3)),
        np.zeros(nh),
        np.zeros(nh),
        np.zeros(nh),
        np.zeros(nh),
        np.zeros((n + 1, 3)),
        np.zeros((n, 3)),
        np.zeros(nh, dtype=np.uint8),
        np.zeros(n + 1),
        np.zeros(1, dtype=np.int64),
    )


@njit(cache=True, inline="always")
def _row_target(kind, j, r, iw):
    """The rate an anchor row of point j leaves the impact with: the point's rebound on
    its vertical rows (r % 3 == 2) and on a sliding point's height row, else 0 (at rest)."""
    if kind == ROW_SLIDE_LOWER or kind == ROW_SLIDE_UPPER:
        return iw.rebound[j]
    return iw.rebound[j] if (kind == ROW_ANCHOR_LOWER or kind == ROW_ANCHOR_UPPER) and r % 3 == 2 else 0.0


@entry
@njit(cache=True, _nrt=False)
def hinge_gaps(e, cos_alpha, out):
    """out[k] = g_k of every hinge of unit axes e (``rules.unit_hinge_gap``)."""
    for k in range(out.shape[0]):
        out[k] = unit_hinge_gap(e, k, cos_alpha)


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def _delassus(e, w, anchored, base, idx, c, ws, wt, col, M, dref):
    """M[:c, :c] = J_L W_eff J_L^T over the hinges idx[:c]: column j = the hinge rates
    that a unit lock impulse on hinge idx[j] produces once the equality rows (hinges,
    anchors, and the locks ``base`` held whatever their sign) have reacted.  One
    factorisation, c O(N) solves; symmetrised.  dref[j] = J_L W J_L^T for row j alone
    (before the equality rows react)."""
    n = e.shape[0]
    J, kind, nrow, rhs, x = ws.J, ws.kind, ws.nrow, ws.rhs, ws.x
    build_rows(e, w, anchored, base, J, kind, nrow, rhs, np.bool_(False))
    factor(e, anchored, J, kind, nrow, ws.S, ws.G, ws.drop)
    for jj in range(c):
        k = idx[jj]
        for i in range(n):
            for q in range(3):
                wt[i, q] = 0.0
        nx = e[k, 1] * e[k + 1, 2] - e[k, 2] * e[k + 1, 1]
        ny = e[k, 2] * e[k + 1, 0] - e[k, 0] * e[k + 1, 2]
        nz = e[k, 0] * e[k + 1, 1] - e[k, 1] * e[k + 1, 0]
        dref[jj] = 0.0
        if not landed_or_landing(anchored, k):
            dref[jj] += W_W * (nx * nx + ny * ny + nz * nz)
            wt[k, 0] = W_W * nx
            wt[k, 1] = W_W * ny
            wt[k, 2] = W_W * nz
        if not landed_or_landing(anchored, k + 1):
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
        solve(kind, nrow, ws.S, ws.G, ws.drop, rhs, x)
        apply_impulses(e, wt, anchored, J, nrow, x, ws.gf, 1.0)
        hinge_rates(e, wt, col)
        for ii in range(c):
            M[ii, jj] = col[idx[ii]]
    symmetrise(M, c)


@njit(cache=True, _nrt=True)
def _dense_fallback(e, w, anchored, base, idx, c, q_all, tol, ws, active):
    """The LCP over the candidates idx[:c] as one dense problem (``_delassus``, then
    ``lcp.dense_lcp``): q = q_all[idx] (the rates or accelerations with no candidate
    active), the locks ``base`` held throughout.  Sets active[idx]; returns Lemke's pivot
    count (-1: failure)."""
    n = e.shape[0]
    q0 = np.empty(c)
    for i in range(c):
        q0[i] = q_all[idx[i]]
    M = np.empty((c, c))
    dref = np.empty(c)
    _delassus(e, w, anchored, base, idx, c, ws, np.empty((n, 3)), np.empty(max(n - 1, 1)), M, dref)
    return dense_lcp(M, q0, c, idx, active, tol, dref)


@njit(cache=True, _nrt=False)
def translation_rates(anchored, J, kind, nrow, fits, dv, jv):
    """jv += the rates of the constraint rows under centre velocities dv (w = 0): a hinge
    row dv_a - dv_c, an anchor row the dv of its segment; lock rows 0."""
    n = dv.shape[0]
    for j in range(nrow.shape[0]):
        nr = nrow[j]
        if nr == 0:
            continue
        a = j - 1
        c = j
        if fits:
            k0 = kind[j, 0]
            if k0 == ROW_HINGE or k0 == ROW_ANCHOR_LOWER:
                for q in range(3):
                    jv[j, q] += dv[a, q]
            if k0 == ROW_HINGE:
                for q in range(3):
                    jv[j, q] -= dv[c, q]
            elif k0 == ROW_ANCHOR_UPPER or nr == 6:
                r0 = 3 if nr == 6 else 0
                for q in range(3):
                    jv[j, r0 + q] += dv[c, q]
        else:
            for r in range(nr):
                acc = 0.0
                if j >= 1:
                    for q in range(3):
                        acc += J[j, r, q] * dv[a, q]
                if j < n:
                    for q in range(3):
                        acc += J[j, r, 6 + q] * dv[c, q]
                jv[j, r] += acc


@njit(cache=True, _nrt=False)
def _impact_trial(e, w, anchored, active, forced, e_lock, ws, iw):
    """Post-impact velocity iw.w_plus and hinge rates iw.rates_after for the lock set
    ``active``: the impulses x solve (J W J^T) x = -J v- (a lock row not held by the
    accumulation rule: -(J v- + e_lock gamma-), gamma- = iw.rates_before, Newton's law,
    ``contacts.newton``), and w+ = w- + W J^T x."""
    n = e.shape[0]
    J, kind, nrow, rhs, x, gf = ws.J, ws.kind, ws.nrow, ws.rhs, ws.x, ws.gf
    jv_minus, w_plus = iw.jv, iw.w_plus
    for i in range(n):
        for q in range(3):
            w_plus[i, q] = w[i, q]
    fits = constraint_rows(e, w, anchored, active, J, kind, nrow, rhs)
    if fits:
        constraint_rates4(e, w, anchored, kind, nrow, iw.pv, iw.vel, jv_minus)
    else:
        constraint_velocities(e, w, J, nrow, iw.pv, iw.vel, jv_minus)
    translation_rates(anchored, J, kind, nrow, fits, iw.dv, jv_minus)
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            if kind[j, r] == ROW_LOCK and not forced[j - 1]:
                rhs[j, r] = impulse_rhs(jv_minus[j, r], iw.rates_before[j - 1], e_lock)
            else:
                rhs[j, r] = _row_target(kind[j, r], j, r, iw) - jv_minus[j, r]
    factor(e, anchored, J, kind, nrow, ws.S, ws.G, ws.drop)
    solve(kind, nrow, ws.S, ws.G, ws.drop, rhs, x)
    if fits:
        torques4(e, kind, nrow, x, gf)
        torque_jump(e, w_plus, anchored, gf, 1.0)
    else:
        apply_impulses(e, w_plus, anchored, J, nrow, x, gf, 1.0)
    hinge_rates(e, w_plus, iw.rates_after)


@njit(cache=True, _nrt=False)
def _impact_violations(cand, forced, active, e_lock, ws, iw, viol):
    """Mark (viol) and count the complementarity violations of the last trial: an active
    hinge pulled by its impulse (unless held) or an inactive candidate whose law rate
    (gamma+ + e gamma-, ``contacts.newton.law_rate``) is negative; iw.impulse gets the
    lock impulses."""
    nh = cand.shape[0]
    impulse = iw.impulse
    for k in range(nh):
        viol[k] = 0
        impulse[k] = 0.0
    lmax = 0.0
    for k in range(nh):
        if active[k]:
            lam = 0.0
            for r in range(ws.nrow[k + 1]):
                if ws.kind[k + 1, r] == ROW_LOCK:
                    lam = ws.x[k + 1, r]
            impulse[k] = lam
            lmax = max(lmax, abs(lam))
    ltol = max(MULT_TOL, MULT_RTOL * max(lmax, 1.0))
    nviol = 0
    for k in range(nh):
        if active[k]:
            if impulse[k] < -ltol and not forced[k]:
                viol[k] = 1
                nviol += 1
        elif cand[k] and law_rate(iw.rates_after[k], iw.rates_before[k], e_lock) < -RATE_TOL:
            viol[k] = 1
            nviol += 1
    return nviol


@njit(cache=True, _nrt=False)
def _impact_books(w, ws, iw):
    """Accept the last trial: w <- w+, the floor's impulse per point, and the energy lost
    per constraint, -1/2 Lambda_c (J_c v- + J_c v+) (J_c v+ = 0 for anchors), split into
    (lost to locking, lost to landing)."""
    nrow, kind, x, jv_minus = ws.nrow, ws.kind, ws.x, iw.jv
    lost_lock = 0.0
    lost_land = 0.0
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            kd = kind[j, r]
            if kd == ROW_LOCK:
                lost_lock += -0.5 * x[j, r] * (jv_minus[j, r] + iw.rates_after[j - 1])
            elif kd == ROW_ANCHOR_LOWER or kd == ROW_ANCHOR_UPPER or kd == ROW_SLIDE_LOWER or kd == ROW_SLIDE_UPPER:
                lost_land += -0.5 * x[j, r] * (jv_minus[j, r] + _row_target(kd, j, r, iw))
    anchor_impulse = iw.anchor_impulse
    for j in range(anchor_impulse.shape[0]):
        for q in range(3):
            anchor_impulse[j, q] = 0.0
        for r in range(nrow[j]):
            kd = kind[j, r]
            if kd == ROW_ANCHOR_LOWER or kd == ROW_ANCHOR_UPPER:
                anchor_impulse[j, r % 3] += x[j, r]
            elif kd == ROW_SLIDE_LOWER or kd == ROW_SLIDE_UPPER:
                anchor_impulse[j, 2] += x[j, r]
    iw.split[0] = lost_lock
    iw.split[1] = lost_land
    for i in range(w.shape[0]):
        for q in range(3):
            w[i, q] = iw.w_plus[i, q]


@njit(cache=True, _nrt=True)
def _pivoted_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw):
    """One impact by principal pivoting on the lock set (``velocity_impact``)."""
    nh = e.shape[0] - 1
    piv = new_pivoting(nh)
    final = False  # the set came from the dense fallback: accept it
    for it in range(PIVOT_BUDGET + 3):
        _impact_trial(e, w, anchored, active, forced, e_lock, ws, iw)
        nviol = _impact_violations(cand, forced, active, e_lock, ws, iw, piv.viol)
        if nviol == 0 or final:
            _impact_books(w, ws, iw)
            return it
        if next_active_set(piv, active, nh, nviol) == PIVOT_FALLBACK:
            # cycling (or too long): the dense problem over the candidates, solved by Lemke
            idx = np.empty(max(nh, 1), dtype=np.int64)
            c = candidates(cand, forced, idx)
            for k in range(nh):
                active[k] = forced[k]
            _impact_trial(e, w, anchored, active, forced, e_lock, ws, iw)
            for k in range(nh):  # the law's rate with no candidate acting: the LCP's q
                if not forced[k]:
                    iw.rates_after[k] = law_rate(iw.rates_after[k], iw.rates_before[k], e_lock)
            if _dense_fallback(e, w, anchored, forced, idx, c, iw.rates_after, RATE_TOL, ws, active) < 0:
                return -1
            final = True
    return -1


@njit(cache=True, _nrt=False)
def _lock_violations(cand, active, ws, ddg, lam, viol):
    """Mark and count the violations of the acceleration-level LCP (a locked hinge pulled
    by its multiplier, a free candidate accelerating through its limit), lam the lock
    multipliers; returns (count, tolerance on d2g/dt2).  The tolerance is the round-off of
    the solve relative to the multipliers and accelerations at stake (lam ~ ddg / W_W)."""
    nh = cand.shape[0]
    for k in range(nh):
        viol[k] = 0
        lam[k] = 0.0
    scale = 1.0
    for k in range(nh):
        if active[k]:
            for r in range(ws.nrow[k + 1]):
                if ws.kind[k + 1, r] == ROW_LOCK:
                    lam[k] = ws.x[k + 1, r]
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
    return nviol, atol


@njit(cache=True, _nrt=True)
def lock_set(e, w, anchored, cand, active, ws, de, dw, ddg, lam):
    """Which hinges at their limit stay locked: the acceleration-level LCP over
    ``cand`` (hinges at the limit with dg/dt = 0).  ``active`` is the initial guess on
    entry and the locked set on exit; ``lam`` the lock multipliers.  Returns the number
    of trials, negative if it did not converge (only if Lemke fails: not expected)."""
    nh = e.shape[0] - 1
    piv = new_pivoting(nh)
    final = False
    for it in range(PIVOT_BUDGET + 3):
        accelerations(e, w, anchored, active, ws, de, dw)
        hinge_accels(e, w, de, dw, ddg)
        nviol, atol = _lock_violations(cand, active, ws, ddg, lam, piv.viol)
        if nviol == 0 or final:
            return it
        if next_active_set(piv, active, nh, nviol) == PIVOT_FALLBACK:
            idx = np.empty(max(nh, 1), dtype=np.int64)
            none = np.zeros(max(nh, 1), dtype=np.uint8)
            c = candidates(cand, none, idx)
            for k in range(nh):
                active[k] = 0
            accelerations(e, w, anchored, active, ws, de, dw)
            hinge_accels(e, w, de, dw, ddg)
            if _dense_fallback(e, w, anchored, none, idx, c, ddg, atol, ws, active) < 0:
                return -1
            final = True
    return -1


@njit(cache=True, _nrt=False)
def velocity_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw):
    """Moreau's inelastic impact, or with ``e_lock`` > 0 Newton's restitution on the
    hinges' lock rows (``contacts.newton``; anchors and held hinges stay inelastic), with
    the hinge rates before the instant in iw.rates_before (the caller's: an instant
    may solve its impact again from the last result, ``contacts.newton.impulse_rhs``).  ``cand[k]``: hinge k at its limit, its limit in force
    (a candidate); ``forced[k]``: a candidate held at its limit whatever the sign of its
    impulse (the accumulation rule, ``rules.must_hold``); ``active`` on entry: initial
    guess (e.g. locked or approaching hinges), on exit: the hinges that carry an
    impulse or stay at the limit.  ``anchored`` includes the points that just touched
    the floor.  On exit ``w`` holds the post-impact angular velocities and ``iw``
    (``ImpactWork``) the lock impulses, the floor impulses per point and the energy split
    (lost to locking, lost to landing): their sum is the kinetic energy lost (>= 0); a
    share alone can be negative when one impact both lands and locks (a hinge that was
    opening is held at its limit).  Returns the number of trials (negative if the
    pivoting did not converge).

    With restitution, a hinge that was leaving its limit and is pushed back to it by the
    others' impulses comes out closing (-e_lock times its rate before); a second,
    inelastic pass from there stops it at its limit (both passes dissipate:
    ``contacts.newton``), and iw.lost_hinge holds each hinge's share over both.  Where
    a landing takes impulse in the same impact (its rows inelastic beside restitution at
    the limits), Newton's law can create energy; such an impact is taken inelastic
    (e_lock = 0) at every hinge instead.

    With iw.rebound (Newton's restitution at the floor, ``contacts.newton``), a landing
    point's vertical rows leave it rising at iw.rebound[j], its horizontal ones at rest (the
    rough floor: the impact stops its sliding); the floor's rows are equalities, as the
    anchor's.  If that creates energy, or the floor would pull a rebounding point down
    (a negative vertical impulse), the impact is taken inelastic everywhere (iw.rebound
    zeroed: the points are anchored, the model's law)."""
    if e_lock == 0.0 and iw.n_rebound[0] == 0:
        return _pivoted_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw)
    nh = e.shape[0] - 1
    for i in range(e.shape[0]):
        for q in range(3):
            iw.w_start[i, q] = w[i, q]
    for k in range(nh):
        iw.active_start[k] = active[k]  # (the initial guess, for a second try)
    t_before = kinetic_energy(e, w, iw.pv, iw.vel)
    it = _newton_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw)
    if it < 0 or (iw.split[0] + iw.split[1] >= -ENERGY_RTOL * t_before and not _floor_pulls(iw)):
        return it
    # Newton's law with the landing's inelastic rows beside it created energy: inelastic
    for i in range(e.shape[0]):
        for q in range(3):
            w[i, q] = iw.w_start[i, q]
    for k in range(nh):
        active[k] = iw.active_start[k]
    clear_rebounds(iw)
    return _newton_impact(e, w, anchored, cand, forced, active, 0.0, ws, iw)


@njit(cache=True, _nrt=False)
def stepped_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw):
    """A time-stepping method's velocity problem with Newton's law at the limits, in one
    pass (Moreau-Jean's form): on every candidate lock row, gamma+ + e_lock gamma- >= 0,
    impulse >= 0, complementary, gamma- = iw.rates_before, which the caller takes as the
    rates at the step's start clamped to min(gamma, 0) (restitution acts on a limit that
    is approached; one that is not takes Moreau's law, gamma+ >= 0), so that no row comes
    out closing and no second pass is needed (``velocity_impact``'s is for an instant of
    the exact method).  The joint and anchor rows are equalities; iw.dv carries the free
    motion of the step (gravity's kick).  Returns the number of trials (negative if the
    pivoting did not converge)."""
    return _pivoted_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw)


@njit(cache=True, _nrt=False)
def clear_rebounds(iw):
    """No point leaves the floor at the next impact: iw.rebound zeroed (Moreau's law at the
    floor: an impact taken inelastic, or an instant's or a step's later rounds)."""
    for j in range(iw.rebound.shape[0]):
        iw.rebound[j] = 0.0
    iw.n_rebound[0] = 0


@njit(cache=True, _nrt=False)
def _floor_pulls(iw):
    """Would the floor pull a point down to make it rebound (a negative vertical impulse
    on a rebounding point: its rows are equalities)?"""
    if iw.n_rebound[0] == 0:
        return False
    for j in range(iw.rebound.shape[0]):
        if iw.rebound[j] > 0.0 and iw.anchor_impulse[j, 2] < 0.0:
            return True
    return False


@njit(cache=True, _nrt=False)
def first_pass_closing(nh, cand, active, iw):
    """After Newton's pass at the limits: each hinge's share of the loss (iw.lost_hinge,
    -Lambda (gamma_start + gamma+) / 2); returns whether a candidate comes out closing
    (gamma+ < -RATE_TOL), each such one made active for the second, inelastic pass."""
    closing = False
    for k in range(nh):
        iw.lost_hinge[k] = -0.5 * iw.impulse[k] * (iw.rates_start[k] + iw.rates_after[k])
        if cand[k] and iw.rates_after[k] < -RATE_TOL:
            closing = True
            active[k] = 1
    return closing


@njit(cache=True, _nrt=False)
def keep_first_pass(nh, iw):
    """Before the second pass: the first pass's impulses kept (iw.keep_impulse,
    iw.keep_anchor), its rates after it the second's start (iw.rates_start)."""
    for k in range(nh):
        iw.keep_impulse[k] = iw.impulse[k]
        iw.rates_start[k] = iw.rates_after[k]
    for j in range(iw.anchor_impulse.shape[0]):
        for q in range(3):
            iw.keep_anchor[j, q] = iw.anchor_impulse[j, q]


@njit(cache=True, _nrt=False)
def add_first_pass(nh, active, iw, lost_lock, lost_land):
    """After the second pass: the books, each hinge's share, the impulses and the floor's
    over both passes; a hinge that carried an impulse in the first is active on exit."""
    iw.split[0] += lost_lock
    iw.split[1] += lost_land
    for k in range(nh):
        iw.lost_hinge[k] += -0.5 * iw.impulse[k] * (iw.rates_start[k] + iw.rates_after[k])
        iw.impulse[k] += iw.keep_impulse[k]
        if iw.keep_impulse[k] != 0.0:
            active[k] = 1
    for j in range(iw.anchor_impulse.shape[0]):
        for q in range(3):
            iw.anchor_impulse[j, q] += iw.keep_anchor[j, q]


@njit(cache=True, _nrt=False)
def _newton_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw):
    """Newton's restitution at the limits (``velocity_impact``), and the second, inelastic
    pass if a hinge comes out closing; iw.lost_hinge: each hinge's share."""
    nh = e.shape[0] - 1
    hinge_rates(e, w, iw.rates_start)
    it = _pivoted_impact(e, w, anchored, cand, forced, active, e_lock, ws, iw)
    if it < 0 or not first_pass_closing(nh, cand, active, iw):
        return it
    lost_lock, lost_land = iw.split[0], iw.split[1]
    keep_first_pass(nh, iw)
    it2 = _pivoted_impact(e, w, anchored, cand, forced, active, 0.0, ws, iw)
    if it2 < 0:
        return it2
    add_first_pass(nh, active, iw, lost_lock, lost_land)
    return it + it2
