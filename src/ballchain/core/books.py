"""The run's books kept by every method (compiled): what the frames record of them."""

from __future__ import annotations

from ..jit import njit
from .kinematics import kinetic_energy, potential_energy

PROJECTED_AT_INSTANTS, PROJECTED_IN_STEPS = 0, 1  # the slots of Books.projected


@njit(cache=True, _nrt=False)
def fill_frame_books(frames, books):
    """Frames written since the last call (``frames.fill[0]`` .. ``frames.count[0]``) get
    the energy lost at impacts, the friction's work on sliding points (none in a method that
    refuses finite friction) and the floor's impulse at impacts as they stand now (no
    impact happens between event instants, so they are constant over those frames)."""
    for f in range(frames.fill[0], frames.count[0]):
        frames.lost_locking[f] = books.lost_locking[0]
        frames.lost_landing[f] = books.lost_landing[0]
        frames.lost_sliding[f] = books.lost_sliding[0]
        for q in range(3):
            frames.floor_impulse[f, q] += books.floor_impulse[q]
    frames.fill[0] = frames.count[0]


@njit(cache=True, _nrt=False)
def lowest_point(e, lowest):
    """lowest <- the lowest point height seen, min(lowest, min_j z_j) (for the max depth)."""
    zlow = 0.0
    zacc = 0.0
    for j in range(e.shape[0] - 1, -1, -1):
        zacc += 2.0 * e[j, 2]
        if zacc < zlow:
            zlow = zacc
    if zlow < lowest[0]:
        lowest[0] = zlow


@njit(cache=True, _nrt=False)
def lowest_above_floor(e, anchored, zf, lowest):
    """``lowest_point`` with the heights measured from the floor, at zf in the chain's frame
    (0, but where a frictionless floor has let point N leave it: ``base.floor_z``)."""
    if anchored[e.shape[0]] != 0:
        lowest_point(e, lowest)
        return
    zlow = -zf
    zacc = 0.0
    for j in range(e.shape[0] - 1, -1, -1):
        zacc += 2.0 * e[j, 2]
        if zacc - zf < zlow:
            zlow = zacc - zf
    if zlow < lowest[0]:
        lowest[0] = zlow


@njit(cache=True, _nrt=False)
def log_row(log, t, kind, index, i0, i1, i2, energy, pts, j):
    """One row of the event log (``state.Log``): t, kind, index, impulse (i0, i1, i2),
    the energy dissipated, the position of point j (a hinge k: its point j = k + 1)."""
    k = log.n[0]
    log.t[k] = t
    log.kind[k] = kind
    log.index[k] = index
    log.impulse[k, 0] = i0
    log.impulse[k, 1] = i1
    log.impulse[k, 2] = i2
    log.energy[k] = energy
    for q in range(3):
        log.pos[k, q] = pts[j, q]
    log.n[0] = k + 1


@njit(cache=True, _nrt=False)
def mechanical_energy(e, w, pv, vel):
    """U + T of axes e and rates w (m g b; pv (N+1, 3), vel (N, 3): scratch)."""
    return potential_energy(e) + kinetic_energy(e, w, pv, vel)
