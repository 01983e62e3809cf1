"""Frames never change a time-stepping fall (``--method timestep``).

No step is cut at a frame time: a frame inside a step is filled from that step's start
and end (``stepper.fill_frames``).  So the run's own numbers (its steps, t_fall, the
books at the end, the event log) are the same at every --frames-per-tff, and its frames
are at their nominal times k t_ff / frames_per_tff, samples of that one fall that pass
the run's audit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.audit import audit

RATES = (37.0, 100.0, 1000.0)  # frames per t_ff
BOOKS = ("potential", "kinetic", "lost_locking", "lost_landing", "imbalance", "projected_in_steps")


def _fall(frames_per_tff: float):
    """N = 96, alpha = 60 deg, the random start of seed 9090 (many locks and landings)."""
    return simulate(
        ChainParams(segments=96, alpha=math.radians(60.0)),
        InitialCondition(kind="random", seed=9090),
        SolverOptions(method="timestep", frames_per_tff=frames_per_tff),
    )


@pytest.fixture(scope="module")
def falls():
    return {f: _fall(f) for f in RATES}


def test_the_fall_is_the_same_at_every_frame_rate(falls):
    """Steps, t_fall, t_landed, the books at the end and the event log agree to
    round-off (they were 1.059, 1.164 and 1.046 t_ff apart at 100, 1000 and 37 frames per
    t_ff when frames cut the steps)."""
    ref = falls[RATES[0]]
    assert ref.status == "landed", ref.message
    assert len(ref.event_t) > 200  # locks, unlocks and landings: a fall with many events
    for f in RATES[1:]:
        r = falls[f]
        assert r.status == "landed", r.message
        assert (r.n_steps, r.n_evals) == (ref.n_steps, ref.n_evals)
        assert r.t_fall == pytest.approx(ref.t_fall, rel=1e-12)
        assert r.t_landed == pytest.approx(ref.t_landed, rel=1e-12)
        for name in BOOKS:
            assert r.energy[name] == pytest.approx(ref.energy[name], rel=1e-12, abs=1e-12 * ref.energy["initial"])
        np.testing.assert_allclose(r.floor_impulse_total, ref.floor_impulse_total, rtol=1e-12)
        np.testing.assert_array_equal(r.event_kind, ref.event_kind)
        np.testing.assert_array_equal(r.event_index, ref.event_index)
        np.testing.assert_allclose(r.event_t, ref.event_t, rtol=1e-12)
        np.testing.assert_allclose(r.t, ref.t, rtol=1e-12)  # the trace: the end of every step
        np.testing.assert_allclose(r.z_top, ref.z_top, rtol=1e-12, atol=1e-12)


def test_frames_are_at_their_nominal_times_and_pass_the_audit(falls):
    for f, r in falls.items():
        assert not audit(r), audit(r)
        k = np.arange(len(r.frame_t))
        np.testing.assert_allclose(r.frame_t, k / f * r.t_ff, rtol=1e-12, atol=1e-12 * r.t_ff)
        assert r.frame_t[-1] < r.t_landed <= r.frame_t[-1] + r.t_ff / f * (1 + 1e-9)  # up to the end


def test_a_frame_lies_within_its_step(falls):
    """A frame's top height z_top = 2 sum e_z lies between the trace's at the ends of the
    step its time falls in (the trace records every step's end; a frame from the step's
    start, or from another step, would not: z_top moves by 0.007 b in a step, the
    median here)."""
    for r in falls.values():
        t, z = np.asarray(r.t), np.asarray(r.z_top)
        zf = 2.0 * np.asarray(r.frame_e)[:, :, 2].sum(axis=1)
        i = np.searchsorted(t, r.frame_t)[1:]  # frame 0 is the start
        inside = t[i - 1] < r.frame_t[1:]  # (not at a step's end)
        lo, hi = np.minimum(z[i - 1], z[i]), np.maximum(z[i - 1], z[i])
        assert inside.sum() > 0.9 * len(i)
        assert np.all((zf[1:] >= lo - 1e-9) & (zf[1:] <= hi + 1e-9))


def test_frames_at_two_rates_are_samples_of_one_fall(falls):
    """Every tenth frame at 1000 frames per t_ff is the frame at 100 of the same time."""
    coarse, fine = falls[100.0], falls[1000.0]
    k = np.arange(len(coarse.frame_t))
    assert len(fine.frame_t) >= 10 * (len(k) - 1)
    np.testing.assert_allclose(fine.frame_e[10 * k], coarse.frame_e, atol=1e-9)
    np.testing.assert_allclose(fine.frame_omega[10 * k], coarse.frame_omega, atol=1e-9)
    np.testing.assert_array_equal(fine.frame_anchored[10 * k], coarse.frame_anchored)
    for name in ("frame_kinetic", "frame_potential", "frame_lost_locking", "frame_lost_landing"):
        np.testing.assert_allclose(getattr(fine, name)[10 * k], getattr(coarse, name), rtol=1e-9, atol=1e-9)


def test_a_step_longer_than_the_frame_buffers_fills_every_frame_in_it(monkeypatch):
    """A rod (N = 1) stepped 0.04 t_ff at a time with 2000 frames per t_ff: 80 frames
    fall in each step, and buffers of 16 frames (the smallest) fill five times within
    one.  The frames are those of buffers that hold them all, and the steps the same."""
    from ballchain.methods import outputs

    e0 = np.array([[math.sin(0.3), 0.0, math.cos(0.3)]])
    options = SolverOptions(method="timestep", dt=0.04, frames_per_tff=2000)

    def rod():
        return simulate(ChainParams(segments=1, alpha=math.pi), None, options, state=(e0, None))

    big = rod()
    monkeypatch.setattr(outputs, "FRAME_CHUNK_BYTES", 1)  # buffers of 16 frames
    small = rod()
    assert big.status == small.status == "landed", (big.message, small.message)
    assert small.n_steps == big.n_steps and 80 * small.n_steps > len(small.frame_t) > 40 * small.n_steps
    np.testing.assert_array_equal(small.frame_t, big.frame_t)
    np.testing.assert_array_equal(small.frame_e, big.frame_e)
    np.testing.assert_array_equal(small.frame_kinetic, big.frame_kinetic)
    k = np.arange(len(small.frame_t))
    np.testing.assert_allclose(small.frame_t, k / 2000 * small.t_ff, rtol=1e-12)
