"""ballchain's side of the comparison: the benchmark state, one evaluation of the
accelerations, and a run of free motion.

``ballchain_eval`` is the ONLY place that knows the kernel's signature: adapt it if
``ballchain.core.dynamics.accelerations`` changes.
"""

from __future__ import annotations

import math
import time

import numpy as np


def random_state(n: int, rng, tilt: float = 0.3, locked_fraction: float = 0.3):
    """A near-vertical chain: random horizontal tilts (about ``tilt`` rad), random angular
    velocities perpendicular to the rods, and a random set of locked hinges (hinge k is
    between segments k and k+1).  Returns e, w, locked."""
    e = np.zeros((n, 3))
    e[:, 2] = 1.0
    e[:, :2] = tilt * rng.standard_normal((n, 2))
    e /= np.linalg.norm(e, axis=1)[:, None]
    w = rng.standard_normal((n, 3))
    w -= np.einsum("ij,ij->i", w, e)[:, None] * e
    locked = (rng.random(max(n - 1, 0)) < locked_fraction).astype(np.uint8)
    return e, w, locked


def ballchain_eval(e: np.ndarray, w: np.ndarray, locked: np.ndarray | None = None):
    """A zero-argument callable evaluating ballchain's accelerations once at (e, w), the
    bottom point pinned, hinges ``locked`` (default none).  It returns (de, dw): de = w x e,
    dw = world-frame angular accelerations (perpendicular to e)."""
    from ballchain.core.dynamics import accelerations
    from ballchain.core.state import new_work

    n = e.shape[0]
    e = np.ascontiguousarray(e, dtype=float)
    w = np.ascontiguousarray(w, dtype=float)
    ws = new_work(n)
    anchored = np.zeros(n + 1, np.uint8)
    anchored[n] = 1
    if locked is None:
        locked = np.zeros(max(n - 1, 0), np.uint8)
    locked = np.ascontiguousarray(locked, dtype=np.uint8)
    de = np.zeros((n, 3))
    dw = np.zeros((n, 3))
    args = (e, w, anchored, locked, ws, de, dw)

    def call():
        accelerations(*args)
        return de, dw

    return call


def free_fall_setup(n: int):
    """Default helix initial condition, no locks (alpha = pi): (params, ic, e0, t_ff)."""
    from ballchain.initial import initial_directions
    from ballchain.model import ChainParams, InitialCondition

    params = ChainParams(segments=n, alpha=math.pi)
    ic = InitialCondition()
    e0 = initial_directions(ic, n, math.pi)
    t_ff = math.sqrt(2.0 * 2.0 * float(np.sum(e0[:, 2])))
    return params, ic, e0, t_ff


def simulate_interval(n: int, until: float, rtol: float, frames: int = 1):
    """Run ballchain's ``simulate`` from the default helix, no locks, until ``until`` t_ff.

    ``frames`` frames are requested over the interval (the last one at ``until``, which
    is nudged up by 1e-9 so that the accumulated frame time is not lost to rounding).  Returns a dict with the final
    time t (nondimensional), e, w at t, the wall time, the minimum height of the points
    over the frames, the landing count and the status.
    """
    from ballchain.engine import simulate
    from ballchain.model import SolverOptions

    params, ic, e0, t_ff = free_fall_setup(n)
    opts = SolverOptions(rtol=rtol, until=until * (1 + 1e-9), frames_per_tff=frames / until)
    t0 = time.perf_counter()
    r = simulate(params, ic, opts)
    wall = time.perf_counter() - t0
    k = int(np.argmin(np.abs(r.frame_t - until * r.t_ff)))
    if abs(r.frame_t[k] - until * r.t_ff) > 1e-9 * r.t_ff:
        raise RuntimeError(f"no frame at {until} t_ff (frames at {r.frame_t / r.t_ff})")
    heights = np.cumsum(2.0 * r.frame_e[:, ::-1, 2], axis=1)  # points N-1 .. 0, every frame
    return dict(
        t=float(r.frame_t[k]),
        e=r.frame_e[k].copy(),
        w=r.frame_omega[k].copy(),
        wall=wall,
        min_z=float(heights.min()),
        landings=int(r.event_counts()["landing"]),
        status=r.status,
        t_ff=r.t_ff,
        e0=e0,
        steps=int(r.n_steps),
        evals=int(r.n_evals),
    )


def full_fall(n: int, alpha: float = math.pi / 4):
    """ballchain's full fall (default helix, default solver options, floor model of the
    defaults) at bend limit alpha.  Returns a dict: wall, status, t_fall and t_landed
    (in t_ff), steps, evals, and the energy imbalance relative to the initial energy."""
    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions

    t0 = time.perf_counter()
    r = simulate(ChainParams(segments=n, alpha=alpha), InitialCondition(), SolverOptions())
    wall = time.perf_counter() - t0
    return dict(
        wall=wall,
        status=r.status,
        t_fall=r.t_fall / r.t_ff,
        t_landed=None if r.t_landed is None else r.t_landed / r.t_ff,
        steps=int(r.n_steps),
        evals=int(r.n_evals),
        imbalance=abs(r.energy["imbalance"]) / r.energy["initial"],
    )
