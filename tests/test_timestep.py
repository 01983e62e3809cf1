"""The Moreau-Jean time-stepping method (``--method timestep``) against independent truths.

* A rigid rod standing on its lower end and falling over (N = 1): its fall time is a
  quadrature of the energy equation, (2/3) theta'^2 = cos(theta0) - cos(theta) (units
  m = b = g = 1, rod length 2 b, I = 4/3 about its end); the method converges to it at
  first order in dt, and its energy imbalance shrinks at first order too.
* A chain with no bend limit that falls straight (alpha = pi, a planar start): the
  event-driven method's first landing time is the reference; the time-stepper's first
  landing converges to it as dt shrinks.
* The same record as the event-driven method: a result file, the event log's kinds, the
  audit (a broken run fails loudly), the option's validation and the CLI contract.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import quad
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.audit import TIMESTEP_ENERGY_RTOL, audit

THETA0 = 0.3  # the rod's tilt from the vertical at rest (rad)


def _rod_fall_time(theta0: float) -> float:
    """t_fall of a rod (length 2 b) pivoting on its lower end from rest at theta0 until
    it lies flat: t = int d theta / sqrt(3/2 (cos theta0 - cos theta))."""
    return quad(lambda th: 1.0 / math.sqrt(1.5 * (math.cos(theta0) - math.cos(th))), theta0, math.pi / 2, limit=200)[0]


def _rod(dt: float, theta: float = 0.5, dt_rule: str = "fixed"):
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    options = SolverOptions(method="timestep", dt=dt, frames_per_tff=1, theta=theta, dt_rule=dt_rule)
    return simulate(ChainParams(segments=1, alpha=math.pi), None, options, state=(e0, None))


@pytest.mark.parametrize(
    "theta, dt_rule, dts",
    # dt_rule landing: the rod starts slow, so its steps start 4 dt t_ff / N long; a finer dt
    [(0.5, "fixed", (0.04, 0.02, 0.01)), (1.0, "fixed", (0.04, 0.02, 0.01)), (1.0, "landing", (0.02, 0.01, 0.005))],
)
def test_rod_fall_time_converges_at_first_order(theta, dt_rule, dts):
    exact = _rod_fall_time(THETA0)
    errors = [abs(_rod(dt, theta, dt_rule).t_fall - exact) for dt in dts]
    # first order: halving dt halves the error (ratios 2 +- 0.4), and it is small
    for coarse, fine in zip(errors, errors[1:]):
        assert 1.6 < coarse / fine < 2.4, errors
    assert errors[-1] < 0.005 * exact


@pytest.mark.parametrize("theta", [0.5, 1.0])
def test_rod_energy_imbalance_shrinks_with_dt(theta):
    imb = []
    for dt in (0.04, 0.02, 0.01):
        r = _rod(dt, theta)
        assert r.status == "landed", r.message
        assert r.energy["lost_locking"] == 0.0  # no hinge
        imb.append(abs(r.energy["imbalance"]) / r.energy["initial"])
    for coarse, fine in zip(imb, imb[1:]):
        assert 1.6 < coarse / fine < 2.4, imb


def _first_landing(method: str, dt: float = 0.02, dt_rule: str = "fixed") -> float:
    p = ChainParams(segments=8, alpha=math.pi)
    ic = InitialCondition(kind="planar", eps=0.2)
    step = {} if method == "event" else dict(dt=dt, dt_rule=dt_rule)  # (the event method takes no step)
    r = simulate(p, ic, SolverOptions(method=method, frames_per_tff=1, until=0.9, **step))
    landings = r.event_t[r.event_kind == 3]  # core.kinds: landing
    assert len(landings) > 0
    return float(landings[0] / r.t_ff)


@pytest.mark.parametrize("dt_rule", ["fixed", "landing"])
def test_first_landing_converges_to_the_event_driven_one(dt_rule):
    ref = _first_landing("event")
    errs = [abs(_first_landing("timestep", dt, dt_rule) - ref) for dt in (0.08, 0.02, 0.005)]
    assert errs[2] < errs[0]
    assert errs[2] < 0.01


def _fall_speed(e: np.ndarray, w: np.ndarray, anchored: np.ndarray) -> float:
    """-mean dz/dt of the airborne segments' centres, from the axes and rates alone: the
    point N is the origin and point j = 2 sum_{i >= j} e_i, so the centre of segment i is
    at e_i + 2 sum_{k > i} e_k and moves at de_i/dt + 2 sum_{k > i} de_k/dt, de/dt = w x e."""
    dez = np.cross(w, e)[:, 2]
    above = np.concatenate([np.cumsum(dez[::-1])[::-1][1:], [0.0]])  # sum_{k > i} de_k/dt
    vz = dez + 2.0 * above
    airborne = ~(anchored[:-1].astype(bool) & anchored[1:].astype(bool))
    return float(-vz[airborne].mean())


def test_the_landing_rule_sizes_each_step_by_the_chains_fall_speed():
    """dt_rule landing: a step is dt t_ff/N times v_ff / v (v the airborne chain's mean
    fall speed, v_ff = g t_ff), within a factor 4 either way; here v is computed from the
    frames' axes and rates with numpy, and the step a frame falls in (between two times
    of the trace) is that long, unless a landing cut it, to what v changes by within a
    step (1%: the rule reads v at the step's start, the frame inside it).  At the end of the
    fall the chain falls at about free-fall speed, and the steps there are about dt t_ff/N;
    over the whole fall the rule takes fewer steps than the fixed one."""
    n, dt = 48, 0.01
    p, ic = ChainParams(segments=n, alpha=math.pi / 4), InitialCondition(kind="random", seed=3, spawn_key=(0,))
    r = simulate(p, ic, SolverOptions(method="timestep", dt=dt, theta=1.0, dt_rule="landing", frames_per_tff=50))
    fixed = simulate(p, ic, SolverOptions(method="timestep", dt=dt, theta=1.0, frames_per_tff=50))
    assert r.status == fixed.status == "landed", (r.message, fixed.message)
    h0 = dt * r.t_ff / n
    steps_t = np.asarray(r.t)  # the trace: the end of every step
    matched, checked = 0, 0
    for k in range(1, len(r.frame_t) - 1):
        t = r.frame_t[k]
        if t >= r.t_fall:
            break
        anchored = r.frame_anchored[k]
        if anchored[:-1].astype(bool).all():
            continue
        v = _fall_speed(r.frame_e[k], r.frame_omega[k], anchored)
        rule = h0 * (4.0 if v <= 0 else min(4.0, max(0.25, r.t_ff / v)))  # v_ff = g t_ff = t_ff (m = b = g = 1)
        i = np.searchsorted(steps_t, t)
        h = steps_t[i] - steps_t[i - 1]
        assert h <= rule * 1.01, (t, h, rule)
        checked += 1
        matched += math.isclose(h, rule, rel_tol=0.01)
    assert checked > 30 and matched >= 0.8 * checked, (matched, checked)
    assert r.n_steps < 0.8 * fixed.n_steps, (r.n_steps, fixed.n_steps)


def test_a_fall_with_locks_keeps_its_books_and_log():
    r = simulate(
        ChainParams(segments=24, alpha=math.pi / 4), InitialCondition(), SolverOptions(method="timestep", dt=0.02)
    )
    assert r.status == "landed", r.message
    assert not audit(r)
    e = r.energy
    assert 0.0 < e["lost_locking"] < e["initial"] and 0.0 < e["lost_landing"] < e["initial"]
    assert abs(e["imbalance"]) <= TIMESTEP_ENERGY_RTOL * e["initial"]
    kinds = set(r.events_table()["kind"])
    assert {"lock", "unlock", "landing"} <= kinds
    # every point lands once; the top end's landing is t_fall (floor all)
    land = r.events_table().query("kind == 'landing'")
    assert sorted(land["index"]) == list(range(24))
    assert math.isclose(float(land.query("index == 0")["t"].iloc[0]), r.t_fall, rel_tol=1e-12)
    # the floor's momentum: total impulse = weight x time (the chain starts and ends at rest)
    assert r.floor_impulse_total[2] == pytest.approx(24 * r.t_landed, rel=0.05)
    assert r.options.method == "timestep" and r.options.dt == 0.02


def test_the_result_file_keeps_the_method(tmp_path):
    from ballchain.records.files import load_result, save_result

    r = simulate(ChainParams(segments=4), InitialCondition(), SolverOptions(method="timestep", dt=0.05, until=0.3))
    path = tmp_path / "r.h5"
    save_result(r, path)
    back = load_result(path)
    assert back.options.method == "timestep" and back.options.dt == 0.05
    np.testing.assert_array_equal(back.frame_e, r.frame_e)


@pytest.mark.parametrize("dt", [0.0, -1.0, math.nan, 5.0])
def test_bad_dt_is_refused(dt):
    with pytest.raises(ParameterError, match="dt"):
        SolverOptions(method="timestep", dt=dt)


@pytest.mark.parametrize("theta", [0.49, 1.01, math.nan])
def test_bad_theta_is_refused(theta):
    with pytest.raises(ParameterError, match="theta"):
        SolverOptions(method="timestep", theta=theta)


def test_the_default_step_is_the_long_one_from_n_1024():
    """Left unset, dt and theta are the short step (0.01, 1/2) below N = 1024 and the long
    one (0.02, 1) from it: the run records them and takes the steps they give (until
    t = 0.01 t_ff: 0.01 N / dt steps), and a value set is kept."""
    from ballchain.methods import LONG_STEP, LONG_STEP_FROM, SHORT_STEP

    o = SolverOptions(method="timestep")
    assert o.dt is None and o.theta is None
    assert (o.for_segments(LONG_STEP_FROM - 1).dt, o.for_segments(LONG_STEP_FROM - 1).theta) == SHORT_STEP
    assert (o.for_segments(LONG_STEP_FROM).dt, o.for_segments(LONG_STEP_FROM).theta) == LONG_STEP
    kept = SolverOptions(method="timestep", dt=0.005).for_segments(4096)
    assert (kept.dt, kept.theta) == (0.005, 1.0)
    kept = SolverOptions(method="timestep", theta=0.5).for_segments(4096)
    assert (kept.dt, kept.theta) == (0.02, 0.5)
    assert SolverOptions().for_segments(4096).dt == SHORT_STEP[0]  # not used by the event-driven method
    ic = InitialCondition(kind="random", seed=3)
    for n, (dt, theta) in ((512, SHORT_STEP), (1024, LONG_STEP)):
        r = simulate(
            ChainParams(segments=n, alpha=math.pi / 4, floor="all"), ic, SolverOptions(method="timestep", until=0.01)
        )
        assert (r.options.dt, r.options.theta) == (dt, theta)
        assert abs(r.n_steps - 0.01 * n / dt) <= 2, r.n_steps  # (round-off in the times: one step more)


def test_a_sweep_names_the_default_step_as_the_same_step_set_by_hand():
    """A sweep that leaves dt and theta unset names its runs as one that sets the step the
    default gives at that N: a table made either way resumes the other."""
    from ballchain.sweeps import SweepSpec

    def ids(**kw):
        spec = SweepSpec(segments=[512, 1024], alphas=[math.pi / 4], floors=["all"], ics=["random"], runs=2, **kw)
        return [t.run_id for t in spec.tasks()]

    default = ids(method="timestep")
    assert default[:2] == ids(method="timestep", dt=0.01, theta=0.5)[:2]
    assert default[2:] == ids(method="timestep", dt=0.02, theta=1.0)[2:]
    assert all("_dt0.02_theta1" in i for i in default[2:]) and all(i.endswith("_dt0.01") for i in default[:2])


def test_the_cli_warns_of_the_short_step_at_large_n():
    """theta = 1/2 set by hand from N = 2048 on: the run says it falls early there."""
    runner = CliRunner()
    args = ["simulate", "-N", "2048", "--method", "timestep", "--until", "0.0005", "--json", "-q"]
    res = runner.invoke(app, [*args, "--theta", "0.5"])
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["theta"] == 0.5 and "--theta 0.5 falls early" in res.stderr
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["dt"] == 0.02 and json.loads(res.stdout)["theta"] == 1.0
    assert "falls early" not in res.stderr
    res = runner.invoke(app, [a for a in args if a != "--json"])  # the summary names the step used
    assert res.exit_code == 0, res.stderr
    assert "time-stepping (Moreau-Jean, experimental), dt = 0.02 t_ff/N, theta = 1, steps fixed" in res.stdout


def test_bad_dt_rule_is_refused():
    with pytest.raises(ParameterError, match="dt_rule"):
        SolverOptions(method="timestep", dt_rule="adaptive")


def test_cli_method_and_dt_in_json():
    runner = CliRunner()
    args = ["simulate", "-N", "6", "--method", "timestep", "--dt", "0.05", "--json", "-q"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary["method"] == "timestep" and summary["dt"] == 0.05 and summary["theta"] == 0.5
    # the run says it is experimental and names the step shown to agree at large N
    assert "experimental" in res.stderr and "--dt 0.02 --theta 1" in res.stderr
    assert "--dt-rule landing" not in res.stderr  # the fixed step: no word of the landing rule
    event = runner.invoke(app, ["simulate", "-N", "6", "--json", "-q"])
    assert event.exit_code == 0 and "experimental" not in event.stderr
    res = runner.invoke(app, [*args, "--theta", "1"])
    assert res.exit_code == 0 and json.loads(res.stdout)["theta"] == 1.0, res.stderr
    assert json.loads(res.stdout)["dt_rule"] == "fixed"
    res = runner.invoke(app, [*args, "--dt-rule", "landing"])
    assert res.exit_code == 0 and json.loads(res.stdout)["dt_rule"] == "landing", res.stderr
    assert "--dt-rule landing was checked from N = 256" in res.stderr  # N = 6: below where it was checked
    bad = runner.invoke(app, [*args, "--dt-rule", "adaptive"])
    assert bad.exit_code == 2 and "dt_rule" in bad.stderr and "Traceback" not in bad.stderr
    bad = runner.invoke(app, ["simulate", "-N", "6", "--method", "timestep", "--dt", "0", "-q"])
    assert bad.exit_code == 2 and "dt" in bad.stderr and "Traceback" not in bad.stderr


def test_the_imbalance_names_the_error_in_gravitys_work():
    """The books name the imbalance's systematic source: over the steps, gravity's kick
    on the kinetic energy and the position update's change of the potential energy
    disagree (work_error_in_steps; zero in exact dynamics, and for the event-driven
    method).  It shrinks with dt at first order (the mean over three starts)."""
    named = []
    for dt in (0.02, 0.01, 0.005):
        w = []
        for k in range(3):
            ic = InitialCondition(kind="random", seed=2026, spawn_key=(k,))
            r = simulate(ChainParams(segments=64), ic, SolverOptions(method="timestep", dt=dt))
            assert r.status == "landed", r.message
            w.append(abs(r.energy["work_error_in_steps"]) / r.energy["initial"])
        named.append(np.mean(w))
    for coarse, fine in zip(named, named[1:]):
        assert 1.5 < coarse / fine < 2.5, named
    ev = simulate(ChainParams(segments=16), InitialCondition(), SolverOptions())
    assert ev.energy["work_error_in_steps"] == 0.0


def _random_fall(n, seed, **options):
    """A time-stepping fall of n segments from the random start (seed, run 0), alpha = pi/4."""
    return simulate(
        ChainParams(segments=n, alpha=math.pi / 4),
        InitialCondition(kind="random", seed=seed, spawn_key=(0,)),
        SolverOptions(method="timestep", **options),
    )


def test_projection_ledger_is_the_potential_energy_it_moves():
    """The projection after a step moves positions only; the velocity state (V, w) is
    kept, so T = sum 1/2 |V|^2 + |w|^2 / 6 does not change and the ledger entry is the
    change of U.  Its moves put drifted anchors and over-bent hinges back (at most the
    drift of one step, O(h^2 |w|^2) b per point), so over a whole fall it is a small
    fraction of E0 (7e-4 here; the old ledger, U + T with T rebuilt from the axes, read
    1.5e-2 E0 in this fall and 5 E0 at N = 512)."""
    r = _random_fall(64, seed=1, dt=0.01, frames_per_tff=1)
    assert r.status == "landed", r.message
    e = r.energy
    assert e["projected_in_steps"] != 0.0  # loops of chain between anchors drift: there were projections
    assert abs(e["projected_in_steps"]) < 3e-3 * e["initial"], e


def test_a_fully_folded_pair_on_one_anchor_creates_no_energy():
    """A planar start with no bend limit (N = 8, alpha = pi) ends with a pair of segments
    folded flat on each other, both feet on one anchored point: a configuration whose
    rows are dependent.  Inelastic impacts and projections can only remove energy, so the
    books may not show energy created (the projection there once moved the free end by
    0.07 b to remove a 1e-12 residual, step after step, and created 1.3 E0 by 3 t_ff)."""
    r = simulate(
        ChainParams(segments=8, alpha=math.pi),
        InitialCondition(kind="planar", eps=0.2),
        SolverOptions(method="timestep", dt=0.005, frames_per_tff=1),
    )
    assert r.status != "error", r.message
    assert r.energy["imbalance"] > -1e-3 * r.energy["initial"], r.energy
    assert r.energy["kinetic"] < 1e-6 * r.energy["initial"]  # at rest at the time cap


def _meander_on_the_floor(n, seed):
    """A chain of n segments lying on the floor in a meander (bends below 0.6 rad, inside
    alpha = pi/4), every other point anchored where its exact position is (math.fsum of
    the axes, correctly rounded): the kernels' positions, sums of up to n axes, miss the
    anchors by their round-off alone.  Returns the stepper's bundles and that miss."""
    from ballchain.core.impacts import hinge_gaps
    from ballchain.core.kinematics import point_positions
    from ballchain.core.state import new_books, new_chain, new_model, new_work
    from ballchain.methods.timestep.stepper import new_scratch

    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.uniform(-0.6, 0.6, n))
    e = np.stack([np.cos(heading), np.sin(heading), np.zeros(n)], axis=1)
    chain = new_chain(e, np.zeros((n, 3)), math.pi / 4)
    chain.anchored[::2] = 1
    for j in range(0, n + 1, 2):
        chain.anchor_pos[j] = [2.0 * math.fsum(e[j:, q]) for q in range(3)]
    model = new_model(math.pi / 4, 0, False, SolverOptions(method="timestep", dt=0.02, theta=1), 10.0, 0.0, 1)
    ws, sc, books = new_work(n), new_scratch(n), new_books()
    hinge_gaps(chain.Y[0], model.cos_alpha, sc.gaps)
    point_positions(chain.Y[0], sc.pv)
    miss = np.nanmax(np.abs(sc.pv - chain.anchor_pos))
    return model, chain, ws, sc, books, miss


