"""The constraint rows of the chain (docs/model.md, section 2), numba kernels,
nondimensional (m = b = g = 1).

Indexing (0-based, from the top): segment ``i = 0..N-1`` has unit axis ``e[i]`` and
angular velocity ``w[i]``; point ``j = 0..N`` is the upper end of segment ``j`` and the
lower end of segment ``j-1``; hinge ``k = 0..N-2`` sits at point ``k+1``.
Each segment has six velocity coordinates (centre velocity v, angular velocity w) and
inverse mass W = diag(1, 1, 1, 3, 3, 3) (rods: m, m b^2/3), or W = 0 once landed.
Constraints are gathered per point j in up to 7 rows, each row acting on the segment
above the point (``a = j-1``, columns 0:6) and the one below (``c = j``, columns 6:12):

  kind 0  hinge (3 rows):      lower end of a - upper end of c = 0
  kind 1  anchor, lower (3):   lower end of a = 0          (point j anchored)
  kind 2  anchor, upper (3):   upper end of c = 0          (point j anchored)
  kind 3  lock (1 row):        d/dt (e_a . e_c) = w_a.(e_a x e_c) + w_c.(e_c x e_a) = 0
  kind 4  slide, lower (1):    height of the lower end of a = 0   (point j sliding: ``rules.SLIDING``)
  kind 5  slide, upper (1):    height of the upper end of c = 0   (... the top end, point 0)

A sliding point (on a frictionless floor) keeps its hinge rows and takes one height row,
on the segment above it (the segment below for the top end): the floor holds it up and
nothing holds it along the floor.

The velocity of the lower end of segment i is v_i + e_i x w_i, of its upper end
v_i - e_i x w_i.  ``build_rows`` writes them in general (J, 12 columns a row),
``rows_rhs4`` in the fixed-size layout (kinds and counts only, at most 4 rows a point:
``blocks``), ``constraint_rows`` the one that fits.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .rules import SLIDING
from .rules import is_landed as _is_landed

ROW_HINGE, ROW_ANCHOR_LOWER, ROW_ANCHOR_UPPER, ROW_LOCK = 0, 1, 2, 3
ROW_SLIDE_LOWER, ROW_SLIDE_UPPER = 4, 5
W_V, W_W = 1.0, 3.0  # inverse mass and inverse moment of inertia, nondimensional


# --------------------------------------------------------------------------- rows


@njit(cache=True, inline="always")
def _end_rows(J, j, r0, col, e, i, sv, sw):
    """Rows r0..r0+2 of point j, columns col..col+5: sv * v_i + sw * (e_i x w_i)."""
    ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
    for r in range(3):
        for q in range(6):
            J[j, r0 + r, col + q] = 0.0
        J[j, r0 + r, col + r] = sv
    J[j, r0 + 0, col + 4] = -ez * sw
    J[j, r0 + 0, col + 5] = ey * sw
    J[j, r0 + 1, col + 3] = ez * sw
    J[j, r0 + 1, col + 5] = -ex * sw
    J[j, r0 + 2, col + 3] = -ey * sw
    J[j, r0 + 2, col + 4] = ex * sw


@njit(cache=True, inline="always")
def _end_row_z(J, j, r, col, e, i, sv, sw):
    """Row r of point j: the height of an end of segment i, sv * v_i,z + sw * (e_i x w_i)_z
    (the third row of ``_end_rows``), nothing on the other segment."""
    for q in range(12):
        J[j, r, q] = 0.0
    J[j, r, col + 2] = sv
    J[j, r, col + 3] = -e[i, 1] * sw
    J[j, r, col + 4] = e[i, 0] * sw


@njit(cache=True, inline="always")
def _zero_cols(J, j, r0, nr, col):
    for r in range(r0, r0 + nr):
        for q in range(6):
            J[j, r, col + q] = 0.0


@njit(cache=True, _nrt=False)
def build_rows(e, w, anchored, locked, J, kind, nrow, rhs, with_acc_rhs):
    """Fill the constraint rows of every point; if ``with_acc_rhs``, also the
    acceleration right-hand side rhs = -(J W f_gravity + velocity-product terms)."""
    n = e.shape[0]
    for j in range(n + 1):
        a = j - 1
        c = j
        a_air = a >= 0 and not _is_landed(anchored, a)
        c_air = c < n and not _is_landed(anchored, c)
        r = 0
        if anchored[j] == 0 or anchored[j] == SLIDING:
            if a_air and c_air:
                _end_rows(J, j, 0, 0, e, a, 1.0, 1.0)
                _end_rows(J, j, 0, 6, e, c, -1.0, 1.0)
                for q in range(3):
                    kind[j, q] = ROW_HINGE
                if with_acc_rhs:
                    wa2 = w[a, 0] ** 2 + w[a, 1] ** 2 + w[a, 2] ** 2
                    wc2 = w[c, 0] ** 2 + w[c, 1] ** 2 + w[c, 2] ** 2
                    for q in range(3):
                        rhs[j, q] = -(wa2 * e[a, q] + wc2 * e[c, q])
                r = 3
            if anchored[j] == SLIDING:
                r = _slide_row(e, w, j, r, a_air, J, kind, rhs, with_acc_rhs)
        else:
            if a_air:
                _end_rows(J, j, 0, 0, e, a, 1.0, 1.0)
                _zero_cols(J, j, 0, 3, 6)
                for q in range(3):
                    kind[j, q] = ROW_ANCHOR_LOWER
                if with_acc_rhs:
                    wa2 = w[a, 0] ** 2 + w[a, 1] ** 2 + w[a, 2] ** 2
                    for q in range(3):
                        rhs[j, q] = -wa2 * e[a, q]
                    rhs[j, 2] += 1.0  # gravity: -(J W f) = +e_z
                r = 3
            if c_air:
                _end_rows(J, j, r, 6, e, c, 1.0, -1.0)
                _zero_cols(J, j, r, 3, 0)
                for q in range(3):
                    kind[j, r + q] = ROW_ANCHOR_UPPER
                if with_acc_rhs:
                    wc2 = w[c, 0] ** 2 + w[c, 1] ** 2 + w[c, 2] ** 2
                    for q in range(3):
                        rhs[j, r + q] = wc2 * e[c, q]
                    rhs[j, r + 2] += 1.0
                r += 3
        # lock row of hinge k = j - 1 (between segments a and c)
        if a >= 0 and c < n and locked[a] != 0:  # (the locked set holds only limits in force)
            x0, x1, x2 = e[a, 0], e[a, 1], e[a, 2]
            y0, y1, y2 = e[c, 0], e[c, 1], e[c, 2]
            cx = x1 * y2 - x2 * y1
            cy = x2 * y0 - x0 * y2
            cz = x0 * y1 - x1 * y0
            for q in range(12):
                J[j, r, q] = 0.0
            if a_air:
                J[j, r, 3] = cx
                J[j, r, 4] = cy
                J[j, r, 5] = cz
            if c_air:
                J[j, r, 9] = -cx
                J[j, r, 10] = -cy
                J[j, r, 11] = -cz
            kind[j, r] = ROW_LOCK
            if with_acc_rhs:
                # d2g/dt2 = J acc - (|w_a|^2 + |w_c|^2) (e_a.e_c) + 2 de_a . de_c
                dax = w[a, 1] * x2 - w[a, 2] * x1
                day = w[a, 2] * x0 - w[a, 0] * x2
                daz = w[a, 0] * x1 - w[a, 1] * x0
                dcx = w[c, 1] * y2 - w[c, 2] * y1
                dcy = w[c, 2] * y0 - w[c, 0] * y2
                dcz = w[c, 0] * y1 - w[c, 1] * y0
                wa2 = w[a, 0] ** 2 + w[a, 1] ** 2 + w[a, 2] ** 2
                wc2 = w[c, 0] ** 2 + w[c, 1] ** 2 + w[c, 2] ** 2
                cdot = x0 * y0 + x1 * y1 + x2 * y2
                rhs[j, r] = (wa2 + wc2) * cdot - 2.0 * (dax * dcx + day * dcy + daz * dcz)
            r += 1
        nrow[j] = r


@njit(cache=True, inline="always")
def _slide_row(e, w, j, r, a_air, J, kind, rhs, with_acc_rhs):
    """Row r of a sliding point j: its height held at the floor's, on the lower end of
    segment a = j - 1 (or, for the top end, the upper end of c = j); the acceleration's
    right-hand side as the anchor's vertical row.  Returns the row count."""
    if a_air:
        i = j - 1
        _end_row_z(J, j, r, 0, e, i, 1.0, 1.0)
        kind[j, r] = ROW_SLIDE_LOWER
        sign = -1.0
    else:
        i = j
        _end_row_z(J, j, r, 6, e, i, 1.0, -1.0)
        kind[j, r] = ROW_SLIDE_UPPER
        sign = 1.0
    if with_acc_rhs:
        w2 = w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2
        rhs[j, r] = sign * w2 * e[i, 2] + 1.0  # (gravity: -(J W f) = +1)
    return r + 1


