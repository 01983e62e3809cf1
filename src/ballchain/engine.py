"""One run: parameters -> initial state -> integrator + events -> Result.

The step loop (``integrator.advance``) and the one event handler
(``events.handle_event``) run together in compiled code (``events.run_events``),
returning here only every ``RETURN_EVERY`` event instants for progress, when a buffer
fills, or at the end.  The rules they apply are in ``rules`` (docs/model.md, "Events").
Event accumulation that the rules cannot resolve stops the run with a clear error:
more than ``ZENO_EVENTS`` event instants within ``ZENO_WINDOW`` t_ff, or more than
``options.max_events`` in all; the result keeps what was computed.
"""

from __future__ import annotations

import math
import os
import signal
import threading
import time as _time
from typing import Callable

import numpy as np

from . import __version__
from .core.dynamics import Workspace, kinetic_energy, potential_energy
from .methods.event_driven.events import (
    ERR_ENERGY,
    ERR_IMPACT_LCP,
    ERR_LOCK_LCP,
    ERR_MAX_EVENTS,
    ERR_ZENO,
    EV_LANDED,
    EV_RETURN,
    arm_functions,
    log_room,
    run_events,
)
from .core.impacts import hinge_gaps
from .initial import check_inside_cone, initial_directions
from .methods.event_driven.integrator import ADV_BUFFER, ADV_FAIL_NAN, ADV_FAIL_STEP, ADV_MAX_STEPS, ADV_STOP
from .model import ChainParams, InitialCondition, ParameterError, SolverOptions
from .records.result import EVENT_KINDS, Result
from .core.rules import FLOOR_CODES

LOOSE_RTOL = 1e-7  # an impact that fails above this tolerance gets a hint to tighten it
RETURN_EVERY = 256  # events handled in compiled code between returns to Python (progress)
ZENO_EVENTS = 20000
ZENO_WINDOW = 1e-9  # in units of t_ff


ERROR_MESSAGES = {
    ERR_IMPACT_LCP: "impact LCP did not converge",
    ERR_ENERGY: "an impact raised the kinetic energy",
    ERR_LOCK_LCP: "lock-set LCP did not converge",
}


def kernels_cached() -> bool:
    """Are the compiled kernels in numba's on-disk cache (or compiled in this process)?
    False means the next run compiles them first (a minute or two, once)."""
    if run_events.signatures:
        return True
    try:
        return bool(run_events._cache._cache_file._load_index())
    except Exception:  # pragma: no cover - a numba without this (private) layout
        return True


def load_kernels() -> bool:
    """Load the compiled kernels from numba's cache (the first time: compile them) with
    a tiny run, so that the wall time of the next run is its integration alone.  Returns
    whether they had to be compiled."""
    cold = not kernels_cached()
    simulate(ChainParams(segments=2), InitialCondition(), SolverOptions(until=0.05))
    return cold


class SimulationError(RuntimeError):
    """A run that cannot go on (blow-up, event accumulation, singular configuration)."""


class Interrupted(KeyboardInterrupt):
    """Raised by a second SIGINT or SIGTERM during a run (the first one asks the run to
    stop at the next safe point and keep its work, see ``_StopOnSignals``)."""

    def __init__(self, reason: str = "SIGTERM"):
        super().__init__(reason)
        self.reason = reason


class _StopOnSignals:
    """While a run lasts (main thread only), the first SIGINT (Ctrl-C) or SIGTERM asks
    it to stop at the next return from compiled code, where the state and every buffer
    are consistent; the run then ends with status ``interrupted`` and keeps its work.
    A second signal, or one that comes before any work was done (``started`` is False:
    e.g. while the kernels compile on a first run), stops at once (``Interrupted``)."""

    NAMES = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM"}

    def __init__(self):
        self.reason: str | None = None
        self.started = False
        self.old: dict = {}

    def _handler(self, signum, frame):
        if self.reason is not None or not self.started:
            raise Interrupted(self.NAMES.get(signum, str(signum)))
        self.reason = self.NAMES.get(signum, str(signum))

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in self.NAMES:
                try:
                    self.old[sig] = signal.signal(sig, self._handler)
                except (ValueError, OSError):  # pragma: no cover - embedded interpreters
                    pass
        return self

    def __exit__(self, *exc):
        for sig, old in self.old.items():
            signal.signal(sig, old)
        return False


