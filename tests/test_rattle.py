"""The nonsmooth RATTLE method (``--method rattle``, experimental) against independent truths:
second order against the exact method where the motion is smooth, a fall whose floor and
books hold, frames that do not change the fall, and what it refuses."""

import math
from pathlib import Path

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions

TOP3 = Path(__file__).parent / "data" / "top3-state.txt"
SMOOTH = (ChainParams(segments=8, alpha=math.pi), InitialCondition(eps=0.2))  # no limits; first landing after 0.5 t_ff


def _frame_error(r, ref, k):
    return float(np.abs(r.frame_e[k] - ref.frame_e[k]).max())


def test_second_order_where_the_motion_is_smooth():
    """Before its first landing a chain with no limits moves smoothly: the axes at 0.25 t_ff
    (a frame taken inside a step) converge to the exact method's about fourfold per halving of dt."""
    params, ic = SMOOTH
    ref = simulate(params, ic, SolverOptions(until=0.3, rtol=1e-12, frames_per_tff=4))
    assert ref.frame_anchored[1].sum() == 1  # only the pivot: the motion is smooth up to the frame
    errors = []
    for dt in (0.2, 0.1, 0.05, 0.025):
        r = simulate(params, ic, SolverOptions(method="rattle", dt=dt, until=0.3, frames_per_tff=4, step_energy_tol=0))
        assert r.status == "until"
        assert r.frame_t[1] == pytest.approx(ref.frame_t[1], rel=1e-12)
        errors.append(_frame_error(r, ref, 1))
    ratios = [a / b for a, b in zip(errors, errors[1:])]
    assert all(3.6 < q < 4.4 for q in ratios), (errors, ratios)


def test_a_fall_with_no_limits_holds_the_floor_and_closes_its_books():
    """alpha = pi, N = 8 to the end: every point anchored, none below the floor beyond the
    solver's tolerance, the books closed to 1e-3 of E0 (the smooth steps' second-order error)."""
    r = simulate(ChainParams(segments=8, alpha=math.pi), options=SolverOptions(method="rattle", dt=0.05))
    assert r.status == "landed", r.message
    assert r.max_depth <= 1e-8
    assert abs(r.energy["imbalance"]) <= 1e-3 * r.energy["initial"]
    assert r.energy["lost_landing"] > 0.5 * r.energy["initial"]  # a fall ends with its energy lost at the floor


def test_a_fall_with_limits_closes_its_books():
    """alpha = pi/4, N = 8 to the end at the defaults: the impact steps book what they remove,
    the smooth steps' error stays below 1e-4 of E0, nothing below the floor, and the losses
    sum to what the chain lost (E0 = U + T + E_lock + E_land, the chain at rest on the floor)."""
    r = simulate(ChainParams(segments=8, alpha=math.pi / 4), options=SolverOptions(method="rattle"))
    assert r.status == "landed", r.message
    e = r.energy
    assert abs(e["imbalance"]) <= 1e-4 * e["initial"]
    assert r.max_depth <= 1e-8
    assert e["lost_locking"] > 0.1 * e["initial"] and e["lost_landing"] > 0.1 * e["initial"]


def test_the_top_is_held():
    """The top of tests/data/top3-state.txt (three segments locked, spinning on a landed
    point) to 1 t_ff at the defaults: it keeps turning (status max_time), its books close to
    1e-4 of E0, and its hinges lose no more at their locks than the exact method's."""
    s = np.loadtxt(TOP3)
    runs = {
        m: simulate(
            ChainParams(segments=3, alpha=math.pi / 4),
            state=(s[:, :3], s[:, 3:]),
            options=SolverOptions(method=m, max_time=1.0),
        )
        for m in ("event", "rattle")
    }
    r, ex = runs["rattle"], runs["event"]
    assert r.status == "max_time"
    assert abs(r.energy["imbalance"]) <= 1e-4 * r.energy["initial"]
    assert r.energy["lost_locking"] <= ex.energy["lost_locking"] + 1e-6 * r.energy["initial"]
    assert r.energy["kinetic"] == pytest.approx(ex.energy["kinetic"], rel=2e-3)


def test_frames_do_not_change_the_fall():
    """Frames are taken by a step of their own from the step's start, on a copy: the fall's
    steps, and so its t_fall, are the same whatever the frame rate."""
    params = ChainParams(segments=6, alpha=math.pi / 4)
    runs = [
        simulate(params, InitialCondition(kind="random", seed=9090), SolverOptions(method="rattle", frames_per_tff=f))
        for f in (37.0, 100.0, 1000.0)
    ]
    assert len({r.n_steps for r in runs}) == 1
    for r in runs[1:]:
        assert r.t_fall == pytest.approx(runs[0].t_fall, rel=1e-12, abs=0.0)
        assert r.energy["lost_locking"] == pytest.approx(runs[0].energy["lost_locking"], rel=1e-9)


def test_the_pivot_floor_is_refused():
    with pytest.raises(ParameterError, match="--floor all only"):
        simulate(ChainParams(segments=4, floor="pivot"), options=SolverOptions(method="rattle"))
