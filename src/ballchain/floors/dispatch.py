"""The compiled dispatch over the floor models.

The floor models as parts: each is one module (``anchor_all``, ``pivot``) that answers which
points the floor watches, the event function that watches them (``floor_value``), which
points touch at an event instant (``floor_contacts``), which land with them
(``floor_cascade``), the height at which a watched point meets the floor (``floor_level``)
and whether the top end's height is an event of its own (``top_event``).  The compiled dispatchers below branch on the model's
code (``registry.FLOOR_CODES``); nothing else in the engine branches on the floor model.
"""

from __future__ import annotations

from ..jit import njit
from . import anchor_all, pivot
from .registry import FLOOR_ALL


@njit(cache=True, _nrt=False)
def floor_watched(floor, anchored, j):
    """Is floor event function j watched?"""
    if floor == FLOOR_ALL:
        return anchor_all.watched(anchored, j)
    return pivot.watched(anchored, j)


@njit(cache=True, _nrt=False)
def floor_watched_range(floor, anchored):
    """(j0, j1): every watched point j lies in j0 <= j < j1 (a loop over the watched
    points in O(their range), not O(N) calls of ``floor_watched``)."""
    if floor == FLOOR_ALL:
        return anchor_all.watched_range(anchored)
    return pivot.watched_range(anchored)


@njit(cache=True, _nrt=False)
def floor_value(floor, e, anchored, zf, j):
    """Floor event function j of axes e (need not be unit length); zf: the floor's height in
    the chain's frame (``core.base.floor_z``: 0 but on a frictionless floor point N has left)."""
    if floor == FLOOR_ALL:
        return anchor_all.value(e, anchored, zf, j)
    return pivot.value(e, anchored, zf, j)


@njit(cache=True, _nrt=False)
def floor_values(floor, e, anchored, zf, out):
    """out[j] = floor_value(floor, e, anchored, zf, j) for every watched j (others: inf), in O(N)."""
    if floor == FLOOR_ALL:
        anchor_all.values(e, anchored, zf, out)
    else:
        pivot.values(e, anchored, zf, out)


@njit(cache=True, _nrt=False)
def floor_contacts(floor, e, pts, pv, anchored, landing_event, ztol, out):
    """Points that the floor anchors at this instant (a floor function at or below
    ``ztol`` touches: ``rules.Z_TOL`` at an event instant); returns their number (in out)."""
    if floor == FLOOR_ALL:
        return anchor_all.contacts(e, pts, pv, anchored, landing_event, ztol, out)
    return pivot.contacts(e, pts, pv, anchored, landing_event, ztol, out)


@njit(cache=True, _nrt=False)
def floor_level(floor, anchor_pos, j):
    """The height at which watched point j meets the floor (anchors' positions anchor_pos):
    a time-stepper's position-level floor row for j is z_j - floor_level >= 0."""
    if floor == FLOOR_ALL:
        return anchor_all.level(anchor_pos, j)
    return pivot.level(anchor_pos, j)


@njit(cache=True, _nrt=False)
def floor_cascade(floor, e, anchored, ztol, out):
    """The points that land in the instant of a touch besides the touching ones, once
    those are anchored (``anchored``: theirs set); their number (in out)."""
    if floor == FLOOR_ALL:
        return anchor_all.cascade(e, anchored, ztol, out)
    return pivot.cascade(e, anchored, ztol, out)


@njit(cache=True, _nrt=False)
def top_event(floor):
    """Is the top end's height an event function of its own (t_fall by crossing)?"""
    if floor == FLOOR_ALL:
        return anchor_all.TOP_EVENT
    return pivot.TOP_EVENT