@pytest.mark.slow
def test_the_projection_leaves_the_round_off_of_a_long_pile_alone():
    """Round-off is not drift.  A point's position is a sum of the axes below it, so on
    a pile of N = 16384 segments the points miss their anchors by the round-off of sums
    of thousands of terms, above an absolute 1e-12 b: projecting it (as the time-stepper
    did) moves the state by round-off, and Gauss-Newton, unable to get under that floor,
    ran to its 25-iteration cap at every step (an N = 16384 fall took 60 ms a step, 6.5
    times the usual, from 0.36 t_ff on).  The tolerance is the one the event-driven
    method uses, ``projection_tol(N)`` (PROJ_ROUNDOFF b per segment): such a state is
    left exactly as it is and books no energy to the projection."""
    from ballchain.core.kinematics import PROJ_TOL, projection_tol
    from ballchain.methods.timestep.stepper import _project, projection_scratch

    n = 16384
    model, chain, ws, sc, books, miss = _meander_on_the_floor(n, seed=3)
    assert PROJ_TOL < miss < projection_tol(n)  # round-off above the absolute tolerance, under the scaled one
    e0 = chain.Y[0].copy()
    assert _project(model, chain, ws, projection_scratch(sc), books) == 0
    np.testing.assert_array_equal(chain.Y[0], e0)  # not moved at all (no projection ran)
    assert books.projected[0] == 0.0


