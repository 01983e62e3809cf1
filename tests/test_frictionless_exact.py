"""The exact method's frictionless floor (``methods.event_driven.slides``, ``--friction 0``)
against independent truths.

* a rod standing at 0.3 rad on a frictionless floor lands when the quadrature of its own
  equation of motion says (``theory.sliding_rod_fall_time``: 2.000412 sqrt(b/g)), to 1e-8,
  its centre on a vertical line, its books closed to 1e-8 E0;
* chains of 8 and 128: nothing horizontal acts, so their horizontal momentum stays zero; the
  floor's vertical impulse is the momentum's change plus the weight's impulse; the books
  close to 1e-8 E0 (every loss booked from its own impulses); no point below the floor;
* the accumulation rule at the floor: the fall does not move as its threshold goes to zero;
* restitution at the floor (``--restitution-floor E``): the rod bounces on its top end and
  rises as the time reversal of a fall from where its kinetic energy E^2 cos(theta0) takes it
  (scipy's integration of its own equation of motion), to 1e-9; each bounce loses (1 - E^2)
  of the landing's kinetic energy; fully elastic (both restitutions 1, free or limited
  hinges) nothing is lost, to 1e-12 E0; bouncing chains keep their momentum and books.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_frictionless_bounce import _after_bounce_error

from ballchain.engine import simulate
from ballchain.errors import ParameterError
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.measures import momentum
from ballchain.theory import sliding_rod_fall_time

THETA0 = 0.3
EVENT = SolverOptions(method="event")


@pytest.mark.parametrize(
    "params, why",
    [
        (dict(friction=0.3), "stick and slip"),
    ],
)
def test_what_it_does_not_take_yet_is_refused_in_one_line_naming_why(params, why):
    with pytest.raises(ParameterError) as err:
        simulate(ChainParams(segments=4, **params), options=EVENT)
    assert "--friction" in str(err.value) and why in str(err.value) and "\n" not in str(err.value)


def test_a_rod_on_a_frictionless_floor_lands_when_the_quadrature_says():
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    r = simulate(ChainParams(segments=1, friction=0.0), state=(e0, None), options=EVENT)
    assert r.status == "landed"
    assert abs(r.t_fall - sliding_rod_fall_time(THETA0)) < 1e-8
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]
    # its centre stays on the vertical line through where it started (x = sin theta0)
    centre = np.asarray(r.frame_base)[:, 0] + np.asarray(r.frame_e)[:, 0, 0]
    np.testing.assert_allclose(centre, math.sin(THETA0), atol=1e-10)
    assert np.all(np.asarray(r.frame_base)[:, 2] == 0.0)  # (its foot never leaves the floor)


@pytest.mark.slow
@pytest.mark.parametrize("n, seed", [(8, 1), (128, 2)])  # (128, 2: its floor's LCP cycles, solved densely)
def test_a_chain_on_the_exact_frictionless_floor_keeps_its_momentum_and_closes_its_books(n, seed):
    r = simulate(
        ChainParams(segments=n, friction=0.0, alpha=math.pi / 4),
        InitialCondition(kind="random", seed=seed),
        SolverOptions(method="event", frames_per_tff=200),
    )
    assert r.status == "landed"
    p = momentum(r)
    ft = np.asarray(r.frame_t)
    M = r.params.segments
    assert np.max(np.abs(p[:, :2])) < 1e-12 * M
    record = np.asarray(r.frame_floor_impulse)[:, 2]
    np.testing.assert_allclose(record, p[:, 2] - p[0, 2] + M * ft, rtol=0, atol=1e-6 * M * ft[-1])
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]
    assert r.max_depth < 1e-8
    counts = r.event_counts()
    assert counts["lift"] > 0 and counts["landing"] >= n  # (points leave the floor and land again)


def test_newtons_law_at_the_limits_on_the_frictionless_floor_books_every_loss():
    """--friction 0 --restitution-lock 0.5: the impacts solve Newton's law at the limits
    beside the floor's rows (``unilateral.floor_velocity_impact``, against Lagrange in
    tests/test_unilateral_floor.py); over a whole fall the books close to 1e-8 E0 (each loss
    from its own impulses), the horizontal momentum stays zero, nothing goes below the floor."""
    r = simulate(
        ChainParams(segments=16, friction=0.0, alpha=math.pi / 4, restitution_lock=0.5),
        InitialCondition(kind="random", seed=2),
        EVENT,
    )
    assert r.status == "landed"
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]
    assert r.energy["lost_locking"] > 0.1 * r.energy["initial"]
    assert np.max(np.abs(momentum(r)[:, :2])) < 1e-12 * 16
    assert r.max_depth < 1e-8


@pytest.mark.slow
def test_the_accumulation_rule_at_the_floor_moves_nothing_as_its_threshold_goes_to_zero():
    """A point that an impact would lift off the floor and that would land again slower
    than --hold-rate-floor is kept on it (``slides.hold_leaving``): the limit of the
    series of ever smaller landings it replaces.  Over four decades of the threshold the
    fall is the same (t_fall to every digit here, the losses to 1e-9 E0), while the rule
    acts hundreds of times a fall."""
    runs = [
        simulate(
            ChainParams(segments=32, friction=0.0, alpha=math.pi / 4),
            InitialCondition(kind="random", seed=2),
            SolverOptions(method="event", hold_rate_floor=h),
        )
        for h in (1e-6, 1e-10)
    ]
    assert all(r.status == "landed" and r.event_counts()["pin"] > 100 for r in runs)
    a, b = runs
    assert abs(a.ratio - b.ratio) < 1e-9
    for k in ("lost_locking", "lost_landing"):
        assert abs(a.energy[k] - b.energy[k]) < 1e-9 * a.energy["initial"]


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_a_rod_bounces_off_the_exact_frictionless_floor_as_time_reversal_and_its_quadrature_say(e):
    """The rod lands flat at t1 (the quadrature), its top end bounces (a ``bounce`` row
    losing (1 - E^2) cos(THETA0), the kinetic energy it landed with) and the rod rises on
    its sliding foot as the fall from theta2 (its centre at E^2 cos(THETA0)) run backwards,
    to 1e-9 rad; it lands again at t1 + 2 T(theta2) (T: the quadrature's fall time) and
    bounces again, losing (1 - E^2) E^2 cos(THETA0).  Its foot never leaves the floor and
    its centre stays on a vertical line."""
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    r = simulate(
        ChainParams(segments=1, friction=0.0, restitution_floor=e),
        state=(e0, None),
        options=SolverOptions(method="event", max_time=2.2, frames_per_tff=200),
    )
    assert r.status == "max_time"  # (it bounces on)
    t1 = sliding_rod_fall_time(THETA0)
    theta2 = math.acos(e * e * math.cos(THETA0))
    t_top = t1 + sliding_rod_fall_time(theta2)
    assert _after_bounce_error(r, theta2, t_top) < 1e-9
    ev = r.events_table()
    bounces = ev[ev.kind == "bounce"]
    expected_t = [t1, t1 + 2.0 * sliding_rod_fall_time(theta2)][: len(bounces)]
    expected_lost = [(1.0 - e * e) * math.cos(THETA0) * e ** (2 * i) for i in range(len(bounces))]
    assert len(bounces) == (1 if e == 1.0 else 2)  # (at E = 1 the second landing is at 4.0008 > max_time)
    np.testing.assert_allclose(bounces.t, expected_t, rtol=0, atol=1e-8)
    np.testing.assert_allclose(bounces.energy, expected_lost, rtol=0, atol=1e-9)
    assert (bounces["index"] == 0).all()
    assert abs(r.energy["imbalance"]) < 1e-9 * r.energy["initial"]
    pts = r.points()
    np.testing.assert_allclose(0.5 * (pts[:, 0, 0] + pts[:, 1, 0]), math.sin(THETA0), rtol=0, atol=1e-10)
    assert np.all(np.asarray(r.frame_base)[:, 2] == 0.0)


@pytest.mark.parametrize("alpha, e_lock", [(math.pi / 2, 1.0), (math.pi, 0.0)])
def test_a_fully_elastic_chain_on_the_exact_frictionless_floor_loses_nothing(alpha, e_lock):
    """--friction 0 --restitution-floor 1, with the limits elastic (--restitution-lock 1) or
    absent (alpha = pi), N = 8, to 2 t_ff: points bounce and hinges lock and rebound, and
    nothing is lost (each loss from its own impulses, to 1e-12 E0); the books close to 1e-8
    E0; the horizontal momentum stays zero."""
    r = simulate(
        ChainParams(segments=8, alpha=alpha, friction=0.0, restitution_floor=1.0, restitution_lock=e_lock),
        InitialCondition(kind="random", seed=1),
        SolverOptions(method="event", max_time=2.0),
    )
    en = r.energy
    assert r.status == "max_time"
    assert r.event_counts()["bounce"] >= 5
    assert abs(en["lost_locking"]) < 1e-12 * en["initial"] and abs(en["lost_landing"]) < 1e-12 * en["initial"]
    assert abs(en["imbalance"]) < 1e-8 * en["initial"]
    assert np.max(np.abs(momentum(r)[:, :2])) < 1e-12 * 8


@pytest.mark.parametrize("e_lock, seed", [(0.0, 11), (0.5, 2)])
def test_a_chain_bouncing_on_the_exact_frictionless_floor_keeps_its_momentum_and_books(e_lock, seed):
    """--friction 0 --restitution-floor 0.5 (and --restitution-lock), N = 16, pi/4: the fall
    lands (every point on the floor at once, ``rules.fall_over``), points bounce, slow bounces are held (``pin``
    rows: the accumulation rule), the horizontal momentum stays zero, the floor's vertical
    record is the momentum change plus the weight's impulse, the books close to 1e-8 E0 and
    no point goes below the floor."""
    r = simulate(
        ChainParams(segments=16, alpha=math.pi / 4, friction=0.0, restitution_floor=0.5, restitution_lock=e_lock),
        InitialCondition(kind="random", seed=seed),
        SolverOptions(method="event", frames_per_tff=200),
    )
    assert r.status == "landed", r.message
    counts = r.event_counts()
    assert counts["bounce"] > 100 and counts["pin"] > 0
    p = momentum(r)
    ft = np.asarray(r.frame_t)
    assert np.max(np.abs(p[:, :2])) < 1e-12 * 16
    record = np.asarray(r.frame_floor_impulse)[:, 2]
    np.testing.assert_allclose(record, p[:, 2] - p[0, 2] + 16 * ft, rtol=0, atol=1e-6 * 16 * ft[-1])
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]
    assert r.max_depth < 1e-8
    assert r.t_landed > r.t_fall  # (landed: every point on the floor at once, after the top's first touch)
