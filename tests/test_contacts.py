"""The contact laws (``ballchain.contacts``): Newton's restitution at the bend limit in
whole falls of the event method, against what the law implies independently of the code
that solves it (nothing lost at e = 1; the first lock, the same instant for every e, loses
(1 - e^2) of the inelastic loss), and the parameter as a contract: the command line, the
sweep's column and key, the result file, and a method that cannot honour it refusing it
in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.result import EVENT_CODES

START = InitialCondition(kind="random", seed=2026, spawn_key=(0,))


def fall(n, e, **opts):
    return simulate(ChainParams(segments=n, restitution_lock=e), START, SolverOptions(**opts))


@pytest.mark.parametrize("n", [4, 8])
def test_an_elastic_limit_loses_nothing_at_the_locks(n):
    """e = 1: every lock impact gives back what it took (the loss of Newton's law is
    (1 - e)/(1 + e) P.GP); the books still close, landings still take their share."""
    r = fall(n, 1.0)
    en, e0 = r.energy, r.energy["initial"]
    assert r.status == "landed"
    locks = r.event_kind == EVENT_CODES["lock"]
    assert locks.sum() > 0
    assert abs(en["lost_locking"]) < 1e-10 * e0
    assert np.abs(r.event_energy[locks]).max() < 1e-10 * e0
    assert abs(en["imbalance"]) < 1e-8 * e0
    assert en["lost_landing"] > 0.1 * e0


@pytest.mark.parametrize("e", [0.25, 0.5, 0.9])
def test_the_first_lock_loses_one_minus_e_squared_of_the_inelastic_loss(e):
    """Before the first impact the fall does not know e: the first lock comes at the same
    instant, and (one hinge closing) loses (1 - e^2) of what the inelastic lock loses."""
    ref = fall(8, 0.0, until=0.7)
    r = fall(8, e, until=0.7)
    assert r.first_lock_time == ref.first_lock_time
    first = np.flatnonzero(ref.event_kind == EVENT_CODES["lock"])[0]
    same_instant = ref.event_t == ref.event_t[first]
    assert (ref.event_kind[same_instant] == EVENT_CODES["lock"]).sum() == 1  # one hinge
    k = np.flatnonzero(r.event_kind == EVENT_CODES["lock"])[0]
    assert r.event_t[k] == ref.event_t[first] and r.event_index[k] == ref.event_index[first]
    assert r.event_energy[k] == pytest.approx((1.0 - e * e) * ref.event_energy[first], rel=1e-9)
    assert r.energy["lost_locking"] >= 0.0
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]


@pytest.mark.parametrize("e", [0.3, 0.7])
def test_a_partly_elastic_limit_closes_its_books_and_stays_inside_its_limits(e):
    """Rebounds, the accumulation rule that ends their series, and the second inelastic
    pass of a hinge pushed back to its limit: the books close to the event method's bound
    and no hinge passes its limit."""
    r = fall(8, e)
    assert r.status == "landed", r.message
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]
    assert r.energy["lost_locking"] > 0.0
    cos_a = np.cos(r.params.alpha)
    g = np.einsum("fij,fij->fi", r.frame_e[:, :-1], r.frame_e[:, 1:]) - cos_a
    landed = r.frame_anchored[:, :-1].astype(bool)
    free_pair = ~(landed[:, :-1] | landed[:, 1:])
    assert g[free_pair].min() > -1e-7


@pytest.mark.parametrize("method", ["timestep", "rattle"])
def test_a_method_that_cannot_honour_it_refuses_it_in_one_line(method):
    with pytest.raises(ParameterError, match=f"not honoured by --method {method}"):
        simulate(ChainParams(segments=4, restitution_lock=0.5), START, SolverOptions(method=method))
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", method, "--restitution-lock", "0.5", "-q"])
    assert res.exit_code == 2
    assert len(res.stderr.strip().splitlines()) == 1 and "--restitution-lock 0.5" in res.stderr
    res = CliRunner().invoke(
        app, ["sweep", "-N", "4", "--method", method, "--restitution-lock", "0.5", "--out", "x.parquet", "-q"]
    )
    assert res.exit_code == 2 and "not honoured" in res.stderr


@pytest.mark.parametrize("bad", ["-0.1", "1.5", "nan"])
def test_a_restitution_outside_0_1_is_refused(bad):
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--restitution-lock", bad, "-q"])
    assert res.exit_code == 2 and "restitution_lock must be in [0, 1]" in res.stderr


def test_the_parameter_in_the_json_the_file_the_sweep_table_and_its_key(tmp_path):
    from ballchain.records.files import load_result, save_result
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.execute import run_sweep
    from ballchain.sweeps.stats import table_stats
    from ballchain.sweeps.table import read_table

    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--restitution-lock", "0.5", "--json", "-q"])
    assert res.exit_code == 0 and json.loads(res.stdout)["restitution_lock"] == 0.5
    r = fall(4, 0.5)
    save_result(r, tmp_path / "r.h5")
    assert load_result(tmp_path / "r.h5").params == r.params
    out = tmp_path / "t.parquet"
    for e in (0.0, 0.5):
        run_sweep(SweepSpec(segments=(4,), alphas=(0.8,), runs=2, restitution_lock=e), out, workers=1, progress=False)
    rows = read_table(out)
    assert sorted(r["restitution_lock"] for r in rows) == [0.0, 0.0, 0.5, 0.5]
    keys = {r["run_id"] for r in rows}
    assert len(keys) == 4 and sum(k.endswith("_restitution_lock0.5") for k in keys) == 2
    points = table_stats(out)["points"]
    assert sorted(p["restitution_lock"] for p in points) == [0.0, 0.5]  # two points, never pooled


def test_without_limits_the_law_never_acts():
    """alpha = pi: no hinge ever reaches a limit, so a fall with restitution at the limit
    is the fall without it, bit for bit (the law acts only where a limit does)."""
    a = simulate(ChainParams(segments=6, alpha=np.pi), START, SolverOptions())
    b = simulate(ChainParams(segments=6, alpha=np.pi, restitution_lock=0.7), START, SolverOptions())
    assert a.status == b.status == "landed"
    assert a.t_fall == b.t_fall and a.energy == b.energy
    np.testing.assert_array_equal(a.frame_e, b.frame_e)
    assert (a.event_kind == EVENT_CODES["lock"]).sum() == 0
