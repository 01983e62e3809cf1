"""Coulomb's friction at the floor (``--friction``) with the RATTLE method, against
independent truths.  The frictionless floor (mu = 0): the rod standing on it (its
equation of motion integrated by scipy, its fall time by quadrature: ``theory``), the
conservation of horizontal momentum (nothing horizontal acts).  Finite mu: the leaning
rod pivots on its foot until the friction its pivoting asks exceeds mu (the closed form's
slip angle, ``theory.pivot_rod_slip_angle``), to first order in the step.  Every law: the
momentum balance of the floor's impulse record, the energy books.  The anchor (mu = inf)
is the default."""

from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.audit import audit
from ballchain.records.measures import momentum
from ballchain.theory import (
    pivot_rod_friction_ratio,
    pivot_rod_slip_angle,
    pivot_rod_time,
    pivot_rod_vertical_force,
    rod_fall_time,
    sliding_rod_fall_time,
    sliding_rod_normal_force,
)

THETA0 = 0.3  # rad from the vertical: the rod's start


def _rod(**opts):
    """N = 1 standing on a frictionless floor at THETA0, released at rest."""
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    return simulate(
        ChainParams(segments=1, friction=0.0), state=(e0, None), options=SolverOptions(method="rattle", **opts)
    )


def _rod_angle(t_end):
    """theta(t) of the sliding rod from its own equation of motion (module ``theory``:
    thetaddot = 3 sin(theta) (1 - cos(theta) thetadot^2) / (1 + 3 sin^2 theta), m = b = g = 1),
    integrated by scipy to 1e-13."""

    def rhs(t, y):
        s, c = math.sin(y[0]), math.cos(y[0])
        return [y[1], 3.0 * s * (1.0 - c * y[1] ** 2) / (1.0 + 3.0 * s * s)]

    return solve_ivp(rhs, (0.0, t_end), [THETA0, 0.0], rtol=1e-13, atol=1e-14, dense_output=True).sol


def test_a_rod_on_a_frictionless_floor_falls_as_its_equation_says_to_second_order():
    """Its angle at the frames (before the landing) against the integrated equation: the
    error shrinks about fourfold per halving of dt (three halvings); its centre stays on a
    vertical line and its foot on the floor (the floor's force, 0.18 m g at least, never
    pulls); its top end lands when the quadrature says."""
    t_end = 1.9  # (the top end lands at 2.0004 sqrt(b/g))
    ref = _rod_angle(t_end)
    errors = []
    for dt in (0.04, 0.02, 0.01, 0.005):
        r = _rod(dt=dt, step_energy_tol=0.0, frames_per_tff=20)
        assert r.status == "landed"
        ft = np.asarray(r.frame_t)
        sel = ft < t_end
        theta = np.arccos(np.asarray(r.frame_e)[sel, 0, 2])
        errors.append(np.max(np.abs(theta - ref(ft[sel])[0])))
        pts = r.points()
        centre_x = 0.5 * (pts[:, 0, 0] + pts[:, 1, 0])
        np.testing.assert_allclose(centre_x, math.sin(THETA0), rtol=0, atol=1e-12)
        np.testing.assert_allclose(pts[:, :, 1], 0.0, atol=1e-12)
        assert np.max(np.abs(np.asarray(r.frame_base)[:, 2])) < 1e-9  # the foot never leaves the floor
        assert np.all(sliding_rod_normal_force(theta, THETA0) > 0.17)  # (... as the theory says it must not)
        assert abs(r.t_fall - sliding_rod_fall_time(THETA0)) < 4e-4
        assert r.event_counts()["landing"] == 1  # the top end: the foot touched at t = 0 and stayed
    ratios = [errors[i] / errors[i + 1] for i in range(3)]
    assert all(3.5 < q < 4.5 for q in ratios), (errors, ratios)


