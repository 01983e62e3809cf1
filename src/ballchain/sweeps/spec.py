"""What a sweep runs: lists and ranges of parameters -> one task per run.

A sweep is the product  N x alpha x floor x contact law x initial-condition family  with
``runs`` initial conditions per point (each contact law's parameter, ``contacts.registry``,
is an axis: ``--friction 0,0.3,inf --restitution-floor 0,0.5`` runs six laws).  Run ``k`` of every point starts from the ``k``-th child
stream of ``numpy.random.SeedSequence(seed).spawn``: the same starting shape for every
N, alpha and floor (common random numbers, so that points are compared on the same
starts), and each run rebuilt on its own from ``(seed, spawn_key)`` with
``ballchain simulate --ic random --seed S --spawn-key k``.

Everything is validated here, before anything runs: a bad specification is one
``ParameterError`` with a one-line message.
"""

from __future__ import annotations

import itertools
import math
import os
from dataclasses import dataclass, field, make_dataclass

from ..contacts.registry import all_params as contact_params
from ..contacts.registry import law_of, law_param_help
from ..methods import all_options, check_contacts, check_options, option_help, option_owner
from ..methods.checkpoint import DEFAULT_EVERY
from ..model import FLOOR_MODELS, IC_KINDS, ChainParams, InitialCondition, ParameterError, SolverOptions, parse_angle
from ..options import options_dataclass

MAX_RUNS = 1_000_000  # a guard against a typo in a range step


def _grid(start: float, stop: float, step: float, what: str) -> list[float]:
    """start, start + step, ... up to stop (stop included when it lies on the grid)."""
    if not (math.isfinite(start) and math.isfinite(stop) and math.isfinite(step)):
        raise ParameterError(f"{what}: range bounds must be finite")
    if step <= 0.0:
        raise ParameterError(f"{what}: range step must be > 0, got {step:g}")
    if stop < start:
        raise ParameterError(f"{what}: empty range (stop {stop:g} < start {start:g})")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > MAX_RUNS:
        raise ParameterError(f"{what}: range has {n} values (too many; check the step)")
    return [start + i * step for i in range(n)]


def _items(text: str, what: str) -> list[str]:
    items = [t.strip() for t in str(text).split(",")]
    if not items or any(t == "" for t in items):
        raise ParameterError(f"{what}: empty item in {text!r} (use a comma-separated list or start:stop:step)")
    return items


def parse_segments(text: str | int) -> list[int]:
    """``64,128`` or ``64:256:64`` (or a mix) -> sorted distinct N >= 1."""
    out: list[int] = []
    for item in _items(str(text), "segments"):
        parts = item.split(":")
        try:
            nums = [int(p) for p in parts]
        except ValueError:
            raise ParameterError(f"segments: {item!r} is not an integer or start:stop:step range") from None
        if len(nums) == 1:
            out.append(nums[0])
        elif len(nums) == 3:
            out.extend(int(round(v)) for v in _grid(*map(float, nums), what="segments"))
        else:
            raise ParameterError(f"segments: {item!r} is not an integer or start:stop:step range")
    for n in out:
        if n < 1:
            raise ParameterError(f"segments must be >= 1, got {n}")
    return sorted(set(out))


def _angle(text: str) -> float:
    try:
        return parse_angle(text)
    except ParameterError as e:
        raise ParameterError(f"alpha: {e}") from None


def parse_alphas(text: str) -> list[float]:
    """``pi/4,60deg`` or ``10deg:120deg:10deg`` (or a mix) -> sorted distinct radians in (0, pi]."""
    out: list[float] = []
    for item in _items(text, "alpha"):
        parts = item.split(":")
        if len(parts) == 1:
            out.append(_angle(parts[0]))
        elif len(parts) == 3:
            if all(p.strip().lower().endswith("deg") for p in parts):  # a grid in degrees: exact degrees
                a, b, s = (float(p.strip()[:-3]) for p in parts)
                out.extend(math.radians(v) for v in _grid(a, b, s, "alpha"))
            else:
                a, b, s = (_angle(p) for p in parts)
                out.extend(_grid(a, b, s, "alpha"))
        else:
            raise ParameterError(f"alpha: {item!r} is not an angle or start:stop:step range")
    for a in out:
        if not (0.0 < a <= math.pi + 1e-12):
            raise ParameterError(f"alpha must be in (0, pi] (0 < alpha <= 180deg), got {math.degrees(a):.6g} deg")
    # values within 1e-12 rad are one alpha (pi/4 and 45deg): the first one given is kept
    kept: list[float] = []
    for a in out:
        if all(abs(a - k) > 1e-12 for k in kept):
            kept.append(min(a, math.pi))
    return sorted(kept)


