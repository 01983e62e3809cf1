"""The run's books kept by every method (compiled): what the frames record of them."""

from __future__ import annotations

from .jit import njit


@njit(cache=True)
def fill_frame_books(frames, books):
    """Frames written since the last call (``frames.fill[0]`` .. ``frames.count[0]``) get
    the energy lost at impacts and the floor's impulse at impacts as they stand now (no
    impact happens between event instants, so they are constant over those frames)."""
    for f in range(frames.fill[0], frames.count[0]):
        frames.lost_locking[f] = books.lost_locking[0]
        frames.lost_landing[f] = books.lost_landing[0]
        for q in range(3):
            frames.floor_impulse[f, q] += books.floor_impulse[q]
    frames.fill[0] = frames.count[0]
