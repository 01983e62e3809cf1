"""The model and its parameters (docs/model.md, section 1).

A chain of ``N`` rigid rods (mass ``m``, length ``2b``) joined by spherical hinges
whose bend angle is limited to ``alpha``, standing on a pivot at the origin under
gravity ``g``.  Parameters are frozen dataclasses validated on construction; they are
plain, picklable data so that sweeps can ship them to workers.

Units: ``m`` in kg, ``b`` in m, ``g`` in m/s^2 for a physical chain, or the
nondimensional ``m = b = g = 1`` (the default).  The engine always works in the
nondimensional units (mass ``m``, length ``b``, time ``sqrt(b/g)``) and converts at
the edges, so results in units of ``t_ff`` do not depend on ``m, b, g``.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, replace

import numpy as np

from .contacts.registry import all_params as contact_params  # (one registry of contact laws)
from .contacts.registry import check_laws, law_of, law_param_help
from .errors import ParameterError  # noqa: F401  (re-exported: the model's validation raises it)
from .floors.registry import FLOOR_MODELS, WATCHES_EVERY_POINT  # noqa: E402  (one registry of floor models)
from .methods import METHOD_NAMES, all_options, method_default, option_help, option_owner  # noqa: E402  (one registry of methods)
from .methods.event_driven import RTOL_MIN  # noqa: E402, F401  (re-exported: the event method's)
from .options import options_dataclass

IC_KINDS = ("helix", "planar", "random")


def _finite_positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ParameterError(f"{name} must be finite and > 0, got {value!r}")
    return v


def parse_angle(text: str | float) -> float:
    """Parse an angle: radians (``0.785``), degrees (``45deg``), or ``pi/4``, ``3pi/4``, ``pi``.
    Anything else (``pi/0``, ``1.2.3pi``) raises ParameterError."""
    if isinstance(text, (int, float)):
        return float(text)
    s = str(text).strip().lower().replace(" ", "")
    try:
        m = re.fullmatch(r"([-+]?[0-9.eE+-]+)(deg|°)", s)
        if m:
            return math.radians(float(m.group(1)))
        m = re.fullmatch(r"([-+]?[0-9.]*)\*?pi(?:/([0-9.]+))?", s)
        if m:
            num = m.group(1)
            coef = 1.0 if num in ("", "+") else (-1.0 if num == "-" else float(num))
            den = float(m.group(2)) if m.group(2) else 1.0
            return coef * math.pi / den
        return float(s)
    except (ValueError, ZeroDivisionError, OverflowError):
        raise ParameterError(f"cannot parse angle {text!r} (use e.g. 45deg, pi/4 or 0.785)") from None


@dataclass(frozen=True)
class _Chain:
    """Physical parameters of the chain.

    segments: number of rods N (>= 1).
    alpha: critical bend angle in radians, 0 < alpha <= pi (pi: hinges never lock).
    floor: ``"all"`` (every point is stopped and anchored by the floor) or
        ``"pivot"`` (the paper read literally: only the bottom airborne segment meets it).
    anchor_cone: keep the hinge limit between a landed segment and the airborne
        segment hinged to it.  Beware: a landed segment is fixed for good and then acts
        as a cantilever with unlimited torque that can hold a locked chain up.
    segment_mass: m in kg (or 1, nondimensional).
    half_length: b in m (or 1); a segment is 2b long.
    gravity: g in m/s^2 (or 1).

    The fields that follow are the contact laws' parameters, stated by their registry
    (``contacts.registry``: name, default, help and check in one place):
    """

    segments: int = 128
    alpha: float = math.pi / 4
    floor: str = "all"
    anchor_cone: bool = False
    segment_mass: float = 1.0
    half_length: float = 1.0
    gravity: float = 1.0

    def __post_init__(self) -> None:
        if isinstance(self.segments, bool) or not isinstance(self.segments, int):
            try:
                n = int(self.segments)
            except (TypeError, ValueError):
                raise ParameterError(f"segments must be an integer >= 1, got {self.segments!r}") from None
            if n != self.segments:
                raise ParameterError(f"segments must be an integer >= 1, got {self.segments!r}")
            object.__setattr__(self, "segments", n)
        if self.segments < 1:
            raise ParameterError(f"segments must be >= 1, got {self.segments}")
        a = float(self.alpha)
        if not math.isfinite(a) or not (0.0 < a <= math.pi + 1e-15):
            raise ParameterError(f"alpha must be in (0, pi] radians, got {self.alpha!r}")
        object.__setattr__(self, "alpha", min(a, math.pi))
        if self.floor not in FLOOR_MODELS:
            raise ParameterError(f"floor must be one of {FLOOR_MODELS}, got {self.floor!r}")
        object.__setattr__(self, "anchor_cone", bool(self.anchor_cone))
        for name in ("segment_mass", "half_length", "gravity"):
            object.__setattr__(self, name, _finite_positive(name, getattr(self, name)))
        for name, p in contact_params().items():  # the contact laws' (contacts.registry)
            object.__setattr__(self, name, p.validated(getattr(self, name)))
        check_laws(self, WATCHES_EVERY_POINT)  # the rules between the laws and the floor (contacts.registry)

    @classmethod
    def from_chain(cls, segments: int, length_m: float, mass_kg: float, gravity_m_s2: float = 9.81, **kw):
        """A real chain: total length (m), total mass (kg), gravity (m/s^2)."""
        length_m = _finite_positive("length", length_m)
        mass_kg = _finite_positive("mass", mass_kg)
        n = int(segments)
        if n < 1:
            raise ParameterError(f"segments must be >= 1, got {segments}")
        return cls(segments=n, segment_mass=mass_kg / n, half_length=length_m / (2 * n), gravity=gravity_m_s2, **kw)

    @property
    def time_unit(self) -> float:
        """sqrt(b/g): the engine's unit of time, in s (or nondimensional)."""
        return math.sqrt(self.half_length / self.gravity)

    @property
    def force_unit(self) -> float:
        """m g: unit of force."""
        return self.segment_mass * self.gravity

    @property
    def energy_unit(self) -> float:
        """m g b: unit of energy."""
        return self.segment_mass * self.gravity * self.half_length

    @property
    def damping_unit(self) -> float:
        """m g b sqrt(b/g): unit of the hinges' damping coefficient (a torque times a time)."""
        return self.energy_unit * self.time_unit

    @property
    def is_si(self) -> bool:
        return not (self.segment_mass == 1.0 and self.half_length == 1.0 and self.gravity == 1.0)

    def to_dict(self) -> dict:
        return asdict(self)


