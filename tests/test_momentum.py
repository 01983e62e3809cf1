"""The floor's momentum record against independent truths: the momentum theorem for the
whole chain (the floor is the only external force besides gravity), at the end of a
run and at every frame, and the closed-form reaction of a rod pivoting on the floor
(theory.pivot_rod_vertical_force, derived from F = m a_c + m g e_z)."""

import math

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.result import EVENT_CODES
from ballchain.theory import pivot_rod_horizontal_force, pivot_rod_vertical_force


def _momentum(r):
    """Total momentum M v_cm of the chain at every frame, from the frames' axes and
    angular velocities alone (run units): v_i = d/dt r_{i+1} + b w_i x e_i."""
    b, m = r.params.half_length, r.params.segment_mass
    e, w = r.frame_e, r.frame_omega
    de = b * np.cross(w, e)  # (F, N, 3): velocity of a segment's centre relative to its lower end
    below = 2.0 * np.cumsum(de[:, ::-1], axis=1)[:, ::-1]  # velocity of point i (upper end of segment i)
    lower = np.concatenate([below[:, 1:], np.zeros_like(below[:, :1])], axis=1)
    return m * np.sum(lower + de, axis=1)


CASES = [
    ("all", 1, math.pi / 4),
    ("all", 8, math.pi / 4),
    ("all", 16, math.pi),
    ("all", 12, math.pi / 2),
    ("pivot", 1, math.pi / 4),
    ("pivot", 8, math.pi / 4),
    ("pivot", 16, math.pi),
]


@pytest.mark.parametrize("floor, n, alpha", CASES)
def test_floor_impulse_total_is_the_weight_times_the_landing_time(floor, n, alpha):
    """Chain at rest at t = 0 and at rest on the floor at t_landed: the floor's whole
    impulse is M g t_landed, vertical (momentum theorem)."""
    r = simulate(
        ChainParams(segments=n, alpha=alpha, floor=floor),
        InitialCondition(kind="helix", eps=0.3 if n == 1 else 0.05),
        SolverOptions(),
    )
    assert r.status == "landed", r.message
    assert r.energy["kinetic"] == 0.0
    mgt = n * r.t_landed
    J = r.floor_impulse_total
    assert J[2] == pytest.approx(mgt, rel=1e-7)
    assert abs(J[0]) < 1e-7 * mgt and abs(J[1]) < 1e-7 * mgt
    # the impacts' part alone does not balance (the record is more than the impulses)
    assert abs(r.floor_impulse[2] - mgt) > 0.1 * mgt


def test_floor_impulse_total_in_si_units():
    """A real chain (1 m, 50 g, 12 segments) in SI: N s, with M = 0.05 kg and g = 9.81."""
    p = ChainParams.from_chain(12, length_m=1.0, mass_kg=0.05, alpha=math.pi / 4)
    r = simulate(p, InitialCondition(kind="helix", eps=0.05), SolverOptions())
    assert r.status == "landed" and r.units == "SI"
    mgt = 0.05 * 9.81 * r.t_landed
    assert r.floor_impulse_total[2] == pytest.approx(mgt, rel=1e-7)
    assert np.all(np.abs(r.floor_impulse_total[:2]) < 1e-7 * mgt)


@pytest.mark.parametrize(
    "floor, laws", [("all", {}), ("pivot", {}), ("all", {"restitution_floor": 0.6, "restitution_lock": 0.5})]
)
def test_floor_impulse_at_every_frame_is_the_momentum_change(floor, laws):
    """J(t_k) = P(t_k) - P(0) + M g t_k e_z at every frame, P computed from the frame's
    state only: the cumulative record holds during the fall, not only at its end (and
    with points bouncing off the floor and hinges off their limits: every contact law)."""
    n = 10
    r = simulate(
        ChainParams(segments=n, alpha=math.pi / 4, floor=floor, **laws),
        InitialCondition(kind="helix", eps=0.05),
        SolverOptions(frames_per_tff=400, max_time=8.0),
    )
    assert r.status == "landed"
    assert not laws or np.sum(r.event_kind == EVENT_CODES["bounce"]) > 0
    P = _momentum(r)
    expected = P - P[0] + n * r.frame_t[:, None] * np.array([0.0, 0.0, 1.0])
    scale = n * r.t_landed
    np.testing.assert_allclose(r.frame_floor_impulse, expected, rtol=0, atol=1e-7 * scale)
    # and the record moves: the floor's impulse grows by more than M g t alone
    assert np.max(np.abs(r.frame_floor_impulse[:, 2] - n * r.frame_t)) > 0.05 * scale


