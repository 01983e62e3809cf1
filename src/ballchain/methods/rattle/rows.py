"""The constraints of the RATTLE method in maximal coordinates (numba, m = b = g = 1).

Coordinates per segment i: its centre c_i and its axis e_i (lower end c - e, upper end
c + e).  For a thin uniform rod the kinetic energy is exactly
1/2 |c'|^2 + 1/6 |e'|^2 (integrate 1/2 |c' + s e'|^2 ds/2 over s in [-1, 1]), so the
inverse mass W = diag(1, 1, 1, 3, 3, 3) is constant: the same weights as the core's
(v, w) rows (``core.rows.W_V``, ``W_W``), and J W J^T is block tridiagonal (``blocks``).  Rows are gathered per point j, on the segment
above it (a = j - 1, columns 0:6 = (c_a, e_a)) and the one below (c = j, columns 6:12):

  kind 0-2   joint, free point:     (c_a - e_a) - (c_c + e_c) = 0          linear
  kind 3-5   anchor, lower end of a: c_a - e_a - p_j = 0                   linear
  kind 6-8   anchor, upper end of c: c_c + e_c - p_j = 0                   linear
  kind 9     the axis of c:         (|e_c|^2 - 1) / 2 = 0                  quadratic
  kind 10    bend limit of hinge a: e_a . e_c - cos(alpha) >= 0            bilinear, unilateral
  kind 11    floor under point j:   z_j = c_c,z + e_c,z >= z_floor          linear, unilateral
             (z_floor: 0, or on the floor "pivot" the height of the segment's lower end)
  kind 12    floor under point j, on the segment above (point N, the bottom end, on a
             frictionless floor: no segment below it): z_j = c_a,z - e_a,z >= 0

At most 8 rows a point (an anchor between two airborne segments: 6 + axis + bend; a
free point bouncing off the floor in stage 2: 3 joints + axis + bend + its velocity's 3).
Which rows a point has is its *layout* (``layout``): the anchors, the bend rows and
floor rows switched on (the active sets), the landed segments (no columns, W = 0).
Kind codes are unique within a point, so multipliers carry over between layouts
(``carry_over``).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ...core.rules import is_landed
from ...floors.dispatch import floor_level
from ...jit import njit

RMAX = 8  # rows per point at most
K_JOINT, K_ANCHOR_LOWER, K_ANCHOR_UPPER = 0, 3, 6  # + the component 0, 1, 2
K_AXIS, K_BEND, K_FLOOR, K_FLOOR_LOWER = 9, 10, 11, 12
BOUNCE = 2  # floor_on[j]: a free point bouncing off the floor in stage 2 (restitution at the floor): its
#   velocity's three rows, an anchor's rows (kinds 6-8, or 3-5 at the bottom end) at a point not anchored


@njit(cache=True, inline="always")
def is_floor(k):
    """A floor row (``K_FLOOR`` or, at the bottom end, ``K_FLOOR_LOWER``)?"""
    return k == K_FLOOR or k == K_FLOOR_LOWER


@njit(cache=True, _nrt=False)
def layout(anchored, bend, floor_on, kind, nrow):
    """The rows of every point (kind, nrow): joints at free points, anchors at anchored
    points (the ends of airborne segments), an axis row per airborne segment, a bend row
    where ``bend[k]``, a floor row at free point j where ``floor_on[j]`` (its velocity's
    three rows where it is ``BOUNCE``)."""
    n = anchored.shape[0] - 1
    for j in range(n + 1):
        a, c = j - 1, j
        a_air = a >= 0 and not is_landed(anchored, a)
        c_air = c < n and not is_landed(anchored, c)
        r = 0
        if anchored[j] == 0:
            if a_air and c_air:
                for q in range(3):
                    kind[j, q] = K_JOINT + q
                r = 3
        else:
            if a_air:
                for q in range(3):
                    kind[j, r + q] = K_ANCHOR_LOWER + q
                r += 3
            if c_air:
                for q in range(3):
                    kind[j, r + q] = K_ANCHOR_UPPER + q
                r += 3
        if c_air:
            kind[j, r] = K_AXIS
            r += 1
        if a >= 0 and c < n and bend[a] != 0:
            kind[j, r] = K_BEND
            r += 1
        if anchored[j] == 0 and floor_on[j] == BOUNCE and (c_air or a_air):  # (stage 2 of a bounce)
            base = K_ANCHOR_UPPER if c_air else K_ANCHOR_LOWER
            for q in range(3):
                kind[j, r + q] = base + q
            r += 3
        elif anchored[j] == 0 and floor_on[j] != 0 and (c_air or a_air):
            kind[j, r] = K_FLOOR if c_air else K_FLOOR_LOWER
            r += 1
        nrow[j] = r


@njit(cache=True, inline="always")
def end_signs(k, below):
    """An end row (kind k < K_AXIS: joint, lower or upper anchor) on one of its segments
    (below: the one below its point, else above): the signs (centre, axis) of its
    component's columns, (0, 0) if it has none there (``rows``)."""
    if k < K_ANCHOR_LOWER:
        return (-1.0, -1.0) if below else (1.0, -1.0)
    if k < K_ANCHOR_UPPER:
        return (0.0, 0.0) if below else (1.0, -1.0)
    return (1.0, 1.0) if below else (0.0, 0.0)


