"""Floor model ``all``: every free point that reaches the floor is stopped and anchored there.

Watched: every free point j, by its height z_j = 2 sum_{i>=j} e_i,z (units b).  A touch
(z_j <= Z_TOL, not moving up) anchors the point for good (``registry.CONTACT_FIXED``).
The fall ends (t_fall) when the top end, point 0, is anchored.
"""

from __future__ import annotations

import math

from ..core.rules import RATE_TOL, point_height
from ..jit import njit

CONTACT = 0  # registry.CONTACT_FIXED
TOP_EVENT = False  # t_fall comes from the top end's anchoring, not from an event of its own


@njit(cache=True, _nrt=False)
def watched(anchored, j):
    """Every free point is watched."""
    return anchored[j] == 0


@njit(cache=True, _nrt=False)
def watched_range(anchored):
    """The points j0 <= j < j1 among which the watched ones are: all of them."""
    return 0, anchored.shape[0]


@njit(cache=True, _nrt=False)
def value(e, anchored, zf, j):
    """The height of point j above the floor, which is at zf in the chain's frame (0, but
    where a frictionless floor has let point N leave it: ``core.base.floor_z``)."""
    if anchored[e.shape[0]] != 0:
        return point_height(e, j)
    return point_height(e, j) - zf


@njit(cache=True, _nrt=False)
def values(e, anchored, zf, out):
    """out[j] = the height above the floor of every free point j (others: inf), in O(N)."""
    n = e.shape[0]
    z = 0.0
    out[n] = math.inf
    for j in range(n - 1, -1, -1):
        z += 2.0 * e[j, 2]
        out[j] = math.inf if anchored[j] != 0 else z
    if anchored[n] == 0:  # (point N off the floor, a frictionless floor's: heights from the floor's)
        out[n] = -zf
        for j in range(n):
            if anchored[j] == 0:
                out[j] -= zf


@njit(cache=True, _nrt=False)
def contacts(e, pts, pv, anchored, landing_event, ztol, out):
    """Every free point at z <= ztol (``Z_TOL`` at an event instant) that is not moving
    up (dz/dt <= RATE_TOL); their number (indices in out)."""
    na = 0
    for j in range(e.shape[0] + 1):  # (point N too: a frictionless floor lets it leave)
        if anchored[j] == 0 and pts[j, 2] <= ztol and pv[j, 2] <= RATE_TOL:
            out[na] = j
            na += 1
    return na


@njit(cache=True, _nrt=False)
def level(anchor_pos, j):
    """The height at which a watched point meets the floor: the floor's, z = 0."""
    return 0.0


@njit(cache=True, _nrt=False)
def cascade(e, anchored, ztol, out):
    """The points that land with a touch beyond the ones that touch: none (a point lands
    by its own touch only)."""
    return 0
