"""One run: parameters -> initial state -> a method over the compiled core -> Result.

``simulate`` sets the run up (``Setup``: the starting state, t_ff, the stop time, the
energy at the start), hands it to the method that ``SolverOptions.method`` names
(``methods.METHODS``; the event-driven one by default), and builds the ``Result`` from
what every method fills: the final state, the books, frames, trace and event log.
Signals stop a run at the method's next return from compiled code (``_StopOnSignals``).
"""

from __future__ import annotations

import math
import os
import signal
import threading
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from . import __version__
from .core.books import PROJECTED_AT_INSTANTS, PROJECTED_IN_STEPS
from .core.kinds import EVENT_KINDS
from .core.kinematics import kinetic_energy, potential_energy
from .core.rules import is_landed
from .initial import check_inside_cone, initial_directions
from .methods import check_contacts, check_options, method_package, method_runner
from .methods.checkpoint import Checkpoint
from .methods.outputs import FRAME_CHUNK_BYTES, RunOutput, SimulationError, frame_bytes  # noqa: F401  (re-exported)
from .model import ChainParams, InitialCondition, ParameterError, SolverOptions
from .provenance import engine_fingerprint
from .records.audit import audited
from .records.result import Result


def kernels_cached(method: str = "event") -> bool:
    """Are the compiled kernels of ``method`` in numba's on-disk cache (or compiled in
    this process)?  False means the next run compiles them first (a minute, once)."""
    from .methods import entry_kernel

    kernel = entry_kernel(method)
    if kernel.signatures:
        return True
    try:
        return bool(kernel._cache._cache_file._load_index())
    except Exception:  # pragma: no cover - a numba without this (private) layout
        return True


def load_kernels(method: str = "event") -> bool:
    """Load the compiled kernels of ``method`` from numba's cache (the first time:
    compile them) with a tiny run, so that the wall time of the next run is its
    integration alone.  Returns whether they had to be compiled."""
    cold = not kernels_cached(method)
    simulate(ChainParams(segments=2), InitialCondition(), SolverOptions(until=0.05, method=method))
    return cold


class Interrupted(KeyboardInterrupt):
    """Raised by a second SIGINT or SIGTERM during a run (the first one asks the run to
    stop at the next safe point and keep its work, see ``_StopOnSignals``)."""

    def __init__(self, reason: str = "SIGTERM"):
        super().__init__(reason)
        self.reason = reason


_STOP_REQUEST: list = [None]  # a stop asked of every run of this process (``request_stop``)


def request_stop(reason: str | None) -> None:
    """Ask every run of this process, under way or to come, to stop at its next return
    from compiled code as a first Ctrl-C does (status ``interrupted``; a checkpointed
    run saves its checkpoint); None withdraws the request.  An interrupted sweep asks
    this of its workers (``sweeps.execute``), whose runs are in threads that signals
    do not reach."""
    _STOP_REQUEST[0] = reason


def stop_requested() -> str | None:
    """The reason of the stop asked by ``request_stop``, None if none."""
    return _STOP_REQUEST[0]


class _StopOnSignals:
    """While a run lasts (main thread only), the first SIGINT (Ctrl-C) or SIGTERM asks
    it to stop at the next return from compiled code, where the state and every buffer
    are consistent; the run then ends with status ``interrupted`` and keeps its work.
    A second signal, or one that comes before any work was done (``started`` is False:
    e.g. while the kernels compile on a first run), stops at once (``Interrupted``).
    A stop asked by ``request_stop`` (any thread) acts as the first signal."""

    NAMES = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM"}

    def __init__(self):
        self._reason: str | None = None
        self.started = False
        self.old: dict = {}

    @property
    def reason(self) -> str | None:
        """Why the run is asked to stop (None: it is not)."""
        return self._reason if self._reason is not None else _STOP_REQUEST[0]

    def _handler(self, signum, frame):
        if self.reason is not None or not self.started:
            raise Interrupted(self.NAMES.get(signum, str(signum)))
        self._reason = self.NAMES.get(signum, str(signum))

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
    gib = 1024.0**3
    what = "lower --frames-per-tff (or --until)" if out > work else "lower --segments (-N)"
    raise ParameterError(
        f"memory: this run needs at least {(work + out) / gib:.3g} GiB ({n} segments, "
        f"{frames:.3g} frames), {avail / gib:.3g} GiB are available: {what}"
    )


