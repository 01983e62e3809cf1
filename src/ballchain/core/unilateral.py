"""The floor's rows as complementarity candidates beside the hinges' (docs/model.md, section
3), numba kernels, nondimensional: a floor that pushes and never pulls.

A floor candidate is a point j with ``fcand[j]`` > 0, the mark it takes while the floor
holds it (``rules.SLIDING`` on a frictionless floor: one height row; 1, the anchor: three
rows); in a trial set it is held (``anchored[j] = fcand[j]``) or free (0).  With P_j its
vertical impulse (velocity level) or force (acceleration level):

* velocity level (``floor_impact``): held => P_j >= 0 and its height's rate leaves the
  impact at the floor's target (``ImpactWork.rebound``: 0, or Newton's e |vz-|); free =>
  its height's rate after the impact is at least that target; a point in ``FloorWork.forced``
  (the accumulation rule at the floor) held whatever its impulse's sign;
* acceleration level (``floor_lock_set``; points at rest on the floor): held => P_j >= 0;
  free => its height's acceleration z_j'' >= 0.

Beside the hinges' complementarity (``impacts``), both are one LCP over the hinges and the
floor candidates together, solved by the same principal pivoting (``lcp``) on a combined
index (hinge k at k, floor candidate j at N - 1 + j).  Where it cycles (degenerate sets:
a pile lying flat, its rows nearly dependent) the problem is solved densely
(``_floor_dense``: the Delassus matrix over the candidates from unit impulses, one
factorisation and a solve per candidate, then Lemke's method, ``lcp.dense_lcp``), as the
hinges' is (``impacts._dense_fallback``).

The points' velocities and accelerations come from the centres' (maximal coordinates: the
segment's velocity v_i, given as the rigid chain's from w with point N at rest plus
``ImpactWork.dv``, and its change J^T x over the unit mass) and the axes': the upper end of
segment i moves at v_i + w_i x e_i, the lower end at v_i - w_i x e_i.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..contacts.newton import law_rate
from ..jit import njit
from .blocks import factor, fits4, forces4, generalized_forces, solve
from .dynamics import accelerations
from .impacts import (
    ENERGY_RTOL,
    MULT_RTOL,
    MULT_TOL,
    _impact_books,
    _impact_trial,
    _impact_violations,
    _lock_violations,
    add_first_pass,
    clear_rebounds,
    first_pass_closing,
    hinge_accels,
    hinge_rates,
    keep_first_pass,
)
from .kinematics import torque_jump, velocities
from .lcp import PIVOT_BUDGET, PIVOT_FALLBACK, dense_lcp, new_pivoting, next_active_set, symmetrise
from .rows import ROW_ANCHOR_LOWER, ROW_ANCHOR_UPPER, ROW_SLIDE_LOWER, ROW_SLIDE_UPPER, W_W, build_rows
from .rules import RATE_TOL, is_landed

# The scratch of the floor's complementarity: the combined candidates and active set
# (hinges, then points), each point's height rate (velocity level: before and after the
# trial; acceleration level: its acceleration), its vertical impulse or force, and the
# centres' velocities before the impact and after the trial (acceleration level: gravity's,
# and the trial's), and the points the impact holds whatever their impulse (``forced``: the
# accumulation rule at the floor, ``rules.must_hold``; the acceleration level ignores it).
FloorWork = namedtuple("FloorWork", ["cand", "active", "vz_before", "vz", "pz", "v0", "vc", "forced"])

# The dense problem's scratch (``_floor_delassus``): a unit impulse's jump of the centres'
# velocities and of the axes' rates, and the candidates' rates it produces (hinges, points).
DelassusWork = namedtuple("DelassusWork", ["vt", "wt", "hcol", "zcol"])


def new_floor_work(n: int) -> FloorWork:
    """Scratch of ``floor_impact`` and ``floor_lock_set`` for an N-segment chain."""
    m = max(n - 1, 0) + n + 1
    return FloorWork(
        np.zeros(m, np.uint8),
        np.zeros(m, np.uint8),
        np.zeros(n + 1),
        np.zeros(n + 1),
        np.zeros(n + 1),
        np.zeros((n, 3)),
        np.zeros((n, 3)),
        np.zeros(n + 1, np.uint8),
    )


@njit(cache=True, _nrt=False)
def vertical_multipliers(kind, nrow, x, out):
    """out[j] = the vertical multiplier of the floor's rows at point j (its height row,
    or the vertical rows of its anchor), 0 where it has none."""
    for j in range(out.shape[0]):
        p = 0.0
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_SLIDE_LOWER or k == ROW_SLIDE_UPPER:
                p += x[j, r]
            elif (k == ROW_ANCHOR_LOWER or k == ROW_ANCHOR_UPPER) and r % 3 == 2:
                p += x[j, r]
        out[j] = p


@njit(cache=True, _nrt=False)
def point_heights_rates(e, w, vc, out):
    """out[j] = dz_j/dt from the centres' velocities vc and the axes' rates w: the upper
    end of segment j, v_j + (w_j x e_j); point N, the lower end of segment N - 1,
    v_{N-1} - (w_{N-1} x e_{N-1})."""
    n = e.shape[0]
    for j in range(n):
        out[j] = vc[j, 2] + w[j, 0] * e[j, 1] - w[j, 1] * e[j, 0]
    i = n - 1
    out[n] = vc[i, 2] - (w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0])


@njit(cache=True, _nrt=False)
def _segment_forces(anchored, ws):
    """ws.gf[:, 0:3] = the multipliers' force on each segment (either layout)."""
    if fits4(ws.kind, ws.nrow):
        forces4(ws.kind, ws.nrow, ws.x, ws.gf)
    else:
        generalized_forces(anchored, ws.J, ws.nrow, ws.x, ws.gf)