def test_a_rod_on_a_frictionless_floor_lands_when_the_quadrature_says():
    """The top end's first touch, located within the step, against the quadrature."""
    r = _rod(dt=0.00625, step_energy_tol=0.0)
    assert abs(r.t_fall - sliding_rod_fall_time(THETA0)) < 1e-5
    assert abs(r.energy["imbalance"]) < 1e-5 * r.energy["initial"]


START = InitialCondition(kind="random", seed=11)


@pytest.fixture(scope="module")
def sliding_fall():
    return simulate(ChainParams(segments=16, friction=0.0), START, SolverOptions(method="rattle", frames_per_tff=200))


def check_frictionless_balances(r):
    """A fall on a frictionless floor: its horizontal momentum stays zero, the floor's impulse
    has no horizontal part, its vertical record is the momentum change plus the weight's
    impulse at every frame; the books close to 1e-3 E0 and no point goes below the floor."""
    p = momentum(r)
    ft = np.asarray(r.frame_t)
    M = r.params.segments
    assert np.max(np.abs(p[:, :2])) < 1e-8 * M
    assert np.all(np.asarray(r.floor_impulse_total)[:2] == 0.0)
    record = np.asarray(r.frame_floor_impulse)[:, 2]
    np.testing.assert_allclose(record, p[:, 2] - p[0, 2] + M * ft, rtol=0, atol=1e-6 * M * ft[-1])
    assert abs(r.energy["imbalance"]) < 1e-3 * r.energy["initial"]
    assert r.max_depth < 1e-8
    assert r.energy["lost_sliding"] == 0.0 and not np.any(r.frame_lost_sliding)  # (no friction force acts)


def test_a_chain_on_a_frictionless_floor_keeps_its_horizontal_momentum_and_closes_its_books(sliding_fall):
    """Nothing horizontal acts on the chain: its horizontal momentum (from the frames'
    axes, rates and the bottom end's velocity) stays zero, the floor's impulse has no
    horizontal part; vertically the floor's record is the momentum change plus the weight's
    impulse at every frame; the books close, no point goes below the floor."""
    r = sliding_fall
    assert r.status == "landed", r.message
    check_frictionless_balances(r)
    base = np.asarray(r.frame_base)
    assert np.max(np.abs(base[:, :2])) > 0.1  # (the bottom end did slide)
    assert np.all(np.isfinite(r.anchor_t)) and r.anchor_t[-1] == 0.0  # every point touched; the foot at t = 0
    assert r.t_fall == pytest.approx(r.anchor_t[0], abs=r.t_ff / r.params.segments)


def test_the_default_is_the_anchor_and_moves_nothing():
    """friction inf is today's law: the same fall to every digit, the bottom end at the origin."""
    a = simulate(ChainParams(segments=16), START, SolverOptions(method="rattle"))
    b = simulate(ChainParams(segments=16, friction=math.inf), START, SolverOptions(method="rattle"))
    assert a.status == b.status == "landed"
    assert a.t_fall == b.t_fall and a.energy == b.energy
    np.testing.assert_array_equal(a.frame_e, b.frame_e)
    assert np.all(np.asarray(a.frame_base) == 0.0) and np.all(np.asarray(a.frame_base_velocity) == 0.0)
    assert a.energy["lost_sliding"] == 0.0 and not np.any(a.frame_lost_sliding)  # (nothing slides on the anchor)


@pytest.mark.parametrize(
    "method, mu", [("event", 0.5), ("timestep", 0.0), ("timestep", 0.5)]
)  # (the event method takes 0: tests/test_frictionless_exact.py)
def test_a_method_that_cannot_honour_it_refuses_it_in_one_line(method, mu):
    with pytest.raises(ParameterError, match=f"not honoured by --method {method}"):
        simulate(ChainParams(segments=4, friction=mu), START, SolverOptions(method=method))
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", method, "--friction", f"{mu:g}", "-q"])
    assert res.exit_code == 2
    assert len(res.stderr.strip().splitlines()) == 1 and f"--friction {mu:g}" in res.stderr and "rattle" in res.stderr


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"friction": -1.0}, "must be in [0, inf]"),
        ({"friction": 0.0, "floor": "pivot"}, "needs floor all"),
        ({"friction": 0.3, "restitution_floor": 0.5}, "not built yet"),
    ],
)
def test_what_is_not_built_is_refused(kw, words):
    with pytest.raises(ParameterError, match=words.replace("[", r"\[").replace("]", r"\]")):
        ChainParams(segments=4, **kw)


