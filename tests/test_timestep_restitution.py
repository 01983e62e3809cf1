"""Newton's restitution at the bend limit in the Moreau-Jean time-stepper
(``--method timestep --restitution-lock E``), against what the law implies independently
of the code: the first lock of a fall, one hinge at one instant, loses (1 - e^2) of the
inelastic loss the event method computes, converging as the step shrinks; the hinge
leaves its limit (it is not locked); whole falls land with their books within the
method's first-order bound and the locks losing energy; the default, e = 0, is the
inelastic fall to every digit."""

from __future__ import annotations

import numpy as np
import pytest
from test_rattle_restitution import START, _first_lock_window

from ballchain.engine import simulate
from ballchain.model import ChainParams, SolverOptions
from ballchain.records.audit import audit
from ballchain.records.result import EVENT_CODES


def _first_lock(e, dt, until):
    r = simulate(
        ChainParams(segments=4, restitution_lock=e), START, SolverOptions(method="timestep", dt=dt, until=until)
    )
    locks = r.event_kind == EVENT_CODES["lock"]
    assert r.status == "until" and locks.sum() == 1
    return r, r.event_energy[locks][0]


@pytest.mark.parametrize("e", [0.5, 0.75])
def test_the_first_lock_loses_one_minus_e_squared_of_the_event_methods_inelastic_loss(e):
    """N = 4 (0.318 m g b lost at the exact method's inelastic first lock): the time-stepper's
    first lock loses (1 - e^2) of it, to 0.1% of the inelastic loss at dt = 0.00125 t_ff/N,
    its error at least three times smaller for a step four times shorter (a hinge that
    rebounds from its limit takes an impulse and leaves: a lock row and a release row at
    the same time, and it is not locked)."""
    inelastic, until = _first_lock_window(4)
    law = (1.0 - e * e) * inelastic
    errs = []
    for dt in (0.02, 0.005, 0.00125):
        r, lost = _first_lock(e, dt, until)
        errs.append(abs(lost - law))
        lock = r.event_kind == EVENT_CODES["lock"]
        release = r.event_kind == EVENT_CODES["release"]
        assert release.sum() == 1 and r.event_t[release][0] == r.event_t[lock][0]
        assert r.event_index[release][0] == r.event_index[lock][0]
        assert not r.frame_locked[-1].any()
    assert errs[-1] < 1e-3 * inelastic
    assert errs[1] < errs[0] / 3.0 and errs[2] < errs[1] / 3.0
    assert max(errs) < 1e-2 * inelastic


@pytest.mark.parametrize("e", [0.3, 0.6])
def test_whole_falls_land_and_their_books_close_at_first_order(e):
    """N = 16: the fall lands and its audit passes (the method's own bounds: books, depth,
    hinges past their limits) at the default step and at a step four times shorter, where
    its books close better (the method's error is first order in the step: |imbalance|
    below 1e-2 E0 and below the default step's); the locks lose energy and some hinges
    rebound (release rows)."""
    imbalance = []
    for dt in (0.01, 0.0025):
        r = simulate(ChainParams(segments=16, restitution_lock=e), START, SolverOptions(method="timestep", dt=dt))
        assert r.status == "landed", r.message
        assert audit(r) == []
        assert r.energy["lost_locking"] > 0.0
        assert (r.event_kind == EVENT_CODES["release"]).sum() > 0
        imbalance.append(abs(r.energy["imbalance"]) / r.energy["initial"])
    assert imbalance[1] < 1e-2 and imbalance[1] < imbalance[0]


def test_the_default_is_the_inelastic_fall_to_every_digit():
    """restitution_lock 0 (the default) takes Moreau's law: the same steps and fall as a run
    that does not name it."""
    a = simulate(ChainParams(segments=16), START, SolverOptions(method="timestep"))
    b = simulate(ChainParams(segments=16, restitution_lock=0.0), START, SolverOptions(method="timestep"))
    assert a.t_fall == b.t_fall and a.n_steps == b.n_steps
    np.testing.assert_array_equal(a.frame_e, b.frame_e)


def test_an_elastic_limit_beyond_what_it_was_shown_to_honour_is_refused_in_one_line():
    """The time-stepper takes --restitution-lock up to 0.75 (16 starts at N = 64 and 128
    against the exact method; at 1 its locks lost 0.63-0.65 E0 more, and two falls broke
    their books): a larger value is refused before anything runs, in one line."""
    from typer.testing import CliRunner

    from ballchain.cli import app
    from ballchain.model import ParameterError

    with pytest.raises(ParameterError, match="takes at most 0.75"):
        simulate(ChainParams(segments=4, restitution_lock=0.9), START, SolverOptions(method="timestep"))
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", "timestep", "--restitution-lock", "1", "-q"])
    assert res.exit_code == 2 and len(res.stderr.strip().splitlines()) == 1 and "at most 0.75" in res.stderr