@njit(cache=True, _nrt=False)
def _centres_after(anchored, base, ws, vc):
    """vc = base + the multipliers' force on each segment (m = 1; ``base``: the centres'
    velocities before the impact, or gravity's acceleration); a landed segment's centre at
    rest."""
    _segment_forces(anchored, ws)
    for i in range(vc.shape[0]):
        for q in range(3):
            vc[i, q] = 0.0 if is_landed(anchored, i) else base[i, q] + ws.gf[i, q]


@njit(cache=True, _nrt=False)
def _centre_velocities(e, w, iw, vc):
    """vc = the centres' velocities before the impact: the chain's from w with point N at
    rest (``kinematics.velocities``) plus iw.dv."""
    velocities(e, w, iw.pv, iw.vel)
    for i in range(e.shape[0]):
        for q in range(3):
            vc[i, q] = iw.vel[i, q] + iw.dv[i, q]


@njit(cache=True, _nrt=False)
def _set_trial(anchored, fcand, fw, nh):
    """The trial's marks: a floor candidate held in fw.active is marked fcand[j], else 0."""
    for j in range(anchored.shape[0]):
        if fcand[j] != 0:
            anchored[j] = fcand[j] if fw.active[nh + j] else 0


@njit(cache=True, _nrt=False)
def _floor_violations(fcand, forced, fw, nh, target, ptol, rtol, viol):
    """Mark (viol[nh + j]) and count the floor candidates that break complementarity: held
    and pulled (fw.pz < -ptol; not one ``forced``, held whatever its impulse), or free and
    below their target (fw.vz < target - rtol; a forced one whatever its rate)."""
    nviol = 0
    for j in range(fcand.shape[0]):
        viol[nh + j] = 0
        if fcand[j] == 0:
            continue
        if fw.active[nh + j]:
            bad = fw.pz[j] < -ptol and forced[j] == 0
        else:
            bad = forced[j] != 0 or fw.vz[j] < target[j] - rtol
        if bad:
            viol[nh + j] = 1
            nviol += 1
    return nviol