@njit(cache=True, inline="always")
def has_columns(k, below):
    """Has a row of kind k columns on the segment below its point (below) or above it?"""
    if k == K_BEND or (K_JOINT <= k < K_ANCHOR_LOWER):
        return True
    if K_ANCHOR_LOWER <= k < K_ANCHOR_UPPER:
        return not below
    if k == K_FLOOR_LOWER:
        return not below
    return below  # an upper anchor, the axis, the floor: on the segment below only


@njit(cache=True, _nrt=False)
def row_values(c, e, anchor_pos, cos_alpha, floor, kind, nrow, out):
    """out[j, r] = the constraint function of row r of point j at (c, e); returns the
    largest |value| (inf if one is not a number).  A floor row's is z_j less the height at
    which the floor model ``floor`` meets point j (``floors.dispatch.floor_level``)."""
    worst = 0.0
    for j in range(nrow.shape[0]):
        a = j - 1
        for r in range(nrow[j]):
            k = kind[j, r]
            if k < K_ANCHOR_LOWER:
                q = k - K_JOINT
                v = c[a, q] - e[a, q] - c[j, q] - e[j, q]
            elif k < K_ANCHOR_UPPER:
                q = k - K_ANCHOR_LOWER
                v = c[a, q] - e[a, q] - anchor_pos[j, q]
            elif k < K_AXIS:
                q = k - K_ANCHOR_UPPER
                v = c[j, q] + e[j, q] - anchor_pos[j, q]
            elif k == K_AXIS:
                v = 0.5 * (e[j, 0] * e[j, 0] + e[j, 1] * e[j, 1] + e[j, 2] * e[j, 2] - 1.0)
            elif k == K_BEND:
                v = e[a, 0] * e[j, 0] + e[a, 1] * e[j, 1] + e[a, 2] * e[j, 2] - cos_alpha
            elif k == K_FLOOR:
                v = c[j, 2] + e[j, 2] - floor_level(floor, anchor_pos, j)
            else:
                v = c[a, 2] - e[a, 2]
            out[j, r] = v
            if not abs(v) <= worst:  # (NaN too: a non-finite value is never small)
                worst = abs(v) if abs(v) == abs(v) else np.inf
    return worst