@njit(cache=True, _nrt=False)
def rows_rhs4(e, w, anchored, locked, kind, nrow, rhs):
    """``build_rows`` without J, for the fixed-size path, in one pass that carries each
    segment's |w|^2, de = w x e and airborne flag to the next point.  Returns False if
    some point does not fit that path (then the general path must be used)."""
    n = e.shape[0]
    fits = True
    a_air = False
    wa2 = 0.0
    da0 = da1 = da2 = 0.0
    for j in range(n + 1):
        c_air = j < n and not (anchored[j] == 1 and anchored[j + 1] == 1)
        wc2 = 0.0
        dc0 = dc1 = dc2 = 0.0
        if j < n:
            w0, w1, w2 = w[j, 0], w[j, 1], w[j, 2]
            e0, e1, e2 = e[j, 0], e[j, 1], e[j, 2]
            wc2 = w0 * w0 + w1 * w1 + w2 * w2
            dc0 = w1 * e2 - w2 * e1
            dc1 = w2 * e0 - w0 * e2
            dc2 = w0 * e1 - w1 * e0
        r = 0
        if anchored[j] == SLIDING:
            fits = False  # (its height row: the general path, ``build_rows``)
        if anchored[j] == 0:
            if a_air and c_air:
                kind[j, 0] = kind[j, 1] = kind[j, 2] = ROW_HINGE
                for q in range(3):
                    rhs[j, q] = -(wa2 * e[j - 1, q] + wc2 * e[j, q])
                r = 3
        elif a_air and c_air:  # an anchor between two airborne segments: 6 rows
            kind[j, 0] = kind[j, 1] = kind[j, 2] = ROW_ANCHOR_LOWER
            kind[j, 3] = kind[j, 4] = kind[j, 5] = ROW_ANCHOR_UPPER
            for q in range(3):
                rhs[j, q] = -wa2 * e[j - 1, q]
                rhs[j, 3 + q] = wc2 * e[j, q]
            rhs[j, 2] += 1.0
            rhs[j, 5] += 1.0
            r = 6
        elif a_air:
            kind[j, 0] = kind[j, 1] = kind[j, 2] = ROW_ANCHOR_LOWER
            for q in range(3):
                rhs[j, q] = -wa2 * e[j - 1, q]
            rhs[j, 2] += 1.0
            r = 3
        elif c_air:
            kind[j, 0] = kind[j, 1] = kind[j, 2] = ROW_ANCHOR_UPPER
            for q in range(3):
                rhs[j, q] = wc2 * e[j, q]
            rhs[j, 2] += 1.0
            r = 3
        if j >= 1 and j < n and locked[j - 1] != 0:
            if r != 3:  # a lock row with no end rows, or beside a split anchor: 7 rows
                fits = False
            kind[j, r] = ROW_LOCK
            cdot = e[j - 1, 0] * e[j, 0] + e[j - 1, 1] * e[j, 1] + e[j - 1, 2] * e[j, 2]
            rhs[j, r] = (wa2 + wc2) * cdot - 2.0 * (da0 * dc0 + da1 * dc1 + da2 * dc2)
            r += 1
        nrow[j] = r
        a_air = c_air
        wa2 = wc2
        da0, da1, da2 = dc0, dc1, dc2
    return fits


@njit(cache=True, _nrt=False)
def constraint_rows(e, w, anchored, locked, J, kind, nrow, rhs):
    """The constraint rows of the current anchors and locks: the fixed-size layout
    (kind, nrow; no J) when every point fits it, else J as well (``build_rows``).
    Returns True for the fixed-size layout.  ``rhs`` is scratch."""
    if rows_rhs4(e, w, anchored, locked, kind, nrow, rhs):
        return True
    build_rows(e, w, anchored, locked, J, kind, nrow, rhs, np.bool_(False))
    return False