@njit(cache=True, _nrt=False)
def _start_sets(cand, active, anchored, fcand, forced, fw, nh):
    """The combined candidates and initial active set: the hinges' as given, a floor
    candidate held where it is held on entry or forced."""
    for k in range(nh):
        fw.cand[k] = cand[k]
        fw.active[k] = active[k]
    for j in range(fcand.shape[0]):
        fw.cand[nh + j] = 1 if fcand[j] != 0 else 0
        fw.active[nh + j] = 1 if (fcand[j] != 0 and (anchored[j] != 0 or forced[j] != 0)) else 0


@njit(cache=True, _nrt=False)
def _unit_impulse(e, anchored, nh, col, vt, wt):
    """(vt, wt) <- the centres' and axes' velocity jump of a unit impulse at the combined
    candidate ``col`` (m = 1, W_W the axes' inverse inertia), and returns its own
    J W J^T: a hinge k < nh, the lock impulse on its two segments (+-W_W n, n = e_k x
    e_k+1, as ``impacts._delassus``); a point j = col - nh, a unit vertical impulse at it
    (on segment j at its upper end, arm e_j; point N on segment N - 1, arm -e_N-1)."""
    n = e.shape[0]
    for i in range(n):
        for q in range(3):
            vt[i, q] = 0.0
            wt[i, q] = 0.0
    d = 0.0
    if col < nh:
        k = col
        nx = e[k, 1] * e[k + 1, 2] - e[k, 2] * e[k + 1, 1]
        ny = e[k, 2] * e[k + 1, 0] - e[k, 0] * e[k + 1, 2]
        nz = e[k, 0] * e[k + 1, 1] - e[k, 1] * e[k + 1, 0]
        for i, sign in ((k, 1.0), (k + 1, -1.0)):
            if not is_landed(anchored, i):
                d += W_W * (nx * nx + ny * ny + nz * nz)
                wt[i, 0] = sign * W_W * nx
                wt[i, 1] = sign * W_W * ny
                wt[i, 2] = sign * W_W * nz
        return d
    j = col - nh
    i, s = (j, 1.0) if j < n else (n - 1, -1.0)
    if is_landed(anchored, i):
        return 0.0
    ax, ay = s * e[i, 0], s * e[i, 1]  # (the arm a; a x z = (a_y, -a_x, 0), perpendicular to e_i)
    vt[i, 2] = 1.0
    wt[i, 0] = W_W * ay
    wt[i, 1] = -W_W * ax
    return 1.0 + W_W * (ax * ax + ay * ay)


@njit(cache=True, _nrt=False)
def _candidate_rates(e, wt, vt, nh, idx, c, hcol, zcol, M, jj):
    """M[:c, jj] = the rates of the combined candidates idx[:c] under (vt, wt): hinge
    rates, points' height rates."""
    hinge_rates(e, wt, hcol)
    point_heights_rates(e, wt, vt, zcol)
    for ii in range(c):
        k = idx[ii]
        M[ii, jj] = hcol[k] if k < nh else zcol[k - nh]


