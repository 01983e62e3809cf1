"""The O(N) production path (dynamics.py, impacts.py) against the dense reference
(reference.py, the dense formulation) on random consistent states."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import chain_directions
from oracle import reference as ref

from ballchain.core import blocks, rows
from ballchain.core import dynamics as dyn
from ballchain.core import kinematics as kin
from ballchain.core.impacts import hinge_rates, new_impact_work, velocity_impact
from ballchain.core.rules import limit_in_force
from ballchain.core.state import new_work

ACC_TOL = 1e-10  # relative to the scale of the compared values
IMP_TOL = 1e-10
EZ = np.array([0.0, 0.0, 1.0])


# ----------------------------------------------------------------- fast path calls


def in_force(anchored, mask):
    """The mask restricted to hinges whose limit is in force (rules.limit_in_force): the
    kernels act on the locked set the event handler keeps, which holds only those."""
    a8 = np.asarray(anchored, np.uint8)
    return np.array([bool(m) and limit_in_force(a8, k, False, 1.0) for k, m in enumerate(mask)], np.uint8)


def fast_accelerations(e, w, anchored, locked):
    n = e.shape[0]
    ws = new_work(n)
    de = np.zeros((n, 3))
    dw = np.zeros((n, 3))
    dyn.accelerations(e, w, np.asarray(anchored, np.uint8), in_force(anchored, locked), ws, de, dw)
    lam = np.zeros(max(n - 1, 0))
    dyn.lock_multipliers(ws.kind, ws.nrow, ws.x, lam)
    af = np.zeros((n + 1, 3))
    dyn.anchor_forces(ws.kind, ws.nrow, ws.x, af)
    return {"dde": np.cross(dw, e) + np.cross(w, de), "dw": dw, "lam": lam, "anchor_force": af}


def fast_impact(e, w, anchored_u8, cand, restitution=0.0):
    """``anchored_u8``: 1 for old anchors, 2 for the points anchored by this impact
    (the engine's convention); ``restitution``: Newton's at the limits."""
    n = e.shape[0]
    ws = new_work(n)
    nh = max(n - 1, 0)
    w_after = np.array(w, dtype=float, copy=True)
    c8 = in_force(anchored_u8, cand)
    active = c8.copy()
    pv = np.zeros((n + 1, 3))
    vel = np.zeros((n, 3))
    iw = new_impact_work(n)
    out = {
        "jv_minus": iw.jv,
        "w_plus": iw.w_plus,
        "rates": iw.rates_after,
        "impulse": iw.impulse,
        "anchor_impulse": iw.anchor_impulse,
        "energy_split": iw.split,
    }
    T0 = kin.kinetic_energy(e, w, pv, vel)
    hinge_rates(e, w_after, iw.rates_before)
    it = velocity_impact(
        e, w_after, np.asarray(anchored_u8, np.uint8), c8, np.zeros(nh, np.uint8), active, restitution, ws, iw
    )
    out["T0"] = T0
    out["active"] = active.copy()
    out["T1"] = kin.kinetic_energy(e, w_after, pv, vel)
    kin.velocities(e, w_after, pv, vel)
    out["point_vel"] = pv.copy()
    out["w"] = w_after
    out["pivots"] = it
    out["active"] = active
    return out


# ------------------------------------------------------------------ random states


def random_anchors(rng, n, p):
    anc = np.zeros(n + 1, dtype=bool)
    anc[:n] = rng.random(n) < p
    anc[n] = True
    return anc


def random_acc_state(rng, n):
    mode = rng.choice(["arbitrary", "vertical", "tilted"])
    alpha = rng.uniform(0.05, 1.5)
    locked = rng.random(max(n - 1, 0)) < rng.uniform(0.0, 1.0)
    anchored = random_anchors(rng, n, rng.choice([0.0, 0.1, 0.3, 0.5]))
    e = chain_directions(rng, n, mode, locked, alpha)
    w = ref.project_velocity(e, rng.normal(size=(n, 3)), anchored, locked)
    return e, w, anchored, locked, alpha


def compare_accelerations(e, w, anchored, locked, alpha):
    r = ref.reference_accelerations(e, w, anchored, locked, alpha)
    f = fast_accelerations(e, w, anchored.astype(np.uint8), locked.astype(np.uint8))
    sa = max(1.0, np.abs(r["dde"]).max())
    err = {
        "dde": np.abs(f["dde"] - r["dde"]).max() / sa,
        "dw": np.abs(f["dw"] - r["dw"]).max() / sa,
    }
    m = r["lam_determined"]
    sl = max(1.0, np.abs(r["lam"]).max(initial=0.0))
    err["lam"] = np.abs(f["lam"] - r["lam"])[m].max(initial=0.0) / sl
    ma = r["anchor_determined"]
    sf = max(1.0, np.abs(r["anchor_force"]).max())
    err["anchor_force"] = np.abs(f["anchor_force"] - r["anchor_force"])[ma].max(initial=0.0) / sf
    return err, r, f


# ------------------------------------------------------- the reference on its own


def test_reference_single_rod_pendulum():
    """Rod pivoting about its lower end: theta'' = 3 g sin(theta) / (4 b); pivot force
    m g (3/4 sin cos, 0, 1 - 3/4 sin^2) at rest; units m, b, g honoured."""
    th = 0.3
    e = np.array([[np.sin(th), 0.0, np.cos(th)]])
    for m, b, g in [(1.0, 1.0, 1.0), (0.3, 0.02, 9.81)]:
        r = ref.reference_accelerations(e, np.zeros((1, 3)), [0, 1], [], 0.5, m=m, b=b, g=g)
        np.testing.assert_allclose(r["dw"][0], [0.0, 3 * g * np.sin(th) / (4 * b), 0.0], atol=1e-12 * g / b)
        expect = m * g * np.array([0.75 * np.sin(th) * np.cos(th), 0.0, 1 - 0.75 * np.sin(th) ** 2])
        np.testing.assert_allclose(r["anchor_force"][1], expect, rtol=1e-12, atol=1e-14 * m * g)


def test_reference_energy_rate_and_constraints():
    """Along the reference accelerations, d(T+U)/dt = 0 and the constraint rows hold."""
    rng = np.random.default_rng(11)
    for n in (2, 5, 8):
        for _ in range(5):
            e, w, anchored, locked, alpha = random_acc_state(rng, n)
            r = ref.reference_accelerations(e, w, anchored, locked, alpha)
            de = np.cross(w, e)
            u = np.concatenate([np.zeros(3), de.ravel()])
            a = np.concatenate([np.zeros(3), r["dde"].ravel()])
            M = ref.mass_matrix(n)
            f = ref.generalized_gravity(n)
            dEdt = u @ M @ a - u @ f  # dT/dt + dU/dt, with f = -grad U
            assert abs(dEdt) <= 1e-11 * max(1.0, np.abs(u).max() * np.abs(M @ a).max())
            R, gam, _ = ref.constraint_rows(e, anchored, locked, de)
            np.testing.assert_allclose(R @ a, gam, atol=1e-11 * max(1.0, np.abs(gam).max()))


# --------------------------------------------------------- accelerations vs fast


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8, 13, 21])
def test_accelerations_random_states(n):
    rng = np.random.default_rng(1000 + n)
    worst = dict.fromkeys(["dde", "dw", "lam", "anchor_force"], 0.0)
    for _ in range(30):
        err, _, _ = compare_accelerations(*random_acc_state(rng, n))
        for k in worst:
            worst[k] = max(worst[k], err[k])
    assert max(worst.values()) < ACC_TOL, worst


def _case(n, anchored_pts, locked_hinges, seed, mode="tilted", alpha=0.7):
    rng = np.random.default_rng(seed)
    anchored = np.zeros(n + 1, dtype=bool)
    anchored[list(anchored_pts)] = True
    anchored[n] = True
    locked = np.zeros(max(n - 1, 0), dtype=bool)
    locked[list(locked_hinges)] = True
    e = chain_directions(rng, n, mode, locked, alpha)
    w = ref.project_velocity(e, rng.normal(size=(n, 3)), anchored, locked)
    return e, w, anchored, locked, alpha


@pytest.mark.parametrize(
    "n, anchored_pts, locked_hinges",
    [
        (1, [0], []),  # the only segment landed: nothing moves
        (3, [0], [0, 1]),  # anchored top point, locked sub-chain between two anchors
        (4, [0], [1]),
        (5, [2, 3], [0, 3]),  # adjacent anchors: segment 2 landed
        (6, [1, 2, 3], [0, 1, 2, 3, 4]),  # two landed segments, locks next to them not in force
        (6, [0, 1, 5], [1, 2, 3]),  # landed top and bottom segments
        (5, [0, 1, 2, 3, 4], [0, 1, 2, 3]),  # everything landed
        (5, [3], [3]),  # bottom pair locked between anchors: redundant lock row
        (8, [0, 2, 4, 6], list(range(7))),  # pairs between anchors, all locked
        (8, [5], [0, 1, 2, 3]),
    ],
)
def test_accelerations_special_cases(n, anchored_pts, locked_hinges):
    for seed in range(3):
        state = _case(n, anchored_pts, locked_hinges, seed)
        err, r, f = compare_accelerations(*state)
        assert max(err.values()) < ACC_TOL, err
        landed = ref.landed_segments(state[2])
        assert np.all(f["dde"][landed] == 0.0) and np.all(r["dde"][landed] == 0.0)


def test_accelerations_redundant_lock_is_flagged():
    """Two rods locked between two anchors: the lock row is a combination of the
    others (its multiplier is not unique); the accelerations still agree."""
    state = _case(2, [0], [0], seed=3)
    err, r, _ = compare_accelerations(*state)
    assert not r["lam_determined"][0]
    assert err["dde"] < ACC_TOL


def test_accelerations_free_chain_without_locks_matches_unlocked():
    """alpha plays no role at the acceleration level; a lock row not in force (next to
    a landed segment) changes nothing."""
    e, w, anchored, locked, alpha = _case(5, [2, 3], [1, 2, 3], seed=5)
    a = ref.reference_accelerations(e, w, anchored, locked, alpha)
    b = ref.reference_accelerations(e, w, anchored, locked & np.array([0, 0, 1, 0], bool), 0.1)
    np.testing.assert_allclose(a["dde"], b["dde"], atol=1e-12)


def test_accelerations_scaling():
    """Physical units (m, b, g) = (0.3, 0.02, 9.81) in the reference vs the
    nondimensional fast path: time unit sqrt(b/g), forces m g, lock multipliers m g b."""
    m, b, g = 0.3, 0.02, 9.81
    tau = np.sqrt(b / g)
    rng = np.random.default_rng(7)
    for n in (3, 8):
        for _ in range(6):
            e, w, anchored, locked, alpha = random_acc_state(rng, n)
            r = ref.reference_accelerations(e, w / tau, anchored, locked, alpha, m=m, b=b, g=g)
            f = fast_accelerations(e, w, anchored.astype(np.uint8), locked.astype(np.uint8))
            sa = max(1.0, np.abs(f["dde"]).max())
            assert np.abs(r["dde"] * tau**2 - f["dde"]).max() < ACC_TOL * sa
            assert np.abs(r["dw"] * tau**2 - f["dw"]).max() < ACC_TOL * sa
            ml = r["lam_determined"]
            sl = max(1.0, np.abs(f["lam"]).max(initial=0.0))
            assert np.abs(r["lam"] / (m * g * b) - f["lam"])[ml].max(initial=0.0) < ACC_TOL * sl
            ma = r["anchor_determined"]
            sf = max(1.0, np.abs(f["anchor_force"]).max())
            assert np.abs(r["anchor_force"] / (m * g) - f["anchor_force"])[ma].max(initial=0.0) < ACC_TOL * sf


# -------------------------------------------------------------- impacts vs fast


def random_impact_state(rng, n, avoid_new_landing_limits=True):
    """Hinges in ``cand`` exactly at their limit (some were locked: dg/dt = 0 before;
    the others approach or separate at random); old anchors at rest, new anchors
    (marked 2) moving.  Returns e, w, anchored_u8, cand, alpha."""
    mode = rng.choice(["arbitrary", "vertical", "tilted"])
    alpha = rng.uniform(0.1, 1.5)
    nh = max(n - 1, 0)
    cand = rng.random(nh) < rng.uniform(0.3, 1.0)
    was_locked = cand & (rng.random(nh) < 0.3)
    old = random_anchors(rng, n, rng.choice([0.0, 0.2]))
    new = old.copy()
    new[:n] |= rng.random(n) < rng.choice([0.0, 0.2, 0.4])
    e = chain_directions(rng, n, mode, cand, alpha)
    w = ref.project_velocity(e, rng.normal(size=(n, 3)), old, was_locked)
    if avoid_new_landing_limits and n > 1:
        # a limit next to a segment that lands in this very impact: see
        # test_impact_limit_next_to_segment_landing_now
        newly = ref.landed_segments(new) & ~ref.landed_segments(old)
        cand &= ~(newly[:-1] | newly[1:])
    anchored = old.astype(np.uint8)
    anchored[new & ~old] = 2
    return e, w, anchored, cand, alpha


def _rigid_pair_residual(e, w, k):
    """Least-squares residual of de_a = Om x e_a, de_c = Om x e_c (a, c = k, k+1)."""
    de = np.cross(w, e)

    def skew(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    A = np.vstack([-skew(e[k]), -skew(e[k + 1])])  # Om x e = -[e]x Om
    rhs = np.concatenate([de[k], de[k + 1]])
    om = np.linalg.lstsq(A, rhs, rcond=None)[0]
    return np.abs(A @ om - rhs).max()


def check_impact(e, w, anchored, cand, alpha):
    n = e.shape[0]
    f = fast_impact(e, w, anchored, cand)
    assert f["pivots"] >= 0
    r = ref.reference_impact(e, w, anchored != 0, cand, alpha)
    assert r["kkt"]
    scale = max(np.abs(w).max(), np.abs(f["impulse"]).max(initial=0.0), np.abs(f["anchor_impulse"]).max())
    vs = np.abs(w).max()
    # post-impact velocity, impulses, energy
    assert np.abs(f["w"] - r["w_plus"]).max() < IMP_TOL * scale
    np.testing.assert_array_equal(f["w"], f["w_plus"])
    mL = r["Lambda_determined"]
    assert np.abs(f["impulse"] - r["Lambda"])[mL].max(initial=0.0) < IMP_TOL * scale
    ma = r["anchor_determined"]
    assert np.abs(f["anchor_impulse"] - r["anchor_impulse"])[ma].max(initial=0.0) < IMP_TOL * scale
    T0, T1 = f["T0"], f["T1"]
    assert abs(T0 - ref.kinetic_energy(e, w)) <= 1e-12 * max(T0, 1e-300)
    assert abs((T0 - T1) - r["lost_energy"]) <= 1e-10 * max(T0, 1e-300)
    # physics of the post-impact state (fast path alone)
    assert T1 <= T0 * (1 + 1e-12)
    assert abs(f["energy_split"].sum() - (T0 - T1)) <= 1e-10 * max(T0, 1e-300)
    if not np.any(anchored == 2) or not np.any(f["impulse"] != 0.0):
        # one kind of impact: its share is the whole (non-negative) loss.  In a mixed
        # landing + lock impact the per-constraint split -1/2 Lambda_c (J_c v- + J_c v+)
        # is not sign-definite (a hinge opening before and held at dg/dt = 0 after
        # "gains"), only the sum is meaningful.
        assert np.all(f["energy_split"] >= -1e-12 * max(T0, 1e-300))
    anc = anchored != 0
    assert np.abs(f["point_vel"][anc]).max() < IMP_TOL * scale
    landed = ref.landed_segments(anc)
    assert np.abs(f["w"][landed]).max(initial=0.0) < IMP_TOL * scale  # ~0 (exactly 0 once landed)
    if n > 1:
        inf = ref.limits_in_force(anc)
        rates = ref.hinge_rates(e, f["w"])
        c = cand & inf
        assert np.all(rates[c] >= -IMP_TOL * vs)
        Lam = f["impulse"]
        assert np.all(Lam >= -IMP_TOL * scale)
        assert np.all(Lam[~c] == 0.0)
        assert np.abs(Lam * rates).max() < IMP_TOL * scale * vs
        for k in np.flatnonzero(Lam > IMP_TOL * scale):
            # a pair that took a lock impulse turns as one rigid body
            assert abs(rates[k]) < IMP_TOL * vs
            assert _rigid_pair_residual(e, f["w"], k) < IMP_TOL * scale
    return f, r


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6, 8])
def test_impacts_random_states(n):
    rng = np.random.default_rng(2000 + n)
    done = 0
    while done < 40:
        e, w, anchored, cand, alpha = random_impact_state(rng, n)
        if np.abs(w).max() == 0.0:
            continue
        check_impact(e, w, anchored, cand, alpha)
        done += 1


def closing_pair(rng, alpha):
    """Two free rods on the pivot, the hinge at its limit and closing faster than 0.1:
    (e, w, its rate v)."""
    e = chain_directions(rng, 2, "tilted", [True], alpha)
    while True:
        w = ref.project_velocity(e, rng.normal(size=(2, 3)), [0, 0, 1], [False])
        v = ref.hinge_rates(e, w)[0]
        if v < -0.1:
            return e, w, v


def test_impact_single_pair_locks_rigidly():
    """Two free rods on the pivot, hinge at its limit and closing: after the impact
    dg/dt = 0, the impulse is positive and the pair turns as one rigid body."""
    rng = np.random.default_rng(3)
    alpha = 0.6
    for _ in range(10):
        e, w, _ = closing_pair(rng, alpha)
        f, r = check_impact(e, w, np.array([0, 0, 1], np.uint8), np.array([True]), alpha)
        assert f["impulse"][0] > 0 and r["Lambda"][0] > 0
        assert abs(ref.hinge_rates(e, f["w"])[0]) < 1e-13
        assert _rigid_pair_residual(e, f["w"], 0) < 1e-13
        assert abs(f["energy_split"][1]) <= 1e-14 * f["T0"]


def test_impact_separating_hinge_is_untouched():
    rng = np.random.default_rng(4)
    e = chain_directions(rng, 3, "tilted", [True, True], 0.5)
    while True:
        w = ref.project_velocity(e, rng.normal(size=(3, 3)), [0, 0, 0, 1], [False, False])
        if np.all(ref.hinge_rates(e, w) > 0.05):
            break
    f, _ = check_impact(e, w, np.array([0, 0, 0, 1], np.uint8), np.array([True, True]), 0.5)
    np.testing.assert_allclose(f["w"], w, atol=1e-15)
    assert f["T1"] == pytest.approx(f["T0"], rel=1e-14)  # no impulse: energy unchanged (to round-off)


def test_impact_scaling():
    m, b, g = 0.3, 0.02, 9.81
    tau = np.sqrt(b / g)
    rng = np.random.default_rng(9)
    done = 0
    while done < 8:
        e, w, anchored, cand, alpha = random_impact_state(rng, 5)
        if np.abs(w).max() == 0.0:
            continue
        f = fast_impact(e, w, anchored, cand)
        r = ref.reference_impact(e, w / tau, anchored != 0, cand, alpha, m=m, b=b, g=g)
        scale = max(np.abs(w).max(), np.abs(f["impulse"]).max(initial=0.0))
        assert np.abs(r["w_plus"] * tau - f["w"]).max() < IMP_TOL * scale
        mL = r["Lambda_determined"]
        # generalised impulse: energy x time = m g b tau
        assert np.abs(r["Lambda"] / (m * g * b * tau) - f["impulse"])[mL].max(initial=0.0) < IMP_TOL * scale
        assert abs(r["lost_energy"] / (m * g * b) - (f["T0"] - f["T1"])) < 1e-10 * f["T0"]
        done += 1


def test_impact_limit_next_to_segment_landing_now():
    """Segment 1 of 3 lands in this impact (point 1 newly anchored, point 2 already
    anchored); hinge 0 (segments 0, 1) is at its limit and closing.  After the impact
    segment 1 has landed, the limit is not in force: segment 0 just pivots on point 1
    (no cone), as in the reference."""
    rng = np.random.default_rng(12)
    alpha = 0.5
    e = chain_directions(rng, 3, "tilted", [True, False], alpha)
    old = np.array([False, False, True, True])  # points 2 and 3 anchored: segment 2 landed
    anchored = old.astype(np.uint8)
    anchored[1] = 2
    cand = np.array([True, False])
    while True:  # closing before, and still closing after (no limit) in the reference
        w = ref.project_velocity(e, rng.normal(size=(3, 3)), old, [False, False])
        r = ref.reference_impact(e, w, anchored != 0, cand, alpha)
        if ref.hinge_rates(e, w)[0] < -0.1 and r["rates"][0] < -0.1:
            break
    f = fast_impact(e, w, anchored, cand)
    np.testing.assert_allclose(f["w"], r["w_plus"], atol=1e-10)


# ---------------------------------------------- fixed-size path vs general path


def _general_path(e, w, anchored, locked):
    """Multipliers and torques from the general (J-based, any row count) kernels."""
    n = e.shape[0]
    ws = new_work(n)
    rows.build_rows(e, w, anchored, locked, ws.J, ws.kind, ws.nrow, ws.rhs, True)
    blocks.factor_general(anchored, ws.J, ws.nrow, ws.S, ws.G, ws.drop)
    blocks.solve_general(ws.nrow, ws.S, ws.G, ws.drop, ws.rhs, ws.x)
    blocks.generalized_forces(anchored, ws.J, ws.nrow, ws.x, ws.gf)
    return ws


@pytest.mark.parametrize("n", [2, 3, 8, pytest.param(40, marks=pytest.mark.slow)])
def test_fixed_size_path_equals_general_path(n):
    """The closed-form 4x4 path (rows_rhs4, factor4, solve4, torques4) solves the same
    system as the general path built from J: multipliers and torques agree."""
    rng = np.random.default_rng(100 + n)
    fitted = 0
    for _ in range(60):
        e, w, anchored, locked, _alpha = random_acc_state(rng, n)
        a8, l8 = anchored.astype(np.uint8), in_force(anchored, locked)
        g = _general_path(e, w, a8, l8)
        ws = new_work(n)
        if not rows.rows_rhs4(e, w, a8, l8, ws.kind, ws.nrow, ws.rhs):
            continue  # a lock beside a split anchor (7 rows): only the general path applies
        fitted += 1
        assert np.array_equal(ws.nrow, g.nrow)
        for j in range(n + 1):
            r = g.nrow[j]
            assert np.array_equal(ws.kind[j, :r], g.kind[j, :r])
            assert np.allclose(ws.rhs[j, :r], g.rhs[j, :r], rtol=0, atol=1e-13 * max(1.0, np.abs(g.rhs).max()))
        ndrop = blocks.factor4(e, a8, ws.kind, ws.nrow, ws.S, ws.G, ws.drop)
        blocks.solve4(ws.nrow, ws.S, ws.G, ws.rhs, ws.x)
        blocks.torques4(e, ws.kind, ws.nrow, ws.x, ws.gf)
        assert ndrop == sum(int(g.drop[j, : g.nrow[j]].sum()) for j in range(n + 1))
        scale = max(1.0, np.abs(g.x).max())
        for j in range(n + 1):
            r = g.nrow[j]
            np.testing.assert_allclose(ws.x[j, :r], g.x[j, :r], rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(ws.gf[:, 3:], g.gf[:, 3:], rtol=0, atol=1e-10 * scale)
    assert fitted >= 10  # the fixed-size path was exercised


def test_fixed_size_path_off_unit_axes_and_folded():
    """Runge-Kutta stages evaluate the equations at axes with |e| != 1.  The closed-form
    path must still solve the system the rows J define (its end.end blocks carry |e|^2,
    not 1): near two segments folded flat between two anchors the smallest eigenvalue
    of J W J^T is ~ (fold angle)^2, so an O(|e|^2 - 1) mismatch makes it indefinite."""
    n = 4
    rng = np.random.default_rng(7)
    for _ in range(20):
        u = rng.normal(size=3)
        u -= u[2] * np.array([0.0, 0.0, 1.0])
        u /= np.linalg.norm(u)
        v = np.cross(u, [0.0, 0.0, 1.0])
        tilt = 1e-3 * rng.uniform(0.2, 1.0)
        e = np.zeros((n, 3))
        e[0] = -u * math.cos(tilt) + v * math.sin(tilt)  # folded back onto segment 1
        e[1] = u
        e[2] = u
        e[3] = u
        e *= 1.0 + 1e-6 * rng.uniform(-1, 1, size=(n, 1))  # an RK stage: |e| != 1
        w = rng.normal(size=(n, 3))
        w -= np.einsum("ij,ij->i", w, e)[:, None] * e / np.einsum("ij,ij->i", e, e)[:, None]
        a8 = np.array([1, 0, 1, 1, 1], np.uint8)  # top anchored, segments 2, 3 landed
        l8 = np.zeros(n - 1, np.uint8)
        w[2:] = 0.0
        g = _general_path(e, w, a8, l8)
        ws = new_work(n)
        assert rows.rows_rhs4(e, w, a8, l8, ws.kind, ws.nrow, ws.rhs)
        assert blocks.factor4(e, a8, ws.kind, ws.nrow, ws.S, ws.G, ws.drop) == 0
        blocks.solve4(ws.nrow, ws.S, ws.G, ws.rhs, ws.x)
        blocks.torques4(e, ws.kind, ws.nrow, ws.x, ws.gf)
        scale = max(1.0, np.abs(g.x).max())
        np.testing.assert_allclose(ws.x, g.x, rtol=0, atol=1e-6 * scale)
        np.testing.assert_allclose(ws.gf[:, 3:], g.gf[:, 3:], rtol=0, atol=1e-6 * scale)


@pytest.mark.parametrize("n, split, locked_hinges", [(5, 2, []), (8, 3, [0, 1, 5]), (12, 6, [4, 7, 9])])
def test_split_anchor_on_the_fixed_size_path(n, split, locked_hinges):
    """An anchored point between two airborne segments (a fold touching the floor) has
    six rows that do not couple: the fixed-size path takes them as the end of one sweep
    and the start of the next.  Accelerations and impacts against the dense reference."""
    for seed in range(4):
        e, w, anchored, locked, alpha = _case(n, [split], locked_hinges, seed)
        ws = new_work(n)
        a8 = anchored.astype(np.uint8)
        assert rows.rows_rhs4(e, w, a8, in_force(anchored, locked), ws.kind, ws.nrow, ws.rhs)
        assert ws.nrow[split] == 6
        err, _, _ = compare_accelerations(e, w, anchored, locked, alpha)
        assert max(err.values()) < ACC_TOL, err
        rng = np.random.default_rng(seed)
        w_minus = ref.project_velocity(e, rng.normal(size=(n, 3)), anchored, np.zeros(n - 1, bool))
        check_impact(e, w_minus, a8, locked, alpha)


@pytest.mark.parametrize("restitution", [0.3, 0.7, 1.0])
@pytest.mark.parametrize("n", [2, 3, 4, 6])
def test_newton_impacts_against_the_dense_enumeration(n, restitution):
    """Newton's restitution at the limits (``contacts.newton``) by the O(N) pivoting
    against the dense enumeration of active sets (``reference_newton_impact``): the
    velocities after, the impulses and the energy lost; the loss is never negative and is
    zero at e = 1 when no hinge needed the second, inelastic pass."""
    rng = np.random.default_rng(7000 + n + int(10 * restitution))
    done = twice = inelastic = 0
    while done < 30:
        e, w, anchored, cand, alpha = random_impact_state(rng, n)
        if np.abs(w).max() == 0.0 or n < 2:
            continue
        f = fast_impact(e, w, anchored, cand, restitution)
        r = ref.reference_newton_impact(e, w, anchored != 0, cand, restitution)
        scale = max(np.abs(w).max(), np.abs(f["impulse"]).max(initial=0.0))
        assert np.abs(r["w_plus"] - f["w"]).max() < IMP_TOL * scale
        mL = r["Lambda_determined"]
        assert np.abs(r["Lambda"] - f["impulse"])[mL].max(initial=0.0) < IMP_TOL * scale
        # every hinge that carries an impulse is reported active (the accumulation rule
        # and the lock decision read it), also one that took it in the first pass only
        carries = mL & (np.abs(r["Lambda"]) > 1e-6 * scale)
        assert np.all(f["active"][carries] != 0), (f["active"], r["Lambda"])
        lost = f["T0"] - f["T1"]
        assert lost == pytest.approx(r["lost_energy"], abs=1e-10 * f["T0"])
        assert lost == pytest.approx(f["energy_split"].sum(), abs=1e-10 * f["T0"])  # the books
        assert lost >= -1e-12 * f["T0"]
        if restitution == 1.0 and not r["two_passes"] and not np.any(anchored == 2):
            assert abs(lost) <= 1e-12 * f["T0"]
        twice += r["two_passes"]
        inelastic += r["inelastic"]
        done += 1
    assert done == 30


def test_a_single_hinge_rebounds_at_e_times_its_rate_and_loses_one_minus_e_squared():
    """Two rods on the pivot, the hinge closing onto its limit at rate v: it leaves at
    -e v, and the energy lost is (1 - e^2) times the inelastic impact's (closed form of
    Newton's law for one row: T lost = (1 - e^2) v^2 / (2 G))."""
    rng = np.random.default_rng(31)
    for _ in range(5):
        e, w, v = closing_pair(rng, 0.6)
        inelastic = fast_impact(e, w, np.array([0, 0, 1], np.uint8), np.array([True]))
        lost0 = inelastic["T0"] - inelastic["T1"]
        for r in (0.25, 0.5, 0.9, 1.0):
            f = fast_impact(e, w, np.array([0, 0, 1], np.uint8), np.array([True]), r)
            assert ref.hinge_rates(e, f["w"])[0] == pytest.approx(-r * v, rel=1e-12)
            assert f["T0"] - f["T1"] == pytest.approx((1 - r * r) * lost0, rel=1e-10, abs=1e-14 * f["T0"])
