"""Kinematics of the chain (docs/model.md, section 2), numba kernels, nondimensional:
the points' positions and velocities, the energies, the rows' rates, impulses applied,
and the projection of a state onto its constraints (``project_state``)."""

from __future__ import annotations

import math

from ..jit import entry, njit
from .blocks import factor, generalized_forces, solve, torques4
from .rows import (
    ROW_ANCHOR_LOWER,
    ROW_ANCHOR_UPPER,
    ROW_HINGE,
    ROW_LOCK,
    ROW_SLIDE_LOWER,
    ROW_SLIDE_UPPER,
    W_W,
    constraint_rows,
)
from .rules import is_landed as _is_landed

PROJ_TOL = 1e-12  # constraint drift tolerated before projection (b; at least)
PROJ_ROUNDOFF = 1e-13  # ... and per segment: the round-off of positions summed over N segments


@njit(cache=True, _nrt=False)
def point_positions(e, out):
    """Positions of points 0..N: point N at the origin, point j = 2 sum_{i>=j} e_i."""
    n = e.shape[0]
    out[n, 0] = 0.0
    out[n, 1] = 0.0
    out[n, 2] = 0.0
    for j in range(n - 1, -1, -1):
        for q in range(3):
            out[j, q] = out[j + 1, q] + 2.0 * e[j, q]


@njit(cache=True, _nrt=False)
def velocities(e, w, pv, vel):
    """Point velocities pv (N+1, 3) and centre velocities vel (N, 3) from w:
    d/dt point_j = 2 sum_{i>=j} w_i x e_i, v_i = pv_{i+1} + w_i x e_i."""
    n = e.shape[0]
    pv[n, 0] = 0.0
    pv[n, 1] = 0.0
    pv[n, 2] = 0.0
    for i in range(n - 1, -1, -1):
        dx = w[i, 1] * e[i, 2] - w[i, 2] * e[i, 1]
        dy = w[i, 2] * e[i, 0] - w[i, 0] * e[i, 2]
        dz = w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0]
        vel[i, 0] = pv[i + 1, 0] + dx
        vel[i, 1] = pv[i + 1, 1] + dy
        vel[i, 2] = pv[i + 1, 2] + dz
        pv[i, 0] = pv[i + 1, 0] + 2.0 * dx
        pv[i, 1] = pv[i + 1, 1] + 2.0 * dy
        pv[i, 2] = pv[i + 1, 2] + 2.0 * dz


@entry
@njit(cache=True, _nrt=False)
def kinetic_energy(e, w, pv, vel):
    """T = sum 1/2 |v_i|^2 + 1/2 (1/3) |w_i|^2 (units m g b)."""
    velocities(e, w, pv, vel)
    t = 0.0
    for i in range(e.shape[0]):
        t += 0.5 * (vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2)
        t += (w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2) / 6.0
    return t


@entry
@njit(cache=True, _nrt=False)
def potential_energy(e):
    """U = sum z_centre_i = sum_i (e_iz + 2 sum_{k>i} e_kz) (units m g b)."""
    n = e.shape[0]
    u = 0.0
    below = 0.0
    for i in range(n - 1, -1, -1):
        u += below + e[i, 2]
        below += 2.0 * e[i, 2]
    return u


@njit(cache=True, _nrt=False)
def constraint_velocities(e, w, J, nrow, pv, vel, out):
    """out[j, r] = J_row (v, w): the rate of every constraint row."""
    velocities(e, w, pv, vel)
    n = e.shape[0]
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            acc = 0.0
            if j >= 1:
                for q in range(3):
                    acc += J[j, r, q] * vel[j - 1, q] + J[j, r, 3 + q] * w[j - 1, q]
            if j < n:
                for q in range(3):
                    acc += J[j, r, 6 + q] * vel[j, q] + J[j, r, 9 + q] * w[j, q]
            out[j, r] = acc


@njit(cache=True, _nrt=False)
def apply_impulses(e, w, anchored, J, nrow, x, gf, sign):
    """w_i += sign * 3 P_i (torque of J^T x on segment i): a velocity jump."""
    generalized_forces(anchored, J, nrow, x, gf)
    torque_jump(e, w, anchored, gf, sign)


