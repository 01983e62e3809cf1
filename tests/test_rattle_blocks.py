"""The RATTLE method's block LU (``methods.rattle.blocks``) against dense linear algebra:
the matrix J1 W J0^T assembled in full from the rows and solved by numpy, for random rows
and for the chain's own rows (whose end rows' products the factorisation takes in closed
form), with and without redundant rows."""

import numpy as np
import pytest

from ballchain.methods.rattle.blocks import factor_blocks, new_factors, solve_blocks
from ballchain.methods.rattle.rows import K_BEND, booked_rates, layout, row_forces, row_gradients, row_rates
from ballchain.methods.rattle.stage1 import TURN_SPLIT, copy_factors, newton_split

RMAX = 8


def _chain(seed, n=12):
    """Rows of an n-segment chain, up to 6 a point, random entries; points 0 and n free
    ends with fewer rows; segment 4 landed (points 4 and 5 anchored: no columns)."""
    rng = np.random.default_rng(seed)
    anchored = np.zeros(n + 1, np.uint8)
    anchored[[4, 5]] = 1
    nrow = rng.integers(3, 7, size=n + 1)
    nrow[0], nrow[n] = 1, 2
    J = np.zeros((n + 1, RMAX, 12))
    for j in range(n + 1):
        J[j, : nrow[j]] = rng.standard_normal((nrow[j], 12))
    J[0, :, :6] = 0.0  # no segment above point 0, none below point n
    J[n, :, 6:] = 0.0
    kind = np.full((n + 1, RMAX), K_BEND, np.int8)  # (a kind with columns on both segments, products taken from J)
    return anchored, nrow, J, kind, rng


def _dense(anchored, nrow, J1, J0):
    """J1 W J0^T assembled in full: the columns of segment i are 6 i .. 6 i + 5."""
    n = anchored.shape[0] - 1
    (G1, idx), (G0, _) = _gradients(nrow, J1), _gradients(nrow, J0)
    w = np.zeros(6 * n)
    for i in range(n):
        if not (anchored[i] == 1 and anchored[i + 1] == 1):
            w[6 * i : 6 * i + 6] = (1, 1, 1, 3, 3, 3)
    return G1 @ np.diag(w) @ G0.T, idx


def _gradients(nrow, J):
    """The rows' gradients as one matrix (a row per (point, row), the columns of segment i
    at 6 i .. 6 i + 5: its centre, then its axis), and the (point, row) of each."""
    n = nrow.shape[0] - 1
    idx = [(j, r) for j in range(n + 1) for r in range(nrow[j])]
    G = np.zeros((len(idx), 6 * n))
    for k, (j, r) in enumerate(idx):
        if j >= 1:
            G[k, 6 * (j - 1) : 6 * j] = J[j, r, :6]
        if j < n:
            G[k, 6 * j : 6 * j + 6] = J[j, r, 6:]
    return G, idx


def _packed(idx, v, n):
    out = np.zeros((n + 1, RMAX))
    for k, (j, r) in enumerate(idx):
        out[j, r] = v[k]
    return out


def _flat(idx, x):
    return np.array([x[j, r] for j, r in idx])


def _assert_solves_as_dense(anchored, J1, J0, kind, nrow, symmetric, rng):
    """Factored (nothing dropped) and solved, J1 W J0^T x = b as numpy solves it."""
    A, idx = _dense(anchored, nrow, J1, J0)
    b = rng.standard_normal(len(idx))
    n = anchored.shape[0] - 1
    F = new_factors(n + 1, RMAX)
    none = np.zeros((n + 1, RMAX), np.uint8)
    assert factor_blocks(anchored, J1, J0, kind, nrow, none, F, symmetric, 0) == 0
    x = np.zeros((n + 1, RMAX))
    solve_blocks(nrow, F, _packed(idx, b, n), x)
    truth = np.linalg.solve(A, b)
    assert np.max(np.abs(_flat(idx, x) - truth)) < 1e-9 * np.max(np.abs(truth))


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("symmetric", [True, False])
def test_block_lu_solves_as_dense_algebra(seed, symmetric):
    anchored, nrow, J0, kind, rng = _chain(seed)
    J1 = J0 if symmetric else J0 + 0.05 * rng.standard_normal(J0.shape) * (J0 != 0)
    _assert_solves_as_dense(anchored, J1, J0, kind, nrow, symmetric, rng)