def _initial_state(params: ChainParams, ic: InitialCondition | None, state) -> tuple[np.ndarray, np.ndarray]:
    n = params.segments
    if state is not None:
        e0 = np.array(state[0], dtype=float).reshape(n, 3)
        w0 = np.array(state[1], dtype=float).reshape(n, 3) if state[1] is not None else np.zeros((n, 3))
        if not (np.all(np.isfinite(e0)) and np.all(np.isfinite(w0))):
            raise ParameterError("state: non-finite initial directions or angular velocities")
        e0 /= np.linalg.norm(e0, axis=1)[:, None]
        w0 -= np.einsum("ij,ij->i", w0, e0)[:, None] * e0
        check_inside_cone(e0, params.alpha, "the explicit initial state: bend it less, or raise --alpha")
        return e0, w0
    ic = ic or InitialCondition()
    return initial_directions(ic, n, params.alpha), np.zeros((n, 3))


@dataclass(frozen=True)
class Setup:
    """A run as every method receives it (nondimensional: m = b = g = 1)."""

    params: ChainParams
    ic: InitialCondition | None
    options: SolverOptions
    e0: np.ndarray  # (N, 3) unit axes at t = 0
    w0: np.ndarray  # (N, 3) angular velocities at t = 0
    z0: float  # height of the top end at t = 0
    t_ff: float  # free-fall time of the top end, sqrt(2 z0)
    t_stop: float  # the run stops here at the latest
    E0: float  # energy at t = 0 (potential + kinetic)
    checkpoint: Checkpoint | None = None  # where the run saves its state, and resumes from
    observer: object | None = None  # what watches the run's steps (a method's package's OBSERVER), or None


def _setup(params: ChainParams, ic: InitialCondition | None, options: SolverOptions, state) -> Setup:
    e0, w0 = (np.ascontiguousarray(a, dtype=float) for a in _initial_state(params, ic, state))
    n = params.segments
    z0 = float(2.0 * np.sum(e0[:, 2]))
    t_ff = math.sqrt(2.0 * z0)
    E0 = potential_energy(e0) + kinetic_energy(e0, w0, np.zeros((n + 1, 3)), np.zeros((n, 3)))
    t_stop = (options.until if options.until is not None else options.max_time) * t_ff
    return Setup(params, ic, options, e0, w0, z0, t_ff, t_stop, E0)


class _Progress:
    """Reports a run's progress to ``callback(fraction, info)``: the fraction of the fall
    done (time until t_ff, then the landed segments; or time until ``until``) and the
    counts the summary counts (log rows by kind, event instants, landed segments)."""

    def __init__(self, setup: Setup, callback: Callable[[float, dict], None] | None):
        self.setup = setup
        self.callback = callback
        self.last = -1.0
        self.counted = 0
        self.counts = np.zeros(max(EVENT_KINDS) + 1, np.int64)

    def info(self, t: float, chain, log, books) -> dict:
        k = len(log)
        kinds = log.compiled.kind
        self.counts[:] += np.bincount(kinds[self.counted : k], minlength=self.counts.size)[: self.counts.size]
        self.counted = k
        return {
            "t_over_tff": t / self.setup.t_ff,
            "events": {name: int(self.counts[c]) for c, name in EVENT_KINDS.items()},
            "instants": int(books.n_instants[0]),
            "landed": _landed(chain.anchored),
            "segments": self.setup.params.segments,
        }

    def __call__(self, t: float, chain, log, books, final: bool = False) -> None:
        if self.callback is None:
            return
        s = self.setup
        n = s.params.segments
        if s.options.until is not None:
            frac = t / s.t_stop
        else:
            frac = 0.5 * min(1.0, t / s.t_ff) + 0.5 * _landed(chain.anchored) / n
        if final or frac - self.last >= 0.002:
            self.last = frac
            self.callback(1.0 if final else min(frac, 1.0), self.info(t, chain, log, books))


