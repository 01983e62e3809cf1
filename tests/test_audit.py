"""Every run checks its own books: a doctored result fails the audit naming the book and
the amounts; real runs pass it; a run that breaks the model ends with status error."""

import dataclasses
import json
import math

import numpy as np
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.audit import DEPTH_TOL, ENERGY_RTOL, anchor_miss, audit, audited, near_bounds


def _run(**kw):
    return simulate(ChainParams(segments=6, **kw), InitialCondition(eps=0.05), SolverOptions())


def test_real_runs_pass_the_audit():
    for floor in ("all", "pivot"):
        for alpha in (math.pi / 4, math.pi):
            r = _run(alpha=alpha, floor=floor)
            assert r.status == "landed", (r.status, r.message)
            assert audit(r) == []
            assert abs(r.energy["imbalance"]) <= ENERGY_RTOL * r.energy["initial"]


def test_doctored_books_fail_loudly():
    r = _run(alpha=math.pi / 4)
    e = dict(r.energy)
    e["imbalance"] = -1e-3 * e["initial"]  # energy created
    bad = audited(dataclasses.replace(r, energy=e))
    assert bad.status == "error" and "energy books do not close" in bad.message and "created" in bad.message
    assert "0.001 of E0" in bad.message
    # the message says how much of it the projections onto the constraints made
    e["projected_at_instants"], e["projected_in_steps"] = 4e-4 * e["initial"], 6e-4 * e["initial"]
    bad = audited(dataclasses.replace(r, energy=e))
    assert "changed U + T by +0.001 of E0 (+0.0004 at event instants, +0.0006 after steps)" in bad.message
    deep = audited(dataclasses.replace(r, max_depth=1e-3 * r.params.half_length))
    assert deep.status == "error" and "below the floor" in deep.message
    # a depth within tolerance, or under a floor that does not watch every point, passes
    ok = dataclasses.replace(r, max_depth=0.5 * DEPTH_TOL * r.params.half_length)
    assert audit(ok) == []
    pivot = _run(alpha=math.pi / 4, floor="pivot")
    assert audit(dataclasses.replace(pivot, max_depth=1.0)) == []


def test_a_run_that_breaks_the_model_exits_1_and_says_which_book():
    """A fall integrated far too loosely (rtol 1e-4) creates energy and sinks points
    into the floor: not a silent number with exit code 0, but status error, exit code 1,
    a message naming both books."""
    res = CliRunner().invoke(app, ["simulate", "-N", "16", "--rtol", "1e-4", "--json", "-q"])
    assert res.exit_code == 1
    s = json.loads(res.stdout)
    assert s["status"] == "error" and "energy books do not close" in s["message"]
    assert "below the floor" in s["message"]


def test_an_anchored_point_off_its_anchor_fails_loudly():
    """A run keeps every anchored point that the airborne chain could move on its anchor
    to its projection's tolerance, in every frame; a result whose anchor is moved by
    1e-3 b (what a projection that cannot converge leaves) fails the audit.  An anchor
    under a landed segment is not such a point: its segment is frozen where it landed."""
    for method in ("event", "timestep"):
        r = simulate(
            ChainParams(segments=8, alpha=math.pi / 4), InitialCondition(eps=0.05), SolverOptions(method=method)
        )
        miss, _ = anchor_miss(r)
        assert miss <= 1e-9, (method, miss)
        anchored = np.asarray(r.frame_anchored) != 0
        n = r.params.segments
        # a point anchored above an airborne segment (in some frame): the chain could move it
        j = next(j for k in range(len(r.frame_t)) for j in range(n) if anchored[k, j] and not anchored[k, j + 1])
        moved = np.array(r.anchor_pos, dtype=float)
        moved[j, 0] += 1e-3 * r.params.half_length
        bad = audited(dataclasses.replace(r, anchor_pos=moved))
        assert bad.status == "error", method
        assert "an anchored point was 0.001 b from its anchor" in bad.message
        # point N - 1 lands with segment N - 1 (its lower end is the pivot): frozen from then on
        moved = np.array(r.anchor_pos, dtype=float)
        moved[n - 1, 0] += 1e-3 * r.params.half_length
        assert anchored[-1, n - 1] and audit(dataclasses.replace(r, anchor_pos=moved)) == []