@pytest.mark.slow
def test_the_projection_removes_drift_above_the_round_off():
    """The same pile with its axes turned by 1e-7 rad (drift, as a step leaves it): the
    projection puts the anchored points back on their anchors, to within the scaled
    tolerance, and its move is of the size of the drift."""
    from ballchain.core.impacts import hinge_gaps
    from ballchain.core.kinematics import point_positions, projection_tol
    from ballchain.methods.timestep.stepper import _project, projection_scratch

    n = 16384
    model, chain, ws, sc, books, _ = _meander_on_the_floor(n, seed=3)
    e = chain.Y[0]
    turn = 1e-7 * np.random.default_rng(4).standard_normal(n)
    c, s = np.cos(turn), np.sin(turn)
    e[:, 0], e[:, 1] = c * e[:, 0] - s * e[:, 1], s * e[:, 0] + c * e[:, 1]
    before = e.copy()
    point_positions(e, sc.pv)
    hinge_gaps(e, model.cos_alpha, sc.gaps)
    drift = np.nanmax(np.abs(sc.pv - chain.anchor_pos))
    assert drift > 100 * projection_tol(n)
    _project(model, chain, ws, projection_scratch(sc), books)
    point_positions(e, sc.pts)
    assert np.nanmax(np.abs(sc.pts - chain.anchor_pos)) <= projection_tol(n)
    assert 0.0 < np.abs(e - before).max() < 10 * drift