def _landed(anchored: np.ndarray) -> int:
    return int(sum(is_landed(anchored, i) for i in range(anchored.shape[0] - 1)))


def simulate(
    params: ChainParams,
    ic: InitialCondition | None = None,
    options: SolverOptions | None = None,
    *,
    state=None,
    progress: Callable[[float, dict], None] | None = None,
    checkpoint: Checkpoint | str | Path | None = None,
    observer=None,
) -> Result:
    """Simulate one fall.  ``state = (e0, w0)`` (nondimensional, w in sqrt(g/b))
    overrides the initial condition family.  ``checkpoint`` (a path, or a
    ``methods.checkpoint.Checkpoint`` to set how often it is written): the run saves its
    state there every 10 minutes of wall time and when interrupted, and, if the file
    holds this run's state (same parameters, start and engine), resumes from it; the
    file is left in place (``Checkpoint.discard`` it once the result is saved).
    ``observer``: what watches the run step by step, for a method that takes one (its
    package's ``OBSERVER`` names the protocol: ``--method rattle``'s
    ``methods.rattle.driver.StepObserver``; TypeError for the others).
    Returns a Result in the run's units."""
    options = (options or SolverOptions()).for_segments(params.segments)
    check_contacts(params, options.method)
    check_options(options, params.segments, filled=True)
    check_memory(params, options)
    wall0 = _time.perf_counter()
    setup = _setup(params, ic, options, state)
    if observer is not None:
        if getattr(method_package(options.method), "OBSERVER", None) is None:
            raise TypeError(f"--method {options.method} takes no observer of its steps")
        setup = replace(setup, observer=observer)
    if checkpoint is not None:
        ck = checkpoint if isinstance(checkpoint, Checkpoint) else Checkpoint(checkpoint)
        ck.open(setup, options.method, engine_fingerprint())
        setup = replace(setup, checkpoint=ck)
    report = _Progress(setup, progress)
    with _StopOnSignals() as stopper:
        out = method_runner(options.method)(setup, report, stopper)
    report(out.t, out.chain, out.log, out.books, final=True)
    return audited(_make_result(setup, out, wall0))


