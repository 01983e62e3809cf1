"""Equations of motion: O(N) hinge forces (docs/model.md, section 2), numba kernels.

Everything here is nondimensional: m = b = g = 1 (mass m, length b, time sqrt(b/g)).

Indexing (0-based, from the top):
  * segment ``i = 0..N-1`` has unit axis ``e[i]`` (lower end -> upper end), angular
    velocity ``w[i]`` (kept perpendicular to ``e[i]``);
  * point ``j = 0..N``: point ``j`` is the upper end of segment ``j`` and the lower end
    of segment ``j-1``; point 0 is the free top, point N the original pivot (origin);
  * hinge ``k = 0..N-2`` sits at point ``k+1`` between segments ``k`` and ``k+1``.
Status arrays (uint8): ``anchored[N+1]`` (point held by the floor; 2 while the impact
that makes the anchor is being solved), ``locked[N-1]``.
A segment is *landed* when both its end points are anchored; it is then frozen.

The accelerations solve (J W J^T) x = rhs over the constraint rows (``rows``) by one
O(N) block factorisation (``blocks``); the kinematics (positions, velocities, energies,
the projection onto the constraints) are in ``kinematics``.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .blocks import factor4, factor_general, generalized_forces, solve4, solve_general, torques4
from .forces import any_smooth_law, smooth_torques, torque_rhs
from .rows import (
    ROW_ANCHOR_LOWER,
    ROW_ANCHOR_UPPER,
    ROW_HINGE,
    ROW_LOCK,
    ROW_SLIDE_LOWER,
    ROW_SLIDE_UPPER,
    W_W,
    build_rows,
    rows_rhs4,
)
from .rules import is_held
from .rules import is_landed as _is_landed


@njit(cache=True, _nrt=False)
def accelerations(e, w, anchored, locked, ws, de, dw):
    """Equations of motion between events: de/dt = w x e, dw/dt = 3 P (torque).

    Solves the hinge forces and lock multipliers (``ws.x``) for the current locked set
    and anchors (``ws``: the ``state.Work`` bundle), with the smooth laws' torques applied
    (``forces``: ``ws.tau``, the power they remove in ``ws.power``); returns the number of
    redundant rows dropped.
    """
    n = e.shape[0]
    J, kind, nrow, S, G, drop, rhs, x, gf = ws.J, ws.kind, ws.nrow, ws.S, ws.G, ws.drop, ws.rhs, ws.x, ws.gf
    applied = any_smooth_law(ws.laws)
    if applied:
        ws.power[0] = smooth_torques(ws.laws, e, w, anchored, ws.tau)
    if rows_rhs4(e, w, anchored, locked, kind, nrow, rhs):
        if applied:
            torque_rhs(e, ws.tau, kind, nrow, rhs)
        ndrop = factor4(e, anchored, kind, nrow, S, G, drop)
        solve4(nrow, S, G, rhs, x)
        torques4(e, kind, nrow, x, gf)
    else:
        build_rows(e, w, anchored, locked, J, kind, nrow, rhs, np.bool_(True))
        if applied:
            torque_rhs(e, ws.tau, kind, nrow, rhs)
        ndrop = factor_general(anchored, J, nrow, S, G, drop)
        solve_general(nrow, S, G, drop, rhs, x)
        generalized_forces(anchored, J, nrow, x, gf)
    for i in range(n):
        if _is_landed(anchored, i):
            for q in range(3):
                de[i, q] = 0.0
                dw[i, q] = 0.0
            continue
        ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
        wx, wy, wz = w[i, 0], w[i, 1], w[i, 2]
        de[i, 0] = wy * ez - wz * ey
        de[i, 1] = wz * ex - wx * ez
        de[i, 2] = wx * ey - wy * ex
        tx, ty, tz = W_W * gf[i, 3], W_W * gf[i, 4], W_W * gf[i, 5]
        if applied:
            tx += W_W * ws.tau[i, 0]
            ty += W_W * ws.tau[i, 1]
            tz += W_W * ws.tau[i, 2]
        tp = tx * ex + ty * ey + tz * ez
        dw[i, 0] = tx - tp * ex
        dw[i, 1] = ty - tp * ey
        dw[i, 2] = tz - tp * ez
    return ndrop


@njit(cache=True, _nrt=False)
def lock_multipliers(kind, nrow, x, lam):
    """lam[k] = multiplier of hinge k's lock row (0 where unlocked)."""
    for k in range(lam.shape[0]):
        lam[k] = 0.0
        j = k + 1
        for r in range(nrow[j]):
            if kind[j, r] == ROW_LOCK:
                lam[k] = x[j, r]