def test_a_frozen_block_whose_anchors_miss_does_not_move_the_chain_above_it():
    """A pile's landed segments are frozen, and point positions are sums of the axes
    from the bottom: no turn of the airborne segments above a landed block moves the
    block's points.  So when a landed segment's two anchors are off its length (both its
    ends anchored in one time step, each beside another anchored neighbour: an N = 16384
    fall had one 1e-5 b off), the misses of the anchors above it are not drift, and a
    projection must not chase them: it ran Gauss-Newton to its cap at every step (57 ms a
    step instead of 9-15) and turned the hanging chain by what it could not remove.  Here:
    24 segments lying along x, the anchors of the upper half of them 1e-5 b off, 40
    segments hanging straight up from the block's top point, at rest with every
    constraint of their own met.  The projection (of the core, and the time-stepper's)
    leaves the hanging chain exactly where it is."""
    from ballchain.core.impacts import hinge_gaps
    from ballchain.core.kinematics import point_positions, project_state, projection_tol
    from ballchain.core.state import new_books, new_chain, new_model, new_work
    from ballchain.methods.timestep.stepper import _project, new_scratch, projection_scratch

    n, top = 64, 40  # segments 40..63 landed (points 40..64 anchored), 0..39 hanging
    e = np.zeros((n, 3))
    e[:top, 2] = 1.0  # hanging straight up (axes point up the chain)
    e[top:, 0] = -1.0  # lying along x on the floor, towards the pivot at the origin
    chain = new_chain(e, np.zeros((n, 3)), math.pi / 4)
    pts = np.zeros((n + 1, 3))
    point_positions(e, pts)
    chain.anchored[top:] = 1
    chain.anchor_pos[top:] = pts[top:]
    chain.anchor_pos[top:52] += [1e-5, -3e-6, 0.0]  # segment 51's anchors are off its length
    assert abs(np.linalg.norm(chain.anchor_pos[51] - chain.anchor_pos[52]) - 2.0) > 5e-6

    ws = new_work(n)
    sc_pts, sc_vel = np.zeros((n + 1, 3)), np.zeros((n, 3))
    before = chain.Y.copy()
    project_state(chain, ws, sc_pts, sc_vel, projection_tol(n), np.int64(25), False)
    np.testing.assert_array_equal(chain.Y, before)  # nothing it could remove, nothing moved

    model = new_model(math.pi / 4, 0, False, SolverOptions(method="timestep", dt=0.02, theta=1), 10.0, 0.0, 1)
    sc, books = new_scratch(n), new_books()
    hinge_gaps(chain.Y[0], model.cos_alpha, sc.gaps)
    point_positions(chain.Y[0], sc.pv)
    assert _project(model, chain, ws, projection_scratch(sc), books) == 0
    np.testing.assert_array_equal(chain.Y, before)
    assert books.projected[0] == 0.0


