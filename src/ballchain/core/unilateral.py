"""The floor's rows as complementarity candidates beside the hinges' (docs/model.md, section
3), numba kernels, nondimensional: a floor that pushes and never pulls.

A floor candidate is a point j with ``fcand[j]`` > 0, the mark it takes while the floor
holds it (``rules.SLIDING`` on a frictionless floor: one height row; 1, the anchor: three
rows); in a trial set it is held (``anchored[j] = fcand[j]``) or free (0).  With P_j its
vertical impulse (velocity level) or force (acceleration level):

* velocity level (``floor_impact``): held => P_j >= 0 and its height's rate leaves the
  impact at the floor's target (``ImpactWork.rebound``: 0, or Newton's e |vz-|); free =>
  its height's rate after the impact is at least that target;
* acceleration level (``floor_lock_set``; points at rest on the floor): held => P_j >= 0;
  free => its height's acceleration z_j'' >= 0.

Beside the hinges' complementarity (``impacts``), both are one LCP over the hinges and the
floor candidates together, solved by the same principal pivoting (``lcp``) on a combined
index (hinge k at k, floor candidate j at N - 1 + j).  Where it cycles the call fails
(-1): there is no dense fallback for floor rows yet.

The points' velocities and accelerations come from the centres' (maximal coordinates: the
segment's velocity v_i, given as the rigid chain's from w with point N at rest plus
``ImpactWork.dv``, and its change J^T x over the unit mass) and the axes': the upper end of
segment i moves at v_i + w_i x e_i, the lower end at v_i - w_i x e_i.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..jit import njit
from .blocks import fits4, forces4, generalized_forces
from .dynamics import accelerations
from .impacts import (
    MULT_RTOL,
    MULT_TOL,
    _impact_books,
    _impact_trial,
    _impact_violations,
    _lock_violations,
    hinge_accels,
)
from .kinematics import velocities
from .lcp import PIVOT_BUDGET, PIVOT_FALLBACK, new_pivoting, next_active_set
from .rows import ROW_ANCHOR_LOWER, ROW_ANCHOR_UPPER, ROW_SLIDE_LOWER, ROW_SLIDE_UPPER, W_W
from .rules import RATE_TOL, is_landed

# The scratch of the floor's complementarity: the combined candidates and active set
# (hinges, then points), each point's height rate (velocity level: before and after the
# trial; acceleration level: its acceleration), its vertical impulse or force, and the
# centres' velocities before the impact and after the trial (acceleration level: gravity's,
# and the trial's).
FloorWork = namedtuple("FloorWork", ["cand", "active", "vz_before", "vz", "pz", "v0", "vc"])


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
def _floor_violations(fcand, fw, nh, target, ptol, rtol, viol):
    """Mark (viol[nh + j]) and count the floor candidates that break complementarity: held
    and pulled (fw.pz < -ptol), or free and below their target (fw.vz < target - rtol)."""
    nviol = 0
    for j in range(fcand.shape[0]):
        viol[nh + j] = 0
        if fcand[j] == 0:
            continue
        if fw.active[nh + j]:
            bad = fw.pz[j] < -ptol
        else:
            bad = fw.vz[j] < target[j] - rtol
        if bad:
            viol[nh + j] = 1
            nviol += 1
    return nviol


@njit(cache=True, _nrt=False)
def _start_sets(cand, active, anchored, fcand, fw, nh):
    """The combined candidates and initial active set: the hinges' as given, a floor
    candidate held where it is held on entry."""
    for k in range(nh):
        fw.cand[k] = cand[k]
        fw.active[k] = active[k]
    for j in range(fcand.shape[0]):
        fw.cand[nh + j] = 1 if fcand[j] != 0 else 0
        fw.active[nh + j] = 1 if (fcand[j] != 0 and anchored[j] != 0) else 0


@njit(cache=True, _nrt=True)
def floor_impact(e, w, anchored, cand, forced, active, fcand, e_lock, ws, iw, fw):
    """Moreau's impact (Newton's at the limits with ``e_lock``, at the floor with the
    targets iw.rebound) with the floor's rows unilateral: the hinges ``cand`` (``forced``
    held whatever their impulse) and the floor candidates ``fcand`` in one LCP
    (module docstring).  ``active`` and ``anchored`` are the initial guess on entry (a
    candidate held on entry is tried held first) and the solution on exit; ``w`` the
    post-impact angular velocities, fw.vz the points' height rates after it, fw.pz their
    vertical impulses, iw as ``impacts.velocity_impact`` leaves it (the books: a sliding
    point's impulse is the floor's).  Returns the number of trials, -1 if the pivoting
    did not settle."""
    nh = cand.shape[0]
    m = nh + anchored.shape[0]
    _start_sets(cand, active, anchored, fcand, fw, nh)
    _centre_velocities(e, w, iw, fw.v0)
    point_heights_rates(e, w, fw.v0, fw.vz_before)
    piv = new_pivoting(m)
    for it in range(PIVOT_BUDGET + 1):
        for k in range(nh):
            active[k] = fw.active[k]
        _set_trial(anchored, fcand, fw, nh)
        _impact_trial(e, w, anchored, active, forced, e_lock, ws, iw)
        nviol = _impact_violations(cand, forced, active, e_lock, ws, iw, piv.viol)
        _centres_after(anchored, fw.v0, ws, fw.vc)
        point_heights_rates(e, iw.w_plus, fw.vc, fw.vz)
        vertical_multipliers(ws.kind, ws.nrow, ws.x, fw.pz)
        pmax = 0.0
        for j in range(fcand.shape[0]):
            pmax = max(pmax, abs(fw.pz[j]))
        ptol = max(MULT_TOL, MULT_RTOL * max(pmax, 1.0))
        nviol += _floor_violations(fcand, fw, nh, iw.rebound, ptol, RATE_TOL, piv.viol)
        if nviol == 0:
            _impact_books(w, ws, iw)
            return it
        if next_active_set(piv, fw.active, m, nviol) == PIVOT_FALLBACK:
            return -1
    return -1


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
    pivoting did not settle."""
    nh = cand.shape[0]
    m = nh + anchored.shape[0]
    _start_sets(cand, active, anchored, fcand, fw, nh)
    zero = np.zeros(fcand.shape[0])
    for i in range(e.shape[0]):  # (gravity, g = 1)
        fw.v0[i, 0], fw.v0[i, 1], fw.v0[i, 2] = 0.0, 0.0, -1.0
    piv = new_pivoting(m)
    for it in range(PIVOT_BUDGET + 1):
        for k in range(nh):
            active[k] = fw.active[k]
        _set_trial(anchored, fcand, fw, nh)
        accelerations(e, w, anchored, active, ws, de, dw)
        hinge_accels(e, w, de, dw, ddg)
        nviol, atol = _lock_violations(cand, active, ws, ddg, lam, piv.viol)
        _centres_after(anchored, fw.v0, ws, fw.vc)
        point_heights_accels(e, w, de, dw, fw.vc, fw.vz)
        vertical_multipliers(ws.kind, ws.nrow, ws.x, fw.pz)
        nviol += _floor_violations(fcand, fw, nh, zero, atol / W_W, atol, piv.viol)
        if nviol == 0:
            return it
        if next_active_set(piv, fw.active, m, nviol) == PIVOT_FALLBACK:
            return -1
    return -1
