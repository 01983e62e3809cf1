"""Restitution inside a RATTLE step (``contacts.newton``'s law): the rate at which each
new contact reached its limit within the step (``impact_rates``), the rates stage 2 aims
the rebounding rows at (``rebound_targets``), what the rebounds carry
(``rebound_energy``) and the limits they leave (``leave_limits``)."""

from __future__ import annotations

import math

import numpy as np

from ...jit import njit
from .blocks import solve_blocks
from .rows import (
    BOUNCE,
    K_ANCHOR_LOWER,
    K_ANCHOR_UPPER,
    K_BEND,
    is_floor,
)
from .stage1 import _factor_symmetric, floor_gap
from .state import MAX_NEW, point_vz

REBOUND_TOL = 0.02  # a step with rebounds may raise U + T by this fraction of the energy they carry (the
#   approach rate is estimated within the step, ``impact_rates``: its error does not shrink with a
#   shorter step from the same start)


@njit(cache=True, inline="always")
def _is_new_contact(k, locked0, mark, p):
    """Is a row of kind k, after stage 1, a new contact: the bend row of a hinge not locked
    at the step's start (locked0), or the floor row of a free point (its mark in
    ``anchored`` and ``touching``: 0), with impulse p > 0?  (Numbers, not the bundles: a call with them in
    the loop over the rows costs numba a reference count of each of their arrays.)"""
    bend = k == K_BEND and locked0 == 0
    return (bend or (is_floor(k) and mark == 0)) and p > 0.0


@njit(cache=True, _nrt=True)
def impact_rates(h, model, mo, ws, sc):
    """After stage 1, with restitution: the rate at which each new contact reached its
    limit (``_is_new_contact``), into sc.hrebound (hinges) and sc.rebound (points); 0
    elsewhere.  The impacts fall inside the step: from a row's gap g0 and rate v0 at the
    step's start and its free mean rate over the step vbar (the rates at u_half less what
    the new contacts' impulses P_B did: vbar_B = rate_B - ((G^-1)_BB)^-1 P_B, G = J W J^T
    at the step's start with the joints, anchors and held rows; one solve per new
    contact, MAX_NEW at most, else none is estimated: a touch), with d2g/dt2 = a =
    2 (vbar - v0) / h, the row reaches its limit at -sqrt(v0^2 - 2 a g0).  It takes the
    inelastic law instead (0) where its free motion would not reach its limit in the step
    (g0 + h vbar > 0: the others' impulses pushed it there, as in the event method's second
    pass), and where it was leaving its limit at the step's start (v0 > 0: it rebounded at
    the last step and is back within one; the series of ever smaller rebounds ends at the
    step's scale, as the accumulation rule ends it in the event method).  Second order in
    the impact's time into the step; the step start's own rate errs by a tau, which
    halving the step does not shorten."""
    for k in range(sc.hrebound.shape[0]):
        sc.hrebound[k] = 0.0
    for j in range(sc.rebound.shape[0]):
        sc.rebound[j] = 0.0
    m = 0
    kind, nrow, x, locked0, anchored, touching = ws.kind, ws.nrow, ws.x, sc.start.locked, mo.anchored, mo.touching
    for j in range(nrow.shape[0]):
        nk = locked0.shape[0]  # (hinge j - 1, at point j: its mark where it exists, clamped elsewhere, unused there)
        lock0 = locked0[min(max(j - 1, 0), nk - 1)] if nk > 0 else 0
        mark = anchored[j] | touching[j]  # (a point sliding on the floor since the last step: no new contact)
        for r in range(nrow[j]):
            if _is_new_contact(kind[j, r], lock0, mark, x[j, r]):
                if m < MAX_NEW:
                    sc.newrow[m, 0], sc.newrow[m, 1] = j, r
                m += 1
    if m == 0 or m > MAX_NEW:
        return
    _factor_symmetric(mo.anchored, ws, sc.ledger, 0)
    ginv = np.zeros((m, m))
    for c in range(m):
        for jj in range(ws.nrow.shape[0]):
            for rr in range(ws.nrow[jj]):
                ws.rhs[jj, rr] = 0.0
        ws.rhs[sc.newrow[c, 0], sc.newrow[c, 1]] = 1.0
        solve_blocks(ws.nrow, ws.sym, ws.rhs, sc.rate)
        for b in range(m):
            ginv[b, c] = sc.rate[sc.newrow[b, 0], sc.newrow[b, 1]]
    p = np.zeros(m)
    for b in range(m):
        p[b] = ws.x[sc.newrow[b, 0], sc.newrow[b, 1]]
        if not ginv[b, b] > 0.0:  # (a redundant row: no estimate)
            return
    y = np.linalg.solve(ginv, p)
    st = sc.start
    for b in range(m):
        j, r = sc.newrow[b, 0], sc.newrow[b, 1]
        vbar = sc.ra1[j, r] - y[b]
        bend = ws.kind[j, r] == K_BEND
        if bend:
            g0, v0 = -model.cos_alpha, 0.0
            for q in range(3):
                g0 += st.e[j - 1, q] * st.e[j, q]
                v0 += st.ve[j - 1, q] * st.e[j, q] + st.e[j - 1, q] * st.ve[j, q]
        else:
            g0, v0 = floor_gap(model, st, j), point_vz(st, j)
        a = 2.0 * (vbar - v0) / h
        rad = v0 * v0 - 2.0 * a * max(g0, 0.0)
        v = -math.sqrt(rad) if (rad > 0.0 and v0 <= 0.0 and g0 + h * vbar <= 0.0) else 0.0
        if bend:
            sc.hrebound[j - 1] = v
        else:
            sc.rebound[j] = v