@pytest.mark.parametrize("seed", [4, 5])
def test_a_redundant_row_is_dropped_and_the_system_still_met(seed):
    """Row 1 of point 7 a copy of row 0 (a constraint stated twice): J W J^T is singular,
    the factorisation drops one of them, and a consistent right-hand side is met by all."""
    anchored, nrow, J, kind, rng = _chain(seed)
    nrow[7] = max(nrow[7], 3)
    J[7, 1] = J[7, 0]
    A, idx = _dense(anchored, nrow, J, J)
    b = A @ rng.standard_normal(len(idx))  # consistent
    n = anchored.shape[0] - 1
    F = new_factors(n + 1, RMAX)
    assert factor_blocks(anchored, J, J, kind, nrow, F.drop, F, True, 0) == 1
    assert F.drop[7, 1] == 1
    x = np.zeros((n + 1, RMAX))
    solve_blocks(nrow, F, _packed(idx, b, n), x)
    assert x[7, 1] == 0.0
    assert np.max(np.abs(A @ _flat(idx, x) - b)) < 1e-9 * np.max(np.abs(b))


def test_the_newton_matrix_takes_the_symmetric_drops_or_says_it_is_singular():
    anchored, nrow, J0, kind, rng = _chain(6)
    nrow[7] = max(nrow[7], 3)
    J0[7, 1] = J0[7, 0]
    J1 = J0 + 0.01 * rng.standard_normal(J0.shape) * (J0 != 0)
    J1[7, 1] = J1[7, 0]  # the rows at q+ stay the same constraint: A is singular
    n = anchored.shape[0] - 1
    sym, newt = new_factors(n + 1, RMAX), new_factors(n + 1, RMAX)
    none = np.zeros((n + 1, RMAX), np.uint8)
    assert factor_blocks(anchored, J1, J0, kind, nrow, none, newt, False, 0) == -1
    assert factor_blocks(anchored, J0, J0, kind, nrow, sym.drop, sym, True, 0) == 1
    assert factor_blocks(anchored, J1, J0, kind, nrow, sym.drop, newt, False, 0) == 1
    # with the row dropped: the other equations of A met, the dropped unknown 0
    A, idx = _dense(anchored, nrow, J1, J0)
    keep = [k for k, (j, r) in enumerate(idx) if (j, r) != (7, 1)]
    b = rng.standard_normal(len(idx))
    x = np.zeros((n + 1, RMAX))
    solve_blocks(nrow, newt, _packed(idx, b, n), x)
    truth = np.linalg.solve(A[np.ix_(keep, keep)], b[keep])
    assert x[7, 1] == 0.0
    assert np.max(np.abs(_flat(idx, x)[keep] - truth)) < 1e-9 * np.max(np.abs(truth))


def _own_rows(seed, n=10):
    """The layout of an n-segment chain with free points, an anchored pile top, an anchor
    between two airborne segments (8 rows), bend and floor rows: every kind of row."""
    rng = np.random.default_rng(seed)
    anchored = np.zeros(n + 1, np.uint8)
    anchored[[0, 1, 5, 10]] = 1  # segment 0 landed; 5 between airborne 4 and 5; the bottom
    bend = (rng.random(n - 1) < 0.5).astype(np.uint8)
    bend[4] = 1  # (the hinge at point 5)
    floor_on = np.zeros(n + 1, np.uint8)
    floor_on[[3, 7]] = 1
    kind, nrow = np.zeros((n + 1, RMAX), np.int8), np.zeros(n + 1, np.int64)
    layout(anchored, bend, floor_on, kind, nrow)
    assert nrow[5] == 8 and set(nrow) >= {3, 4, 5}
    return anchored, kind, nrow, rng


@pytest.mark.parametrize("seed", [7, 8, 9])
@pytest.mark.parametrize("symmetric", [True, False])
def test_the_chains_own_rows(seed, symmetric):
    """The rows of a 10-segment chain (``layout``, ``row_gradients``) at random axes, with
    free points, an anchored pile top, an anchor between two airborne segments, bend and
    floor rows: every kind, the end rows' products in closed form."""
    anchored, kind, nrow, rng = _own_rows(seed)
    n = anchored.shape[0] - 1
    e0 = rng.standard_normal((n, 3))
    e1 = e0 if symmetric else e0 + 0.05 * rng.standard_normal((n, 3))
    J0, J1 = np.zeros((n + 1, RMAX, 12)), np.zeros((n + 1, RMAX, 12))
    row_gradients(e0, kind, nrow, J0, 0)
    row_gradients(e1, kind, nrow, J1, 0)
    _assert_solves_as_dense(anchored, J1, J0, kind, nrow, symmetric, rng)