def _bend(u, angle):
    """A unit vector at ``angle`` from the unit vector ``u``."""
    w = np.cross(u, [0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0])
    w /= np.linalg.norm(w)
    return math.cos(angle) * u + math.sin(angle) * w


def test_a_hinge_bent_past_its_limit_fails_loudly():
    """No frame of a sound run has a hinge whose limit is in force bent past it by more
    than the method's tolerance (the event-driven method: round-off; the time-stepper: its
    first-order overshoot, a few dt); a result with one hinge of the airborne chain bent
    0.3 rad past the limit (cosine 0.24 past it) fails the audit naming the hinge.  A
    bend past the limit where the limit is not in force (alpha = pi) is not a break."""
    from ballchain.records.audit import hinge_excess, hinge_tolerance

    alpha = math.pi / 4
    for method in ("event", "timestep"):
        r = simulate(ChainParams(segments=8, alpha=alpha), InitialCondition(eps=0.05), SolverOptions(method=method))
        excess, _, _ = hinge_excess(r)
        assert excess <= 0.5 * hinge_tolerance(r.options), (method, excess)
        e = np.array(r.frame_e, dtype=float)
        e[0, 3] = _bend(e[0, 2] / np.linalg.norm(e[0, 2]), alpha + 0.3)
        bent = dataclasses.replace(r, frame_e=e)
        excess, when, hinge = hinge_excess(bent)
        assert hinge == 2 and when == r.frame_t[0]
        assert math.isclose(excess, math.cos(alpha) - math.cos(alpha + 0.3), rel_tol=1e-9)
        bad = audited(bent)
        assert bad.status == "error", method
        assert "hinge 2 was bent past its limit by 0.241 in the cosine" in bad.message
        if method == "timestep":  # past half its bound but within it: a warning, not an error
            tol = hinge_tolerance(r.options)
            e[0, 3] = _bend(e[0, 2] / np.linalg.norm(e[0, 2]), math.acos(math.cos(alpha) - 0.75 * tol))
            warned = dataclasses.replace(r, frame_e=e)
            assert audit(warned) == []
            assert any("a hinge was bent" in w and "past half the method's bound" in w for w in near_bounds(warned))
    free = simulate(ChainParams(segments=8, alpha=math.pi), InitialCondition(eps=0.05), SolverOptions())
    e = np.array(free.frame_e, dtype=float)
    e[0, 3] = _bend(e[0, 2] / np.linalg.norm(e[0, 2]), 2.0)
    assert audit(dataclasses.replace(free, frame_e=e)) == []


def test_a_run_stopped_at_the_time_cap_that_fails_its_books_says_the_books_first():
    """A top that RATTLE without an energy bound keeps turning to the time cap and whose books
    then do not close (issue 82): its error is the books, said first; where it had stopped
    follows (the CLI prints ``the run failed: <message>``)."""
    from test_cli import fake_result

    cap = "the chain had not landed by t = 3 t_ff (the time cap, --max-time); its top end, 3 segments locked"
    r = fake_result(
        ChainParams(segments=8),
        InitialCondition(),
        SolverOptions(method="rattle", step_energy_tol=0.0),
        status="max_time",
        message=cap,
    )
    e = dict(r.energy)
    e["imbalance"] = -0.2 * e["initial"]
    bad = audited(dataclasses.replace(r, energy=e))
    assert bad.status == "error" and bad.message.startswith("the energy books do not close: 0.2 of E0 created")
    assert bad.message.endswith(f" (it had stopped with status max_time: {cap})")
    failed = audited(dataclasses.replace(r, energy=e, status="error", message="non-finite state (blow-up)"))
    assert failed.message.startswith("non-finite state (blow-up); the energy books do not close")