@njit(cache=True, _nrt=False)
def constraint_rates4(e, w, anchored, kind, nrow, pv, vel, out):
    """``constraint_velocities`` for the fixed-size layout, without J: hinge rows
    (lower end of a) - (upper end of c), anchor rows the velocity of the anchored end,
    lock row n . (w_a - w_c) with n = e_a x e_c (the terms of airborne segments only)."""
    velocities(e, w, pv, vel)
    n = e.shape[0]
    for j in range(nrow.shape[0]):
        nr = nrow[j]
        if nr == 0:
            continue
        a = j - 1
        c = j
        k0 = kind[j, 0]
        for q in range(3):
            out[j, q] = 0.0
        if k0 == ROW_HINGE or k0 == ROW_ANCHOR_LOWER:  # lower end of a: v_a + e_a x w_a
            out[j, 0] += vel[a, 0] + e[a, 1] * w[a, 2] - e[a, 2] * w[a, 1]
            out[j, 1] += vel[a, 1] + e[a, 2] * w[a, 0] - e[a, 0] * w[a, 2]
            out[j, 2] += vel[a, 2] + e[a, 0] * w[a, 1] - e[a, 1] * w[a, 0]
        if k0 == ROW_HINGE:  # minus the upper end of c: -v_c + e_c x w_c
            out[j, 0] += -vel[c, 0] + e[c, 1] * w[c, 2] - e[c, 2] * w[c, 1]
            out[j, 1] += -vel[c, 1] + e[c, 2] * w[c, 0] - e[c, 0] * w[c, 2]
            out[j, 2] += -vel[c, 2] + e[c, 0] * w[c, 1] - e[c, 1] * w[c, 0]
        elif k0 == ROW_ANCHOR_UPPER or nr == 6:  # upper end of c: v_c - e_c x w_c
            r0 = 3 if nr == 6 else 0  # (rows 3:6 of a split anchor)
            out[j, r0] = vel[c, 0] - e[c, 1] * w[c, 2] + e[c, 2] * w[c, 1]
            out[j, r0 + 1] = vel[c, 1] - e[c, 2] * w[c, 0] + e[c, 0] * w[c, 2]
            out[j, r0 + 2] = vel[c, 2] - e[c, 0] * w[c, 1] + e[c, 1] * w[c, 0]
        if nr == 4:
            nx = e[a, 1] * e[c, 2] - e[a, 2] * e[c, 1]
            ny = e[a, 2] * e[c, 0] - e[a, 0] * e[c, 2]
            nz = e[a, 0] * e[c, 1] - e[a, 1] * e[c, 0]
            acc = 0.0
            if not _is_landed(anchored, a):
                acc += nx * w[a, 0] + ny * w[a, 1] + nz * w[a, 2]
            if c < n and not _is_landed(anchored, c):
                acc -= nx * w[c, 0] + ny * w[c, 1] + nz * w[c, 2]
            out[j, 3] = acc


@njit(cache=True, _nrt=False)
def torque_jump(e, w, anchored, gf, sign):
    """w_i += sign * 3 P_i gf[i, 3:6] (P_i: projection perpendicular to e_i); w = 0 on
    landed segments."""
    for i in range(e.shape[0]):
        if _is_landed(anchored, i):
            w[i, 0] = 0.0
            w[i, 1] = 0.0
            w[i, 2] = 0.0
            continue
        tx, ty, tz = W_W * gf[i, 3], W_W * gf[i, 4], W_W * gf[i, 5]
        tp = tx * e[i, 0] + ty * e[i, 1] + tz * e[i, 2]
        w[i, 0] += sign * (tx - tp * e[i, 0])
        w[i, 1] += sign * (ty - tp * e[i, 1])
        w[i, 2] += sign * (tz - tp * e[i, 2])


@njit(cache=True, _nrt=False)
def normalize_state(e, w, anchored):
    """|e_i| = 1, w_i perpendicular to e_i, w = 0 on landed segments."""
    for i in range(e.shape[0]):
        nrm = math.sqrt(e[i, 0] ** 2 + e[i, 1] ** 2 + e[i, 2] ** 2)
        e[i, 0] /= nrm
        e[i, 1] /= nrm
        e[i, 2] /= nrm
        if _is_landed(anchored, i):
            w[i, 0] = 0.0
            w[i, 1] = 0.0
            w[i, 2] = 0.0
        else:
            p = w[i, 0] * e[i, 0] + w[i, 1] * e[i, 1] + w[i, 2] * e[i, 2]
            w[i, 0] -= p * e[i, 0]
            w[i, 1] -= p * e[i, 1]
            w[i, 2] -= p * e[i, 2]


