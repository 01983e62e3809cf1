"""The complementarity solvers finish, and give the solution, where the O(N)
principal pivoting cannot (singular or near-singular rows)."""

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import chain_directions
from oracle import reference as ref

from ballchain.core import dynamics as dyn
from ballchain.core.impacts import hinge_accels, lock_set
from ballchain.core.lcp import _lemke
from ballchain.core.rules import limit_in_force
from ballchain.core.state import new_work

DATA = Path(__file__).parent / "data"


def _enumerate(M, q):
    """The LCP w = q + M z >= 0, z >= 0, w.z = 0 by trying every complementary basis
    (unique solution for a P-matrix)."""
    c = len(q)
    for r in range(c + 1):
        for S in itertools.combinations(range(c), r):
            S = list(S)
            z = np.zeros(c)
            if S:
                z[S] = np.linalg.solve(M[np.ix_(S, S)], -q[S])
            w = q + M @ z
            if np.all(z >= -1e-12) and np.all(w >= -1e-12):
                return z
    raise AssertionError("no solution")


def test_lemke_matches_enumeration():
    rng = np.random.default_rng(5)
    for trial in range(400):
        c = int(rng.integers(1, 7))
        A = rng.normal(size=(c, c))
        M = A @ A.T + 0.05 * np.eye(c)  # symmetric positive definite
        if trial % 2:  # half the time: positive definite but not symmetric (still a P-matrix)
            K = rng.normal(size=(c, c))
            M = M + 0.5 * (K - K.T)
        q = rng.normal(size=c)
        z = np.zeros(c)
        piv = _lemke(M.copy(), q.copy(), c, z)
        assert piv >= 0
        np.testing.assert_allclose(z, _enumerate(M, q), atol=1e-9)


@pytest.mark.slow
def test_lock_set_finishes_on_a_span_between_two_anchors():
    """Segments 1 and 2 of a 3-segment chain span the anchored points 1 and 3: their
    hinge's angle is fixed by the anchors, so its lock row is a combination of the
    anchor rows.  The rule takes that limit out of force; and even when a caller offers
    it as a candidate anyway, the lock-set LCP (a singular problem) finishes with every
    condition met, and the motion is the one without that limit (a redundant row
    changes how the load is shared between it and the anchors, never the motion)."""
    n, alpha = 3, math.pi / 4
    rng = np.random.default_rng(2)
    anchored = np.array([0, 1, 0, 1], np.uint8)
    assert not limit_in_force(anchored, 1, False, alpha)
    assert limit_in_force(anchored, 0, False, alpha)
    for _ in range(10):
        e = chain_directions(rng, n, "tilted", [True, True], alpha)
        w = ref.project_velocity(e, rng.normal(size=(n, 3)), anchored.astype(bool), [False, False])
        ws = new_work(n)
        cand = np.array([1, 1], np.uint8)
        active = np.array([1, 1], np.uint8)
        de, dw = np.zeros((n, 3)), np.zeros((n, 3))
        ddg, lam = np.zeros(2), np.zeros(2)
        it = lock_set(e, w, anchored, cand, active, ws, de, dw, ddg, lam)
        assert it >= 0
        hinge_accels(e, w, de, dw, ddg)
        scale = max(1.0, np.abs(ddg).max(), np.abs(lam).max())
        # complementarity: lam >= 0, ddg >= 0, one of them zero, on both hinges
        assert np.all(lam >= -1e-9 * scale) and np.all(ddg >= -1e-9 * scale)
        assert np.all(np.minimum(np.abs(lam), np.abs(ddg)) <= 1e-9 * scale)
        assert abs(ddg[1]) <= 1e-8 * scale  # the span's angle cannot change
        ws2 = new_work(n)
        de2, dw2 = np.zeros((n, 3)), np.zeros((n, 3))
        dyn.accelerations(e, w, anchored, np.array([active[0], 0], np.uint8), ws2, de2, dw2)
        np.testing.assert_allclose(dw, dw2, atol=1e-9 * max(1.0, np.abs(dw2).max()))


def test_lock_set_finishes_on_the_state_where_it_used_to_cycle():
    """The state of an N = 128 fall (random start, seed 4) at which the lock-set LCP
    once cycled until its pivot cap: hinge 29 spans the anchored points 29 and 31 and
    was offered as a candidate.  Offered the same candidates, the solver now finishes
    with complementarity met; the rule no longer offers hinge 29."""
    d = np.load(DATA / "lock-set-span-n128.npz")
    e, w, anchored = d["e"], d["w"].copy(), d["anchored"].astype(np.uint8)
    n = e.shape[0]
    assert not limit_in_force(anchored, 29, False, math.pi / 4)
    for cand in (
        d["cand"].astype(np.uint8),
        np.array([c and limit_in_force(anchored, k, False, math.pi / 4) for k, c in enumerate(d["cand"])], np.uint8),
    ):
        ws = new_work(n)
        active = (d["active"].astype(np.uint8) & cand).copy()
        de, dw = np.zeros((n, 3)), np.zeros((n, 3))
        ddg, lam = np.zeros(n - 1), np.zeros(n - 1)
        it = lock_set(e, w, anchored, cand, active, ws, de, dw, ddg, lam)
        assert it >= 0
        hinge_accels(e, w, de, dw, ddg)
        c = cand != 0
        scale = max(1.0, np.abs(ddg[c]).max(), 3 * np.abs(lam[c]).max())
        assert np.all(lam[c] >= -1e-9 * scale) and np.all(ddg[c] >= -1e-9 * scale)
        assert np.all(np.minimum(np.abs(lam[c]), np.abs(ddg[c])) <= 1e-9 * scale)