def parse_choices(text: str, allowed: tuple[str, ...], what: str) -> list[str]:
    out = []
    for item in _items(text, what):
        if item not in allowed:
            raise ParameterError(f"{what} must be one of {', '.join(allowed)}; got {item!r}")
        if item not in out:
            out.append(item)
    return out


def law_values(name: str, values) -> tuple:
    """The values of a contact law's parameter ``name`` as a sweep's axis: one value, a
    sequence, or the command line's text ``0,0.3,inf``; each checked as the law states it
    (``contacts.registry``), duplicates dropped, in the order given."""
    prm = contact_params()[name]
    if isinstance(values, str):
        values = _items(values, prm.flag or name)
    elif not isinstance(values, (list, tuple)):
        values = (values,)
    if len(values) == 0:
        raise ParameterError(f"{prm.flag or name}: needs at least one value")
    out: list = []
    for v in values:
        v = prm.validated(v)
        if v is None:
            v = prm.default
        if v not in out:
            out.append(v)
    return tuple(out)


@dataclass(frozen=True)
class Task:
    """One run of a sweep: its identity and its validated inputs (picklable)."""

    run_id: str
    run_index: int
    params: ChainParams
    ic: InitialCondition
    options: SolverOptions
    save_path: str | None = None
    checkpoint_path: str | None = None  # the run's checkpoint (``methods.checkpoint``), if the sweep keeps them
    checkpoint_every: float = DEFAULT_EVERY  # seconds of wall time between checkpoints


def sweep_options() -> list[str]:
    """The methods' options a sweep sets (those with a sweep column: ``methods.all_options``)."""
    return [name for name, opt in all_options().items() if opt.column is not None]


@dataclass(frozen=True)
class _SweepGrid:
    """A sweep: the grid, the starts per point, and the per-run options (the methods' own
    follow, ``sweep_options``: one field each, as ``SolverOptions`` has; ``dt`` and
    ``theta`` None: by N, ``SolverOptions.for_segments``)."""

    segments: tuple[int, ...]
    alphas: tuple[float, ...]
    floors: tuple[str, ...] = ("all",)
    ics: tuple[str, ...] = ("random",)
    runs: int = 1
    seed: int = 0
    eps: float = InitialCondition.eps
    until: float | None = SolverOptions.until
    frames_per_tff: float = SolverOptions.frames_per_tff
    max_time: float = SolverOptions.max_time
    method: str = SolverOptions.method
    save_runs: str | None = None
    checkpoints: str | None = None  # a directory: each run checkpoints there and resumes from it
    checkpoint_every: float = DEFAULT_EVERY
    options: SolverOptions = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.segments or not self.alphas or not self.floors or not self.ics:
            raise ParameterError("sweep: every axis (segments, alpha, floor, ic) needs at least one value")
        if int(self.runs) != self.runs or self.runs < 1:
            raise ParameterError(f"runs must be an integer >= 1, got {self.runs!r}")
        if not (self.checkpoint_every >= 0.0):
            raise ParameterError(f"checkpoint-every must be >= 0 seconds, got {self.checkpoint_every!r}")
        if int(self.seed) != self.seed or self.seed < 0:
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        for kind in self.ics:
            if kind not in IC_KINDS:
                raise ParameterError(f"ic must be one of {', '.join(IC_KINDS)}; got {kind!r}")
            if kind != "random" and self.runs > 1:
                raise ParameterError(
                    f"--runs {self.runs} needs --ic random: the {kind} start is one "
                    f"deterministic shape (vary --eps instead)"
                )
        for f in self.floors:
            if f not in FLOOR_MODELS:
                raise ParameterError(f"floor must be one of {', '.join(FLOOR_MODELS)}; got {f!r}")
        object.__setattr__(
            self,
            "options",
            SolverOptions(
                until=self.until,
                frames_per_tff=self.frames_per_tff,
                max_time=self.max_time,
                method=self.method,
                **{name: getattr(self, name) for name in sweep_options()},
            ),
        )
        InitialCondition(eps=self.eps)  # validates eps
        for name in contact_params():
            object.__setattr__(self, name, law_values(name, getattr(self, name)))
        for laws in self.law_grid():  # every law of the grid: one the model and the method take
            try:
                for fl in self.floors:
                    check_contacts(ChainParams(segments=1, floor=fl, **laws), self.method)
            except ParameterError as exc:
                shown = ", ".join(
                    f"{contact_params()[k].flag} {v:g}"
                    for k, v in laws.items()
                    if len(getattr(self, k)) > 1 or v != contact_params()[k].default
                )
                raise ParameterError(f"sweep point {shown}: {exc}") from None
        check_options(self.options, min(self.segments))
        n = self.size
        if n > MAX_RUNS:
            raise ParameterError(f"sweep has {n} runs (more than {MAX_RUNS}); narrow it")

    def law_grid(self) -> list[dict]:
        """The contact laws of the grid: every combination of the laws' parameters' values
        (``contacts.registry``, in its order), one dict of parameter values each."""
        names = list(contact_params())
        return [dict(zip(names, values)) for values in itertools.product(*(getattr(self, n) for n in names))]

    @property
    def size(self) -> int:
        laws = math.prod(len(getattr(self, name)) for name in contact_params())
        return len(self.segments) * len(self.alphas) * len(self.floors) * laws * len(self.ics) * self.runs

    def tasks(self) -> list[Task]:
        """Every run, validated (parameters and the initial state inside the cone)."""
        from ..initial import initial_directions

        out = []
        checked: set = set()
        for n in self.segments:
            for a in self.alphas:
                for fl, laws in itertools.product(self.floors, self.law_grid()):
                    params = ChainParams(segments=n, alpha=a, floor=fl, **laws)
                    for kind in self.ics:
                        for k in range(self.runs):
                            ic = InitialCondition(
                                kind=kind, eps=self.eps, seed=self.seed, spawn_key=(k,) if kind == "random" else ()
                            )
                            key = (n, a, kind, k)
                            if key not in checked:  # the floor and the laws do not change the start
                                try:
                                    initial_directions(ic, n, params.alpha)
                                except ParameterError as exc:
                                    raise ParameterError(
                                        f"N = {n}, alpha = {math.degrees(a):.6g} deg, {kind} run {k}: {exc}"
                                    ) from None
                                checked.add(key)
                            options = self.options.for_segments(n)
                            rid = run_id(params, ic, options)
                            path = ck = None
                            if self.save_runs is not None:
                                path = os.path.join(self.save_runs, rid + ".h5")
                            if self.checkpoints is not None:
                                ck = os.path.join(self.checkpoints, rid + ".ckpt.npz")
                            out.append(Task(rid, k, params, ic, options, path, ck, self.checkpoint_every))
        return out