def _rod_angles(r):
    e = r.frame_e[:, 0]
    return np.arccos(np.clip(e[:, 2], -1.0, 1.0))


@pytest.mark.parametrize("floor", ["all", "pivot"])
def test_pile_pull_on_a_single_rod_is_the_closed_form(floor):
    """N = 1: the rod pivots on its anchored lower end; the pile's pull on it is the
    pivot's reaction (m g / 4)(1 + 9 c^2 - 6 c0 c - 4 s c), c = cos theta."""
    theta0 = 0.4
    e0 = np.array([[math.sin(theta0), 0.0, math.cos(theta0)]])
    r = simulate(ChainParams(segments=1, floor=floor), state=(e0, None), options=SolverOptions(frames_per_tff=200))
    assert r.status == "landed"
    air = r.frame_t < r.t_landed
    theta = _rod_angles(r)[air]
    assert theta.size > 50 and theta.max() > 1.4
    np.testing.assert_allclose(r.frame_pile_pull[air, 2], pivot_rod_vertical_force(theta, theta0), rtol=0, atol=1e-8)
    # the rod leans towards +x: the horizontal pull is the closed form along x
    np.testing.assert_allclose(r.frame_pile_pull[air, 0], pivot_rod_horizontal_force(theta, theta0), rtol=0, atol=1e-8)
    # the pull is the whole force of the floor on the airborne rod, and the scale reads it
    np.testing.assert_allclose(r.frame_pile_pull[air], r.frame_floor_force[air], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.frame_scale_force[air], r.frame_floor_force[air, 2], rtol=0, atol=1e-12)


def test_pile_pull_on_the_last_rod_pivoting_about_an_anchored_point():
    """N = 2, no limits, in a vertical plane: once point 1 has landed, segment 0 is a rod
    pivoting about an anchored point with the angular velocity the landing left it;
    the pull is the closed form with theta0, s = b thetadot^2 / g taken at any frame
    after the landing, and the scale reads the pull plus the landed segment's weight."""
    a, b = 0.15, 0.5
    e0 = np.array([[math.sin(a), 0.0, math.cos(a)], [math.sin(b), 0.0, math.cos(b)]])
    r = simulate(ChainParams(segments=2, alpha=math.pi), state=(e0, None), options=SolverOptions(frames_per_tff=400))
    assert r.status == "landed"
    land1 = r.anchor_t[1]
    assert 0.0 < land1 < r.t_landed
    after = (r.frame_t > land1) & (r.frame_t < r.t_landed)
    assert after.sum() > 20
    k0 = np.flatnonzero(after)[0]
    theta = _rod_angles(r)
    theta0 = theta[k0]
    s = float(np.sum(r.frame_omega[k0, 0] ** 2))  # b = g = 1
    assert s > 1e-3  # the rod moves when it starts pivoting
    expected = pivot_rod_vertical_force(theta[after], theta0, s)
    np.testing.assert_allclose(r.frame_pile_pull[after, 2], expected, rtol=0, atol=1e-7)
    np.testing.assert_allclose(r.frame_scale_force[after], expected + 1.0, rtol=0, atol=1e-7)
    # before the landing the pile (the pivot, point 2) pulls segment 1, not segment 0
    before = r.frame_t < land1
    assert np.all(r.anchor_t[1] > r.frame_t[before])
