"""Floor model ``pivot`` (the paper read literally): only the bottom airborne segment meets the floor.

Watched: the upper end j of the bottom airborne segment, by e_j,z / |e_j| (the segment
turns about its lower end on the floor).  When it lies flat (e_z <= Z_TOL) its upper end
anchors for good (``registry.CONTACT_FIXED``), cascading up while the next segment lies
flat too (``cascade``); a time-stepper holds the watched point at the height of its
segment's lower end (``level``).  The top end reaching z = 0 is an event of its own (t_fall), with no change of
state.
"""

from __future__ import annotations

import math

from ..core.rules import bottom_airborne
from ..jit import njit

CONTACT = 0  # registry.CONTACT_FIXED
TOP_EVENT = True  # t_fall: the top end's height crossing zero is watched


@njit(cache=True, _nrt=False)
def watched(anchored, j):
    """Only the upper end of the bottom airborne segment."""
    return anchored[j] == 0 and j == bottom_airborne(anchored)


@njit(cache=True, _nrt=False)
def watched_range(anchored):
    """The points j0 <= j < j1 among which the watched one is: itself (none when every
    segment has landed)."""
    m = bottom_airborne(anchored)
    if m >= 0 and anchored[m] == 0:
        return m, m + 1
    return 0, 0


@njit(cache=True, _nrt=False)
def value(e, anchored, zf, j):
    """e_j,z / |e_j| of the segment whose upper end is point j (e need not be unit)."""
    return e[j, 2] / math.sqrt(e[j, 0] ** 2 + e[j, 1] ** 2 + e[j, 2] ** 2)


@njit(cache=True, _nrt=False)
def values(e, anchored, zf, out):
    """out[j] = value(e, j) for the watched point (others: inf)."""
    m = bottom_airborne(anchored)
    for j in range(out.shape[0]):
        out[j] = math.inf
    if m >= 0 and anchored[m] == 0:
        out[m] = value(e, anchored, 0.0, m)


@njit(cache=True, _nrt=False)
def level(anchor_pos, j):
    """The height at which the watched point j meets the floor: its segment lies flat when
    j is as high as the segment's lower end, the pivot j + 1 (z = 0, or below it where a
    cascade anchored the pivot)."""
    return anchor_pos[j + 1, 2]


@njit(cache=True, _nrt=False)
def cascade(e, anchored, ztol, out):
    """Once the bottom airborne segment has landed (its upper end anchored): the segments
    above it that lie flat or point below the horizontal (e_z <= ztol) land in the same
    instant, from the bottom up; their upper ends in out, their number."""
    na = 0
    m = bottom_airborne(anchored)
    while m >= 0 and value(e, anchored, 0.0, m) <= ztol:
        out[na] = m
        na += 1
        m -= 1
    return na


@njit(cache=True, _nrt=False)
def contacts(e, pts, pv, anchored, landing_event, ztol, out):
    """After a landing event: the upper end of the bottom airborne segment once it lies
    flat (e_z <= ztol; ``Z_TOL`` at an event instant), cascading up while the next one
    does too (``cascade``); their number (indices in out)."""
    return cascade(e, anchored, ztol, out) if landing_event else 0