def test_a_loop_landed_past_its_limits_keeps_its_anchors():
    """The time-stepper's bends pass their limits within a step, so a loop of airborne
    chain can land with both ends anchored while bent past its limits: here 3 segments
    arched between two anchored points in a vertical plane, both hinges bent 46 deg
    (limit 45), the anchors 2 (1 + 2 cos 46 deg) = 4.78 b apart; with both hinges on
    their limits the loop's ends are between 4.83 b (an arch) and 5.59 b (a zigzag)
    apart, so no state meets the anchors and the limits together.  Gauss-Newton on both
    then ends unconverged (an N = 16384 fall took such steps to 0.027 b anchor misses
    and bends 0.39 past the limits); the projection keeps the anchors instead and
    leaves the bends as they are (the steps' impulses hold them from closing further)."""
    from ballchain.core.impacts import hinge_gaps
    from ballchain.core.kinematics import point_positions, projection_tol
    from ballchain.core.state import new_books, new_chain, new_model, new_work
    from ballchain.methods.timestep.stepper import _project, new_scratch, projection_scratch

    n, loop = 12, 3  # segments 0..2 the loop (points 0 and 3 anchored), 3..11 landed along -x
    bend = math.radians(46.0)
    e = np.zeros((n, 3))
    e[loop:, 0] = -1.0
    e[2] = [-math.cos(bend), 0.0, math.sin(bend)]
    e[1] = [-1.0, 0.0, 0.0]
    e[0] = [-math.cos(bend), 0.0, -math.sin(bend)]
    chain = new_chain(e, np.zeros((n, 3)), math.pi / 4)
    pts = np.zeros((n + 1, 3))
    point_positions(e, pts)
    assert abs(pts[0, 2]) < 1e-15 and pts[1, 2] > 1.0 and pts[2, 2] > 1.0  # both ends on the floor
    assert math.isclose(np.linalg.norm(pts[0] - pts[3]), 2 * (1 + 2 * math.cos(bend)))
    chain.anchored[loop:] = 1
    chain.anchored[0] = 1
    chain.anchor_pos[:] = pts
    model = new_model(math.pi / 4, 0, False, SolverOptions(method="timestep", dt=0.02, theta=1), 10.0, 0.0, 1)
    ws, sc, books = new_work(n), new_scratch(n), new_books()
    hinge_gaps(chain.Y[0], model.cos_alpha, sc.gaps)
    gaps = sc.gaps.copy()
    assert gaps[0] < -0.01 and gaps[1] < -0.01  # both past the limit, by cos 45 - cos 46 = 0.0124
    point_positions(chain.Y[0], sc.pv)
    _project(model, chain, ws, projection_scratch(sc), books)
    point_positions(chain.Y[0], pts)
    assert np.abs(pts - chain.anchor_pos).max() <= projection_tol(n)  # the anchors kept
    hinge_gaps(chain.Y[0], model.cos_alpha, sc.gaps)
    np.testing.assert_allclose(sc.gaps[:2], gaps[:2], atol=1e-12)  # the bends left as they were