@njit(cache=True, _nrt=False)
def _floor_delassus(e, w, anchored, base, nh, idx, c, ws, dw, M, dref):
    """M[:c, :c] = H W_eff H^T over the combined candidates idx[:c] (hinges, then points at
    nh + j): column jj, the candidates' rates that a unit impulse at idx[jj]
    (``_unit_impulse``) produces once the equality rows (the hinges, the points
    ``anchored`` marks, the locks ``base``) have reacted; one factorisation, c O(N) solves;
    symmetrised.  dref[jj]: H W H^T of its row alone.  dw: its scratch (``DelassusWork``)."""
    n = e.shape[0]
    J, kind, nrow, rhs, x, gf = ws.J, ws.kind, ws.nrow, ws.rhs, ws.x, ws.gf
    vt, wt, hcol, zcol = dw.vt, dw.wt, dw.hcol, dw.zcol
    build_rows(e, w, anchored, base, J, kind, nrow, rhs, np.bool_(False))
    factor(e, anchored, J, kind, nrow, ws.S, ws.G, ws.drop)
    for jj in range(c):
        dref[jj] = _unit_impulse(e, anchored, nh, idx[jj], vt, wt)
        for j in range(nrow.shape[0]):  # the equality rows' rates under the jump, then their reaction
            for r in range(nrow[j]):
                acc = 0.0
                for q in range(3):
                    if j >= 1:
                        acc += J[j, r, q] * vt[j - 1, q] + J[j, r, 3 + q] * wt[j - 1, q]
                    if j < n:
                        acc += J[j, r, 6 + q] * vt[j, q] + J[j, r, 9 + q] * wt[j, q]
                rhs[j, r] = -acc
        solve(kind, nrow, ws.S, ws.G, ws.drop, rhs, x)
        generalized_forces(anchored, J, nrow, x, gf)
        torque_jump(e, wt, anchored, gf, 1.0)
        for i in range(n):
            for q in range(3):
                vt[i, q] = 0.0 if is_landed(anchored, i) else vt[i, q] + gf[i, q]
        _candidate_rates(e, wt, vt, nh, idx, c, hcol, zcol, M, jj)
    symmetrise(M, c)


@njit(cache=True, _nrt=False)
def _dense_candidates(cand, forced, fcand, fforced, nh, idx):
    """idx[:c] = the combined candidates not held whatever their multiplier (hinges
    ``forced``, points ``fforced``); returns c."""
    c = 0
    for k in range(nh):
        if cand[k] and not forced[k]:
            idx[c] = k
            c += 1
    for j in range(fcand.shape[0]):
        if fcand[j] != 0 and not fforced[j]:
            idx[c] = nh + j
            c += 1
    return c


@njit(cache=True, _nrt=True)
def _floor_dense(e, w, anchored, forced, nh, idx, c, q, tol, ws, fw):
    """The combined LCP over idx[:c] as one dense problem (``_floor_delassus``, then
    ``lcp.dense_lcp``) with q its candidates' rates (or accelerations) with none of them
    acting, the held ones (``anchored`` marks, the locks ``forced``) acting throughout.
    Sets fw.active[idx]; returns Lemke's pivot count (-1: failure)."""
    n = e.shape[0]
    M = np.empty((c, c))
    dref = np.empty(c)
    dw = DelassusWork(np.empty((n, 3)), np.empty((n, 3)), np.empty(max(nh, 1)), np.empty(n + 1))
    _floor_delassus(e, w, anchored, forced, nh, idx, c, ws, dw, M, dref)
    return dense_lcp(M, q, c, idx, fw.active, tol, dref)


@njit(cache=True, _nrt=True)
def floor_impact(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw):
    """Moreau's impact (Newton's at the limits with ``e_lock``, at the floor with the
    targets iw.rebound) with the floor's rows unilateral: the hinges ``cand`` (``forced``
    held whatever their impulse) and the floor candidates ``fcand`` (fw.forced: held
    whatever their impulse) in one LCP (module docstring).  ``active`` and ``anchored`` are the initial guess on entry (a
    candidate held on entry is tried held first) and the solution on exit; ``w`` the
    post-impact angular velocities, fw.vz the points' height rates after it, fw.pz their
    vertical impulses, iw as ``impacts.velocity_impact`` leaves it (the books: a sliding
    point's impulse is the floor's).  Returns the number of trials, -1 if the pivoting
    cycled and the dense problem (``dense_impact_set``) failed too."""
    nh = cand.shape[0]
    m = nh + anchored.shape[0]
    _start_sets(cand, active, anchored, fcand, fw.forced, fw, nh)
    _centre_velocities(e, w, iw, fw.v0)
    point_heights_rates(e, w, fw.v0, fw.vz_before)
    piv = new_pivoting(m)
    final = False  # the set came from the dense problem: accept it
    for it in range(PIVOT_BUDGET + 3):
        _impact_set(e, w, anchored, forced, active, fcand, e_lock, ws, iw, fw, nh)
        nviol = _impact_violations(cand, forced, active, e_lock, ws, iw, piv.viol)
        pmax = 0.0
        for j in range(fcand.shape[0]):
            pmax = max(pmax, abs(fw.pz[j]))
        ptol = max(MULT_TOL, MULT_RTOL * max(pmax, 1.0))
        nviol += _floor_violations(fcand, fw.forced, fw, nh, iw.rebound, ptol, RATE_TOL, piv.viol)
        if nviol == 0 or final:
            _impact_books(w, ws, iw)
            return it
        if next_active_set(piv, fw.active, m, nviol) == PIVOT_FALLBACK:  # (cycling, or too long)
            if dense_impact_set(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw) < 0:
                return -1
            final = True
    return -1