class _Log:
    """The event log in growable arrays (written by the compiled handler in place)."""

    def __init__(self, cap: int = 4096):
        self.n = np.zeros(1, np.int64)
        self._alloc(cap)

    def _alloc(self, cap):
        old = getattr(self, "arrays", None)
        k = int(self.n[0])
        arrays = (np.zeros(cap), np.zeros(cap, np.int64), np.zeros(cap, np.int64), np.zeros((cap, 3)),
                  np.zeros(cap), np.zeros((cap, 3)))
        if old is not None:
            for new_a, old_a in zip(arrays, old):
                new_a[:k] = old_a[:k]
        self.arrays = arrays

    def reserve(self, rows: int) -> None:
        """Make room for ``rows`` more rows (capacity doubles)."""
        cap = self.arrays[0].shape[0]
        if cap - int(self.n[0]) < rows:
            self._alloc(max(2 * cap, int(self.n[0]) + rows))

    def __len__(self) -> int:
        return int(self.n[0])

    def view(self):
        """(t, kind, index, impulse, energy, position) of the rows written so far."""
        k = int(self.n[0])
        return tuple(a[:k] for a in self.arrays)


FRAME_CHUNK_BYTES = 32 << 20  # frame buffers are emptied into the result this often


class _Frames:
    """Output frames in fixed-size buffers that the compiled loop fills (``advance``
    returns ADV_BUFFER when they are full); ``flush`` moves them into chunks, so a run
    holds what it has written, never what it might write."""

    def __init__(self, n: int, frame_dt: float, frames_wanted: float):
        per_frame = frame_bytes(n)
        self.cap = int(max(16, min(frames_wanted + 2, FRAME_CHUNK_BYTES // per_frame)))
        cap, nh = self.cap, max(n - 1, 0)
        self.names = ("t", "e", "omega", "anchored", "locked", "floor_force", "kinetic", "potential",
                      "pile_pull", "scale_force", "floor_impulse", "lost_locking", "lost_landing")
        self.buf = {
            "t": np.zeros(cap), "e": np.zeros((cap, n, 3)), "omega": np.zeros((cap, n, 3)),
            "anchored": np.zeros((cap, n + 1), np.uint8), "locked": np.zeros((cap, nh), np.uint8),
            "floor_force": np.zeros((cap, 3)), "kinetic": np.zeros(cap), "potential": np.zeros(cap),
            "pile_pull": np.zeros((cap, 3)), "scale_force": np.zeros(cap), "floor_impulse": np.zeros((cap, 3)),
            "lost_locking": np.zeros(cap), "lost_landing": np.zeros(cap),
        }
        self.count = np.zeros(1, np.int64)
        self.fill = np.zeros(1, np.int64)
        self.next = np.zeros(1)
        self.chunks = {name: [] for name in self.names}
        b = self.buf
        self.compiled = (frame_dt, self.next, cap, b["t"], b["e"], b["omega"], b["anchored"], b["locked"],
                         b["floor_force"], b["kinetic"], b["potential"], self.count, b["pile_pull"],
                         b["scale_force"], b["floor_impulse"], b["lost_locking"], b["lost_landing"], self.fill)

    def flush(self) -> None:
        k = int(self.count[0])
        if k:
            parts = {name: self.buf[name][:k].copy() for name in self.names}
            for name in self.names:
                self.chunks[name].append(parts[name])
        self.count[0] = 0
        self.fill[0] = 0

    def arrays(self) -> dict:
        self.flush()
        return {name: np.concatenate(self.chunks[name]) if self.chunks[name] else self.buf[name][:0]
                for name in self.names}


def frame_bytes(n: int) -> int:
    """Bytes one output frame of an N-segment chain takes in memory."""
    return 8 * (2 * 3 * n) + (n + 1) + max(n - 1, 0) + 8 * 14


def run_bytes(n: int) -> int:
    """Bytes the working arrays of an N-segment run take, not counting output (measured
    with tracemalloc: 5.4-6.8 kB per segment for N = 1000-16000)."""
    return 7000 * (n + 1) + (4 << 20)


def available_memory() -> int | None:
    """Bytes of memory available to a new run (MemAvailable), None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


MIN_RUN_TFF = 0.5  # every run that is not stopped earlier lasts at least this long (t_ff)


def check_memory(params: ChainParams, options: SolverOptions) -> None:
    """Refuse, before it starts, a run that cannot fit in memory: its working arrays
    and the frames it will surely write (up to ``until`` or MIN_RUN_TFF t_ff, twice:
    chunks and the final arrays).  One-line ParameterError naming what to change."""
    avail = available_memory()
    if avail is None:
        return
    n = params.segments
    horizon = min(options.until, MIN_RUN_TFF) if options.until is not None else MIN_RUN_TFF
    frames = horizon * options.frames_per_tff
    work = run_bytes(n)
    out = 2.0 * frames * frame_bytes(n)
    if work + out <= avail:
        return
    gib = 1024.0 ** 3
    what = ("lower --frames-per-tff (or --until)" if out > work else "lower --segments (-N)")
    raise ParameterError(f"memory: this run needs at least {(work + out) / gib:.3g} GiB ({n} segments, "
                         f"{frames:.3g} frames), {avail / gib:.3g} GiB are available: {what}")


class Run:
    """The mutable state of one run (kept out of the frozen parameter objects)."""

    def __init__(self, params: ChainParams, e0: np.ndarray, w0: np.ndarray, options: SolverOptions):
        n = params.segments
        self.p = params
        self.o = options
        self.n = n
        self.Y = np.zeros((2, n, 3))
        self.Y[0] = e0
        self.Y[1] = w0
        self.anchored = np.zeros(n + 1, np.uint8)
        self.anchored[n] = 1
        self.locked = np.zeros(max(n - 1, 0), np.uint8)
        self.lock_cos = np.full(max(n - 1, 0), math.cos(params.alpha))  # cosine held by each lock
        self.anchor_pos = np.full((n + 1, 3), np.nan)
        self.anchor_pos[n] = 0.0
        self.anchor_t = np.full(n + 1, np.nan)
        self.anchor_t[n] = 0.0
        # how each event function is watched (rules.arm_state; set by arm_functions)
        self.arm_lock = np.zeros(max(n - 1, 0), np.int8)
        self.arm_unlock = np.zeros(max(n - 1, 0), np.int8)
        self.arm_land = np.zeros(n + 1, np.int8)
        self.arm_top = np.zeros(1, np.int8)
        self.arms = (self.arm_lock, self.arm_unlock, self.arm_land, self.arm_top)
        self.refs = (np.zeros(max(n - 1, 0)), np.zeros(max(n - 1, 0)), np.zeros(n + 1), np.zeros(1))
        self.apexes = (np.full(max(n - 1, 0), np.inf), np.full(n + 1, np.inf))  # events.apex_times
        self.ws = Workspace(n)
        self.wst = self.ws.arrays()
        self.cos_alpha = math.cos(params.alpha)
        self.floor = FLOOR_CODES[params.floor]
        self.cone = params.anchor_cone
        self.log = _Log()
        # [lost_locking, lost_landing, floor impulse (3), t_fall, t_landed] (events.ACC_*)
        self.acc = np.array([0.0, 0.0, 0.0, 0.0, 0.0, math.nan, math.nan])
        # scratch
        nh = max(n - 1, 0)
        self.scratch = {
            "gaps": np.zeros(nh), "rates": np.zeros(nh), "rates_after": np.zeros(nh), "impulse": np.zeros(nh),
            "anchor_impulse": np.zeros((n + 1, 3)), "split": np.zeros(2), "jv": np.zeros_like(self.ws.rhs),
            "w_plus": np.zeros((n, 3)), "de": np.zeros((n, 3)), "dw": np.zeros((n, 3)), "ddg": np.zeros(nh),
            "lam": np.zeros(nh),
        }
        self.pv = np.zeros((n + 1, 3))
        self.vel = np.zeros((n, 3))
        self.pts = np.zeros((n + 1, 3))

    # the run's scalars live in ``acc`` (shared with the compiled event handler)
    lost_locking = property(lambda self: self.acc[0], lambda self, v: self.acc.__setitem__(0, v))
    lost_landing = property(lambda self: self.acc[1], lambda self, v: self.acc.__setitem__(1, v))
    t_fall = property(lambda self: self.acc[5], lambda self, v: self.acc.__setitem__(5, v))
    t_landed = property(lambda self: self.acc[6], lambda self, v: self.acc.__setitem__(6, v))

    @property
    def floor_impulse(self) -> np.ndarray:
        return self.acc[2:5]

    @floor_impulse.setter
    def floor_impulse(self, v):
        self.acc[2:5] = v

    def compiled_scratch(self) -> tuple:
        """Scratch arrays of ``events.handle_event`` (its ``sc`` argument)."""
        n, nh = self.n, max(self.n - 1, 0)
        sc = self.scratch
        u8 = lambda: np.zeros(nh, np.uint8)  # noqa: E731
        return (sc["gaps"], sc["rates"], sc["rates_after"], sc["impulse"], sc["anchor_impulse"], sc["split"],
                sc["jv"], sc["w_plus"], sc["de"], sc["dw"], sc["ddg"], sc["lam"], u8(), u8(), u8(), u8(), u8(), u8(),
                np.zeros(n + 1, np.int64), np.zeros((n + 1, 3)), u8(), u8(), np.zeros(nh), np.zeros(nh),
                np.zeros((n + 1, 3)), np.zeros(n + 1))

    def arm(self) -> None:
        """Arm the event functions of the current state (events.arm_functions)."""
        gaps = np.zeros(max(self.n - 1, 0))
        hinge_gaps(self.Y[0], self.cos_alpha, gaps)
        arm_functions(self.floor, self.p.alpha, self.cone, self.Y[0], self.anchored, self.locked, gaps,
                      self.scratch["lam"], not math.isnan(self.t_fall), self.arms, self.refs, np.zeros(self.n + 1))

    def landed(self) -> np.ndarray:
        a = self.anchored
        return (a[:-1] != 0) & (a[1:] != 0)

    def energy_now(self) -> tuple[float, float]:
        e, w = self.Y
        return kinetic_energy(e, w, self.pv, self.vel), potential_energy(e)


def _initial_state(params: ChainParams, ic: InitialCondition | None, state) -> tuple[np.ndarray, np.ndarray]:
    n = params.segments
    if state is not None:
        e0 = np.array(state[0], dtype=float).reshape(n, 3)
        w0 = np.array(state[1], dtype=float).reshape(n, 3) if state[1] is not None else np.zeros((n, 3))
        if not (np.all(np.isfinite(e0)) and np.all(np.isfinite(w0))):
            raise ParameterError("state: non-finite initial directions or angular velocities")
        e0 /= np.linalg.norm(e0, axis=1)[:, None]
        w0 -= np.einsum("ij,ij->i", w0, e0)[:, None] * e0
        check_inside_cone(e0, params.alpha)
        return e0, w0
    ic = ic or InitialCondition()
    return initial_directions(ic, n, params.alpha), np.zeros((n, 3))


def simulate(params: ChainParams, ic: InitialCondition | None = None, options: SolverOptions | None = None, *,
             state=None, progress: Callable[[float, dict], None] | None = None) -> Result:
    """Simulate one fall.  ``state = (e0, w0)`` (nondimensional, w in sqrt(g/b))
    overrides the initial condition family.  Returns a Result in the run's units."""
    options = options or SolverOptions()
    check_memory(params, options)
    wall0 = _time.perf_counter()
    e0, w0 = _initial_state(params, ic, state)
    run = Run(params, e0, w0, options)
    n = params.segments
    z0 = float(2.0 * np.sum(e0[:, 2]))
    t_ff = math.sqrt(2.0 * z0)
    U0 = potential_energy(run.Y[0])
    T0 = kinetic_energy(run.Y[0], run.Y[1], run.pv, run.vel)
    E0 = U0 + T0
    t_stop = (options.until if options.until is not None else options.max_time) * t_ff
    frames = _Frames(n, t_ff / options.frames_per_tff, t_stop * options.frames_per_tff / t_ff)
    trace_chunks_t, trace_chunks_z = [], []
    tr_t = np.zeros(65536)
    tr_z = np.zeros(65536)
    tr_count = np.zeros(1, np.int64)
    ev_kind = np.zeros(3 * n + 4, np.int64)
    ev_idx = np.zeros(3 * n + 4, np.int64)
    ev_theta = np.zeros(3 * n + 4)
    counters = np.zeros(3, np.int64)
    stats = np.zeros(1)
    K = np.zeros((7, 2, n, 3))
    K2 = np.zeros((7, 2, n, 3))
    Y1 = np.zeros((2, n, 3))
    Ytmp = np.zeros((2, n, 3))
    dYtmp = np.zeros((2, n, 3))
    lam = np.zeros(max(n - 1, 1))
    lam1 = np.zeros(max(n - 1, 1))
    F = np.zeros((7, 3))
    F2 = np.zeros((7, 3))
    fint = np.zeros(3)  # the floor's continuous impulse so far (integrator.floor_impulse_step)
    xtol = options.event_xtol
    t = 0.0
    h = 1e-3
    status, message = "landed", ""
    last_report = -1.0

    counted = 0
    counts = np.zeros(max(EVENT_KINDS) + 1, np.int64)

    def progress_info() -> dict:
        """What the progress bar shows, counted as the summary counts it: log rows by
        kind (``Result.event_counts``), event instants, landed segments."""
        nonlocal counted
        k = len(run.log)
        counts[:] += np.bincount(run.log.arrays[1][counted:k], minlength=counts.size)[:counts.size]
        counted = k
        return {"t_over_tff": t / t_ff, "events": {name: int(counts[c]) for c, name in EVENT_KINDS.items()},
                "instants": int(zeno_n[0]), "landed": int(np.sum(run.landed())), "segments": n}

    def report(final=False):
        nonlocal last_report
        if progress is None:
            return
        landed = int(np.sum(run.landed()))
        frac = t / t_stop if options.until is not None else 0.5 * min(1.0, t / t_ff) + 0.5 * landed / n
        if final or frac - last_report >= 0.002:
            last_report = frac
            progress(1.0 if final else min(frac, 1.0), progress_info())

    def flush_trace():
        k = int(tr_count[0])
        trace_chunks_t.append(tr_t[:k].copy())
        trace_chunks_z.append(tr_z[:k].copy())
        tr_count[0] = 0

    def stop_code(code):
        """Status and message of an integrator code that ends the run (None: go on)."""
        if code == ADV_STOP:
            st = "until" if options.until is not None else "max_time"
            return st, (f"not all segments landed by t = {options.max_time} t_ff" if st == "max_time" else "")
        if code == ADV_FAIL_NAN:
            raise SimulationError(f"non-finite state (blow-up) at t/t_ff = {t / t_ff:.6f}")
        if code == ADV_FAIL_STEP:
            raise SimulationError(f"step size underflow (h = {h:.3g}) at t/t_ff = {t / t_ff:.6f}")
        if code == ADV_MAX_STEPS:
            raise SimulationError(f"more than max_steps = {options.max_steps} steps at t/t_ff = {t / t_ff:.6f}")
        return None

    run.arm()
    ws = run.wst
    adv = (K, K2, Y1, Ytmp, dYtmp, lam, lam1, F, F2, fint, np.zeros(1, np.int64))
    sc = run.compiled_scratch()
    zeno_t = np.zeros(ZENO_EVENTS + 1)
    zeno_n = np.zeros(1, np.int64)
    stopper = _StopOnSignals()
    try:
        with stopper:
            while True:
                if stopper.reason is not None:
                    status, message = "interrupted", f"{stopper.reason} at t/t_ff = {t / t_ff:.6f}"
                    break
                run.log.reserve(4 * log_room(n))
                code, t, h = run_events(run.Y, t, h, t_stop, params.alpha, run.floor, run.cone, run.anchored,
                                        run.locked, run.lock_cos, run.anchor_pos, run.anchor_t, run.arms, run.refs,
                                        run.apexes, options.rtol,
                                        xtol, options.hold_rate, options.hold_apex,
                                        ws, adv, frames.compiled, (tr_t, tr_z, tr_count), (ev_kind, ev_idx, ev_theta),
                                        run.pts, run.pv, run.vel, counters, options.max_steps, stats, sc,
                                        run.log.arrays, run.log.n, run.acc, zeno_t, zeno_n, ZENO_WINDOW * t_ff,
                                        options.max_events, RETURN_EVERY)
                stopper.started = True
                if code == ADV_BUFFER:
                    flush_trace()
                    frames.flush()
                    continue
                if code == EV_LANDED:
                    status = "landed"
                    break
                if code == ERR_ZENO:
                    raise SimulationError(f"event accumulation: {ZENO_EVENTS} events within {ZENO_WINDOW:.3g} t_ff "
                                          f"before t/t_ff = {t / t_ff:.6f} (Zeno); stopping")
                if code == ERR_MAX_EVENTS:
                    raise SimulationError(f"more than max_events = {options.max_events} events; stopping")
                if code in ERROR_MESSAGES:
                    hint = (f" (rtol = {options.rtol:g} is loose: the state reaching the impact is not accurate "
                            f"enough; tighten it, e.g. --rtol 1e-9)" if options.rtol > LOOSE_RTOL else "")
                    raise SimulationError(f"{ERROR_MESSAGES[code]} at t = {t:.17g}{hint}")
                if code != EV_RETURN:
                    stop = stop_code(code)
                    if stop is not None:
                        status, message = stop
                        break
                report()
    except SimulationError as exc:
        status, message = "error", str(exc)
    except MemoryError:
        status = "error"
        message = (f"out of memory at t/t_ff = {t / t_ff:.6f} after {sum(map(len, frames.chunks['t']))} frames "
                   f"(lower --frames-per-tff or --until)")
    flush_trace()
    if progress is not None:
        report(final=True)
    T_end, U_end = run.energy_now()
    floor_total = run.floor_impulse + fint
    return _make_result(params, ic, options, run, status, message, z0, t_ff, E0, T_end, U_end,
                        np.concatenate([[0.0]] + trace_chunks_t), np.concatenate([[z0]] + trace_chunks_z),
                        frames.arrays(), floor_total, -min(stats[0], 0.0), wall0, counters, int(zeno_n[0]))


def _make_result(params, ic, options, run, status, message, z0, t_ff, E0, T_end, U_end, tr_t, tr_z, fr, floor_total,
                 max_depth, wall0, counters, n_instants) -> Result:
    """Convert the nondimensional run to the run's units and package it."""
    tu = params.time_unit
    lu = params.half_length
    fu = params.force_unit
    eu = params.energy_unit
    iu = fu * tu
    log_t, log_kind, log_index, log_imp, log_energy, log_pos = run.log.view()
    energy = {
        "initial": E0 * eu,
        "potential": U_end * eu,
        "kinetic": T_end * eu,
        "lost_locking": run.lost_locking * eu,
        "lost_landing": run.lost_landing * eu,
        "imbalance": (E0 - U_end - T_end - run.lost_locking - run.lost_landing) * eu,
    }
    return Result(
        params=params, ic=ic, options=options, version=__version__, status=status, message=message,
        z0=z0 * lu, t_ff=t_ff * tu, t_fall=run.t_fall * tu, t_landed=run.t_landed * tu,
        t=tr_t * tu, z_top=tr_z * lu,
        frame_t=fr["t"] * tu, frame_e=fr["e"], frame_omega=fr["omega"] / tu,
        frame_anchored=fr["anchored"].astype(bool), frame_locked=fr["locked"].astype(bool),
        frame_floor_force=fr["floor_force"] * fu, frame_kinetic=fr["kinetic"] * eu,
        frame_potential=fr["potential"] * eu, frame_lost_locking=fr["lost_locking"] * eu,
        frame_lost_landing=fr["lost_landing"] * eu, frame_pile_pull=fr["pile_pull"] * fu,
        frame_scale_force=fr["scale_force"] * fu, frame_floor_impulse=fr["floor_impulse"] * iu,
        event_t=log_t * tu, event_kind=log_kind.astype(np.int8), event_index=log_index.copy(),
        event_impulse=log_imp * iu, event_energy=log_energy * eu, event_pos=log_pos * lu,
        anchor_t=run.anchor_t * tu, anchor_pos=run.anchor_pos * lu,
        energy=energy, max_depth=max_depth * lu, floor_impulse=run.floor_impulse * iu,
        floor_impulse_total=floor_total * iu,
        wall_seconds=_time.perf_counter() - wall0, n_steps=int(counters[0]), n_evals=int(counters[1]),
        n_instants=n_instants,
        units="SI" if params.is_si else "nondimensional",
    )