def test_floor_impulse_at_landings_is_bounded_by_the_chains_momentum():
    """Each landing step's floor impulse changes the chain's momentum, whose size is at
    most sqrt(2 M T) <= sqrt(2 N E0) (units m = b = g = 1), so their sum over the N
    landings is bounded by (N + 1) sqrt(2 N E0).  A segment held between two anchors has
    nearly dependent rows whose impulses split between its ends without bound; the
    record once summed the new anchor's share alone (6e5 against a bound of 5e4 here)."""
    n = 64
    r = simulate(
        ChainParams(segments=n, alpha=math.pi / 4),
        InitialCondition(kind="random", seed=1, spawn_key=(0,)),
        SolverOptions(method="timestep", dt=0.01, frames_per_tff=1),
    )
    assert r.status == "landed", r.message
    bound = (n + 1) * math.sqrt(2.0 * n * r.energy["initial"])
    assert np.all(np.abs(r.floor_impulse) < bound), (r.floor_impulse, bound)
    # each landing row of the log: one step's impulse, at most the chain's momentum (it read 6.5e5)
    landing = r.event_kind == 3  # core.kinds: landing
    assert landing.sum() >= n
    assert np.max(np.linalg.norm(r.event_impulse[landing], axis=1)) < math.sqrt(2.0 * n * r.energy["initial"])
    # the whole impulse is the weight's, N g t_end (the chain starts and ends at rest), to the
    # method's error: 2e-7 to 2e-5 of it over seeds 1 to 8 (1.6e-6 in this one)
    assert r.floor_impulse_total[2] == pytest.approx(n * r.t_landed, rel=1e-4)


