"""Interrupts keep the work: Ctrl-C (SIGINT) or SIGTERM stops a real run at the next
return from compiled code, saves a valid file with status ``interrupted``, and the
data up to the stop are those of an uninterrupted run."""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.files import load_result

N = 256  # a fall of several seconds


def _interrupted_run(tmp_path, sig):
    """Run the CLI in a subprocess and signal it mid-run: later if the signal arrived
    before the run had started (module import, kernel loading), sooner if the whole
    fall ran before it (a fast machine)."""
    # compile the kernels into the on-disk cache first, so that the subprocess only loads them
    simulate(ChainParams(segments=3), InitialCondition(), SolverOptions(until=0.05))
    stderr, wait = "", 5.0
    for attempt in range(6):
        out = tmp_path / f"run-{attempt}.h5"
        p = subprocess.Popen(
            [sys.executable, "-m", "ballchain.cli", "simulate", "-N", str(N), "-q", "--output", str(out)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        time.sleep(wait)
        p.send_signal(sig)
        stdout, stderr = p.communicate(timeout=600)
        status = load_result(out).status if out.exists() else None
        if status == "interrupted":
            return p.returncode, stderr, out
        if status is not None:
            # the fall ended and saved its file before the signal (which may arrive while
            # the interpreter shuts down: the process is killed then, the work kept)
            wait /= 3.0
        else:  # signalled before the run's loop
            wait *= 2.5
    pytest.fail(f"no signal arrived during the run's loop in 6 attempts: {stderr}")


def _same_as_uninterrupted(r, params, t_stop):
    """The interrupted run is a prefix of the same run left to go on (on one machine,
    the same steps give the same numbers): every step, event row and frame up to t_stop.
    (The reference runs past t_stop, so none of its steps up to there is shortened to
    hit its own stop time.)"""
    ref = simulate(params, InitialCondition(), SolverOptions(until=t_stop / r.t_ff + 0.05))
    assert ref.status in ("until", "landed") and ref.t[-1] > t_stop
    assert r.energy["initial"] == ref.energy["initial"]
    k = r.t.size
    np.testing.assert_array_equal(r.t, ref.t[:k])
    np.testing.assert_array_equal(r.z_top, ref.z_top[:k])
    a, b = r.event_t <= t_stop, ref.event_t <= t_stop
    assert a.all() and a.sum() == b.sum() > 100
    for name in ("event_t", "event_kind", "event_index", "event_impulse", "event_energy"):
        np.testing.assert_array_equal(getattr(r, name), getattr(ref, name)[b], err_msg=name)
    f = r.frame_t.size
    assert f > 0 and ref.frame_t[f - 1] == r.frame_t[-1]
    for name in (
        "frame_t",
        "frame_e",
        "frame_omega",
        "frame_anchored",
        "frame_locked",
        "frame_kinetic",
        "frame_lost_locking",
    ):
        np.testing.assert_array_equal(getattr(r, name), getattr(ref, name)[:f], err_msg=name)


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_saves_the_work(tmp_path, sig, code):
    rc, stderr, out = _interrupted_run(tmp_path, sig)
    assert rc == code, stderr
    err = stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: interrupted by"), stderr
    r = load_result(out)
    assert r.status == "interrupted"
    t_stop = r.t[-1]
    assert 0.0 < t_stop and r.event_t.size > 100  # (mid-fall: before or after t_ff, as the machine's speed has it)
    _same_as_uninterrupted(r, ChainParams(segments=N), t_stop)
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]


def test_ctrl_c_in_python_returns_the_work_so_far():
    """In-process (a notebook's Ctrl-C): the first SIGINT ends the run at the next safe
    point and ``simulate`` returns the result so far instead of raising."""
    import os

    sent = []

    def progress(fraction, info):
        if not sent and info["t_over_tff"] > 0.3:
            sent.append(info["t_over_tff"])
            os.kill(os.getpid(), signal.SIGINT)

    params = ChainParams(segments=64)
    before = signal.getsignal(signal.SIGINT)  # (SIG_IGN in a background job)
    r = simulate(params, InitialCondition(), SolverOptions(), progress=progress)
    assert sent and r.status == "interrupted" and r.message.startswith("SIGINT"), r.message
    t_stop = r.t[-1]
    assert sent[0] * r.t_ff <= t_stop < r.t_ff
    # the handler in place before the run is restored after it
    assert signal.getsignal(signal.SIGINT) is before
    _same_as_uninterrupted(r, params, t_stop)
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]


def test_a_signal_before_any_work_stops_at_once(monkeypatch):
    """A Ctrl-C that arrives before the first return from compiled code (e.g. while the
    kernels compile on a first run) has nothing to keep: it stops at once."""
    import os

    from ballchain.methods.event_driven import driver

    real = driver.run_events
    calls = []

    def signalled_first_call(*args):
        if not calls:
            os.kill(os.getpid(), signal.SIGINT)  # delivered before the compiled call starts
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(driver, "run_events", signalled_first_call)
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        simulate(ChainParams(segments=8), InitialCondition(), SolverOptions())
    assert not calls and signal.getsignal(signal.SIGINT) is before  # raised before the compiled call