@njit(cache=True, _nrt=False)
def row_gradients(e, kind, nrow, J, j_from):
    """J[j, r] = the gradient of row r of point j at axes e, over (c_a, e_a, c_c, e_c), for
    the points from j_from on."""
    for j in range(j_from, nrow.shape[0]):
        a = j - 1
        for r in range(nrow[j]):
            for q in range(12):
                J[j, r, q] = 0.0
            k = kind[j, r]
            if k < K_ANCHOR_LOWER:
                q = k - K_JOINT
                J[j, r, q] = 1.0
                J[j, r, 3 + q] = -1.0
                J[j, r, 6 + q] = -1.0
                J[j, r, 9 + q] = -1.0
            elif k < K_ANCHOR_UPPER:
                q = k - K_ANCHOR_LOWER
                J[j, r, q] = 1.0
                J[j, r, 3 + q] = -1.0
            elif k < K_AXIS:
                q = k - K_ANCHOR_UPPER
                J[j, r, 6 + q] = 1.0
                J[j, r, 9 + q] = 1.0
            elif k == K_AXIS:
                for q in range(3):
                    J[j, r, 9 + q] = e[j, q]
            elif k == K_BEND:
                for q in range(3):
                    J[j, r, 3 + q] = e[j, q]
                    J[j, r, 9 + q] = e[a, q]
            elif k == K_FLOOR:
                J[j, r, 8] = 1.0
                J[j, r, 11] = 1.0
            else:
                J[j, r, 2] = 1.0
                J[j, r, 5] = -1.0


@njit(cache=True, _nrt=False)
def row_rates(J, kind, nrow, vc, ve, out):
    """out[j, r] = J[j, r] . u, the rate of row r of point j at velocities (vc, ve)."""
    _rates(J, kind, nrow, nrow, vc, ve, out, False)  # (every row: no marks read; nrow stands in)


@njit(cache=True, _nrt=False)
def booked_rates(J, kind, nrow, anchored, vc, ve, out):
    """``row_rates`` of the rows whose work the books take: the bend and floor rows, and
    every row of a point being anchored (marked 2) or bouncing (anchor rows at a free
    point); the other entries of out are left as they were."""
    _rates(J, kind, nrow, anchored, vc, ve, out, True)


@njit(cache=True, _nrt=False)
def _rates(J, kind, nrow, anchored, vc, ve, out, booked):
    """out[j, r] = J[j, r] . u at velocities (vc, ve), of every row, or (``booked``) of
    those ``booked_rates`` names (anchored: the points' marks).  An end row's rate is its
    signed component (``end_signs``).  Written out in the loop, not in a helper: a helper
    that takes the arrays costs numba a reference count of each at every row."""
    n = vc.shape[0]
    for j in range(nrow.shape[0]):
        every = (not booked) or anchored[j] == 2
        free = anchored[j] == 0
        ia, ic = max(j - 1, 0), min(j, n - 1)  # (the segments above and below, clamped: unused where absent)
        for r in range(nrow[j]):
            k = kind[j, r]
            if not (every or k >= K_BEND or (free and K_ANCHOR_LOWER <= k < K_AXIS)):
                continue
            acc = 0.0
            if k < K_AXIS:
                q = k % 3
                if j >= 1 and has_columns(k, False):
                    sc, se = end_signs(k, False)
                    acc += sc * vc[ia, q] + se * ve[ia, q]
                if j < n and has_columns(k, True):
                    sc, se = end_signs(k, True)
                    acc += sc * vc[ic, q] + se * ve[ic, q]
            else:
                if j >= 1 and has_columns(k, False):
                    for q in range(3):
                        acc += J[j, r, q] * vc[ia, q] + J[j, r, 3 + q] * ve[ia, q]
                if j < n and has_columns(k, True):
                    for q in range(3):
                        acc += J[j, r, 6 + q] * vc[ic, q] + J[j, r, 9 + q] * ve[ic, q]
            out[j, r] = acc