@njit(cache=True, inline="always")
def drift_removable(anchored, j):
    """Whether a projection can move anchored point j (0..N) onto its anchor: only by
    turning the segment below it, j, so only if that one is airborne.  Positions are sums
    of the axes from the bottom (``point_positions``): a point whose lower segment is
    landed (frozen) is where that segment's upper end is, and the row that holds it there
    (ROW_ANCHOR_LOWER of the segment above) is a joint to a frozen body, met by
    construction.  Its anchor's miss (a landed segment whose two ends were anchored in
    one time step, each beside another anchored neighbour, has its anchors off its length
    by the drift between them) is not drift: no turn of the airborne segments changes it."""
    return j < anchored.shape[0] - 1 and not _is_landed(anchored, j)


@njit(cache=True, inline="always")
def _floor_z(anchored, pts):
    """The floor's height in the chain's frame (``rules.floor_height``) from the points'
    positions or velocities ``pts``: 0 while point N is held, else that of the held point
    of largest index (a frictionless floor that point N has left)."""
    n1 = anchored.shape[0]
    if anchored[n1 - 1] != 0:
        return 0.0
    for j in range(n1 - 2, -1, -1):
        if anchored[j] != 0:
            return pts[j, 2]
    return 0.0


@njit(cache=True, _nrt=False)
def slide_rates_from_floor(anchored, kind, nrow, pv, out):
    """The sliding points' height rows' rates (``out``, from velocities with point N at
    rest, ``pv``) made the rates relative to the floor: minus the held reference's vertical
    rate (``_floor_z`` of the velocities; nothing while point N is held)."""
    vz = _floor_z(anchored, pv)
    if vz == 0.0:
        return
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            if kind[j, r] == ROW_SLIDE_LOWER or kind[j, r] == ROW_SLIDE_UPPER:
                out[j, r] -= vz


@njit(cache=True, _nrt=False)
def position_residuals(e, anchored, locked, lock_cos, anchor_pos, kind, nrow, pts, out):
    """Residual of every row at the position level: anchors (point - anchor, where
    ``drift_removable``; else 0), locks (e_a . e_c - lock_cos: the cosine at which the
    hinge locked, cos(alpha) to within the event tolerance), hinges 0 (positions are
    built from e).  Returns max |.|."""
    point_positions(e, pts)
    zf = _floor_z(anchored, pts)
    worst = 0.0
    for j in range(nrow.shape[0]):
        removable = drift_removable(anchored, j)
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_HINGE:
                out[j, r] = 0.0
            elif k == ROW_LOCK:
                a = j - 1
                out[j, r] = e[a, 0] * e[j, 0] + e[a, 1] * e[j, 1] + e[a, 2] * e[j, 2] - lock_cos[a]
            elif k == ROW_SLIDE_LOWER or k == ROW_SLIDE_UPPER:
                out[j, r] = pts[j, 2] - zf  # (its height above the floor: ``_floor_z``)
            elif removable:
                out[j, r] = pts[j, r % 3] - anchor_pos[j, r % 3]
            else:
                out[j, r] = 0.0
            worst = max(worst, abs(out[j, r]))
    return worst


@njit(cache=True, _nrt=False)
def rotate_by(e, anchored, gf, sign):
    """e_i <- normalize(e_i + sign * 3 P_i tau_i x e_i) (a small rotation)."""
    for i in range(e.shape[0]):
        if _is_landed(anchored, i):
            continue
        tx, ty, tz = sign * W_W * gf[i, 3], sign * W_W * gf[i, 4], sign * W_W * gf[i, 5]
        ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
        nx = ex + (ty * ez - tz * ey)
        ny = ey + (tz * ex - tx * ez)
        nz = ez + (tx * ey - ty * ex)
        nrm = math.sqrt(nx * nx + ny * ny + nz * nz)
        e[i, 0] = nx / nrm
        e[i, 1] = ny / nrm
        e[i, 2] = nz / nrm


@njit(cache=True, _nrt=False)
def _axis_rates(e, w, out):
    """out_i = de_i/dt = w_i x e_i."""
    for i in range(e.shape[0]):
        out[i, 0] = w[i, 1] * e[i, 2] - w[i, 2] * e[i, 1]
        out[i, 1] = w[i, 2] * e[i, 0] - w[i, 0] * e[i, 2]
        out[i, 2] = w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0]