def _law_axes(base: type) -> type:
    """``base`` with one field per contact law's parameter (``contacts.registry``): the tuple
    of its values, an axis of the grid (default: the law's default alone; one value or a
    sequence is taken, ``law_values``)."""
    cls = make_dataclass(
        "_SweepContacts",
        [(name, tuple, field(default=(prm.default,))) for name, prm in contact_params().items()],
        bases=(base,),
        frozen=True,
        kw_only=True,
        namespace={"__module__": __name__},
    )
    cls.__doc__ = (base.__doc__ or "") + "".join(
        f"\n    {name}: (``{law_of(name)}``) the values of the grid's axis (one or more): {law_param_help(name)}"
        for name in contact_params()
    )
    return cls


# the contact laws' parameters (each an axis of the grid), then the methods' options
_SweepContacts = _law_axes(_SweepGrid)
SweepSpec = options_dataclass(
    _SweepContacts, "SweepSpec", __name__, (all_options(), option_owner, option_help), sweep_options()
)


def run_id(params: ChainParams, ic: InitialCondition, options: SolverOptions) -> str:
    """A run's key in the table: every input that changes the run, readable (``options``
    with dt and theta filled in: ``SolverOptions.for_segments``); the methods' options
    each add their part (``MethodOption.key``: nothing when not set, as before they existed;
    among the inputs those with ``key_among_inputs``, at the end the others)."""
    until = "end" if options.until is None else f"{options.until:.12g}"
    key = "-".join(str(k) for k in ic.spawn_key) or "none"
    opts = all_options().values()
    among_inputs = "".join(opt.key(options) for opt in opts if opt.key_among_inputs)
    return (
        f"N{params.segments}_a{math.degrees(params.alpha):.10g}deg_{params.floor}"
        f"{'_cone' if params.anchor_cone else ''}_{ic.kind}_eps{ic.eps:.12g}_q{ic.turns:.12g}"
        f"_ph{ic.phase:.12g}_seed{ic.seed}_key{key}{among_inputs}_until{until}"
        f"_fr{options.frames_per_tff:.12g}"
        + ("" if options.max_time == SolverOptions.max_time else f"_tmax{options.max_time:.12g}")
        + "".join(opt.key(options) for opt in opts if not opt.key_among_inputs)
        + "".join(prm.key(params) for prm in contact_params().values())  # (nothing at their defaults)
    )
