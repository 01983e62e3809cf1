"""Checkpoints of a run in progress: all a method needs to go on from where it stopped,
in one file, so that a fall longer than the time one can give it at once (N = 16384
takes hours) survives a kill and resumes bit for bit.

A checkpoint is an ``.npz`` file (numpy, no pickle): every array of the method's
mutable bundles (``core.state``: the chain, the solver's workspace, the books, the
method's own state and scratch), what the outputs hold so far (frames, trace, event
log), and a JSON header that names the run (parameters, initial condition, options, a
digest of the starting state), the engine that wrote it (``provenance``), the time
reached and the wall time spent.  It is written atomically (to a temporary file, then
renamed) at a return from compiled code once ``every`` seconds of wall time have passed
since the last one, and when the run is interrupted.  A run given the same path
resumes from the file if its header names this run and this engine; a checkpoint of
another run or of another engine is refused (``CheckpointError``), never mixed in.
Constants (``core.state.Model`` and the scalar fields of a bundle) are not stored: the
run rebuilds them from its parameters.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..core.state import FRAME_FIELDS
from ..errors import ParameterError

FORMAT = "ballchain-checkpoint/1"
DEFAULT_EVERY = 600.0  # seconds of wall time between checkpoints
LOG_FIELDS = ("t", "kind", "index", "impulse", "energy", "pos")


class CheckpointError(ParameterError):
    """A checkpoint that cannot be resumed here: of another run, another engine, or unreadable."""


def state_digest(e0: np.ndarray, w0: np.ndarray) -> str:
    """sha256 (16 hex digits) of the starting axes and rates: which start a run is."""
    h = hashlib.sha256()
    for a in (e0, w0):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()[:16]


def run_identity(setup, method: str) -> dict:
    """What names a run in a checkpoint's header: the method, the parameters, the
    initial condition, the options and the digest of the starting state (JSON types)."""
    ident = {
        "method": method,
        "params": asdict(setup.params),
        "ic": asdict(setup.ic) if setup.ic is not None else None,
        "options": asdict(setup.options),
        "start": state_digest(setup.e0, setup.w0),
    }
    return json.loads(json.dumps(ident, sort_keys=True, default=str))


def _arrays(prefix: str, bundle, out: dict) -> dict:
    """The arrays of ``bundle`` (a namedtuple or dict of arrays and constants, nested
    bundles included, or one array) under keys ``prefix.field``."""
    if isinstance(bundle, np.ndarray):
        out[prefix] = bundle
    elif isinstance(bundle, dict):
        for name, value in bundle.items():
            _arrays(f"{prefix}.{name}", value, out)
    elif isinstance(bundle, tuple) and hasattr(bundle, "_fields"):
        for name, value in zip(bundle._fields, bundle):
            _arrays(f"{prefix}.{name}", value, out)
    return out


class Checkpoint:
    """The checkpoint file of one run: ``path``, written every ``every`` seconds of wall
    time.  ``open`` reads it (if there is one) for the run ``setup``; ``resume`` puts its
    state into the method's bundles; ``save_if_due`` / ``save`` write it; ``discard``
    removes it once the run's result is safe elsewhere."""

    def __init__(self, path, every: float = DEFAULT_EVERY):
        if not (every >= 0.0):
            raise ParameterError(f"checkpoint every: must be >= 0 seconds, got {every!r}")
        self.path = Path(path)
        if self.path.name == "" or self.path.is_dir():
            raise ParameterError(f"checkpoint: {str(path)!r} is not a file name")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ParameterError(f"checkpoint: cannot create the directory of {str(path)!r}: {exc}") from exc
        if not os.access(self.path.parent, os.W_OK):
            raise ParameterError(f"checkpoint: cannot write into {str(self.path.parent)!r}")
        self.every = float(every)
        self.identity: dict | None = None
        self.payload: dict | None = None
        self.header: dict | None = None
        self.wall_before = 0.0  # wall time spent on this run before this process took it up
        self.failure = ""  # why the last checkpoint could not be written (the run goes on)
        self.started = time.perf_counter()
        self.last = self.started

    # -- reading -----------------------------------------------------------------
    def open(self, setup, method: str, engine: str) -> bool:
        """Read the checkpoint of the run ``setup`` if the file exists (True: it will
        resume).  Raises CheckpointError if the file is of another run or engine."""
        self.identity = {"format": FORMAT, "engine": engine, **run_identity(setup, method)}
        self.started = self.last = time.perf_counter()
        if not self.path.exists():
            return False
        try:
            with np.load(self.path, allow_pickle=False) as z:
                payload = {k: z[k] for k in z.files}
            header = json.loads(str(payload.pop("header")))
        except Exception as exc:
            raise CheckpointError(
                f"checkpoint {self.path}: unreadable ({type(exc).__name__}: {exc}); delete it to start the run over"
            ) from exc
        if header.get("format") != FORMAT:
            raise CheckpointError(f"checkpoint {self.path}: format {header.get('format')!r}, expected {FORMAT!r}")
        if header.get("engine") != engine:
            raise CheckpointError(
                f"checkpoint {self.path} was written by engine {header.get('engine')}, this is engine {engine}: "
                f"resume it with the code that wrote it, or delete it to start the run over"
            )
        mine = {k: v for k, v in self.identity.items() if k != "engine"}
        theirs = {k: header.get(k) for k in mine}
        if theirs != mine:
            differ = sorted(k for k in mine if theirs[k] != mine[k])
            raise CheckpointError(
                f"checkpoint {self.path} is of another run (it differs in: {', '.join(differ)}); "
                f"give this run another checkpoint path, or delete the file"
            )
        self.payload, self.header = payload, header
        self.wall_before = float(header.get("wall_seconds", 0.0))
        return True

    @property
    def resumes(self) -> bool:
        return self.payload is not None

    def resume(self, state: dict, out) -> float:
        """Put the saved state into the method's bundles ``state`` and the outputs of
        ``out`` (a ``RunOutput``), in place; returns the time reached."""
        p = self.payload
        saved = {}
        for name, bundle in state.items():
            _arrays(name, bundle, saved)
        _arrays("frames", _frame_state(out.frames.compiled), saved)
        for key, target in saved.items():
            if key not in p:
                raise CheckpointError(f"checkpoint {self.path}: no array {key!r} (written by another layout)")
            src = p[key]
            if src.shape != target.shape or src.dtype != target.dtype:
                raise CheckpointError(
                    f"checkpoint {self.path}: {key} is {src.dtype}{src.shape}, the run has {target.dtype}{target.shape}"
                )
            np.copyto(target, src)
        out.frames.chunks = {name: [p[f"frames.chunk.{name}"]] for name in FRAME_FIELDS}
        out.trace.t_chunks, out.trace.z_chunks = [p["trace.t"]], [p["trace.z"]]
        out.trace.compiled.count[0] = 0
        rows = int(p["log.n"][0])
        out.log.reserve(rows)
        log = out.log.compiled
        for name in LOG_FIELDS:
            getattr(log, name)[:rows] = p[f"log.{name}"]
        log.n[0] = rows
        return float(self.header["t"])

    # -- writing -----------------------------------------------------------------
    def wall_seconds(self) -> float:
        """Wall time spent on the run so far, over every process that took it up."""
        return self.wall_before + (time.perf_counter() - self.started)

    def save_if_due(self, t: float, state: dict, out) -> bool:
        if time.perf_counter() - self.last < self.every:
            return False
        self.save(t, state, out)
        return True

    def save(self, t: float, state: dict, out) -> Path | None:
        """Write the run's state at time t (nondimensional) atomically.  A file that
        cannot be written (a full disk, a directory gone) does not stop the run: None,
        and ``failure`` says why (the run's message carries it)."""
        try:
            path = self._write(t, state, out)
        except OSError as exc:
            self.failure = f"checkpoint not written at t = {t:.6g} ({type(exc).__name__}: {exc})"
            self.last = time.perf_counter()
            return None
        self.failure = ""
        return path

    def _write(self, t: float, state: dict, out) -> Path:
        arrays: dict = {}
        for name, bundle in state.items():
            _arrays(name, bundle, arrays)
        frames = out.frames.arrays()  # (emptied into one chunk each: the next save concatenates less)
        out.frames.chunks = {name: [a] for name, a in frames.items()}
        arrays.update({f"frames.chunk.{name}": a for name, a in frames.items()})
        _arrays("frames", _frame_state(out.frames.compiled), arrays)
        arrays["trace.t"], arrays["trace.z"] = out.trace.arrays()
        out.trace.t_chunks, out.trace.z_chunks = [arrays["trace.t"]], [arrays["trace.z"]]
        for name, rows in zip(LOG_FIELDS, out.log.view()):
            arrays[f"log.{name}"] = rows
        arrays["log.n"] = out.log.compiled.n
        header = dict(self.identity or {}, t=float(t), wall_seconds=self.wall_seconds(), saved=_now())
        arrays["header"] = np.array(json.dumps(header, sort_keys=True))
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        try:
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, self.path)
        except OSError:
            tmp.unlink(missing_ok=True)
            raise
        self.last = time.perf_counter()
        return self.path

    def discard(self) -> None:
        """Remove the checkpoint (the run's result is saved elsewhere)."""
        self.path.unlink(missing_ok=True)


def _frame_state(frames):
    """The frame buffers' counters (the per-frame arrays travel as chunks)."""
    return {"next": frames.next, "count": frames.count, "fill": frames.fill}


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


__all__ = ["Checkpoint", "CheckpointError", "DEFAULT_EVERY", "run_identity", "state_digest"]