@njit(cache=True, _nrt=False)
def anchor_forces(kind, nrow, x, out):
    """out[j] = force of the anchor at point j on the non-landed chain (of the floor on a
    sliding point: its height row, vertical)."""
    for j in range(out.shape[0]):
        out[j, 0] = 0.0
        out[j, 1] = 0.0
        out[j, 2] = 0.0
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_ANCHOR_LOWER or k == ROW_ANCHOR_UPPER:
                out[j, r % 3] += x[j, r]
            elif k == ROW_SLIDE_LOWER or k == ROW_SLIDE_UPPER:
                out[j, 2] += x[j, r]


@njit(cache=True, _nrt=False)
def anchor_force_total(kind, nrow, x, out):
    """out = sum_j F_j, the continuous force of all anchors on the airborne chain
    (the multipliers of the anchor rows, and of the sliding points' height rows; landed
    segments, at rest, are not included)."""
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_ANCHOR_LOWER or k == ROW_ANCHOR_UPPER:
                out[r % 3] += x[j, r]
            elif k == ROW_SLIDE_LOWER or k == ROW_SLIDE_UPPER:
                out[2] += x[j, r]


@njit(cache=True, _nrt=False)
def pile_pull(anchored, kind, nrow, x, out):
    """out = force of the pile on the hanging chain: the force of the first anchored
    point from the top, j*, on segment j* - 1 above it (its ROW_ANCHOR_LOWER rows);
    zero when the top end is anchored (no hanging part).  out[2] < 0: a pull down."""
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    for j in range(anchored.shape[0]):
        if is_held(anchored, j):
            if j > 0 and nrow[j] >= 3 and kind[j, 0] == ROW_ANCHOR_LOWER:
                for q in range(3):
                    out[q] = x[j, q]
            return


@njit(cache=True, _nrt=False)
def chain_tension(e, kind, nrow, x, out):
    """out[j] = T_j, the tension of the airborne chain at point j, pulling positive: the
    force on the segment above point j there, along it, T_j = -F_j . e_{j-1} (F_j: the
    hinge's multipliers, which act on the segment above (``rows``), or at a held point
    the support's force on it, its anchor-lower rows).  At a held point with no airborne
    segment above (a held top end) the support's force on the segment below, along it,
    T_j = F_j . e_j.  0 where no such row acts: a free end, the points between landed
    segments (the floor holds them).  Units of x (m g: forces, or m sqrt(g b): a step's
    impulses)."""
    n = e.shape[0]
    for j in range(n + 1):
        above, nh = 0.0, 0  # the hinge's or the lower anchor's force on the segment above, along it
        below, nu = 0.0, 0  # the upper anchor's force on the segment below, along it
        for r in range(nrow[j]):
            k = kind[j, r]
            if (k == ROW_HINGE or k == ROW_ANCHOR_LOWER) and j > 0:
                above += x[j, r] * e[j - 1, r % 3]
                nh += 1
            elif k == ROW_ANCHOR_UPPER and j < n:
                below += x[j, r] * e[j, r % 3]
                nu += 1
        out[j] = -above if nh > 0 else (below if nu > 0 else 0.0)