@njit(cache=True, inline="always")
def _point_force(J, kind, nrow, x, j, below):
    """(J^T x) of the rows of point j on its segment below (below) or above: 6 values,
    the segment's (centre, axis) columns (an end row's: its signed component)."""
    f0 = f1 = f2 = f3 = f4 = f5 = 0.0
    g = 6 if below else 0
    r0 = 0
    if nrow[j] >= 4 and kind[j, 0] == K_JOINT:  # a free point: its joints and the axis below in closed form
        r0 = 4
        x0, x1, x2 = x[j, 0], x[j, 1], x[j, 2]
        if below:  # (joint: -1 on the centre and the axis below; axis row: e)
            x3 = x[j, 3]
            f0, f1, f2 = -x0, -x1, -x2
            f3, f4, f5 = -x0 + J[j, 3, 9] * x3, -x1 + J[j, 3, 10] * x3, -x2 + J[j, 3, 11] * x3
        else:  # (joint: +1 on the centre above, -1 on its axis)
            f0, f1, f2 = x0, x1, x2
            f3, f4, f5 = -x0, -x1, -x2
    for r in range(r0, nrow[j]):
        v = x[j, r]
        k = kind[j, r]
        if v == 0.0 or not has_columns(k, below):
            continue
        if k < K_AXIS:
            sc, se = end_signs(k, below)
            q = k % 3
            if q == 0:
                f0 += sc * v
                f3 += se * v
            elif q == 1:
                f1 += sc * v
                f4 += se * v
            else:
                f2 += sc * v
                f5 += se * v
        else:
            f0 += J[j, r, g] * v
            f1 += J[j, r, g + 1] * v
            f2 += J[j, r, g + 2] * v
            f3 += J[j, r, g + 3] * v
            f4 += J[j, r, g + 4] * v
            f5 += J[j, r, g + 5] * v
    return f0, f1, f2, f3, f4, f5


@njit(cache=True, inline="always")
def segment_force(J, kind, nrow, x, i):
    """(J^T x) on segment i, its (centre, axis) columns: the rows of point i on the
    segment below it and those of point i + 1 on the segment above it."""
    a0, a1, a2, a3, a4, a5 = _point_force(J, kind, nrow, x, i, True)
    b0, b1, b2, b3, b4, b5 = _point_force(J, kind, nrow, x, i + 1, False)
    return a0 + b0, a1 + b1, a2 + b2, a3 + b3, a4 + b4, a5 + b5


@njit(cache=True, _nrt=False)
def row_forces(J, kind, nrow, x, gf):
    """gf[i] = (J^T x) on segment i (``segment_force``): what impulses x on the rows do to
    each segment."""
    for i in range(gf.shape[0]):
        gf[i, 0], gf[i, 1], gf[i, 2], gf[i, 3], gf[i, 4], gf[i, 5] = segment_force(J, kind, nrow, x, i)


@njit(cache=True, _nrt=False)
def carry_over(kind_old, nrow_old, x_old, kind, nrow, x):
    """x of the new layout (kind, nrow) from x_old of the old one, row by row of the same
    kind at the same point (0 for a row that is new)."""
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            v = 0.0
            for s in range(nrow_old[j]):
                if kind_old[j, s] == kind[j, r]:
                    v = x_old[j, s]
            x[j, r] = v


@njit(cache=True, _nrt=False)
def copy_layout(kind, nrow, x, kind_to, nrow_to, x_to):
    """kind_to, nrow_to, x_to <- kind, nrow, x (the rows in use)."""
    for j in range(nrow.shape[0]):
        nrow_to[j] = nrow[j]
        for r in range(nrow[j]):
            kind_to[j, r] = kind[j, r]
            x_to[j, r] = x[j, r]


# The rows and the solvers' workspace: the rows' gradients J (at q), kinds and counts,
# right-hand side and impulses x (the forces they make are gathered per segment where they
# are used: ``segment_force``), the rows at q+ (J1, stage 1), the factors of J W J^T (``sym``, the last stage 2's: the next
# stage 1 starts from them, and gives its Newton matrix their redundant rows) and of stage
# 1's Newton matrix J1 W J^T (``newt``; ``blocks``);
# valid (1,): J, kind, nrow and ``sym`` are the last stage 2's, at the state's axes.
Rows = namedtuple("Rows", ["J", "kind", "nrow", "rhs", "x", "J1", "sym", "newt", "valid"])


def new_rows(n: int) -> Rows:
    """The rows of an N-segment chain, RMAX a point, and their solvers' workspace."""
    from .blocks import new_factors  # (blocks reads the kinds from here)

    p = n + 1
    return Rows(
        np.zeros((p, RMAX, 12)),
        np.zeros((p, RMAX), np.int8),
        np.zeros(p, np.int64),
        np.zeros((p, RMAX)),
        np.zeros((p, RMAX)),
        np.zeros((p, RMAX, 12)),
        new_factors(p, RMAX),
        new_factors(p, RMAX),
        np.zeros(1, np.uint8),
    )
