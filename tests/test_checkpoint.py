"""Checkpoints: a run killed mid-fall resumes from its last checkpoint and ends exactly
as the same run left alone (on one machine the same steps give the same numbers), with
any method, from the command line and in a sweep; a checkpoint of another run or
of another engine is refused, never mixed in."""

import json
import os
import signal

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.methods.checkpoint import Checkpoint, CheckpointError
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.files import load_result

IC = InitialCondition(kind="random", seed=7, spawn_key=(1,))
CASES = {
    # (chain, options): falls with several returns from compiled code before t_ff / 2
    "event": (ChainParams(segments=24), SolverOptions()),
    "timestep": (ChainParams(segments=24), SolverOptions(method="timestep", dt=0.005)),
    "rattle": (ChainParams(segments=24), SolverOptions(method="rattle", dt=0.005)),
}
FIELDS = (
    "t", "z_top", "frame_t", "frame_e", "frame_omega", "frame_anchored", "frame_locked", "frame_floor_force",
    "frame_kinetic", "frame_potential", "frame_lost_locking", "frame_lost_landing", "frame_lost_damping", "frame_floor_impulse",
    "event_t", "event_kind", "event_index", "event_impulse", "event_energy", "event_pos", "anchor_t", "anchor_pos",
    "floor_impulse", "floor_impulse_total",
)  # fmt: skip


class Killed(Exception):
    """Stands for the process dying (a kill, the end of a session) in mid-fall."""


def _header(path) -> dict:
    with np.load(path, allow_pickle=False) as z:
        return json.loads(str(z["header"]))


def _kill_after(t_over_tff: float):
    def progress(fraction, info):
        if info["t_over_tff"] > t_over_tff:
            raise Killed

    return progress


def _killed(params, ic, options, path) -> dict:
    """Run with a checkpoint saved at every return from compiled code (every = 0) and
    kill it at t_ff / 2; returns the checkpoint's header (the last return before)."""
    with pytest.raises(Killed):
        simulate(params, ic, options, checkpoint=Checkpoint(path, every=0.0), progress=_kill_after(0.5))
    return _header(path)


def _assert_same_run(res, ref):
    assert res.status == ref.status == "landed"
    assert (res.t_fall, res.t_landed, res.n_steps, res.n_evals) == (ref.t_fall, ref.t_landed, ref.n_steps, ref.n_evals)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(res, name), getattr(ref, name), err_msg=name)
    assert res.energy == ref.energy
    assert res.max_depth == ref.max_depth


@pytest.mark.parametrize("method", sorted(CASES))
def test_a_killed_run_resumes_to_the_same_fall(tmp_path, method):
    params, options = CASES[method]
    ref = simulate(params, IC, options)
    path = tmp_path / "run.ckpt.npz"
    saved = _killed(params, IC, options, path)
    assert 0.0 < saved["t"] <= 0.5 * ref.t_ff and saved["engine"] == ref.engine
    res = simulate(params, IC, options, checkpoint=Checkpoint(path, every=0.0))
    _assert_same_run(res, ref)
    assert res.message.startswith(f"resumed at t/t_ff = {saved['t'] / ref.t_ff:.6f}"), res.message
    assert res.wall_seconds >= saved["wall_seconds"]
    assert path.exists()  # the caller removes it once the result is safe (Checkpoint.discard)


def test_an_interrupted_run_saves_a_checkpoint_and_resumes(tmp_path):
    """Ctrl-C: the run ends ``interrupted`` with its checkpoint written at that point,
    and the same call resumes it to the fall left alone."""
    params, options = CASES["timestep"]
    ref = simulate(params, IC, options)
    path = tmp_path / "run.ckpt.npz"
    sent = []

    def progress(fraction, info):
        if not sent and info["t_over_tff"] > 0.3:
            sent.append(1)
            os.kill(os.getpid(), signal.SIGINT)

    r = simulate(params, IC, options, checkpoint=Checkpoint(path, every=1e9), progress=progress)
    assert r.status == "interrupted" and f"checkpoint saved to {path}" in r.message, r.message
    assert _header(path)["t"] == pytest.approx(r.t[-1] / params.time_unit, rel=1e-15)
    res = simulate(params, IC, options, checkpoint=str(path))
    _assert_same_run(res, ref)


def test_another_run_or_engine_is_refused(tmp_path):
    params, options = CASES["timestep"]
    path = tmp_path / "run.ckpt.npz"
    _killed(params, IC, options, path)
    other_dt = SolverOptions(method="timestep", dt=0.01)
    with pytest.raises(CheckpointError, match="another run.*options"):
        simulate(params, IC, other_dt, checkpoint=path)
    with pytest.raises(CheckpointError, match="another run.*start"):
        simulate(params, InitialCondition(kind="random", seed=7, spawn_key=(2,)), options, checkpoint=path)
    # the same run, written by other code
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays["header"]))
    header["engine"] = "0123456789ab"
    arrays["header"] = np.array(json.dumps(header))
    other = tmp_path / "other-engine.ckpt.npz"
    with open(other, "wb") as fh:
        np.savez(fh, **arrays)
    with pytest.raises(CheckpointError, match="written by engine 0123456789ab"):
        simulate(params, IC, options, checkpoint=other)
    broken = tmp_path / "broken.ckpt.npz"
    broken.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(CheckpointError, match="unreadable"):
        simulate(params, IC, options, checkpoint=broken)
    assert issubclass(CheckpointError, ParameterError)  # (the command line's usage error)
    with pytest.raises(ParameterError, match="not a file name"):
        Checkpoint(tmp_path)
    with pytest.raises(ParameterError, match=">= 0"):
        Checkpoint(path, every=-1.0)