@pytest.mark.parametrize("symmetric", [True, False])
def test_factors_done_again_from_a_changed_point_on(symmetric):
    """Factors of one set of rows, then the rows of points 7 and 9 changed (a row switched
    off, another's values) and the factors done again from point 6 on only: they solve the
    new matrix as dense algebra does."""
    anchored, nrow, J0, kind, rng = _chain(10)
    J1 = J0 if symmetric else J0 + 0.05 * rng.standard_normal(J0.shape) * (J0 != 0)
    n = anchored.shape[0] - 1
    F = new_factors(n + 1, RMAX)
    none = np.zeros((n + 1, RMAX), np.uint8)
    assert factor_blocks(anchored, J1, J0, kind, nrow, none, F, symmetric, 0) == 0
    nrow[7] -= 1
    J0[9, 0] = rng.standard_normal(12)
    if not symmetric:
        J1[9, 0] = J0[9, 0] + 0.05 * rng.standard_normal(12)
    assert factor_blocks(anchored, J1, J0, kind, nrow, none, F, symmetric, 6) == 0
    _assert_factors_solve(anchored, nrow, J1, J0, F, rng)


def _assert_factors_solve(anchored, nrow, J1, J0, F, rng):
    """The factors F solve J1 W J0^T x = b as numpy solves it."""
    n = anchored.shape[0] - 1
    A, idx = _dense(anchored, nrow, J1, J0)
    b = rng.standard_normal(len(idx))
    x = np.zeros((n + 1, RMAX))
    solve_blocks(nrow, F, _packed(idx, b, n), x)
    truth = np.linalg.solve(A, b)
    assert np.max(np.abs(_flat(idx, x) - truth)) < 1e-9 * np.max(np.abs(truth))


@pytest.mark.parametrize("k", [0, 5, 9, 12])
def test_newton_factors_kept_above_a_point_solve_the_mixed_matrix(k):
    """Stage 1's first Newton factors in a step: those of J0 W J0^T copied for the points
    before k, J1 W J0^T factored from k on.  They solve the matrix whose rows before point
    k are J0 W J0^T's and from it on J1 W J0^T's, as dense algebra does."""
    anchored, nrow, J0, kind, rng = _chain(21)
    J1 = J0 + 0.05 * rng.standard_normal(J0.shape) * (J0 != 0)
    n = anchored.shape[0] - 1
    none = np.zeros((n + 1, RMAX), np.uint8)
    sym, newt = new_factors(n + 1, RMAX), new_factors(n + 1, RMAX)
    assert factor_blocks(anchored, J0, J0, kind, nrow, none, sym, True, 0) == 0
    newt.D[:] = np.nan  # (nothing of an earlier matrix left to lean on)
    newt.L[:] = np.nan
    newt.X[:] = np.nan
    copy_factors(sym, newt, nrow, k)
    assert factor_blocks(anchored, J1, J0, kind, nrow, sym.drop, newt, False, k) == 0
    mixed = J1.copy()
    mixed[:k] = J0[:k]
    _assert_factors_solve(anchored, nrow, mixed, J0, newt, rng)


def test_the_split_is_the_first_segment_that_turned_past_its_share_of_the_most():
    """``newton_split``: the first point whose segment below turned by more than
    TURN_SPLIT of the largest turn |e - e0|, at most ``upto``; the number of points if
    none did (no segment turned)."""
    e0 = np.tile([0.0, 0.0, -1.0], (10, 1))
    turn = np.full(10, 1e-3)
    turn[6], turn[8] = 0.5, 1.0  # the largest turn 1.0 (segment 8); segment 6 past TURN_SPLIT of it
    turn[3] = 0.9 * TURN_SPLIT  # ... segment 3 just short of it
    e = e0.copy()
    e[:, 0] = turn
    assert newton_split(e, e0, 11, 11) == 6
    assert newton_split(e, e0, 11, 4) == 4
    e[3, 0] = 1.1 * TURN_SPLIT
    assert newton_split(e, e0, 11, 11) == 3
    assert newton_split(e0, e0, 11, 11) == 10  # (nothing turned: J W J^T serves every point but the bottom end)