def test_books_past_half_their_bound_are_a_warning(tmp_path):
    """A run whose books close within the method's bound but past half of it says so (its
    error is first order: halving dt halves it); one well inside says nothing; the
    event-driven method, whose bounds are round-off's, never."""
    from ballchain.records.audit import near_bounds

    coarse, fine = _rod(0.04), _rod(0.005)  # imbalance 0.054 and 0.0067 of E0 (the rod table)
    assert coarse.status == fine.status == "landed"
    assert len(near_bounds(coarse)) == 1 and "0.02" in near_bounds(coarse)[0]
    assert near_bounds(fine) == []
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    np.save(tmp_path / "rod.npy", e0)
    args = ["simulate", "-N", "1", "--alpha", "pi", "--initial", str(tmp_path / "rod.npy"), "--frames-per-tff", "1"]
    runner = CliRunner()
    res = runner.invoke(app, [*args, "--method", "timestep", "--dt", "0.04"])
    assert res.exit_code == 0, res.output
    assert "past half the method's bound" in res.output
    res = runner.invoke(app, args)  # event-driven
    assert res.exit_code == 0, res.output
    assert "past half" not in res.output


def test_the_books_of_a_fall_stopped_midway_close_as_its_frames_do():
    """The time-stepper keeps the centres' velocities V of its own (maximal coordinates),
    and its kinetic energy is T = sum 1/2 |V_i|^2 + |w_i|^2 / 6, as its frames record it.
    A fall stopped at 0.5 t_ff (--until) reports at its end the same books as its last
    frame, 0.001 t_ff earlier (their imbalances within 1e-3 E0: 3e-4 here, what the
    fall's own imbalance moves by in that time, as runs stopped there read it).  The end's
    T used to be rebuilt from the axes and rates (V as sums of the rates from the
    bottom), which the time-stepper's V need not equal once points are anchored: the
    end's books then read -0.001 E0 against the frame's +0.005 (0.11 E0 apart at
    N = 16384)."""
    r = _random_fall(64, seed=2026, until=0.5, frames_per_tff=1000)
    assert r.status == "until", r.message
    e = r.energy
    e0 = e["initial"]
    frame = e0 - r.frame_kinetic[-1] - r.frame_potential[-1] - r.frame_lost_locking[-1] - r.frame_lost_landing[-1]
    assert r.frame_t[-1] > 0.498 * r.t_ff and np.asarray(r.frame_anchored)[-1].sum() > 1  # a pile below
    assert abs(e["imbalance"] - frame) < 1e-3 * e0, (e["imbalance"] / e0, frame / e0)


def test_the_warnings_point_to_the_pages_and_quote_no_study():
    """The time-stepper's warnings name the defaults and the page with the numbers; no
    measured difference (a number of t_ff) or count of falls is quoted in them."""
    import re

    from ballchain import cli

    for text in (cli.TIMESTEP_WARNING, cli.SHORT_STEP_WARNING.format(n=4096), cli.LANDING_WARNING.format(n=256)):
        assert re.search(r"docs/[a-z-]+\.md", text), text
        assert not re.search(r"\d\s*t_ff\b", text), text
        assert not re.search(r"\b\d+ of \d+\b", text), text
