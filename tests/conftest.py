"""Shared helpers of the tests: random chain states.

(The tests directory is on ``sys.path``: test modules import these helpers with
``from conftest import ...``; the dense oracle lives in ``tests/oracle/``.)
"""

from __future__ import annotations

import numpy as np

EZ = np.array([0.0, 0.0, 1.0])


def _unit(v):
    return v / np.linalg.norm(v)


def _direction(rng, mode):
    if mode == "arbitrary":
        return _unit(rng.normal(size=3))
    if mode == "vertical":  # near-vertical chain
        return _unit(EZ + 0.05 * rng.normal(size=3))
    return _unit(EZ + 0.4 * rng.normal(size=3))  # "tilted"


def _at_angle(rng, e_below, alpha):
    """A unit vector at exactly angle alpha from e_below, random azimuth."""
    u = rng.normal(size=3)
    u = _unit(u - (u @ e_below) * e_below)
    return np.cos(alpha) * e_below + np.sin(alpha) * u


def chain_directions(rng, n, mode, at_limit, alpha):
    """Axes built from the bottom; hinges in ``at_limit`` exactly at angle alpha."""
    e = np.zeros((n, 3))
    e[n - 1] = _direction(rng, mode)
    for k in range(n - 2, -1, -1):
        e[k] = _at_angle(rng, e[k + 1], alpha) if at_limit[k] else _direction(rng, mode)
    return e
