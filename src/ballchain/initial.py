"""Initial conditions (docs/model.md, section 5): the chain at rest, almost vertical.

Arrays are indexed from the top: row ``i`` is segment ``n = i + 1`` of docs/model.md.
Directions ``e`` have shape (N, 3), unit vectors pointing up the chain.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .model import InitialCondition, ParameterError


def _normalize_tilts(tilt: np.ndarray) -> np.ndarray:
    """e = normalize(e_z + tilt), tilt horizontal, shape (N, 2)."""
    e = np.empty((tilt.shape[0], 3))
    e[:, :2] = tilt
    e[:, 2] = 1.0
    return e / np.linalg.norm(e, axis=1)[:, None]


def helix_directions(segments: int, eps: float, turns: float, phase: float) -> np.ndarray:
    """The helix of docs/model.md: e_n = normalize(e_z + eps (cos phi_n, sin phi_n, 0)),
    phi_n = 2 pi q (N - n)/N + phi0, n = 1..N from the top."""
    n = np.arange(1, segments + 1)
    phi = 2.0 * math.pi * turns * (segments - n) / segments + phase
    return _normalize_tilts(eps * np.stack([np.cos(phi), np.sin(phi)], axis=1))


def planar_directions(segments: int, eps: float, turns: float, phase: float) -> np.ndarray:
    """A bend in the vertical plane at azimuth phi0:
    e_n = normalize(e_z + eps cos(2 pi q (N - n)/N) (cos phi0, sin phi0, 0))."""
    n = np.arange(1, segments + 1)
    amp = eps * np.cos(2.0 * math.pi * turns * (segments - n) / segments)
    return _normalize_tilts(np.outer(amp, [math.cos(phase), math.sin(phase)]))


def random_directions(
    segments: int, eps: float, modes: int, seed: int, phase: float, spawn_key: tuple[int, ...] = ()
) -> np.ndarray:
    """A smooth random tilt: ``modes`` Fourier modes along the chain with random
    horizontal coefficients (amplitude falling as 1/k), scaled so that the largest
    tilt |e_n - (e_n . e_z) e_z| / (e_n . e_z) is ``eps`` (as in the other families),
    then rotated by phi0 about z.  Seeded: the same seed (and spawn key) gives the same
    chain; ``spawn_key=(k,)`` is the k-th child of ``SeedSequence(seed).spawn``."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=tuple(spawn_key)))
    coef = rng.standard_normal((modes, 2, 2)) / np.arange(1, modes + 1)[:, None, None]
    s = (segments - np.arange(1, segments + 1) + 0.5) / segments  # 0 at bottom, 1 at top
    k = np.arange(1, modes + 1)[:, None]
    c, sn = np.cos(math.pi * k * s), np.sin(math.pi * k * s)  # (modes, N)
    tilt = np.einsum("kn,kd->nd", c, coef[:, 0]) + np.einsum("kn,kd->nd", sn, coef[:, 1])
    largest = float(np.max(np.hypot(tilt[:, 0], tilt[:, 1])))
    tilt *= eps / largest if largest > 0 else 0.0
    cp, sp = math.cos(phase), math.sin(phase)
    tilt = tilt @ np.array([[cp, sp], [-sp, cp]])
    return _normalize_tilts(tilt)


def initial_directions(ic: InitialCondition, segments: int, alpha: float) -> np.ndarray:
    """Directions e (N, 3) of the initial chain; raises ParameterError if any hinge
    starts outside (or on) the critical angle alpha."""
    if ic.kind == "helix":
        e = helix_directions(segments, ic.eps, ic.turns, ic.phase)
    elif ic.kind == "planar":
        e = planar_directions(segments, ic.eps, ic.turns, ic.phase)
    else:
        e = random_directions(segments, ic.eps, ic.modes, ic.seed, ic.phase, ic.spawn_key)
    check_inside_cone(e, alpha)
    return e


def hinge_angles(e: np.ndarray) -> np.ndarray:
    """Bend angle at each hinge, arccos(e_k . e_{k+1}), shape (N-1,)."""
    c = np.clip(np.einsum("ij,ij->i", e[:-1], e[1:]), -1.0, 1.0)
    return np.arccos(c)


def check_inside_cone(e: np.ndarray, alpha: float, remedy: str = "reduce eps") -> None:
    """Raise ParameterError (ending with ``remedy``: what to change; an explicit state's
    differs from a family's) if a hinge of ``e`` starts outside (or on) the critical
    angle alpha, or a segment at or below the horizontal."""
    if e.shape[0] < 2:
        return
    ang = hinge_angles(e)
    worst = int(np.argmax(ang))
    if ang[worst] >= alpha:
        raise ParameterError(
            f"initial state: hinge {worst + 1} bends {math.degrees(ang[worst]):.3g} deg, "
            f"not strictly inside alpha = {math.degrees(alpha):.3g} deg ({remedy})"
        )
    if np.any(e[:, 2] <= 0.0):
        raise ParameterError(f"initial state: a segment points at or below the horizontal ({remedy})")


def load_initial_state(path) -> tuple[np.ndarray, np.ndarray | None]:
    """An initial state from a file: a text file (whitespace-separated, ``#`` comments)
    or a ``.npy`` array of shape (N, 3) (the axes e_n, rows n = 1..N from the top,
    pointing up the chain) or (N, 6) (axes, then angular velocities in sqrt(g/b)).
    Axes need not be exactly unit length (they are normalised); the engine checks the
    state like any input (inside the cone, above the floor).  Raises ParameterError
    with a one-line message naming the file."""
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise ParameterError(f"initial: no such file {str(p)!r}")
    if p.stat().st_size == 0:
        raise ParameterError(f"initial: {str(p)!r} is empty (no rows)")
    try:
        if p.suffix == ".npy":
            a = _load_npy(p)
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # (numpy's on an empty file: said below)
                a = np.loadtxt(p, comments="#", ndmin=2)
    except (OSError, ValueError, EOFError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ParameterError(f"initial: cannot read {str(p)!r}: {msg}") from None
    a = np.asarray(a, dtype=float)
    if a.size == 0:
        raise ParameterError(f"initial: {str(p)!r} holds no rows (only comments or blank lines)")
    if a.ndim != 2 or a.shape[1] not in (3, 6) or a.shape[0] < 1:
        raise ParameterError(
            f"initial: {str(p)!r} must hold an N x 3 (axes) or N x 6 (axes, angular velocities) "
            f"array, got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"initial: {str(p)!r} has non-finite entries")
    norms = np.linalg.norm(a[:, :3], axis=1)
    if np.any(norms < 1e-6):
        bad = int(np.argmin(norms))
        raise ParameterError(f"initial: {str(p)!r} row {bad + 1}: axis of (near) zero length")
    e = a[:, :3] / norms[:, None]
    w = a[:, 3:].copy() if a.shape[1] == 6 else None
    return e, w


NPY_MAGIC = b"\x93NUMPY"  # the first bytes of every .npy file


def _load_npy(p) -> np.ndarray:
    """A ``.npy`` array of numbers (ValueError naming what the file is instead: not a .npy
    file, or an array of Python objects, which is never unpickled)."""
    with open(p, "rb") as f:
        if f.read(len(NPY_MAGIC)) != NPY_MAGIC:
            raise ValueError("not a .npy file (no NumPy header; a text array needs another suffix, e.g. .txt)")
    try:
        return np.load(p, allow_pickle=False)
    except ValueError as exc:
        if "allow_pickle" in str(exc):
            raise ValueError("it holds an array of Python objects, not numbers") from None
        raise