def test_the_parameter_in_the_json_the_file_and_the_sweep_table(tmp_path):
    from ballchain.records.files import load_result, save_result
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.execute import run_sweep
    from ballchain.sweeps.table import read_table

    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", "rattle", "--friction", "0", "--json", "-q"])
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["friction"] == 0.0
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", "rattle", "--friction", "0"])
    assert res.exit_code == 0 and "contact laws       --friction 0" in res.stdout
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", "rattle", "--json", "-q"])
    assert json.loads(res.stdout)["friction"] is None  # (inf, the anchor: null in JSON)
    r = simulate(ChainParams(segments=4, friction=0.0), START, SolverOptions(method="rattle"))
    save_result(r, tmp_path / "r.h5")
    back = load_result(tmp_path / "r.h5")
    assert back.params == r.params
    np.testing.assert_array_equal(back.frame_base, r.frame_base)
    np.testing.assert_array_equal(back.frame_base_velocity, r.frame_base_velocity)
    out = tmp_path / "t.parquet"
    for mu in (0.0, math.inf):
        spec = SweepSpec(segments=(4,), alphas=(0.8,), runs=2, friction=mu, method="rattle")
        run_sweep(spec, out, workers=1, progress=False)
    rows = read_table(out)
    assert sorted(r["friction"] for r in rows) == [0.0, 0.0, math.inf, math.inf]
    assert sum(r["run_id"].endswith("_friction0") for r in rows) == 2
    res = CliRunner().invoke(app, ["stats", str(out)])  # two points, never pooled; inf named so
    assert res.exit_code == 0 and "friction" in res.stdout
    assert [ln.split()[3] for ln in res.stdout.splitlines()[2:4]] == ["0", "inf"]
    res = CliRunner().invoke(app, ["stats", str(out), "--json"])
    assert sorted(str(p["friction"]) for p in json.loads(res.stdout)["points"]) == ["0.0", "None"]


@functools.cache
def _leaning_rod(mu, dt):
    """N = 1 on a floor with friction mu, its foot held at the origin, released at rest at
    THETA0 from the vertical; steps of dt t_ff/N (no energy bound: fixed steps)."""
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    return simulate(
        ChainParams(segments=1, friction=mu),
        state=(e0, None),
        options=SolverOptions(method="rattle", dt=dt, step_energy_tol=0),
    )


@pytest.mark.parametrize("mu", [0.3, 0.6])
def test_a_leaning_rod_slips_where_the_closed_form_says(mu):
    """The rod pivots on its held foot until the friction its pivoting asks, F_x / F_z of
    the closed form, first exceeds mu; the log's first ``slip`` row (the foot, point 1)
    comes after that and within 1.5 steps of it: the cone is checked at the end of each
    step with the anchor's mean force over it (half a step old), and the row is logged at
    the step's end.  So the delay shrinks with the step."""
    truth = pivot_rod_time(pivot_rod_slip_angle(THETA0, mu), THETA0)
    delays = []
    for dt in (0.02, 0.01, 0.005):
        r = _leaning_rod(mu, dt)
        assert r.status == "landed", r.message
        ev = r.events_table()
        slips = ev[ev.kind == "slip"]
        assert len(slips) >= 1 and int(slips["index"].iloc[0]) == 1
        delay = float(slips.t.iloc[0]) - truth
        assert 0.0 < delay <= 1.5 * dt * r.t_ff, (dt, delay)
        assert abs(r.energy["imbalance"]) < 1e-4 * r.energy["initial"]
        delays.append(delay)
    assert delays[-1] < 0.5 * delays[0], delays