def _rod(e, dt, theta0=0.4):
    """N = 1 leaning theta0 from the vertical, its lower end anchored, restitution e at the floor."""
    e0 = np.array([[np.sin(theta0), 0.0, np.cos(theta0)]])
    return simulate(
        ChainParams(segments=1, restitution_floor=e),
        state=(e0, None),
        options=SolverOptions(method="timestep", dt=dt, max_time=8.0),
    )


def test_a_rod_bounces_on_its_top_end_as_newtons_law_says_at_first_order(monkeypatch):
    """Restitution at the floor in Moreau-Jean's form, against the rigid rod's closed forms:
    the top end strikes flat with the kinetic energy cos(theta0) m g b and each bounce keeps
    e^2 of what it lands with, so the first loses (1 - e^2) cos(theta0); the step's error
    in it shrinks at first order (three times or more for a step four times shorter, under
    1% at the shorter); the bounces go on while a flight lasts four steps or more (the
    top end leaves the k-th at e^k v0, v0 = 2 sqrt(3/2 cos theta0): a flight 2 v / g), and
    the series ends with one ``pin`` row (Newton's law would bounce it again), no plain
    ``landing``; the books close within the method's bound.  (The kernels' law, on one
    contact: the registry refuses it for chains, whose bouncing points sink below the
    floor, so the test lets it through.)"""
    import ballchain.methods.timestep as ts

    monkeypatch.setattr(ts, "CONTACTS", (*ts.CONTACTS, "restitution_floor"))
    theta0, e = 0.4, 0.5
    first = (1 - e**2) * np.cos(theta0)
    v0 = 2.0 * np.sqrt(1.5 * np.cos(theta0))
    errs = []
    for dt in (0.0125, 0.003125):
        r = _rod(e, dt, theta0)
        assert r.status == "landed", r.message
        top = r.event_index == 0
        bounce = top & (r.event_kind == EVENT_CODES["bounce"])
        assert (top & (r.event_kind == EVENT_CODES["pin"])).sum() == 1
        assert (top & (r.event_kind == EVENT_CODES["landing"])).sum() == 0
        errs.append(abs(r.event_energy[bounce][0] - first) / first)
        expected = int(np.sum(e ** np.arange(1, 200) * v0 > 2.0 * dt * r.t_ff))
        assert abs(bounce.sum() - expected) <= 1, (bounce.sum(), expected)
        assert audit(r) == []
        assert r.energy["lost_landing"] == pytest.approx(r.energy["initial"], rel=0.05)
    assert errs[1] < 0.01 and errs[0] > 3.0 * errs[1], errs


@pytest.mark.parametrize("spawn_key, e_floor", [(14, 0.3), (20, 0.6), (2, 0.3)])
def test_a_bouncing_chains_points_stay_at_the_floor(monkeypatch, spawn_key, e_floor):
    """A point that has bounced lies at the floor, free, beside hinges that the step's
    projection puts back on their limits: the projection holds it at the floor's height
    where it would push it below (``stepper._hold_sinking``), and a point at the floor that
    the step turns down lands at once (``_turned_down``).  On starts of N = 64 where a point
    went 0.29 b below the floor, or a step's impact raised the kinetic energy, before
    (spawn keys 14 and 20 of seed 2026; 2: 1.5e-3 b below after a projection), the fall
    lands with no point deeper than 1e-3 b (a step's travel: the method is first order)
    and its audit clean.  (The kernels' law: the registry refuses it, see below.)"""
    import ballchain.methods.timestep as ts
    from ballchain.model import InitialCondition

    monkeypatch.setattr(ts, "CONTACTS", (*ts.CONTACTS, "restitution_floor"))
    r = simulate(
        ChainParams(segments=64, alpha=np.pi / 4, restitution_floor=e_floor),
        InitialCondition(kind="random", seed=2026, spawn_key=(spawn_key,)),
        SolverOptions(method="timestep"),
    )
    assert r.status == "landed", r.message
    assert r.event_counts()["bounce"] > 100
    assert r.max_depth < 1e-3
    assert np.asarray(r.points())[:, :, 2].min() > -1e-3  # (the frames too, inside the steps)
    assert audit(r) == []


def test_a_bouncing_floor_is_refused_with_its_reason():
    """Some falls of a bouncing chain still break their anchors (docs/restitution-floor.md,
    finding 6; benchmarks/probes/timestep_bounce.py): the time-stepper refuses the law in
    one line that says so and names the methods that take it."""
    from ballchain.model import ParameterError

    with pytest.raises(ParameterError, match="break their anchors.*event method and RATTLE take it"):
        simulate(ChainParams(segments=10, restitution_floor=0.5), START, SolverOptions(method="timestep"))
