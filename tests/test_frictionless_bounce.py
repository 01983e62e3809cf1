"""Newton's restitution on a frictionless floor (``--friction 0 --restitution-floor E``,
RATTLE): a point that lands leaves the floor at E times the vertical velocity it landed
with and keeps its horizontal velocity.  Checked against what holds independently of the
code: a rod standing on the floor falls, lands flat and, elastic, retraces its fall by
time reversal (its angle after the bounce is the fall's, run backwards, from the rod's
own equation of motion integrated by scipy); at E = 0.5 it rises to E^2 of its height at
rest, when the quadrature of a fall from there says; a chain keeps its horizontal momentum
(nothing horizontal acts), closes its books and stays above the floor; with free hinges
and E = 1 it loses almost nothing."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_friction import check_frictionless_balances

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.audit import audit
from ballchain.theory import sliding_rod_angular_velocity, sliding_rod_fall_time

THETA0 = 0.3  # rad from the vertical: the rod's start


def _rod(e_floor, dt, max_time=2.2):
    """N = 1 standing on a frictionless floor at THETA0, released at rest (t_ff = 2 sqrt(b/g))."""
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    return simulate(
        ChainParams(segments=1, friction=0.0, restitution_floor=e_floor),
        state=(e0, None),
        options=SolverOptions(method="rattle", dt=dt, step_energy_tol=0.0, frames_per_tff=200, max_time=max_time),
    )


def _fall_angle(theta0, t_end):
    """theta(t) of the rod sliding on its foot from rest at theta0, from its equation of
    motion (thetaddot = 3 sin(theta) (1 - cos(theta) thetadot^2) / (1 + 3 sin^2 theta),
    m = b = g = 1), integrated by scipy to 1e-13."""

    def rhs(t, y):
        s, c = math.sin(y[0]), math.cos(y[0])
        return [y[1], 3.0 * s * (1.0 - c * y[1] ** 2) / (1.0 + 3.0 * s * s)]

    return solve_ivp(rhs, (0.0, t_end), [theta0, 0.0], rtol=1e-13, atol=1e-14, dense_output=True).sol


def _after_bounce_error(r, theta_top, t_top):
    """The largest error of the rod's angle at the frames after its bounce (from 0.05 past
    the landing to its top, reached at t_top at the angle theta_top) against the fall from
    theta_top run backwards: theta(t) = theta_fall(t_top - t)."""
    t1 = sliding_rod_fall_time(THETA0)
    ref = _fall_angle(theta_top, t_top - t1)
    ft = np.asarray(r.frame_t)
    sel = (ft > t1 + 0.05) & (ft < t_top)
    theta = np.arccos(np.clip(np.asarray(r.frame_e)[sel, 0, 2], -1.0, 1.0))
    return np.max(np.abs(theta - ref(t_top - ft[sel])[0]))


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_a_rod_bounces_off_a_frictionless_floor_as_time_reversal_and_its_quadrature_say(e):
    """The rod lands flat at t1 = 2.000412 sqrt(b/g) (the quadrature), bounces on its top end
    (a ``bounce`` row) and rises on its sliding foot as the time reversal of a fall from the
    angle theta2 at which its centre's height is E^2 cos(THETA0) (the kinetic energy it keeps),
    reached at t1 + the quadrature's fall time from theta2: 2 t1 at E = 1, where it is back at
    its start.  Its foot never leaves the floor, its centre stays on a vertical
    line; the bounce loses (1 - E^2) of the landing's kinetic energy, cos(THETA0).  The
    angle's error after the bounce is first order: the impact is resolved at the end of the
    step it falls in, so the rise starts up to a step late; the error stays below the angle
    the rod turns in one step as it leaves the floor (0.32 to 0.80 of it, decreasing with
    the step)."""
    t1 = sliding_rod_fall_time(THETA0)
    theta2 = math.acos(e * e * math.cos(THETA0))
    t_top = t1 + sliding_rod_fall_time(theta2)
    errors = []
    for dt in (0.02, 0.01, 0.005):
        r = _rod(e, dt)
        assert r.status == "max_time"  # (the rod bounces on: it never lies on the floor at rest)
        assert abs(r.t_fall - t1) < 1e-3
        assert r.event_counts()["bounce"] >= 1 and r.event_counts()["pin"] == 0
        pts = r.points()
        np.testing.assert_allclose(0.5 * (pts[:, 0, 0] + pts[:, 1, 0]), math.sin(THETA0), rtol=0, atol=1e-12)
        assert np.max(np.abs(np.asarray(r.frame_base)[:, 2])) < 1e-9
        assert r.max_depth < 1e-9
        ft = np.asarray(r.frame_t)
        first = ft < t_top + 0.5 * (t_top - t1)  # (up to the second landing)
        lost = np.asarray(r.frame_lost_landing)[first][-1]
        assert lost == pytest.approx((1.0 - e * e) * math.cos(THETA0), abs=2e-4)
        errors.append(_after_bounce_error(r, theta2, t_top))
    w1 = e * sliding_rod_angular_velocity(0.5 * math.pi, THETA0)  # (its rate as it leaves the floor)
    steps = [dt * 2.0 for dt in (0.02, 0.01, 0.005)]  # (h = dt t_ff / N)
    assert all(err < w1 * h for err, h in zip(errors, steps)), (errors, [w1 * h for h in steps])
    assert errors[0] > errors[1] > errors[2], errors


START = InitialCondition(kind="random", seed=11)


@pytest.fixture(scope="module")
def bouncing_fall():
    return simulate(
        ChainParams(segments=16, alpha=math.pi / 4, friction=0.0, restitution_floor=0.5),
        START,
        SolverOptions(method="rattle", frames_per_tff=200),
    )


def test_a_chain_bouncing_on_a_frictionless_floor_keeps_its_momentum_and_books_and_ends_on_the_floor(bouncing_fall):
    """Nothing horizontal acts: the horizontal momentum stays zero and the floor's impulse
    has no horizontal part; vertically the floor's record is the momentum change plus the
    weight's impulse at every frame; the books close to 1e-3 E0, no point goes below the
    floor, no hinge past its limit; points bounce (``bounce`` rows) and the run ends with
    every point on the floor at once."""
    r = bouncing_fall
    assert r.status == "landed", r.message
    check_frictionless_balances(r)
    assert audit(r) == []
    counts = r.event_counts()
    assert counts["bounce"] > 10 and counts["pin"] > 0
    assert np.max(np.abs(r.points()[-1][:, 2])) < 1e-8  # (the last frame: every point on the floor)


def test_an_elastic_floor_under_free_hinges_loses_almost_nothing():
    """alpha = pi (no bend limit: no lock), E = 1, N = 8, to 2 t_ff: the landings lose under
    2% of E0 (RATTLE's error at its impacts: the approach rate estimated inside the step,
    a few short bounces kept on the floor), where the inelastic frictionless floor loses
    97-99% of E0 (the chain brought down nearly all of it: it lies on the floor by then); the books
    close."""
    for seed in (1, 2):
        lost = {}
        for e in (0.0, 1.0):
            r = simulate(
                ChainParams(segments=8, alpha=math.pi, friction=0.0, restitution_floor=e),
                InitialCondition(kind="random", seed=seed),
                SolverOptions(method="rattle", max_time=2.0),
            )
            en = r.energy
            assert en["lost_locking"] == 0.0 and abs(en["imbalance"]) < 1e-4 * en["initial"]
            lost[e] = en["lost_landing"] / en["initial"]
        assert lost[1.0] < 0.02 and lost[0.0] > 0.9, lost
