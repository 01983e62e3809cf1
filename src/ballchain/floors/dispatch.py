"""The compiled dispatch over the floor models.

The floor models as parts: each is one module (``anchor_all``, ``pivot``) that answers which
points the floor watches, the event function that watches them (``floor_value``), which
points touch at an event instant (``floor_contacts``) and whether the top end's height is
an event of its own (``top_event``).  The compiled dispatchers below branch on the model's
code (``registry.FLOOR_CODES``); nothing else in the engine branches on the floor model.
"""

from __future__ import annotations

from ..jit import njit
from . import anchor_all, pivot
from .registry import FLOOR_ALL


@njit(cache=True)
def floor_watched(floor, anchored, j):
    """Is floor event function j watched?"""
    if floor == FLOOR_ALL:
        return anchor_all.watched(anchored, j)
    return pivot.watched(anchored, j)


@njit(cache=True)
def floor_value(floor, e, j):
    """Floor event function j of axes e (need not be unit length)."""
    if floor == FLOOR_ALL:
        return anchor_all.value(e, j)
    return pivot.value(e, j)


@njit(cache=True)
def floor_values(floor, e, anchored, out):
    """out[j] = floor_value(floor, e, j) for every watched j (others: inf), in O(N)."""
    if floor == FLOOR_ALL:
        return anchor_all.values(e, anchored, out)
    return pivot.values(e, anchored, out)


@njit(cache=True)
def floor_contacts(floor, e, pts, pv, anchored, landing_event, ztol, out):
    """Points that the floor anchors at this instant (a floor function at or below
    ``ztol`` touches: ``rules.Z_TOL`` at an event instant); returns their number (in out)."""
    if floor == FLOOR_ALL:
        return anchor_all.contacts(e, pts, pv, anchored, landing_event, ztol, out)
    return pivot.contacts(e, pts, pv, anchored, landing_event, ztol, out)


@njit(cache=True)
def top_event(floor):
    """Is the top end's height an event function of its own (t_fall by crossing)?"""
    if floor == FLOOR_ALL:
        return anchor_all.TOP_EVENT
    return pivot.TOP_EVENT