@pytest.mark.parametrize("seed", [11, 12])
def test_the_rows_forces_and_rates_are_the_gradients_products(seed):
    """``row_forces`` (J^T x per segment) and ``row_rates`` (J u per row), which take the
    end rows' signed components from their kinds, against the dense gradient matrix."""
    anchored, kind, nrow, rng = _own_rows(seed)
    n = anchored.shape[0] - 1
    J = np.zeros((n + 1, RMAX, 12))
    row_gradients(rng.standard_normal((n, 3)), kind, nrow, J, 0)
    G, idx = _gradients(nrow, J)
    x = _packed(idx, rng.standard_normal(len(idx)), n)
    gf = np.full((n, 6), np.nan)
    row_forces(J, kind, nrow, x, gf)
    assert np.allclose(gf.reshape(-1), G.T @ _flat(idx, x), rtol=0, atol=1e-13)
    vc, ve = rng.standard_normal((n, 3)), rng.standard_normal((n, 3))
    rate = np.zeros((n + 1, RMAX))
    row_rates(J, kind, nrow, vc, ve, rate)
    u = np.hstack([vc, ve]).reshape(-1)
    assert np.allclose(_flat(idx, rate), G @ u, rtol=0, atol=1e-13)
    # the rows the books take: bend and floor rows, and every row of a point being anchored
    marked = anchored.copy()
    marked[5] = 2
    booked = np.full((n + 1, RMAX), np.nan)
    booked_rates(J, kind, nrow, marked, vc, ve, booked)
    want = [(j, r) for j, r in idx if j == 5 or kind[j, r] >= K_BEND]
    assert len(want) > nrow[5] and np.isnan(_flat(idx, booked)).sum() == len(idx) - len(want)
    for j, r in want:
        assert booked[j, r] == pytest.approx(rate[j, r], abs=1e-13)


def test_the_locks_share_of_a_landing_step_is_what_they_dissipate_after_the_landing():
    """``lock_loss_after_landing`` against the impacts taken one after the other by dense
    algebra: an inelastic impact is the M-orthogonal projection of u onto the velocities
    its rows allow.  The landing (point 6 anchored anew, the lock of hinge 1 held from
    before) and then hinges 3 and 4 locking anew: the locks dissipate T(u_landed) - T(u+),
    where u+ comes from all rows at once, as the step solves them (their impulses split
    between the step's two stages)."""
    from ballchain.methods.rattle.books import lock_loss_after_landing
    from ballchain.methods.rattle.rows import new_rows
    from ballchain.methods.rattle.state import new_motion, new_scratch

    n = 8
    rng = np.random.default_rng(21)
    mo, ws, sc = new_motion(n), new_rows(n), new_scratch(n)
    mo.e[:] = rng.standard_normal((n, 3))
    mo.anchored[[6, 7, 8]] = (2, 1, 1)  # segment 7 landed before; segment 6 lands now (point 6: its impact)
    sc.start.locked[1] = 1
    mo.locked[[1, 3, 4]] = 1
    floor_on = np.zeros(n + 1, np.uint8)
    layout(mo.anchored, mo.locked, floor_on, ws.kind, ws.nrow)
    row_gradients(mo.e, ws.kind, ws.nrow, ws.J, 0)
    G, idx = _gradients(ws.nrow, ws.J)
    w = np.zeros(6 * n)
    for i in range(6):  # (segments 6 and 7 have landed: no motion)
        w[6 * i : 6 * i + 6] = (1, 1, 1, 3, 3, 3)
    W, M = np.diag(w), np.diag(np.where(w > 0, 1.0 / np.where(w > 0, w, 1.0), 0.0))

    def project(rows, u):  # the inelastic impact of the given rows of G on u
        Gr = G[rows]
        return u - W @ Gr.T @ np.linalg.lstsq(Gr @ W @ Gr.T, Gr @ u, rcond=None)[0]

    u0 = rng.standard_normal(6 * n) * (w > 0)
    every = list(range(len(idx)))
    new_bend = [k for k, (j, r) in enumerate(idx) if ws.kind[j, r] == K_BEND and j - 1 in (3, 4)]
    u_plus, u_landed = project(every, u0), project([k for k in every if k not in new_bend], u0)
    truth = 0.5 * u_landed @ M @ u_landed - 0.5 * u_plus @ M @ u_plus
    P = np.linalg.lstsq(G @ W @ G.T, -(G @ u0), rcond=None)[0]  # u+ = u0 + W G^T P
    assert np.allclose(u0 + W @ G.T @ P, u_plus, atol=1e-10)
    ws.x[:] = _packed(idx, P, n)
    # a third of hinge 3's impulse taken in stage 1 (its row among stage 1's), the rest in stage 2
    j3 = 4
    r3 = [r for r in range(ws.nrow[j3]) if ws.kind[j3, r] == K_BEND][0]
    sc.kind1[j3, 0], sc.nrow1[j3], sc.x1[j3, 0] = K_BEND, 1, ws.x[j3, r3] / 3.0
    ws.x[j3, r3] *= 2.0 / 3.0
    got = lock_loss_after_landing(mo, ws, sc)
    assert truth > 1e-3 * (0.5 * u0 @ M @ u0)  # (the locks do dissipate)
    assert abs(got - truth) < 1e-10 * truth
    assert list(mo.locked) == [0, 1, 0, 1, 1, 0, 0]  # (the step's locks as they were)
