"""Every floor model (``ballchain.floors``) against its plain-numpy reference
(``tests/oracle/floors.py``, written from docs/model.md), on random chains with random
piles: the points it watches, its event function, and the points that touch."""

from __future__ import annotations

import numpy as np
import pytest
from oracle.floors import REFERENCE_FLOORS, heights

from ballchain.core.rules import Z_TOL
from ballchain.floors import dispatch
from ballchain.floors.registry import CONTACT_FIXED, FLOOR_CODES, FLOORS


def random_chain(rng, n):
    """Axes of an N-segment chain with a pile: its lowest segments flat on the floor (their
    points anchored), some points just at the floor (z within 1e-12), random rates."""
    e = rng.normal(size=(n, 3))
    e[:, 2] = np.abs(e[:, 2]) + 0.05
    k = rng.integers(0, n)  # segments k.. lie on the floor
    e[k:, 2] = 0.0
    if k > 0 and rng.random() < 0.5:
        e[k - 1, 2] = 1e-13  # a segment about to lie flat
    e /= np.linalg.norm(e, axis=1)[:, None]
    anchored = np.zeros(n + 1, np.uint8)
    anchored[k:] = 1
    pv = rng.normal(size=(n + 1, 3))
    return e, anchored, pv


def test_every_floor_model_has_a_reference_and_a_known_contact():
    assert set(FLOORS) == set(REFERENCE_FLOORS)
    for name, (code, module, _) in FLOORS.items():
        mod = __import__(f"ballchain.floors.{module}", fromlist=["CONTACT"])
        assert mod.CONTACT == CONTACT_FIXED  # the one contact the core implements (anchor rows)
        assert FLOOR_CODES[name] == code


@pytest.mark.parametrize("name", sorted(FLOORS))
def test_floor_model_agrees_with_its_reference(name):
    ref = REFERENCE_FLOORS[name]
    code = FLOOR_CODES[name]
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(1, 12))
        e, anchored, pv = random_chain(rng, n)
        watched = np.array([dispatch.floor_watched(code, anchored, j) for j in range(n + 1)])
        np.testing.assert_array_equal(watched, ref.watched(anchored))
        j0, j1 = dispatch.floor_watched_range(code, anchored)
        assert not watched[:j0].any() and not watched[j1:].any()
        vals = np.zeros(n + 1)
        dispatch.floor_values(code, e, anchored, 0.0, vals)
        want = ref.values(e, anchored)
        np.testing.assert_allclose(vals[np.isfinite(want)], want[np.isfinite(want)], rtol=0, atol=1e-12)
        assert np.all(np.isinf(vals[~np.isfinite(want)]))
        for j in np.flatnonzero(np.isfinite(want)):
            assert dispatch.floor_value(code, e, anchored, 0.0, j) == pytest.approx(want[j], abs=1e-12)
        pts = np.zeros((n + 1, 3))
        pts[:, 2] = heights(e)
        for landing in (False, True):
            out = np.zeros(n + 1, np.int64)
            k = dispatch.floor_contacts(code, e, pts, pv, anchored, landing, Z_TOL, out)
            assert sorted(out[:k].tolist()) == sorted(ref.contacts(e, pv, anchored, landing))
        out = np.zeros(n + 1, np.int64)
        k = dispatch.floor_cascade(code, e, anchored, Z_TOL, out)
        assert out[:k].tolist() == ref.cascade(e, anchored)
        anchor_pos = rng.normal(size=(n + 1, 3))
        for j in np.flatnonzero(watched):
            assert dispatch.floor_level(code, anchor_pos, j) == ref.level(anchor_pos, j)


def test_the_floors_differ_where_the_models_do():
    """A chain hanging with its lowest free point at the floor: ``all`` anchors it, ``pivot``
    (which watches the bottom segment's elevation, not points) does not."""
    e = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, -0.8], [0.6, 0.0, 0.8]])  # point 1: z = 2 (-0.8 + 0.8) = 0
    anchored = np.array([0, 0, 0, 1], np.uint8)
    pv = np.zeros((4, 3))
    pts = np.zeros((4, 3))
    pts[:, 2] = heights(e)
    assert abs(pts[1, 2]) < 1e-12  # point 1 at the floor
    out = np.zeros(4, np.int64)
    assert dispatch.floor_contacts(FLOOR_CODES["all"], e, pts, pv, anchored, True, Z_TOL, out) == 1 and out[0] == 1
    assert dispatch.floor_contacts(FLOOR_CODES["pivot"], e, pts, pv, anchored, True, Z_TOL, out) == 0