@pytest.fixture(scope="module")
def gripping_fall():
    return simulate(ChainParams(segments=16, friction=0.3), START, SolverOptions(method="rattle", frames_per_tff=200))


def test_a_chain_with_friction_balances_the_floors_record_and_closes_its_books(gripping_fall):
    """Finite friction: what the floor gave the chain (its impulse record, horizontal and
    vertical, with the weight's) is the chain's momentum change at every frame; the books
    close, no point goes below the floor, the bottom end slides away, and the points both
    slip and stop (the log's ``slip`` and ``stick`` rows, at points 0..N)."""
    r = gripping_fall
    assert r.status == "landed", r.message
    p = momentum(r)
    ft = np.asarray(r.frame_t)
    M = r.params.segments
    record = np.asarray(r.frame_floor_impulse)
    np.testing.assert_allclose(record[:, :2], p[:, :2] - p[0, :2], rtol=0, atol=1e-8 * M * ft[-1])
    np.testing.assert_allclose(record[:, 2], p[:, 2] - p[0, 2] + M * ft, rtol=0, atol=1e-6 * M * ft[-1])
    assert np.max(np.abs(record[-1, :2])) > 1e-3  # (friction did act horizontally)
    assert abs(r.energy["imbalance"]) < 1e-4 * r.energy["initial"]
    assert r.max_depth < 1e-8
    counts = r.event_counts()
    assert counts["slip"] > 0 and counts["stick"] > 0
    assert np.all(np.isfinite(r.anchor_t))  # every point touched the floor


def test_frames_do_not_change_a_fall_with_friction():
    """Finite friction: frames come from steps of their own on a copy of the state, so a
    fall (its steps, slips and stops, books) does not depend on how many frames it takes."""
    runs = [
        simulate(
            ChainParams(segments=24, alpha=math.pi / 4, friction=0.3),
            InitialCondition(kind="random", seed=2026, spawn_key=(1,)),
            SolverOptions(method="rattle", frames_per_tff=fr),
        )
        for fr in (37, 1000)
    ]
    a, b = runs
    assert a.status == b.status == "landed"
    assert a.t_fall == b.t_fall and a.n_steps == b.n_steps and a.energy == b.energy
    assert a.event_counts() == b.event_counts() and a.event_counts()["slip"] > 0