@njit(cache=True, _nrt=False)
def rates_for_axes(e, de, w):
    """w_i = e_i x de_i: the rates that turn the (moved, unit) axes e_i at the rates de_i
    they had before the move, but for the components along e_i (which a segment's fixed
    length forbids): the points' velocities are kept through a position projection up to
    the move's size times the rates, so the move leaves the kinetic energy alone."""
    for i in range(e.shape[0]):
        w[i, 0] = e[i, 1] * de[i, 2] - e[i, 2] * de[i, 1]
        w[i, 1] = e[i, 2] * de[i, 0] - e[i, 0] * de[i, 2]
        w[i, 2] = e[i, 0] * de[i, 1] - e[i, 1] * de[i, 0]


@njit(cache=True, inline="always")
def projection_tol(n):
    """Constraint drift (b) left as it is by the projection of either method: PROJ_TOL,
    or the round-off of point positions summed over n segments (PROJ_ROUNDOFF n),
    whichever is larger.  Projecting round-off only moves the state by round-off, and
    changes its energy each time (docs/model.md, section 3, "The books")."""
    return max(PROJ_TOL, PROJ_ROUNDOFF * n)


@njit(cache=True, _nrt=False)
def project_state(chain, ws, pts, vel, tol, iters, with_velocities=True):
    """Remove constraint drift from the state of ``chain`` (``state.Chain``; ``pts``,
    ``vel``: scratch of the points' positions and the centres' velocities): normalise,
    then Gauss-Newton on anchor positions and locked angles
    (delta = -W J^T (J W J^T)^{-1} c), then (``with_velocities``) the rates that keep
    the axes' velocities de_i/dt through that move (``rates_for_axes``), and the same
    projection on velocities.  Returns the largest position residual before projection
    and after it (above ``tol`` only when Gauss-Newton ran ``iters`` iterations without
    meeting every row)."""
    e, w, anchored, locked = chain.Y[0], chain.Y[1], chain.anchored, chain.locked
    lock_cos, anchor_pos = chain.lock_cos, chain.anchor_pos
    J, kind, nrow, S, G, drop, rhs, x, gf = ws.J, ws.kind, ws.nrow, ws.S, ws.G, ws.drop, ws.rhs, ws.x, ws.gf
    normalize_state(e, w, anchored)
    fits = constraint_rows(e, w, anchored, locked, J, kind, nrow, rhs)
    res0 = position_residuals(e, anchored, locked, lock_cos, anchor_pos, kind, nrow, pts, rhs)
    res = res0
    it = 0
    if with_velocities and res > tol:
        _axis_rates(e, w, vel)  # de_i/dt, kept through the move (the points' velocities)
    while res > tol and it < iters:
        factor(e, anchored, J, kind, nrow, S, G, drop)
        solve(kind, nrow, S, G, drop, rhs, x)
        if fits:
            torques4(e, kind, nrow, x, gf)
        else:
            generalized_forces(anchored, J, nrow, x, gf)
        rotate_by(e, anchored, gf, -1.0)
        fits = constraint_rows(e, w, anchored, locked, J, kind, nrow, rhs)
        res = position_residuals(e, anchored, locked, lock_cos, anchor_pos, kind, nrow, pts, rhs)
        it += 1
    normalize_state(e, w, anchored)
    if not with_velocities:
        return res0, res
    if it > 0:
        rates_for_axes(e, vel, w)
        normalize_state(e, w, anchored)
        fits = constraint_rows(e, w, anchored, locked, J, kind, nrow, rhs)
    # velocities
    if fits:
        constraint_rates4(e, w, anchored, kind, nrow, pts, vel, rhs)
    else:
        constraint_velocities(e, w, J, nrow, pts, vel, rhs)
        slide_rates_from_floor(anchored, kind, nrow, pts, rhs)
    vres = 0.0
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            vres = max(vres, abs(rhs[j, r]))
    if vres > tol:
        factor(e, anchored, J, kind, nrow, S, G, drop)
        solve(kind, nrow, S, G, drop, rhs, x)
        if fits:
            torques4(e, kind, nrow, x, gf)
            torque_jump(e, w, anchored, gf, -1.0)
        else:
            apply_impulses(e, w, anchored, J, nrow, x, gf, -1.0)
    return res0, res