@njit(cache=True, _nrt=True)
def floor_velocity_impact(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw):
    """``floor_impact`` with Newton's restitution at the limits as
    ``impacts.velocity_impact`` takes it beside the floor's rows: a hinge that comes out
    closing (pushed back to its limit by the others' impulses) is stopped by a second,
    inelastic pass from there (iw.lost_hinge: each hinge's share over both), and an impact
    whose law would create energy is taken inelastic at every hinge instead.  The same
    check with Newton's law at the floor (the targets iw.rebound: each point's own
    restitution, where its rows need not dissipate beside the others'): an impact that would
    create energy is taken inelastic there too (iw.rebound zeroed; the points it would
    bounce are held, logged ``pin``).  With ``e_lock`` 0 and no rebound, ``floor_impact``
    itself.  Returns the number of trials (-1: failure)."""
    if e_lock == 0.0 and iw.n_rebound[0] == 0:
        return floor_impact(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw)
    n = e.shape[0]
    held = anchored.copy()
    for i in range(n):
        for q in range(3):
            iw.w_start[i, q] = w[i, q]
    for k in range(cand.shape[0]):
        iw.active_start[k] = active[k]
    u0 = np.empty(3)
    for q in range(3):
        u0[q] = iw.dv[0, q]
    it = _floor_newton(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw)
    if it < 0:
        return it
    t_before = 0.0  # (fw.v0: the centres' velocities before the first pass)
    for i in range(n):
        t_before += 0.5 * (fw.v0[i, 0] ** 2 + fw.v0[i, 1] ** 2 + fw.v0[i, 2] ** 2)
        t_before += 0.5 / W_W * (iw.w_start[i, 0] ** 2 + iw.w_start[i, 1] ** 2 + iw.w_start[i, 2] ** 2)
    if iw.split[0] + iw.split[1] >= -ENERGY_RTOL * t_before:
        return it
    # Newton's law beside the floor's inelastic rows created energy: inelastic
    for i in range(n):
        for q in range(3):
            w[i, q] = iw.w_start[i, q]
            iw.dv[i, q] = u0[q]
    for k in range(cand.shape[0]):
        active[k] = iw.active_start[k]
    for j in range(anchored.shape[0]):
        anchored[j] = held[j]
    clear_rebounds(iw)
    hinge_rates(e, w, iw.rates_start)
    it = floor_impact(e, w, anchored, cand, forced, active, fcand, 0.0, ws, iw, fw)
    for k in range(cand.shape[0]):
        iw.lost_hinge[k] = -0.5 * iw.impulse[k] * (iw.rates_start[k] + iw.rates_after[k])
    return it