def test_a_stuck_stretch_is_held_where_it_lies():
    """Where a stage cannot move a stretch of sliding points (its rows repeat one another:
    ``friction.hold_stuck_stretch``), the whole stretch of consecutive sliding points near
    the failing row is held, and nothing else: at the next step's start each of its points
    is anchored where it lies (a zigzag on the floor: the anchors are the points, one
    segment length apart), its stop logged as a ``jam`` (a fallback rule's hold), its state
    otherwise untouched.  Where no sliding point lies within the reach of the failing row,
    every sliding stretch is held."""
    from ballchain.core.rules import LOG_JAM
    from ballchain.methods.rattle.friction import JAMMED, SLIDING, hold_marked, hold_stuck_stretch
    from ballchain.methods.rattle.state import new_motion, new_scratch

    n = 10
    mo, sc = new_motion(n), new_scratch(n)
    pts = np.array(
        [[2.0 * j * math.cos(math.pi / 8), 2.0 * (j % 2) * math.sin(math.pi / 8), 0.0] for j in range(n + 1)]
    )
    mo.c[:] = 0.5 * (pts[:-1] + pts[1:])
    mo.e[:] = 0.5 * (pts[:-1] - pts[1:])
    #           points 0  1  2  3  4  5  6  7  8  9  10
    anchored = np.array([1, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1], np.uint8)
    touching = np.array([0, 0, 1, 2, 1, 0, 0, 1, 0, 0, 0], np.uint8)  # (3: reversed, to be anchored)
    mo.anchored[:], mo.touching[:] = anchored, touching
    mo.anchor_pos[:] = np.where(anchored[:, None] != 0, pts, np.nan)
    mo.vc[[1, 2, 3, 4, 6, 7]] = 1e-3  # (the segments not landed; a held point's velocity is the stages' to take)
    assert hold_stuck_stretch(mo, -1) == 0  # (no failing row named)
    assert hold_stuck_stretch(mo, 2) == 3  # points 2, 3, 4 (the reach, 2 +- 4, ends before point 7)
    assert [j for j in range(n + 1) if mo.touching[j] == JAMMED] == [2, 3, 4]
    assert hold_marked(mo, sc) == 3
    np.testing.assert_array_equal(mo.anchored, [1, 1, 1, 1, 1, 1, 1, 0, 1, 1, 1])
    np.testing.assert_allclose(mo.anchor_pos[2:5], pts[2:5], atol=1e-14)
    assert np.allclose(np.linalg.norm(np.diff(mo.anchor_pos[1:6], axis=0), axis=1), 2.0)
    assert [j for j in range(n + 1) if sc.grip_log[j, 0] == LOG_JAM] == [2, 3, 4]
    # segments 1..4 now lie between anchors: stopped, their momentum taken by the floor
    assert np.all(mo.vc[1:5] == 0.0) and np.all(mo.ve[1:5] == 0.0)
    assert mo.touching[7] == SLIDING and np.all(mo.vc[6:8] == 1e-3)
    np.testing.assert_allclose(sc.ledger.floor_impulse, -4e-3, rtol=1e-12)
    assert hold_marked(mo, sc) == 0  # (marked once: held once)
    assert hold_stuck_stretch(mo, 0) == 1  # (no sliding point within 0 +- 4: every sliding one, point 7)
    assert [j for j in range(n + 1) if mo.touching[j] == JAMMED] == [7]


def _bend(a, b, c):
    """The bend angle at b between the segments a-b and b-c (rad)."""
    u, v = b - a, c - b
    return math.acos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1.0, 1.0))


def test_a_flat_fold_between_held_points_is_held_where_no_sliding_point_is_near():
    """A free point lying on the floor between two held points, in an arc whose bends are all
    at their limit: its one freedom (turning about the line through its neighbours) changes
    the bends beside it only to second order, so the bend rows cannot hold it and no active
    set of them settles (a fall at mu = 0.5, N = 1024 ended so).  Where a stage fails there
    and no sliding point is near, that point is held (``friction.hold_stuck_stretch``: a
    ``jam`` row), not a point standing in the air, nor one beyond the reach."""
    from ballchain.methods.rattle.friction import JAMMED, hold_stuck_stretch
    from ballchain.methods.rattle.state import new_motion

    n, alpha = 12, math.pi / 4
    turn = np.cumsum(np.full(n, alpha)) - alpha  # (an arc on the floor: every bend at alpha)
    pts = np.zeros((n + 1, 3))
    for j in range(n):
        pts[j + 1] = pts[j] + 2.0 * np.array([math.cos(turn[j]), math.sin(turn[j]), 0.0])
    assert all(abs(_bend(*pts[k - 1 : k + 2]) - alpha) < 1e-12 for k in range(1, n))
    # the fold's freedom: point 4 turned by phi about the line through points 3 and 5
    axis = (pts[5] - pts[3]) / np.linalg.norm(pts[5] - pts[3])
    arm = pts[4] - pts[3] - ((pts[4] - pts[3]) @ axis) * axis
    foot = pts[4] - arm

    def bends_turned(phi):
        p = pts.copy()
        p[4] = foot + math.cos(phi) * arm + math.sin(phi) * np.linalg.norm(arm) * np.array([0.0, 0.0, 1.0])
        return np.array([_bend(*p[k - 1 : k + 2]) for k in (3, 4, 5)])

    for phi in (1e-2, 1e-3):  # second order: the bends beside it move by O(phi^2), the fold's own not at all
        d = bends_turned(phi) - alpha
        assert abs(d[1]) < 1e-12 and 0.0 < d[0] < phi**2 and 0.0 < d[2] < phi**2

    def fold(lift):
        p = pts.copy()
        p[4, 2] = lift
        mo = new_motion(n)
        mo.c[:] = 0.5 * (p[:-1] + p[1:])
        mo.e[:] = 0.5 * (p[:-1] - p[1:])
        #                    points 0  1  2  3  4  5  6  7  8  9 10 11 12
        mo.anchored[:] = np.array([0, 0, 1, 1, 0, 1, 1, 0, 0, 0, 0, 0, 0], np.uint8)
        return mo

    mo = fold(0.0)
    assert hold_stuck_stretch(mo, 5) == 1
    assert [j for j in range(n + 1) if mo.touching[j] == JAMMED] == [4]
    assert hold_stuck_stretch(fold(0.0), 0) == 1  # (0 +- 4 reaches it)
    assert hold_stuck_stretch(fold(0.0), 9) == 0  # (9 +- 4 does not; nothing slides: nothing is held)
    assert hold_stuck_stretch(fold(2e-6), 4) == 0  # (standing 2e-6 b in the air: its bends see its turn)