def test_cli_resumes_and_removes_its_checkpoint(tmp_path):
    params, options = CASES["timestep"]
    ref = simulate(params, IC, options)
    ck = tmp_path / "ck" / "run.ckpt.npz"  # (its directory is created)
    _killed(params, IC, options, ck)
    out = tmp_path / "run.h5"
    args = ["simulate", "-N", "24", "--ic", "random", "--seed", "7", "--spawn-key", "1", "--method", "timestep"]
    args += ["--dt", "0.005", "-q", "--checkpoint", str(ck), "--output", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert not ck.exists()  # the run ended and its result is saved
    r = load_result(out)
    assert r.message.startswith("resumed at"), r.message
    _assert_same_run(r, ref)
    # a checkpoint of another run: a usage error, and the file is left alone
    _killed(params, IC, options, ck)
    bad = CliRunner().invoke(app, [*args[:-2], "--dt", "0.01"])
    assert bad.exit_code == 2 and "another run" in bad.output and ck.exists(), bad.output


def test_sweep_runs_resume_from_their_checkpoints(tmp_path):
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.execute import run_task

    spec = SweepSpec(
        segments=(24,), alphas=(np.pi / 4,), runs=2, seed=7, method="timestep", dt=0.005, checkpoints=str(tmp_path)
    )
    tasks = spec.tasks()
    assert [t.checkpoint_path for t in tasks] == [str(tmp_path / f"{t.run_id}.ckpt.npz") for t in tasks]
    task = tasks[1]  # spawn key (1,), seed 7: the start of IC
    assert task.ic == IC
    ref = simulate(task.params, task.ic, task.options)
    _killed(task.params, task.ic, task.options, task.checkpoint_path)
    row = run_task(task)
    assert row["status"] == "landed" and row["message"].startswith("resumed at"), row
    assert row["ratio"] == ref.t_fall / ref.t_ff
    assert not os.path.exists(task.checkpoint_path)


def test_sweep_cli_checkpoints_and_leaves_none_behind(tmp_path):
    ck, out = tmp_path / "ck", tmp_path / "t.parquet"
    args = ["sweep", "-N", "10", "--runs", "2", "--seed", "3", "--method", "timestep", "--dt", "0.02"]
    res = CliRunner().invoke(app, [*args, "--checkpoints", str(ck), "--checkpoint-every", "0", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert ck.is_dir() and not list(ck.iterdir())  # every run ended: its checkpoint is gone
    bad = CliRunner().invoke(app, [*args, "--checkpoint-every", "-1", "--out", str(tmp_path / "u.parquet")])
    assert bad.exit_code == 2 and "checkpoint-every" in bad.output, bad.output


def test_a_checkpoint_that_cannot_be_written_does_not_stop_the_run(tmp_path):
    """A full disk or a directory gone: the fall goes on to its end, and its message says
    the checkpoint was not written."""
    params, options = CASES["timestep"]
    ck = Checkpoint(tmp_path / "gone" / "run.ckpt.npz", every=0.0)
    (tmp_path / "gone").rmdir()  # (created by the constructor, removed before the run)
    r = simulate(params, IC, options, checkpoint=ck)
    assert r.status == "landed" and "checkpoint not written" in r.message, r.message
    assert r.t_fall == simulate(params, IC, options).t_fall


def test_an_interrupted_sweep_saves_its_runs_checkpoints_and_resumes_them(tmp_path, monkeypatch):
    """Ctrl-C on a sweep: its run under way (in a worker thread, which signals do not
    reach) is asked to stop at its next return from compiled code and saves its
    checkpoint there (no periodic one is due); its row is not written; the same sweep
    resumes it from there and removes the checkpoint."""
    import threading

    import ballchain.engine as engine
    from ballchain.engine import load_kernels
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.execute import read_table, run_sweep

    load_kernels("timestep")
    spec = SweepSpec(
        segments=(256,), alphas=(np.pi / 4,), runs=1, seed=7, method="timestep", dt=0.01,
        checkpoints=str(tmp_path / "ck"), checkpoint_every=1e9,
    )  # fmt: skip
    (task,) = spec.tasks()
    started = threading.Event()
    real = engine.simulate

    def watched(*args, **kwargs):
        if kwargs.get("checkpoint") is not None:  # the sweep's run (not the kernels' warm-up)
            started.set()
        return real(*args, **kwargs)

    monkeypatch.setattr(engine, "simulate", watched)

    ended = threading.Event()

    def interrupt():  # half a second into the run (a few returns from compiled code), if the sweep still runs
        if started.wait(120) and not ended.wait(0.5):
            os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt, daemon=True).start()
    out = tmp_path / "t.parquet"
    try:
        report = run_sweep(spec, out, workers=1, progress=False)
    finally:
        ended.set()
    assert report.interrupted and report.ran == 0
    assert not read_table(out)  # no row: the run is not done
    header = _header(task.checkpoint_path)
    assert header["t"] > 0.0
    assert engine.stop_requested() is None  # the request ends with the sweep
    monkeypatch.setattr(engine, "simulate", real)
    report = run_sweep(spec, out, workers=1, progress=False)
    (row,) = read_table(out)
    assert row["status"] == "landed" and row["message"].startswith("resumed at"), row
    assert not os.path.exists(task.checkpoint_path)
