"""Whole falls: energy budget, the floor, invariances, reproducibility, guards.

Sizes are small so that CI stays short; BALLCHAIN_FULL=1 runs larger chains.
"""

import math
import os

import numpy as np
import pytest

from ballchain.core.rules import limit_in_force
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.result import EVENT_CODES

FULL = os.environ.get("BALLCHAIN_FULL") == "1"
SIZES = [8, 16, 32, 64] if FULL else [8, 16]


def _fall(n, alpha=math.pi / 4, floor="all", ic=None, rtol=1e-10, **opt):
    return simulate(
        ChainParams(segments=n, alpha=alpha, floor=floor), ic or InitialCondition(), SolverOptions(rtol=rtol, **opt)
    )


@pytest.mark.parametrize("floor", ["all", "pivot"])
@pytest.mark.parametrize("alpha", [math.pi / 6, math.pi / 4, math.pi / 2])
@pytest.mark.parametrize("n", SIZES)
def test_energy_budget_closes_over_whole_fall(n, alpha, floor):
    """initial = potential + kinetic + lost_locking + lost_landing, to 1e-8 of the
    initial potential energy, after a whole fall with thousands of impacts."""
    r = _fall(n, alpha, floor)
    assert r.status == "landed", r.message
    en = r.energy
    assert abs(en["imbalance"]) <= 1e-8 * en["initial"], en
    assert en["lost_locking"] + en["lost_landing"] > 0.5 * en["initial"]  # most energy is dissipated
    assert en["kinetic"] == 0.0  # everything at rest on the floor
    # the frames obey the same budget (dense output: looser)
    total = r.frame_kinetic + r.frame_potential + r.frame_lost_locking + r.frame_lost_landing
    assert np.max(np.abs(total - en["initial"])) <= 1e-6 * en["initial"]
    # each logged constraint dissipates, and the rows add up to the totals
    assert np.isclose(np.sum(r.event_energy), en["lost_locking"] + en["lost_landing"], rtol=1e-9, atol=1e-12)
    assert r.t_fall <= r.t_landed


@pytest.mark.parametrize("n", SIZES)
def test_floor_all_keeps_every_point_above_the_floor(n):
    r = _fall(n, floor="all")
    assert r.status == "landed"
    assert r.max_depth <= 1e-9
    # points at every frame: point j = 2 b sum_{i >= j} e_i
    z = 2.0 * np.cumsum(r.frame_e[:, ::-1, 2], axis=1)[:, ::-1]
    assert z.min() >= -1e-6  # frames come from the dense output (4th order)
    assert np.all(np.abs(r.anchor_pos[:, 2]) <= 1e-9)
    assert np.all(np.isfinite(r.anchor_t))  # every point ended on the floor


def test_pivot_model_reports_penetration():
    """The literal model lets airborne points pass below the floor: max_depth says how deep."""
    r = _fall(16, floor="pivot")
    assert r.status == "landed"
    assert r.max_depth > 0.1


@pytest.mark.parametrize("n", [2, 8, 64])
def test_energy_conserved_without_events(n):
    """alpha = pi: no hinge ever locks; before the first point reaches the floor,
    kinetic + potential energy is constant."""
    r = simulate(
        ChainParams(segments=n, alpha=math.pi),
        InitialCondition(eps=0.02),
        SolverOptions(rtol=1e-11, until=0.5, frames_per_tff=80),
    )
    assert r.event_counts()["lock"] == 0 and r.event_counts()["unlock"] == 0
    t_first = r.event_t[0] if r.event_t.size else np.inf
    smooth = r.frame_t < t_first
    assert np.sum(smooth) >= 10
    e = (r.frame_kinetic + r.frame_potential)[smooth]
    assert r.frame_kinetic[smooth][-1] > 1e-4 * r.energy["initial"]  # it is really moving
    assert np.max(np.abs(e - e[0])) <= 1e-9 * r.energy["initial"]
    assert abs(r.energy["imbalance"]) <= 1e-9 * r.energy["initial"]


