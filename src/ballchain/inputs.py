"""The run's inputs from plain values: what the CLI's options and ``ballchain.simulate``'s
keywords become (validated parameter dataclasses).  Defaults are the dataclasses' own."""

from __future__ import annotations

from typing import Any

from .contacts.registry import all_params as contact_params
from .methods import all_options, check_contacts, check_options
from .model import ChainParams, InitialCondition, ParameterError, SolverOptions, parse_angle


def _parse_angle(name: str, text: str | float) -> float:
    try:
        return parse_angle(text)
    except (ParameterError, ValueError):
        raise ParameterError(f"{name}: cannot parse angle {text!r} (use e.g. 45deg, pi/4 or 0.785)") from None


def _parse_spawn_key(text: str) -> tuple[int, ...]:
    """``""`` -> (), ``"3"`` -> (3,), ``"3,1"`` -> (3, 1)."""
    text = str(text or "").strip()
    if not text:
        return ()
    try:
        return tuple(int(k) for k in text.split(","))
    except ValueError:
        raise ParameterError(
            f"spawn-key must be comma-separated integers >= 0 (as a sweep table's spawn_key), got {text!r}"
        ) from None


START_OPTIONS = ("ic", "eps", "turns", "phase", "seed", "spawn_key")  # an initial-condition family's


def check_start(given, source: str) -> None:
    """Refuse, in one line, an option of the initial-condition families (``START_OPTIONS``,
    among the names ``given``) beside an explicit initial state (from ``source``), which
    they would not change (the command line's ``--initial``, ``bc.simulate``'s ``initial``)."""
    named = [name for name in START_OPTIONS if name in given]
    if named:
        flags = ", ".join("--" + name.replace("_", "-") for name in named)
        raise ParameterError(
            f"{flags} {'is' if len(named) == 1 else 'are'} not used beside {source}: the start is its state "
            f"(leave {'it' if len(named) == 1 else 'them'} out)"
        )


# the defaults of the options are those of the parameter dataclasses (stated once, there)
_CHAIN, _START, _SOLVER = ChainParams(), InitialCondition(), SolverOptions()


def build_inputs(values: dict[str, Any]) -> tuple[ChainParams, InitialCondition, SolverOptions]:
    """The CLI's option values (by the dataclasses' field names, plus ``ic`` for the start's
    kind, ``spawn_key`` as text and ``length``/``mass``/``gravity`` for a chain in SI units;
    a missing value takes the dataclass's default; the methods' options by their names,
    ``methods.all_options``) -> validated dataclasses (raises
    ParameterError)."""
    v = dict(values)
    chain_kw = dict(
        alpha=_parse_angle("alpha", v.get("alpha", _CHAIN.alpha)),
        floor=v.get("floor", _CHAIN.floor),
        anchor_cone=v.get("anchor_cone", _CHAIN.anchor_cone),
        # the contact laws' parameters (contacts.registry)
        **{name: v[name] for name in contact_params() if v.get(name) is not None},
    )
    segments = v.get("segments", _CHAIN.segments)
    length, mass, gravity = v.get("length"), v.get("mass"), v.get("gravity")
    if length is None and mass is None and gravity is None:
        params = ChainParams(segments=segments, **chain_kw)
    else:
        missing = [n for n, x in (("--length", length), ("--mass", mass)) if x is None]
        if missing:
            raise ParameterError(
                f"{' and '.join(missing)} required: SI units (--length/--mass/--gravity) "
                f"need the total length (m) and total mass (kg)"
            )
        if isinstance(segments, int) and segments < 1:
            raise ParameterError(f"segments must be >= 1, got {segments}")
        params = ChainParams.from_chain(segments, length, mass, 9.81 if gravity is None else gravity, **chain_kw)
    init = InitialCondition(
        kind=v.get("ic", _START.kind),
        eps=v.get("eps", _START.eps),
        turns=v.get("turns", _START.turns),
        phase=_parse_angle("phase", v.get("phase", _START.phase)),
        seed=v.get("seed", _START.seed),
        spawn_key=_parse_spawn_key(v.get("spawn_key", "")),
    )
    options = SolverOptions(
        until=v.get("until", _SOLVER.until),
        frames_per_tff=v.get("frames_per_tff", _SOLVER.frames_per_tff),
        max_time=v.get("max_time", _SOLVER.max_time),
        max_events=v.get("max_events", _SOLVER.max_events),
        method=v.get("method", _SOLVER.method),
        **{name: v[name] for name in all_options() if name in v},  # the methods' own (methods.all_options)
    )
    check_contacts(params, options.method)  # (before anything compiles)
    check_options(options, params.segments)
    return params, init, options
