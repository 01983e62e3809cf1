"""The floor models written again in plain numpy, from their definitions in docs/model.md
(section 4), independently of ``ballchain.floors``: which points each floor watches, its
event function, and which points touch at an event instant.  Slow and simple; tests only.

Every floor model in ``ballchain.floors.registry.FLOORS`` must have an entry in
``REFERENCE_FLOORS``: a new floor model is checked against its own reference here.
"""

from __future__ import annotations

import numpy as np

Z_TOL = 1e-9  # a point this close to the floor touches it (docs/model.md)
RATE_TOL = 1e-8


def heights(e: np.ndarray) -> np.ndarray:
    """z of points 0..N (point N at the origin): z_j = 2 sum_{i >= j} e_i,z."""
    z = np.zeros(e.shape[0] + 1)
    z[:-1] = 2.0 * np.cumsum(e[::-1, 2])[::-1]
    return z


def landed(anchored: np.ndarray) -> np.ndarray:
    a = np.asarray(anchored) != 0
    return a[:-1] & a[1:]


def bottom_airborne(anchored: np.ndarray) -> int:
    free = np.flatnonzero(~landed(anchored))
    return int(free[-1]) if free.size else -1


class AnchorAll:
    """Every free point is watched by its height; it touches at z <= Z_TOL, not moving up."""

    @staticmethod
    def watched(anchored):
        return np.asarray(anchored) == 0

    @staticmethod
    def values(e, anchored):
        v = heights(e)
        v[~AnchorAll.watched(anchored)] = np.inf
        return v

    @staticmethod
    def contacts(e, point_velocity, anchored, landing_event):
        z = heights(e)
        return [j for j in range(e.shape[0]) if anchored[j] == 0 and z[j] <= Z_TOL and point_velocity[j, 2] <= RATE_TOL]

    @staticmethod
    def level(anchor_pos, j):
        """Every point meets the floor at z = 0."""
        return 0.0

    @staticmethod
    def cascade(e, anchored):
        """A point lands by its own touch only."""
        return []


class Pivot:
    """Only the upper end of the bottom airborne segment is watched, by the sine of that
    segment's elevation; after a landing event it anchors when the segment lies flat,
    and so on up the chain."""

    @staticmethod
    def watched(anchored):
        m = bottom_airborne(anchored)
        out = np.zeros(len(anchored), bool)
        if m >= 0 and anchored[m] == 0:
            out[m] = True
        return out

    @staticmethod
    def values(e, anchored):
        v = np.full(e.shape[0] + 1, np.inf)
        w = Pivot.watched(anchored)
        for j in np.flatnonzero(w):
            v[j] = e[j, 2] / np.linalg.norm(e[j])
        return v

    @staticmethod
    def contacts(e, point_velocity, anchored, landing_event):
        if not landing_event:
            return []
        return Pivot.cascade(e, anchored)

    @staticmethod
    def level(anchor_pos, j):
        """The watched point's segment lies flat at the height of its lower end, the pivot."""
        return anchor_pos[j + 1][2]

    @staticmethod
    def cascade(e, anchored):
        """The bottom airborne segment and those above it while each lies flat or points
        below the horizontal: their upper ends."""
        out = []
        m = bottom_airborne(anchored)
        while m >= 0 and e[m, 2] / np.linalg.norm(e[m]) <= Z_TOL:
            out.append(m)
            m -= 1
        return out


REFERENCE_FLOORS = {"all": AnchorAll, "pivot": Pivot}
