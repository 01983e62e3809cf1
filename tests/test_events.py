"""Events as the physics has them: the number of lock events, the energy lost to
locking, and the accumulation rule, against convergence and the energy books.
"""

import math
import os
from pathlib import Path

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.initial import load_initial_state
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions

FULL = os.environ.get("BALLCHAIN_FULL") == "1"
DATA = Path(__file__).parent / "data"


def _run(n, alpha=math.pi / 4, until=None, rtol=SolverOptions.rtol, floor="all", ic=None, **opt):
    return simulate(
        ChainParams(segments=n, alpha=alpha, floor=floor),
        ic or InitialCondition(),
        SolverOptions(rtol=rtol, until=until, **opt),
    )


def test_lock_events_and_energy_converge_with_rtol_n8():
    """N = 8 until 0.8 t_ff (dozens of lock impacts): no chatter (the same count of lock
    and unlock events at every tolerance, a few per hinge), E_lock converging as rtol
    tightens (the finest two agree to 1e-7), and the energy books closed at each."""
    runs = {rtol: _run(8, until=0.8, rtol=rtol) for rtol in (1e-10, 1e-11, 1e-12)}
    assert all(x.status == "until" for x in runs.values())
    counts = [x.event_counts() for x in runs.values()]
    assert len({(c["lock"], c["unlock"]) for c in counts}) == 1, counts
    assert 10 <= counts[0]["lock"] <= 10 * 7  # events, not chatter: a few per hinge
    e = [x.energy["lost_locking"] for x in runs.values()]
    assert abs(e[1] - e[2]) <= abs(e[0] - e[2]) + 1e-12 * e[2]
    assert abs(e[1] - e[2]) < 1e-7 * e[2], e
    assert all(abs(x.energy["imbalance"]) < 1e-9 * x.energy["initial"] for x in runs.values())


@pytest.mark.parametrize("n, alpha, until", [(4, math.pi / 4, 1.0), (6, math.pi / 3, 0.9), (12, math.pi / 4, 0.45)])
def test_energy_lost_to_locking_converges_with_rtol(n, alpha, until):
    """Short, well-conditioned runs: the same lock events at every tolerance, and E_lock
    converging (successive differences shrink, the finest two agree to 1e-8)."""
    rtols = (1e-10, 1e-11, 1e-12)
    runs = [_run(n, alpha, until, rtol) for rtol in rtols]
    locks = [r.event_counts()["lock"] for r in runs]
    assert locks[0] > 0 and len(set(locks)) == 1, locks
    e = [r.energy["lost_locking"] for r in runs]
    d1, d2 = abs(e[0] - e[2]), abs(e[1] - e[2])
    assert d2 <= d1 + 1e-12 * e[2]
    assert d2 <= 1e-8 * e[2], e
    first = [r.first_lock_time for r in runs]
    assert abs(first[1] - first[2]) <= 1e-9 * first[2]


def test_accumulation_threshold_does_not_move_results():
    """The hold rule replaces a converging series of ever smaller impacts by its limit:
    lowering its thresholds (hold_rate, hold_apex) changes E_lock by less than the
    tolerance does."""
    base = _run(8, until=0.8, rtol=1e-11)
    fine = _run(8, until=0.8, rtol=1e-11, hold_rate=1e-8, hold_apex=2e-12)
    coarse = _run(8, until=0.8, rtol=1e-11, hold_rate=1e-5, hold_apex=1e-10)
    tol_scale = abs(_run(8, until=0.8, rtol=1e-9).energy["lost_locking"] - base.energy["lost_locking"])
    for other in (fine, coarse):
        assert abs(other.energy["lost_locking"] - base.energy["lost_locking"]) <= max(tol_scale, 1e-12)


def test_converging_series_ends_locked():
    """Where the engine takes the accumulation limit, each hold ends a series of
    impacts between neighbouring hinges whose impulses shrink, and the held hinge is
    locked (or released with zero rate by the lock set, then logged as a release)."""
    r = _run(64, until=0.9)
    k = r.event_kind
    holds = np.flatnonzero(k == 7)
    assert holds.size > 0
    # a hold never leaves the hinge approaching: the next row of that hinge is not a
    # lock impact at the same instant
    for i in holds[:200]:
        same = (r.event_t == r.event_t[i]) & (r.event_index == r.event_index[i])
        assert not np.any(same & (k == 1))


@pytest.mark.parametrize("floor", ["all", "pivot"])
@pytest.mark.parametrize("alpha", [math.pi / 6, math.pi / 4, math.pi / 2])
@pytest.mark.parametrize("n", [8, 32, 128] if not FULL else [8, 16, 32, 64, 128])
def test_energy_budget_closes_at_the_default_tolerance(n, alpha, floor):
    r = _run(n, alpha, floor=floor)
    assert r.status == "landed", r.message
    assert abs(r.energy["imbalance"]) <= 1e-8 * r.energy["initial"], r.energy
    if floor == "all":
        assert r.max_depth <= 1e-9


def test_fold_case_closes_its_energy_books():
    """Two top segments folded almost flat at the last landing (alpha = pi, floor all):
    the books close, and better with the tolerance."""
    e0, w0 = load_initial_state(DATA / "fold-n16.txt")
    imb = []
    for rtol in (1e-9, 1e-11):
        r = simulate(ChainParams(segments=16, alpha=math.pi), None, SolverOptions(rtol=rtol), state=(e0, w0))
        assert r.status == "landed", r.message
        assert r.event_counts()["landing"] == 16
        imb.append(abs(r.energy["imbalance"]) / r.energy["initial"])
    assert imb[0] <= 1e-8 and imb[1] <= 1e-10, imb


@pytest.mark.slow
def test_no_solver_error_in_an_ensemble():
    """Random starts at N = 128 (the size where the lock-set LCP used to fail) end
    landed, with closed books, for both floor models."""
    seeds = range(16) if FULL else range(3)
    for floor in ("all", "pivot"):
        for seed in seeds:
            r = _run(128, floor=floor, ic=InitialCondition(kind="random", seed=seed))
            assert r.status == "landed", (floor, seed, r.message)
            assert abs(r.energy["imbalance"]) <= 1e-8 * r.energy["initial"]


def test_initial_state_file(tmp_path):
    e0, w0 = load_initial_state(DATA / "fold-n16.txt")
    assert e0.shape == (16, 3) and w0 is None
    np.testing.assert_allclose(np.linalg.norm(e0, axis=1), 1.0, rtol=1e-15)
    np.save(tmp_path / "s.npy", np.hstack([e0, np.zeros((16, 3))]))
    e1, w1 = load_initial_state(tmp_path / "s.npy")
    np.testing.assert_array_equal(e1, e0)
    assert w1.shape == (16, 3)
    (tmp_path / "bad.txt").write_text("1 2\n3 4\n")
    with pytest.raises(ParameterError, match="N x 3"):
        load_initial_state(tmp_path / "bad.txt")
    (tmp_path / "zero.txt").write_text("0 0 1\n0 0 0\n")
    with pytest.raises(ParameterError, match="row 2"):
        load_initial_state(tmp_path / "zero.txt")
    with pytest.raises(ParameterError, match="no such file"):
        load_initial_state(tmp_path / "missing.txt")