def _make_result(setup: Setup, out: RunOutput, wall0: float) -> Result:
    """Convert the nondimensional run to the run's units and package it."""
    params, books, chain = setup.params, out.books, out.chain
    tu = params.time_unit
    lu = params.half_length
    fu = params.force_unit
    eu = params.energy_unit
    iu = fu * tu
    e, w = chain.Y
    n = params.segments
    T_end = out.kinetic if out.kinetic is not None else kinetic_energy(e, w, np.zeros((n + 1, 3)), np.zeros((n, 3)))
    U_end = out.potential if out.potential is not None else potential_energy(e)
    lost_locking, lost_landing = float(books.lost_locking[0]), float(books.lost_landing[0])
    lost_damping, lost_sliding = float(books.lost_damping[0]), float(books.lost_sliding[0])
    energy = {
        "initial": setup.E0 * eu,
        "potential": U_end * eu,
        "kinetic": T_end * eu,
        "lost_locking": lost_locking * eu,
        "lost_landing": lost_landing * eu,
        "lost_damping": lost_damping * eu,  # the smooth laws' (the hinges' damping): their power integrated
        "lost_sliding": lost_sliding * eu,  # Coulomb's friction force on sliding points: its work
        "imbalance": (setup.E0 - U_end - T_end - lost_locking - lost_landing - lost_damping - lost_sliding) * eu,
        # what the projections onto the constraints changed U + T by (a part of -imbalance;
        # the integrator's own error is the rest): at event instants, after steps
        "projected_at_instants": float(books.projected[PROJECTED_AT_INSTANTS]) * eu,
        "projected_in_steps": float(books.projected[PROJECTED_IN_STEPS]) * eu,
        # time-stepping: gravity's kick on T plus the position update's change of U over the steps
        # (zero in exact dynamics; with the projections and the impacts' unbooked share, -imbalance)
        "work_error_in_steps": float(books.work_error[0]) * eu,
    }
    tr_t, tr_z = out.trace.arrays()
    fr = out.frames.arrays()
    log_t, log_kind, log_index, log_imp, log_energy, log_pos = out.log.view()
    return Result(
        params=params,
        ic=setup.ic,
        options=setup.options,
        version=__version__,
        status=out.status,
        message=_resumed_note(setup, out.message),
        z0=setup.z0 * lu,
        t_ff=setup.t_ff * tu,
        t_fall=float(books.t_fall[0]) * tu,
        t_landed=float(books.t_landed[0]) * tu,
        t=tr_t * tu,
        z_top=tr_z * lu,
        frame_t=fr["t"] * tu,
        frame_e=fr["e"],
        frame_omega=fr["omega"] / tu,
        frame_anchored=fr["anchored"].astype(bool),
        frame_locked=fr["locked"].astype(bool),
        frame_floor_force=fr["floor_force"] * fu,
        frame_kinetic=fr["kinetic"] * eu,
        frame_potential=fr["potential"] * eu,
        frame_lost_locking=fr["lost_locking"] * eu,
        frame_lost_landing=fr["lost_landing"] * eu,
        frame_lost_damping=fr["lost_damping"] * eu,
        frame_lost_sliding=fr["lost_sliding"] * eu,
        frame_tension=fr["tension"] * fu,
        frame_pile_pull=fr["pile_pull"] * fu,
        frame_scale_force=fr["scale_force"] * fu,
        frame_floor_impulse=fr["floor_impulse"] * iu,
        frame_base=fr["base"] * lu,
        frame_base_velocity=fr["base_velocity"] * lu / tu,
        event_t=log_t * tu,
        event_kind=log_kind.astype(np.int8),
        event_index=log_index.copy(),
        event_impulse=log_imp * iu,
        event_energy=log_energy * eu,
        event_pos=log_pos * lu,
        anchor_t=chain.anchor_t * tu,
        anchor_pos=chain.anchor_pos * lu,
        energy=energy,
        max_depth=-min(float(books.lowest[0]), 0.0) * lu,
        floor_impulse=books.floor_impulse * iu,
        floor_impulse_total=(books.floor_impulse + books.floor_flow) * iu,
        wall_seconds=_wall_seconds(setup, wall0),
        n_steps=int(books.n_steps[0]),
        n_evals=int(books.n_evals[0]),
        n_instants=int(books.n_instants[0]),
        units="SI" if params.is_si else "nondimensional",
        engine=engine_fingerprint(),
    )


def _wall_seconds(setup: Setup, wall0: float) -> float:
    """The run's wall time: this process's, plus what the processes before it spent on
    the run if it resumed from a checkpoint."""
    ck = setup.checkpoint
    before = ck.wall_before if ck is not None and ck.resumes else 0.0
    return before + _time.perf_counter() - wall0


def _resumed_note(setup: Setup, message: str) -> str:
    """The run's message, with a note of where it resumed from a checkpoint (if it did)."""
    ck = setup.checkpoint
    if ck is None or not ck.resumes:
        return message
    note = f"resumed at t/t_ff = {float(ck.header['t']) / setup.t_ff:.6f} from checkpoint {ck.path.name}"
    return f"{message}; {note}" if message else note