ChainParams = options_dataclass(_Chain, "ChainParams", __name__, (contact_params(), law_of, law_param_help))


@dataclass(frozen=True)
class InitialCondition:
    """Initial shape of the chain, at rest (docs/model.md, section 5).

    kind: ``helix`` (exactly as docs/model.md defines it), ``planar`` (a bend in one vertical
        plane) or ``random`` (a few seeded random Fourier modes of the tilt).
    eps: amplitude of the tilt (dimensionless).
    turns: q, turns of the helix / wavenumber of the planar bend along the chain.
    phase: phi0 in radians (rotates the chain rigidly about z).
    seed: seed of the ``random`` family (the entropy of its ``numpy.random.SeedSequence``).
    modes: number of Fourier modes of the ``random`` family.
    spawn_key: spawn key of that SeedSequence (``()``: the seed's own stream; ``(k,)``:
        the k-th child of ``SeedSequence(seed).spawn``, as ``ballchain sweep`` draws run k).
    """

    kind: str = "helix"
    eps: float = 0.02
    turns: float = 1.0
    phase: float = 0.0
    seed: int = 0
    modes: int = 4
    spawn_key: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in IC_KINDS:
            raise ParameterError(f"ic must be one of {IC_KINDS}, got {self.kind!r}")
        e = float(self.eps)
        if not math.isfinite(e) or e < 0.0:
            raise ParameterError(f"eps must be finite and >= 0, got {self.eps!r}")
        object.__setattr__(self, "eps", e)
        for name in ("turns", "phase"):
            v = float(getattr(self, name))
            if not math.isfinite(v):
                raise ParameterError(f"{name} must be finite, got {getattr(self, name)!r}")
            object.__setattr__(self, name, v)
        if int(self.seed) != self.seed or int(self.seed) < 0:
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        object.__setattr__(self, "seed", int(self.seed))
        if int(self.modes) < 1:
            raise ParameterError(f"modes must be >= 1, got {self.modes!r}")
        object.__setattr__(self, "modes", int(self.modes))
        key = self.spawn_key
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            key = (key,)
        if isinstance(key, (str, bytes)) or not hasattr(key, "__iter__"):
            raise ParameterError(f"spawn_key must be a sequence of integers >= 0, got {self.spawn_key!r}")
        key = tuple(key)
        if not all(isinstance(k, (int, np.integer)) and not isinstance(k, bool) and k >= 0 for k in key):
            raise ParameterError(f"spawn_key must be a sequence of integers >= 0, got {self.spawn_key!r}")
        key = tuple(int(k) for k in key)
        object.__setattr__(self, "spawn_key", key)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["spawn_key"] = list(self.spawn_key)  # as JSON writes it
        return d