@njit(cache=True, inline="always")
def restitution(model):
    """Does either restitution law act (``contacts.newton``; 0, the default, is inelastic)?"""
    return model.e_lock > 0.0 or model.e_floor > 0.0


@njit(cache=True, inline="always")
def _bounce_row(anchored, j, k):
    """Is a row of kind k at point j the vertical row of a point bouncing off the floor
    (an anchor's z row at a free point: ``rows.BOUNCE``)?"""
    return anchored[j] == 0 and (k == K_ANCHOR_UPPER + 2 or k == K_ANCHOR_LOWER + 2)


@njit(cache=True, _nrt=False)
def rebound_targets(anchored, ws, sc):
    """Stage 2's right-hand side with restitution: a rebounding hinge's row and a bouncing
    point's vertical row (on a frictionless floor: its height row) aim at the rate they
    leave with (G P = target - rate before)."""
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            k = ws.kind[j, r]
            if k == K_BEND:
                ws.rhs[j, r] += sc.hrebound[j - 1]
            elif _bounce_row(anchored, j, k) or is_floor(k):
                ws.rhs[j, r] += sc.rebound[j]


@njit(cache=True, _nrt=False)
def rebound_energy(anchored, ws, sc):
    """(1/2) sum P2 v over the rows that rebound in stage 2 (v their target rate): about the
    kinetic energy the rebounds carry away from their limits."""
    s = 0.0
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            k = ws.kind[j, r]
            if k == K_BEND:
                s += 0.5 * abs(ws.x[j, r]) * sc.hrebound[j - 1]
            elif _bounce_row(anchored, j, k) or is_floor(k):
                s += 0.5 * abs(ws.x[j, r]) * sc.rebound[j]
    return s


@njit(cache=True, _nrt=False)
def leave_limits(mo, sc):
    """After stage 2 with restitution: a hinge that took its impulse and rebounds is not
    locked (sc.hrebound stays its rate: ``commit`` logs its impact as a lock's); one that
    was released takes no rebound (0).  A bouncing point's floor rows are off again; on a
    frictionless floor a point whose height row took its impulse and rebounds leaves the
    floor (not touching), one whose row was released takes no rebound."""
    for k in range(mo.locked.shape[0]):
        if sc.hrebound[k] > 0.0:
            if mo.locked[k] != 0:
                mo.locked[k] = 0
            else:
                sc.hrebound[k] = 0.0
    for j in range(sc.floor_on.shape[0]):
        if sc.floor_on[j] == BOUNCE:
            sc.floor_on[j] = 0
        elif sc.rebound[j] > 0.0:  # (a frictionless floor's height row: ``stage2.land``)
            if sc.floor_on[j] != 0:
                sc.floor_on[j] = 0
                mo.touching[j] = 0
            else:
                sc.rebound[j] = 0.0
