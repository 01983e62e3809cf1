"""The outputs every method fills, on the Python side: frames in fixed-size buffers
emptied into chunks, the trace (z_top at every step) and the event log in growable
arrays, and what a method hands back (``RunOutput``).  The compiled side of each is a
``core.state`` bundle (``Frames``, ``Trace``, ``Log``)."""

from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from ..core.kinematics import kinetic_energy
from ..core.state import FRAME_FIELDS, Books, Chain, new_frames, new_log, new_trace

FRAME_CHUNK_BYTES = 32 << 20  # frame buffers are emptied into the result this often


def frame_bytes(n: int) -> int:
    """Bytes one output frame of an N-segment chain takes in memory."""
    return 8 * (2 * 3 * n) + (n + 1) + max(n - 1, 0) + 8 * 14


class FrameBuffer:
    """Output frames in fixed-size buffers that the compiled loop fills (a method returns
    when they are full); ``flush`` moves them into chunks, so a run holds what it has
    written, never what it might write."""

    def __init__(self, n: int, frame_dt: float, frames_wanted: float):
        cap = int(max(16, min(frames_wanted + 2, FRAME_CHUNK_BYTES // frame_bytes(n))))
        self.compiled = new_frames(n, frame_dt, cap)
        self.chunks = {name: [] for name in FRAME_FIELDS}

    def flush(self) -> None:
        fr = self.compiled
        k = int(fr.count[0])
        if k:
            for name in FRAME_FIELDS:
                self.chunks[name].append(getattr(fr, name)[:k].copy())
        fr.count[0] = 0
        fr.fill[0] = 0

    def written(self) -> int:
        """Frames written so far."""
        return sum(map(len, self.chunks["t"])) + int(self.compiled.count[0])

    def arrays(self) -> dict:
        self.flush()
        return {
            name: np.concatenate(self.chunks[name]) if self.chunks[name] else getattr(self.compiled, name)[:0]
            for name in FRAME_FIELDS
        }


class TraceBuffer:
    """z_top at every step and event, in a fixed-size buffer emptied into chunks."""

    def __init__(self, z0: float):
        self.compiled = new_trace()
        self.t_chunks = [np.zeros(1)]
        self.z_chunks = [np.array([z0])]

    def flush(self) -> None:
        tr = self.compiled
        k = int(tr.count[0])
        self.t_chunks.append(tr.t[:k].copy())
        self.z_chunks.append(tr.z[:k].copy())
        tr.count[0] = 0

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        self.flush()
        return np.concatenate(self.t_chunks), np.concatenate(self.z_chunks)


class LogBuffer:
    """The event log in growable arrays (written by the compiled handler in place)."""

    def __init__(self, cap: int = 4096):
        self.compiled = new_log(cap)

    def reserve(self, rows: int) -> None:
        """Make room for ``rows`` more rows (capacity doubles)."""
        old = self.compiled
        cap = old.t.shape[0]
        k = int(old.n[0])
        if cap - k < rows:
            new = new_log(max(2 * cap, k + rows), n_rows=old.n)
            for a_new, a_old in zip(new[:-1], old[:-1]):
                a_new[:k] = a_old[:k]
            self.compiled = new

    def __len__(self) -> int:
        return int(self.compiled.n[0])

    def view(self):
        """(t, kind, index, impulse, energy, position) of the rows written so far."""
        k = len(self)
        return tuple(a[:k] for a in self.compiled[:-1])


# What a method's compiled loop asks of the Python side when it returns (``drive``)
GO_ON, FLUSH, LANDED, STOPPED = 0, 1, 2, 3


def drive(setup, progress, stop, advance, out: RunOutput, log_rows: int, state: dict | None = None) -> RunOutput:
    """The Python side of every method.  ``advance(t)`` runs the method's compiled loop
    from t and returns (verdict, t): GO_ON (progress is reported), FLUSH (the trace and
    frame buffers are emptied), LANDED, STOPPED (the stop time) -- or raises
    SimulationError.  A stop request ends the run with status ``interrupted``, a failure
    with ``error``; the work is kept.  ``out`` holds the run's bundles (its status and
    message are filled in); the log gets room for ``log_rows`` before each call.
    ``state``: the method's mutable bundles by name (beside the outputs), which a
    checkpoint (``setup.checkpoint``, ``methods.checkpoint``) saves at GO_ON returns when
    due and at an interruption, and from which a run resumes."""
    ck = getattr(setup, "checkpoint", None)
    t = 0.0
    if ck is not None and ck.resumes:
        t = ck.resume(state, out)
    status, message = "landed", ""
    try:
        while True:
            if stop.reason is not None:
                status, message = "interrupted", f"{stop.reason} at t/t_ff = {t / setup.t_ff:.6f}"
                if ck is not None:
                    saved = ck.save(t, state, out) is not None
                    message += f"; checkpoint saved to {ck.path}" if saved else ""
                break
            out.log.reserve(log_rows)
            verdict, t = advance(t)
            stop.started = True
            if verdict == FLUSH:
                out.trace.flush()
                out.frames.flush()
            elif verdict == LANDED:
                break
            elif verdict == STOPPED:
                status, message = stop_status(setup.options, out.chain)
                break
            else:
                progress(t, out.chain, out.log, out.books)
                if ck is not None:
                    ck.save_if_due(t, state, out)
    except SimulationError as exc:
        status, message = "error", str(exc)
    except MemoryError:
        status = "error"
        message = (
            f"out of memory at t/t_ff = {t / setup.t_ff:.6f} after {out.frames.written()} frames "
            f"(lower --frames-per-tff or --until)"
        )
    if ck is not None and ck.failure:
        message += ("; " if message else "") + ck.failure
    out.status, out.message, out.t = status, message, t
    return out


LoopCodes = namedtuple("LoopCodes", ["stop", "buffer", "returned", "landed", "max_steps"])


def loop_verdict(code: int, t: float, codes: LoopCodes, errors: dict, where: str, max_steps: int):
    """What ``drive`` makes of a stepping method's compiled loop returning ``code`` at t
    (``codes``: its return codes; ``errors``: the messages of its failures, each followed
    by ``where`` it failed): (verdict, t), or SimulationError."""
    if code == codes.buffer:
        return FLUSH, t
    if code == codes.landed:
        return LANDED, t
    if code in errors:
        raise SimulationError(f"{errors[code]} {where}")
    if code == codes.max_steps:
        raise SimulationError(f"more than max_steps = {max_steps} steps {where}")
    if code == codes.stop:
        return STOPPED, t
    if code != codes.returned:  # pragma: no cover - every code is handled above
        raise SimulationError(f"unknown code {code} from the compiled loop")
    return GO_ON, t


REST_RATE = 1e-9  # every |w_i| below this (sqrt(g/b)): the chain is at rest


def stop_status(options, chain: Chain | None = None) -> tuple[str, str]:
    """(status, message) of a run stopped at its stop time: ``until`` (asked for), or
    ``max_time`` (the time cap) with a message that says the chain had not landed, and,
    if it is at rest (every |w_i| < REST_RATE), how many points stand off the floor, or,
    if its top end spins as a top (``spinning_top_note``), that it does."""
    if options.until is not None:
        return "until", ""
    message = f"the chain had not landed by t = {options.max_time} t_ff (the time cap, --max-time)"
    if chain is not None:
        message += at_rest_note(chain) or spinning_top_note(chain)
    return "max_time", message


def at_rest_note(chain: Chain) -> str:
    """'; it is at rest with k of N + 1 points off the floor ...' if the chain is at rest
    (every |w_i| < REST_RATE), else ''.  Points' heights z_j = 2 sum_{i>=j} e_i,z (b)."""
    e, w = chain.Y[0], chain.Y[1]
    if e.shape[0] == 0 or float(np.max(np.abs(w))) >= REST_RATE:
        return ""
    z = np.append(2.0 * np.cumsum(e[::-1, 2])[::-1], 0.0)
    free = chain.anchored == 0
    return (
        f"; it is at rest with {int(free.sum())} of {len(z)} points off the floor (the highest at "
        f"z = {float(z[free].max(initial=0.0)):.3g} b): an equilibrium, such as a fold standing in the "
        f"plane of a planar start, which that plane's symmetry holds"
    )


def spinning_top_note(chain: Chain) -> str:
    """'; its top end, k segments locked at their limits, turns on landed point k ...' if
    the only airborne part is the top end (points 0..k-1 free, every point from k on
    anchored), of two segments or more, every hinge between them locked: one rigid body
    on a frictionless pivot, a heavy top, which nothing in the model slows down; '; the
    only part off the floor is its top end, k segments (j of the k - 1 hinges between them
    locked), moving on landed point k ...' if some of those hinges are free and some
    segment has landed: bodies joined at free hinges on that pivot (their kinetic energy,
    m g b: ``kinematics.kinetic_energy``); else ''."""
    e, w, anchored = chain.Y[0], chain.Y[1], chain.anchored
    if e.shape[0] == 0 or float(np.max(np.abs(w))) < REST_RATE:
        return ""
    k = int(np.argmax(anchored != 0)) if np.any(anchored != 0) else -1
    if k < 1 or np.any(anchored[:k] != 0) or np.any(anchored[k:] == 0):
        return ""
    n = e.shape[0]  # (the landed segments below are at rest: the chain's T is the top's)
    t = float(kinetic_energy(e, w, np.zeros((n + 1, 3)), np.zeros((n, 3))))
    held = int(np.count_nonzero(chain.locked[: k - 1]))
    if k >= 2 and held == k - 1:
        return (
            f"; its top end, {k} segments locked at their bend limits, turns on landed point {k} as one "
            f"rigid body (kinetic energy {t:.4g} m g b): a heavy top on a frictionless pivot, which nothing "
            f"in the model slows down (docs/model.md, section 4)"
        )
    if k >= n:  # (nothing has landed: the chain on its starting pivot, still falling)
        return ""
    hinges = f" ({held} of the {k - 1} hinges between them locked)" if k >= 2 else ""
    return (
        f"; the only part off the floor is its top end, {k} segment{'s' if k > 1 else ''}{hinges}, "
        f"moving on landed point {k} (kinetic energy {t:.4g} m g b; docs/model.md, section 4)"
    )


CLOSED_STRETCH_GAP = 1e-2  # a locked stretch between two anchors this near (relative) an extreme of its chord is named


def stretch_chord_extremes(k: int, alpha: float) -> tuple[float, float]:
    """The least and greatest distance (b) between the ends of k segments (length 2b) whose
    k - 1 hinges all bend by alpha: the planar arc, 2 |sin(k alpha/2)| / sin(alpha/2) (the
    least while k alpha <= 2 pi, where it closes), and the planar zigzag, its axes
    alternating between two:
    2 sqrt(m1^2 + m2^2 + 2 m1 m2 cos alpha), m1 = ceil(k/2), m2 = floor(k/2) (2 k cos(alpha/2)
    for even k)."""
    m1, m2 = (k + 1) // 2, k // 2
    zigzag = 2.0 * math.sqrt(m1 * m1 + m2 * m2 + 2.0 * m1 * m2 * math.cos(alpha))
    return 2.0 * abs(math.sin(k * alpha / 2.0)) / math.sin(alpha / 2.0), zigzag


def closed_stretch_note(e, anchored, locked, anchor_pos, alpha: float) -> str:
    """'; the stretch of k segments ... is within x of its tightest curl ...' for the first
    stretch of k >= 2 segments between two anchored points a and a + k, the points between
    them free and its k - 1 hinges locked, whose anchors' distance D lies within
    CLOSED_STRETCH_GAP (relative) of the chord of the planar arc (k alpha <= 2 pi) or of the
    planar zigzag at the limits (``stretch_chord_extremes``): there the anchors leave its
    free twists almost no room, a near-singular configuration of its constraints; else ''."""
    held = np.flatnonzero(np.asarray(anchored) != 0)
    for a, b in zip(held[:-1], held[1:]):
        k = int(b - a)
        if k < 2 or not np.all(np.asarray(locked)[a : b - 1] != 0):
            continue
        d = float(np.linalg.norm(np.asarray(anchor_pos[b]) - np.asarray(anchor_pos[a])))
        arc, zigzag = stretch_chord_extremes(k, alpha)
        shapes = (
            (arc, "tightest curl (a planar arc)", k * alpha <= 2.0 * math.pi),
            (zigzag, "straightest reach (a planar zigzag)", True),
        )
        for chord, shape, extreme in shapes:
            if not extreme or abs(d - chord) > CLOSED_STRETCH_GAP * chord:
                continue
            return (
                f"; the stretch of {k} segments {a}-{b - 1} between anchored points {a} and {b}, its {k - 1} "
                f"hinges locked, is within {abs(d - chord) / chord:.2g} of the chord of its {shape}: the anchors "
                f"leave its twists almost no room (a near-singular configuration of its constraints), and it "
                f"moves in that room faster than the step can follow"
            )
    return ""


class SimulationError(RuntimeError):
    """A run that cannot go on (blow-up, event accumulation, singular configuration)."""


@dataclass
class RunOutput:
    """What a method hands back to ``engine``: how the run ended, its final state and its
    outputs (nondimensional)."""

    status: str
    message: str
    t: float
    chain: Chain
    books: Books
    frames: FrameBuffer
    trace: TraceBuffer
    log: LogBuffer
    # the kinetic energy at the end, when the method keeps velocities of its own (the
    # time-stepper's centre velocities V: ``stepper.kinetic_energy_maximal``, as its
    # frames record it); None: from the axes and rates (``kinematics.kinetic_energy``)
    kinetic: float | None = None
    # the potential energy at the end, when the chain's bottom end may have left the origin
    # (a frictionless floor: U = sum of the centres' heights); None: from the axes
    potential: float | None = None