@njit(cache=True, _nrt=True)
def _floor_newton(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw):
    """Newton's law at the limits and at the floor (``floor_velocity_impact``), and the
    second, inelastic pass if a hinge comes out closing, the centres then moving with point
    N's velocity after the first (iw.dv), the floor's targets zeroed (Moreau's law there: a
    bouncing point the pass pushes back down is stopped); iw.lost_hinge: each hinge's
    share."""
    nh = cand.shape[0]
    n = e.shape[0]
    hinge_rates(e, w, iw.rates_start)
    it = floor_impact(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw)
    if it < 0 or not first_pass_closing(nh, cand, active, iw):
        return it
    lost_lock, lost_land = iw.split[0], iw.split[1]
    keep_first_pass(nh, iw)
    i = n - 1  # point N after the first pass: the lower end of segment N - 1, v - w x e
    ux = fw.vc[i, 0] - (w[i, 1] * e[i, 2] - w[i, 2] * e[i, 1])
    uy = fw.vc[i, 1] - (w[i, 2] * e[i, 0] - w[i, 0] * e[i, 2])
    uz = fw.vc[i, 2] - (w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0])
    for c in range(n):
        iw.dv[c, 0], iw.dv[c, 1], iw.dv[c, 2] = ux, uy, uz
    clear_rebounds(iw)
    it2 = floor_impact(e, w, anchored, cand, forced, active, fcand, 0.0, ws, iw, fw)
    if it2 < 0:
        return it2
    add_first_pass(nh, active, iw, lost_lock, lost_land)
    return it + it2


@njit(cache=True, _nrt=True)
def dense_impact_set(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw):
    """fw.active <- the solution set of ``floor_impact``'s LCP solved as one dense problem
    (``_floor_dense``), from the held ones (hinges ``forced``, points fw.forced) acting
    alone: its fallback where pivoting cycles.  Returns Lemke's pivot count (-1: failure)."""
    nh = cand.shape[0]
    m = nh + anchored.shape[0]
    idx = np.empty(m, dtype=np.int64)
    c = _dense_candidates(cand, forced, fcand, fw.forced, nh, idx)
    for k in range(nh):
        fw.active[k] = forced[k]
    for j in range(fcand.shape[0]):
        fw.active[nh + j] = 1 if (fcand[j] != 0 and fw.forced[j]) else 0
    _centre_velocities(e, w, iw, fw.v0)
    _impact_set(e, w, anchored, forced, active, fcand, e_lock, ws, iw, fw, nh)
    q = np.empty(c)
    for ii in range(c):
        k = idx[ii]
        q[ii] = (
            law_rate(iw.rates_after[k], iw.rates_before[k], e_lock) if k < nh else fw.vz[k - nh] - iw.rebound[k - nh]
        )
    return _floor_dense(e, w, anchored, forced, nh, idx, c, q, RATE_TOL, ws, fw)


@njit(cache=True, _nrt=False)
def _impact_set(e, w, anchored, forced, active, fcand, e_lock, ws, iw, fw, nh):
    """One trial of the impact for the combined set fw.active: the hinges' active set and
    the points' marks from it, the impulses and velocities after (iw), the points' height
    rates (fw.vz) and vertical impulses (fw.pz)."""
    for k in range(nh):
        active[k] = fw.active[k]
    _set_trial(anchored, fcand, fw, nh)
    _impact_trial(e, w, anchored, active, forced, e_lock, ws, iw)
    _centres_after(anchored, fw.v0, ws, fw.vc)
    point_heights_rates(e, iw.w_plus, fw.vc, fw.vz)
    vertical_multipliers(ws.kind, ws.nrow, ws.x, fw.pz)


@njit(cache=True, _nrt=False)
def point_heights_accels(e, w, de, dw, ac, out):
    """out[j] = d2z_j/dt2 from the centres' accelerations ac and the axes' (dw, de):
    the upper end of segment j, a_j + (dw_j x e_j + w_j x de_j); point N, the lower end
    of segment N - 1, with the sign of the arm reversed."""
    n = e.shape[0]
    for j in range(n):
        out[j] = ac[j, 2] + dw[j, 0] * e[j, 1] - dw[j, 1] * e[j, 0] + w[j, 0] * de[j, 1] - w[j, 1] * de[j, 0]
    i = n - 1
    out[n] = ac[i, 2] - (dw[i, 0] * e[i, 1] - dw[i, 1] * e[i, 0] + w[i, 0] * de[i, 1] - w[i, 1] * de[i, 0])


