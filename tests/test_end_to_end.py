"""The command line with the real engine, and what a real run writes: the file's event
kinds are the documented ones, the rows' positions are the chain's, frames stream in
chunks without changing a number, and runs that cannot fit are refused before they
start."""

import json
import math
import subprocess
import sys

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.methods import outputs
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.files import load_result
from ballchain.records.result import EVENT_KINDS

runner = CliRunner()


def test_simulate_saves_and_info_reads_a_real_run(tmp_path):
    out = tmp_path / "fall.h5"
    res = runner.invoke(app, ["simulate", "-N", "12", "--floor", "pivot", "--json", "-q", "--output", str(out)])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["status"] == "landed" and s["segments"] == 12
    r = load_result(out)
    assert r.status == "landed" and r.event_counts() == s["events"]
    # the summary's momentum record balances (chain at rest at both ends): M g t_landed
    assert s["floor_impulse_total"][2] == pytest.approx(12 * s["t_landed"], rel=1e-7)
    assert set(s["events"]) == set(EVENT_KINDS.values())
    # every kind the engine wrote is documented, in the code and in the file
    kinds = set(np.unique(r.event_kind).tolist())
    assert kinds <= set(EVENT_KINDS) and {1, 3, 4, 8} <= kinds
    with h5py.File(out) as f:
        in_file = {int(c) for c in json.loads(f["events"].attrs["kinds"])}
    assert kinds <= in_file
    info = runner.invoke(app, ["info", str(out), "--json"])
    assert info.exit_code == 0, info.output
    assert json.loads(info.stdout)["status"] == "landed"


def test_event_rows_carry_the_position_of_their_hinge_or_point():
    """Landing rows sit where the point touched, which is where it is held (recorded
    apart, in anchor_pos) up to the located state's drift from the anchors already made
    (a point beside an anchored neighbour is held at the neighbour's anchor plus the
    segment between them: rules.hold_at); lock rows sit where the frames put hinge k, i.e. point k + 1, at that time."""
    fpt = 4000
    r = simulate(ChainParams(segments=10), InitialCondition(eps=0.05), SolverOptions(frames_per_tff=fpt))
    land = r.event_kind == 3
    np.testing.assert_allclose(r.event_pos[land], r.anchor_pos[r.event_index[land]], rtol=0, atol=1e-10)
    assert np.all(np.abs(r.event_pos[land, 2]) < 1e-9)
    lock = np.flatnonzero(r.event_kind == 1)
    assert lock.size > 10
    pts = r.points()
    dt = r.t_ff / fpt
    speed = np.max(np.abs(np.diff(pts, axis=0))) / dt  # fastest point between frames
    for i in lock:
        f = int(np.argmin(np.abs(r.frame_t - r.event_t[i])))
        near = pts[f, r.event_index[i] + 1]
        assert np.linalg.norm(r.event_pos[i] - near) <= speed * abs(r.frame_t[f] - r.event_t[i]) + 1e-9
        # and not the neighbouring points (a hinge k row is point k + 1, not k or k + 2)
        assert np.linalg.norm(r.event_pos[i] - pts[f, r.event_index[i]]) > 1.0


def test_points_follow_the_stated_conventions():
    r = simulate(ChainParams(segments=5), InitialCondition(eps=0.1), SolverOptions(until=0.3))
    p = r.points()
    assert p.shape == (r.frame_t.size, 6, 3)
    np.testing.assert_array_equal(p[:, 5], 0.0)  # point N, the pivot, at the origin
    seg = np.linalg.norm(p[:, :-1] - p[:, 1:], axis=-1)
    np.testing.assert_allclose(seg, 2.0, rtol=1e-8)  # segments 2b long (frames: dense output, the default rtol)
    np.testing.assert_allclose(p[0, 0, 2], r.z0, rtol=1e-14)  # point 0 is the top end
    np.testing.assert_allclose(p[:, 0, 2], np.interp(r.frame_t, r.t, r.z_top), atol=1e-3)


def test_frames_stream_in_chunks_without_changing_a_number(monkeypatch):
    """With buffers of a few frames only, the run returns to empty them many times and
    redoes the step it stopped in: the result is that of one big buffer (same machine)."""
    params, ic, opts = ChainParams(segments=8), InitialCondition(eps=0.05), SolverOptions(frames_per_tff=300)
    whole = simulate(params, ic, opts)
    monkeypatch.setattr(outputs, "FRAME_CHUNK_BYTES", 7 * outputs.frame_bytes(8))
    chunked = simulate(params, ic, opts)
    assert chunked.frame_t.size == whole.frame_t.size > 300
    for name in (
        "frame_t",
        "frame_e",
        "frame_omega",
        "frame_floor_impulse",
        "frame_pile_pull",
        "event_t",
        "event_pos",
        "t",
    ):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name), err_msg=name)
    assert chunked.t_landed == whole.t_landed


def test_a_long_until_costs_what_is_written():
    res = runner.invoke(app, ["simulate", "-N", "2", "--until", "1e9", "--frames-per-tff", "10", "--json", "-q"])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["status"] == "landed" and s["landed_ratio"] < 10


@pytest.mark.parametrize(
    "args, option", [(["-N", "2", "--frames-per-tff", "1e12"], "--frames-per-tff"), (["-N", "100000000"], "--segments")]
)
def test_a_run_that_cannot_fit_is_refused_before_it_starts(args, option):
    p = subprocess.run(
        [sys.executable, "-m", "ballchain.cli", "simulate", *args, "-q"], capture_output=True, text=True, timeout=120
    )
    assert p.returncode == 2
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: memory:") and option in err[0], p.stderr
    assert "Traceback" not in p.stderr


def test_theory_commands():
    from ballchain.theory import gamma_from_time_ratio, hamm_geminard_time_ratio, pivot_rod_critical_s

    r = runner.invoke(app, ["theory", "hamm-geminard", "--gamma", "0", "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["time_ratio"] == hamm_geminard_time_ratio(0.0)
    r = runner.invoke(app, ["theory", "gamma", "--ratio", "0.9", "--json"])
    assert json.loads(r.stdout)["gamma"] == gamma_from_time_ratio(0.9)
    r = runner.invoke(app, ["theory", "pivot-rod", "--theta0", "30deg", "--s", "0.2", "--theta", "1", "--json"])
    out = json.loads(r.stdout)
    assert out["critical_s"] == pivot_rod_critical_s(math.pi / 6) and out["impulse"] > 0
    bad = runner.invoke(app, ["theory", "hamm-geminard", "--gamma", "2"])
    assert bad.exit_code == 2 and "gamma" in bad.output


def test_frames_do_not_change_the_trajectory():
    """--frames-per-tff sets only what is written: frames come from the steps' dense output
    and the step sequence does not depend on them (as the help says), so a whole fall with
    many lock events is the same at 20 and 500 frames per t_ff."""
    runs = [
        simulate(ChainParams(segments=10), InitialCondition(eps=0.05), SolverOptions(frames_per_tff=f))
        for f in (20, 500)
    ]
    a, b = runs
    assert a.n_steps == b.n_steps and a.n_instants == b.n_instants > 50
    assert a.event_counts() == b.event_counts()
    assert b.t_fall == pytest.approx(a.t_fall, rel=1e-12) and b.t_landed == pytest.approx(a.t_landed, rel=1e-12)
    # the frames they share (every 25th of the finer run) hold the same states
    np.testing.assert_allclose(
        b.frame_e[::25][: a.frame_e.shape[0]], a.frame_e[: b.frame_e[::25].shape[0]], rtol=0, atol=1e-12
    )