@dataclass(frozen=True, kw_only=True)  # by name only: the methods' fields follow (their order is the registry's)
class _RunOptions:
    """Numerical options.

    until: stop at this time in units of t_ff (None: run until every segment has
        landed, at most ``max_time`` t_ff).
    max_time: the time cap, in units of t_ff (a chain not landed by then stops with
        status ``max_time``).
    frames_per_tff: output frames (all segment directions) per t_ff.
    max_events: stop with a clear error after this many event instants (a Zeno guard;
        one instant can add many rows to the event log).
    max_steps: stop with a clear error after this many integrator steps.
    progress: report progress.
    method: the integration method (``methods.METHODS``): ``event`` (event-driven:
        every event located and resolved exactly), ``timestep`` (Moreau-Jean
        time-stepping, first order in dt) or ``rattle`` (nonsmooth RATTLE, second order
        where the motion is smooth).

    The fields that follow are the methods' own options, stated by their packages
    (``methods.all_options``: name, default, help and check in one place):
    """

    until: float | None = None
    max_time: float = 3.0
    frames_per_tff: float = 100.0
    max_events: int = 2_000_000
    max_steps: int = 50_000_000
    progress: bool = False
    method: str = "event"

    def __post_init__(self) -> None:
        if self.until is not None:
            object.__setattr__(self, "until", _finite_positive("until", self.until))
        object.__setattr__(self, "max_time", _finite_positive("max_time", self.max_time))
        object.__setattr__(self, "frames_per_tff", _finite_positive("frames_per_tff", self.frames_per_tff))
        if self.method not in METHOD_NAMES:
            raise ParameterError(f"method must be one of {METHOD_NAMES}, got {self.method!r}")
        for name, opt in all_options().items():
            object.__setattr__(self, name, opt.validated(getattr(self, name)))
        if int(self.max_events) < 1:
            raise ParameterError(f"max_events must be >= 1, got {self.max_events!r}")

    def for_segments(self, segments: int) -> SolverOptions:
        """These options with those left to a default by N (None; ``MethodOption.by_segments``:
        ``dt`` and ``theta``) filled in for an N-segment chain (``methods.method_default``)."""
        unset = [
            name for name, opt in all_options().items() if opt.by_segments is not None and getattr(self, name) is None
        ]
        if not unset:
            return self
        return replace(self, **{name: method_default(self.method, name, int(segments)) for name in unset})

    def to_dict(self) -> dict:
        return asdict(self)


SolverOptions = options_dataclass(_RunOptions, "SolverOptions", __name__, (all_options(), option_owner, option_help))