@njit(cache=True, _nrt=True)
def floor_lock_set(e, w, anchored, cand, active, fcand, ws, de, dw, ddg, lam, fw):
    """Which hinges at their limit stay locked and which floor candidates (points at rest
    on the floor) the floor holds: the acceleration-level LCP over both (module
    docstring; ``impacts.lock_set`` over the hinges alone).  ``active``, ``anchored``: the
    initial guess on entry, the solution on exit; de, dw the accelerations, ddg the
    hinges' d2g/dt2, lam the lock multipliers, fw.pz the floor's vertical forces and
    fw.vz the points' height accelerations.  Returns the number of trials, -1 if the
    pivoting cycled and the dense problem (``dense_lock_set``) failed too."""
    nh = cand.shape[0]
    m = nh + anchored.shape[0]
    free = np.zeros(fcand.shape[0], np.uint8)  # (the accumulation rule's holds: impacts only)
    _start_sets(cand, active, anchored, fcand, free, fw, nh)
    zero = np.zeros(fcand.shape[0])
    for i in range(e.shape[0]):  # (gravity, g = 1)
        fw.v0[i, 0], fw.v0[i, 1], fw.v0[i, 2] = 0.0, 0.0, -1.0
    piv = new_pivoting(m)
    final = False  # the set came from the dense problem: accept it
    for it in range(PIVOT_BUDGET + 3):
        _lock_trial(e, w, anchored, active, fcand, ws, de, dw, ddg, fw, nh)
        nviol, atol = _lock_violations(cand, active, ws, ddg, lam, piv.viol)
        nviol += _floor_violations(fcand, free, fw, nh, zero, atol / W_W, atol, piv.viol)
        if nviol == 0 or final:
            return it
        if next_active_set(piv, fw.active, m, nviol) == PIVOT_FALLBACK:  # (cycling, or too long)
            if dense_lock_set(e, w, anchored, cand, active, fcand, ws, de, dw, ddg, atol, fw) < 0:
                return -1
            final = True
    return -1


@njit(cache=True, _nrt=True)
def dense_lock_set(e, w, anchored, cand, active, fcand, ws, de, dw, ddg, atol, fw):
    """fw.active <- the solution set of ``floor_lock_set``'s LCP solved as one dense problem
    (``_floor_dense``; accelerations within atol), from none of the candidates acting: its
    fallback where pivoting cycles.  Returns Lemke's pivot count (-1: failure)."""
    nh = cand.shape[0]
    m = nh + anchored.shape[0]
    idx = np.empty(m, dtype=np.int64)
    none = np.zeros(max(nh, 1), np.uint8)
    free = np.zeros(fcand.shape[0], np.uint8)
    c = _dense_candidates(cand, none, fcand, free, nh, idx)
    for k in range(m):
        fw.active[k] = 0
    for i in range(e.shape[0]):  # (gravity, g = 1)
        fw.v0[i, 0], fw.v0[i, 1], fw.v0[i, 2] = 0.0, 0.0, -1.0
    _lock_trial(e, w, anchored, active, fcand, ws, de, dw, ddg, fw, nh)
    q = np.empty(c)
    for ii in range(c):
        k = idx[ii]
        q[ii] = ddg[k] if k < nh else fw.vz[k - nh]
    return _floor_dense(e, w, anchored, none, nh, idx, c, q, atol, ws, fw)


@njit(cache=True, _nrt=False)
def _lock_trial(e, w, anchored, active, fcand, ws, de, dw, ddg, fw, nh):
    """One trial of the lock set for the combined set fw.active: the accelerations (de,
    dw), the hinges' d2g/dt2, the points' height accelerations (fw.vz) and vertical
    forces (fw.pz)."""
    for k in range(nh):
        active[k] = fw.active[k]
    _set_trial(anchored, fcand, fw, nh)
    accelerations(e, w, anchored, active, ws, de, dw)
    hinge_accels(e, w, de, dw, ddg)
    _centres_after(anchored, fw.v0, ws, fw.vc)
    point_heights_accels(e, w, de, dw, fw.vc, fw.vz)
    vertical_multipliers(ws.kind, ws.nrow, ws.x, fw.pz)