@pytest.mark.parametrize("mu", [1e3, 1e6])
def test_a_leaning_rod_on_a_floor_of_large_friction_pivots_and_lands_when_the_pivots_quadrature_says(mu):
    """Pivoting on its foot from THETA0 the rod asks of the floor a vertical force that stays
    above 0.02 m g and a friction at most about 32 times it (the closed forms): a grip of 1e3
    or 1e6 holds it, no slip, no lift-off, and its top end lands at the pivot's quadrature
    time, within a step (the anchor's, mu inf, to 1e-8 in the exact method)."""
    theta = np.linspace(THETA0, 0.5 * math.pi, 2001)
    assert np.min(pivot_rod_vertical_force(theta, THETA0)) > 0.02
    assert np.max(np.abs(pivot_rod_friction_ratio(theta, THETA0))) < 40.0
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    dt = 0.01
    r = simulate(ChainParams(segments=1, friction=mu), state=(e0, None), options=SolverOptions(method="rattle", dt=dt))
    assert r.status == "landed", r.message
    counts = r.event_counts()
    assert counts.get("slip", 0) == 0 and counts.get("lift", 0) == 0
    assert abs(r.t_fall - rod_fall_time(THETA0)) < dt * r.t_ff
    assert abs(r.energy["imbalance"]) < 1e-4 * r.energy["initial"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_chain_on_a_floor_of_large_friction_lands_and_its_friction_creates_no_energy(seed):
    """At mu = 1000 a point that slips is pressed hard and slides slowly: the explicit friction
    force of a step can be far more than what stops it (the step's reversal created up to 1e5
    E0 of energy, booked as a negative loss at the floor, and the falls stopped with an
    error). Such a step is taken again with the point held (``friction.hold_reversed``): the
    falls land, U + T never rises above E0 at a frame, the loss at the floor is positive and
    the books close."""
    r = simulate(
        ChainParams(segments=64, alpha=math.pi / 4, friction=1e3),
        InitialCondition(kind="random", seed=seed),
        SolverOptions(method="rattle", max_time=4.0),
    )
    assert r.status == "landed", r.message
    e0 = r.energy["initial"]
    mech = np.asarray(r.frame_kinetic) + np.asarray(r.frame_potential)
    assert np.max(mech) <= e0 * (1.0 + 1e-4)
    assert r.energy["lost_landing"] > 0.0 and r.energy["lost_locking"] > 0.0
    assert abs(r.energy["imbalance"]) < 1e-3 * e0


def _rod_on_rough_floor(mu, t_end=10.0, work=None):
    """The transitions of a rod (N = 1, released at rest at THETA0 on its foot) on a floor of
    friction mu, from its own equations, integrated by scipy to 1e-12: [(kind, t)], kind
    "slip", "stick", "reverse" (the foot's sliding reverses through zero speed with the
    force beyond the cone: no stick) or "landing" (the top end).  ``work`` (a list): gets
    what the friction force removed while the foot slid, its power -F x_f' = mu N |x_f'|
    integrated as a fourth state (m g b).  Lagrange's equations in
    (x_f, theta), the foot on the floor, m = b = g = 1, I = 1/3 about the centre:
    sticking, theta'' = 3/4 sin(theta) and the floor's forces F = cos(theta) theta'' -
    sin(theta) theta'^2, N = 1 - cos(theta) theta'^2 - sin(theta) theta''; sliding at
    sign s, F = -mu s N and theta'' = (sin - F cos - sin cos theta'^2) / (sin^2 + 1/3),
    x_f'' = F - cos theta'' + sin theta'^2."""

    def stuck(th, w):
        a = 0.75 * math.sin(th)
        return a, math.cos(th) * a - math.sin(th) * w * w, 1.0 - math.cos(th) * w * w - math.sin(th) * a

    def sliding(th, w, s):
        sn, cs = math.sin(th), math.cos(th)
        d = sn * sn + 1.0 / 3.0
        n = (1.0 - cs * w * w - sn * (sn - sn * cs * w * w) / d) / (1.0 + mu * s * sn * cs / d)
        f = -mu * s * n
        a = (sn - f * cs - sn * cs * w * w) / d
        return a, f - cs * a + sn * w * w, n

    def landed(t, y):
        return y[0] - 0.5 * math.pi

    landed.terminal = True
    t, y, s, seq = 0.0, [THETA0, 0.0, 0.0, 0.0], 0.0, []
    while t < t_end:
        if s == 0.0:

            def onset(t, y):
                _, f, n = stuck(y[0], y[1])
                return abs(f) - mu * n

            onset.terminal, onset.direction = True, 1
            sol = solve_ivp(lambda t, y: [y[1], stuck(y[0], y[1])[0]], (t, t_end), y[:2], events=[onset, landed],
                            rtol=1e-12, atol=1e-13)  # fmt: skip
            t, y = sol.t[-1], [sol.y[0, -1], sol.y[1, -1], 0.0, y[3]]
            if sol.t_events[1].size:
                return _ended(seq + [("landing", t)], y[3], work)
            s = -math.copysign(1.0, stuck(y[0], y[1])[1])
            seq.append(("slip", t))
            continue

        def stop(t, y):
            return y[2]

        stop.terminal, stop.direction = True, -s

        def rhs(t, y, s=s):
            a, xdd, n = sliding(y[0], y[1], s)
            return [y[1], a, xdd, mu * n * abs(y[2])]

        sol = solve_ivp(rhs, (t, t_end), y, events=[stop, landed], rtol=1e-12, atol=1e-13)
        t, y = sol.t[-1], list(sol.y[:, -1])
        assert sliding(y[0], y[1], s)[2] > 0.0  # (the foot stays on the floor)
        if sol.t_events[1].size:
            return _ended(seq + [("landing", t)], y[3], work)
        _, f, n = stuck(y[0], y[1])
        if abs(f) <= mu * n:
            seq.append(("stick", t))
            s, y[2] = 0.0, 0.0
        else:
            seq.append(("reverse", t))
            s = -s
    return _ended(seq, y[3], work)


def _ended(seq, w, work):
    if work is not None:
        work.append(w)
    return seq


@pytest.mark.parametrize("mu", [0.3, 0.39, 0.45])
def test_a_leaning_rods_slips_and_sticks_follow_its_motion_not_the_step(mu):
    """The foot's slip and stick rows against the rod's own equations: at mu 0.3 it slips
    and its sliding later reverses through zero speed (no stick); at 0.39 it slips, sticks and
    slips back the other way; at 0.45 (above the pivoting rod's largest 0.405) it slips once,
    late, the other way.  RATTLE logs the same sequence at dt and at dt/4, a sliding foot's
    reversal within a step not logged as a stick; each slip within 1.5 steps after its
    time, the stick within 8 steps (the friction force lags a step: the sliding speed is
    first order in it): bounds that shrink with the step."""
    truth = _rod_on_rough_floor(mu)
    kinds = [k for k, _ in truth if k in ("slip", "stick")]
    assert kinds == {0.3: ["slip"], 0.39: ["slip", "stick", "slip"], 0.45: ["slip"]}[mu]
    assert ("reverse" in [k for k, _ in truth]) == (mu == 0.3)
    times = [t for k, t in truth if k in ("slip", "stick")]
    for dt in (0.01, 0.0025):
        r = _leaning_rod(mu, dt)
        assert r.status == "landed", r.message
        ev = r.events_table()
        rows = ev[ev.kind.isin(["slip", "stick"])]
        assert list(rows.kind) == kinds
        h = dt * r.t_ff
        late = np.asarray(rows.t) - np.asarray(times)
        bound = np.array([1.5 if k == "slip" else 8.0 for k in kinds]) * h
        assert np.all(late > 0.0) and np.all(late <= bound), (dt, late / h)


@pytest.mark.parametrize(
    "mu",
    [0.3, 0.39, 0.45, 0.6],
)
def test_the_friction_force_books_its_own_work_as_the_rods_equations_say(mu):
    """``lost_sliding`` is the work of the friction force on the sliding foot, from the
    force itself: against mu N |x_f'| integrated along the rod's own equations (at 0.3 the
    sliding reverses through zero speed, at 0.39 it slips, sticks and slips again), to 5%
    at dt = 0.0025 and converging (its error at dt/4 at most half its error at dt: the
    friction force lags a step).  Nothing else is booked
    there: U + T plus the other losses close the books as before."""
    work = []
    _rod_on_rough_floor(mu, work=work)
    errs = []
    for dt in (0.01, 0.0025):
        r = _leaning_rod(mu, dt)
        assert r.status == "landed", r.message
        errs.append(abs(r.energy["lost_sliding"] - work[0]) / work[0])
        assert abs(r.energy["imbalance"]) < 1e-4 * r.energy["initial"]
    assert errs[1] < 0.05 and errs[1] < 0.5 * errs[0], (work[0], errs)


def test_a_point_let_go_in_the_step_that_held_it_keeps_its_last_anchor():
    """A sliding point that ``stops`` holds and the cone lets go again in the same stage 2
    was never held there: its last anchor stays the one before (the audit checks the frames
    since its last hold against it), and one held after all logs its ``stick``.  N = 64 at
    MU = 20, a start on which the audit found a point 7.3e-5 b off its anchor (its anchor
    overwritten by the hold that did not happen) and called a sound run an error."""
    r = simulate(
        ChainParams(segments=64, alpha=math.pi / 4, friction=20.0),
        InitialCondition(kind="random", seed=1),
        SolverOptions(method="rattle", max_time=4.0),
    )
    assert r.status in ("landed", "max_time"), r.message
    assert audit(r) == []
    assert abs(r.energy["imbalance"]) < 1e-3 * r.energy["initial"]


def test_a_friction_far_beyond_what_stops_a_point_does_not_end_the_run():
    """N = 64 at MU = 1e6, a start on which a sliding point's friction force (MU times a
    normal force of 8.5e3 m g) kicked the chain so hard that stage 1 failed at every step
    near the top and the run ended in error: the sliding points are held (they stick) and
    the fall lands, its books closed, its audit clean."""
    r = simulate(
        ChainParams(segments=64, alpha=math.pi / 4, friction=1e6),
        InitialCondition(kind="random", seed=3),
        SolverOptions(method="rattle", max_time=4.0),
    )
    assert r.status == "landed", r.message
    assert audit(r) == []
    assert abs(r.energy["imbalance"]) < 1e-3 * r.energy["initial"]
