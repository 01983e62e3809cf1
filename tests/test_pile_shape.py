"""The pile's shape at the end of a run (``records.measures.pile_shape``: its radius of
gyration seen from above, and how far its centroid lies from the bottom end's start),
against independent truths: a rod pivoting on its anchored foot lies down along the
azimuth it leaned to, its top end 2b from the foot (radius b, centroid b from the start);
a rod on a frictionless floor keeps its centre of mass on a vertical line (centroid b sin
theta0 from the start); turning the start about the vertical turns the pile and changes
neither number."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.measures import derived_measures, pile_shape

THETA0 = 0.3  # rad from the vertical
AZIMUTH = 2.2  # rad: the vertical plane the rod leans in


def _rod(method: str, friction: float = math.inf, **opts):
    e0 = np.array([[math.sin(THETA0) * math.cos(AZIMUTH), math.sin(THETA0) * math.sin(AZIMUTH), math.cos(THETA0)]])
    return simulate(
        ChainParams(segments=1, friction=friction), state=(e0, None), options=SolverOptions(method=method, **opts)
    )


@pytest.mark.parametrize("method", ["event", "timestep", "rattle"])
def test_an_anchored_rod_lies_down_2b_from_its_foot_along_its_lean(method):
    r = _rod(method)
    assert r.status == "landed"
    pile = pile_shape(r)
    assert pile.points == 2
    assert pile.radius == pytest.approx(1.0, abs=1e-9)  # half the rod, b = 1
    assert pile.offset == pytest.approx(1.0, abs=1e-9)
    assert abs(pile.kinetic) < 1e-12  # landed: at rest, the pile read where it lies
    top = np.asarray(r.anchor_pos)[0]
    assert math.atan2(top[1], top[0]) == pytest.approx(AZIMUTH, abs=1e-9)  # in the plane it leaned in


def test_a_rod_on_a_frictionless_floor_lies_down_about_its_centre_of_mass():
    r = _rod("rattle", friction=0.0, frames_per_tff=2000)
    assert r.status == "landed"
    pile = pile_shape(r)
    assert pile.offset == pytest.approx(math.sin(THETA0), abs=1e-9)  # its centre's start, b sin theta0
    assert pile.radius == pytest.approx(1.0, abs=1e-4)  # flat to within the last frame's turn
    # its centre falls vertically, and the touch of its top stops the rest: at rest when read
    assert abs(pile.kinetic) < 1e-12


def test_a_pile_read_while_the_chain_still_slides_says_how_much_moves():
    """On a frictionless floor the run ends when every point has touched it; a chain's pile
    is read then, from the last frame, with the kinetic energy that frame still had."""
    r = simulate(
        ChainParams(segments=16, friction=0.0), InitialCondition("random", seed=1), SolverOptions(method="rattle")
    )
    assert r.status == "landed"
    pile = pile_shape(r)
    assert pile.kinetic == pytest.approx(r.frame_kinetic[-1] / r.energy["initial"], rel=1e-12)
    assert pile.kinetic > 1e-3
    res = CliRunner().invoke(
        app, ["simulate", "-N", "16", "--friction", "0", "--method", "rattle", "--seed", "1", "--ic", "random"]
    )
    assert res.exit_code == 0, res.stderr
    assert "still kinetic" in res.stdout


def test_turning_the_start_about_the_vertical_changes_neither_number():
    rng = np.random.default_rng(7)
    e0 = rng.normal(size=(8, 3))
    e0[:, 2] = np.abs(e0[:, 2]) + 0.5
    e0 /= np.linalg.norm(e0, axis=1)[:, None]
    c, s = math.cos(1.1), math.sin(1.1)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    params = ChainParams(segments=8, alpha=math.pi)
    a = pile_shape(simulate(params, state=(e0, None)))
    b = pile_shape(simulate(params, state=(e0 @ turn.T, None)))
    assert a.points == b.points == 9
    assert b.radius == pytest.approx(a.radius, rel=1e-7)
    assert b.offset == pytest.approx(a.offset, rel=1e-7)
    assert a.radius > 0.5 and a.offset > 0.0  # a pile, not a point


def test_a_run_with_nothing_on_the_floor_has_no_pile_and_says_so():
    r = simulate(ChainParams(segments=4), options=SolverOptions(until=0.05))
    m = derived_measures(r)
    assert math.isnan(m["pile_radius"]) and math.isnan(m["pile_offset"])  # the bottom end alone
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--until", "0.05", "--json", "-q"])
    assert res.exit_code == 0, res.stderr
    out = json.loads(res.stdout)
    assert out["pile_radius"] is None and out["pile_offset"] is None


def test_the_summary_the_json_and_the_sweep_table_carry_it(tmp_path):
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.execute import run_sweep
    from ballchain.sweeps.table import read_table

    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--json", "-q"])
    out = json.loads(res.stdout)
    assert out["pile_radius"] > 0.0 and out["pile_offset"] >= 0.0
    res = CliRunner().invoke(app, ["simulate", "-N", "4"])
    assert "radius of gyration" in res.stdout
    table = tmp_path / "t.parquet"
    run_sweep(SweepSpec(segments=(4,), alphas=(0.8,), runs=2), table, workers=1, progress=False)
    rows = read_table(table)
    assert all(r["pile_radius"] > 0.0 for r in rows)
    assert all(abs(r["pile_kinetic"]) < 1e-12 for r in rows)  # anchored piles are at rest