def test_units_scaling_m_b_g():
    """A lab chain in SI (0.535 m, 170 beads' worth of mass at 10.2 g/m) and the same chain
    nondimensional give the same times in units of t_ff and energies in units of m g b."""
    n = 12
    si = ChainParams.from_chain(n, length_m=0.535, mass_kg=0.535 * 10.2e-3, gravity_m_s2=9.81)
    nd = ChainParams(segments=n)
    opt = SolverOptions(rtol=1e-10)
    r_si = simulate(si, InitialCondition(), opt)
    r_nd = simulate(nd, InitialCondition(), opt)
    assert r_si.units == "SI" and r_nd.units == "nondimensional"
    assert r_si.t_ff == pytest.approx(math.sqrt(2 * r_si.z0 / 9.81), rel=1e-14)
    assert r_si.t_fall / r_si.t_ff == pytest.approx(r_nd.t_fall / r_nd.t_ff, rel=1e-12)
    assert r_si.t_landed / r_si.t_ff == pytest.approx(r_nd.t_landed / r_nd.t_ff, rel=1e-12)
    eu = si.energy_unit
    for k in ("initial", "lost_locking", "lost_landing"):
        assert r_si.energy[k] / eu == pytest.approx(r_nd.energy[k], rel=1e-12)
    np.testing.assert_allclose(r_si.z_top / si.half_length, r_nd.z_top, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(r_si.event_kind, r_nd.event_kind)


def test_rotation_about_z():
    """Changing phi0 of the helix rotates the chain rigidly about z: the smooth phase and
    the first events are the same, rotated (later events are chaotic, docs/measures.md, section 7)."""
    n, phi = 16, 0.7
    a = _fall(n, ic=InitialCondition(phase=0.0), rtol=1e-11, until=0.5, frames_per_tff=50)
    b = _fall(n, ic=InitialCondition(phase=phi), rtol=1e-11, until=0.5, frames_per_tff=50)
    rot = np.array([[math.cos(phi), -math.sin(phi), 0], [math.sin(phi), math.cos(phi), 0], [0, 0, 1]])
    assert a.event_t.size > 0
    assert b.event_t[0] == pytest.approx(a.event_t[0], rel=1e-9)
    assert b.event_index[0] == a.event_index[0]
    before = a.frame_t < a.event_t[0]
    np.testing.assert_allclose(b.frame_e[before], a.frame_e[before] @ rot.T, atol=1e-9)
    np.testing.assert_allclose(b.frame_floor_force[before], a.frame_floor_force[before] @ rot.T, atol=1e-8)


def test_planar_start_stays_planar():
    """A bend in the x-z plane stays in that plane through locks, unlocks and landings.
    (Under exact planar symmetry a locked arch between two anchors can stand for good, so
    the run is stopped at a fixed time rather than asked to land.)"""
    r = _fall(16, ic=InitialCondition(kind="planar", eps=0.05, turns=1.0, phase=0.0), until=1.5)
    assert r.status == "until", r.message
    assert r.event_counts()["landing"] > 3
    assert r.event_counts()["lock"] > 0
    assert np.max(np.abs(r.frame_e[:, :, 1])) <= 1e-12
    assert np.max(np.abs(r.frame_omega[:, :, [0, 2]])) <= 1e-9
    assert np.nanmax(np.abs(r.anchor_pos[:, 1])) <= 1e-12


@pytest.mark.parametrize("floor", ["all", "pivot"])
def test_same_seed_is_bit_identical(floor):
    ic = InitialCondition(kind="random", eps=0.03, seed=7)
    a = _fall(12, floor=floor, ic=ic, rtol=1e-8)
    b = _fall(12, floor=floor, ic=ic, rtol=1e-8)
    c = _fall(12, floor=floor, ic=InitialCondition(kind="random", eps=0.03, seed=8), rtol=1e-8)
    for name in (
        "t",
        "z_top",
        "frame_e",
        "frame_omega",
        "event_t",
        "event_kind",
        "event_index",
        "event_impulse",
        "anchor_pos",
    ):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.t_fall == b.t_fall and a.t_landed == b.t_landed
    assert not np.array_equal(a.frame_e[0], c.frame_e[0])


def test_locked_set_matches_event_log():
    """Replaying the event log reproduces the locked set at every frame: a hinge becomes
    locked at a lock or hold row and free at an unlock or release row."""
    r = _fall(16)
    locked = np.zeros(15, bool)
    ev = 0
    for f, tf in enumerate(r.frame_t):
        while ev < r.event_t.size and r.event_t[ev] < tf:
            if r.event_kind[ev] in (EVENT_CODES["lock"], EVENT_CODES["hold"]):
                locked[r.event_index[ev]] = True
            elif r.event_kind[ev] in (EVENT_CODES["unlock"], EVENT_CODES["release"]):
                locked[r.event_index[ev]] = False
            ev += 1
        # (a lock whose limit leaves force, rules.limit_in_force, ends with no row: a
        # neighbour landed, or the two segments came to span two anchors)
        a8 = r.frame_anchored[f].astype(np.uint8)
        in_force = np.array([limit_in_force(a8, k, False, r.params.alpha) for k in range(15)])
        np.testing.assert_array_equal(r.frame_locked[f] & in_force, locked & in_force, err_msg=f"frame {f}")


def test_guard_stops_with_clear_message_and_keeps_data():
    r = _fall(16, max_events=50)
    assert r.status == "error"
    assert "max_events" in r.message
    assert r.event_t.size > 50 and r.frame_t.size > 0 and np.isnan(r.t_landed)


def test_until_stops_early():
    r = _fall(8, until=0.3)
    assert r.status == "until"
    assert r.frame_t[-1] <= 0.3 * r.t_ff + 1e-12
    assert np.isnan(r.t_fall)


def test_initial_state_outside_cone_is_rejected():
    with pytest.raises(ParameterError, match="alpha"):
        simulate(ChainParams(segments=16, alpha=0.01), InitialCondition(eps=0.2), SolverOptions())


def test_helix_is_exactly_model_md():
    from ballchain.initial import helix_directions

    n, eps, q, phi0 = 10, 0.02, 1.5, 0.3
    e = helix_directions(n, eps, q, phi0)
    for i in range(n):
        nn = i + 1
        phi = 2 * math.pi * q * (n - nn) / n + phi0
        v = np.array([eps * math.cos(phi), eps * math.sin(phi), 1.0])
        np.testing.assert_allclose(e[i], v / np.linalg.norm(v), rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "method, n, module, kernel",
    [
        ("event", 64, "ballchain.methods.event_driven.driver", "run_events"),
        ("timestep", 256, "ballchain.methods.timestep.driver", "run_steps"),
    ],
)
def test_the_compiled_loop_lets_other_threads_run(monkeypatch, method, n, module, kernel):
    """While a run is in its compiled loop, another Python thread runs: the loop releases
    the GIL.  (A sweep's one worker is a thread of the sweep's process; a loop that held
    the GIL would starve the event loop that sends its heartbeats.)  A second thread
    wakes every millisecond and notes the time; holding the GIL, the loop would let it
    run only between calls, never inside one."""
    import importlib
    import threading
    import time

    driver = importlib.import_module(module)
    compiled = getattr(driver, kernel)
    calls = []

    def timed(*args):
        t0 = time.perf_counter()
        out = compiled(*args)
        calls.append((t0, time.perf_counter()))
        return out

    params = ChainParams(segments=n, alpha=math.pi / 4, floor="all")
    ic = InitialCondition(kind="random", seed=3)
    opts = SolverOptions(method=method, **({"dt": 0.02} if method == "timestep" else {}))
    simulate(ChainParams(segments=8, alpha=math.pi / 4, floor="all"), ic, opts)  # compiled before timing
    monkeypatch.setattr(driver, kernel, timed)
    ticks, done = [], threading.Event()

    def ticker():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    th = threading.Thread(target=ticker, daemon=True)
    th.start()
    try:
        res = simulate(params, ic, opts)
    finally:
        done.set()
        th.join()
    assert res.status == "landed", res.message
    ticks = np.array(ticks)
    long_calls = [(a, b) for a, b in calls if b - a > 0.02]
    inside = sum(int(np.count_nonzero((ticks > a + 0.005) & (ticks < b - 0.005))) for a, b in long_calls)
    busy = sum(b - a for a, b in long_calls)
    assert busy > 0.2, f"the test needs compiled calls of 20 ms or more: {len(long_calls)} of {len(calls)}"
    assert inside >= 20, f"the other thread ran {inside} times in {busy:.2f} s of compiled loop"
