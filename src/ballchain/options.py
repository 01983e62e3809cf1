"""What an option is, as plain data (``MethodOption``: a method's option, or a contact law's
parameter), and the checks its values pass (``positive``, ``in_range``, ``one_of``, ...).

Each method's package states the options it owns in its ``__init__`` (``OPTIONS``: a tuple
of ``MethodOption``, importable without its kernels); the registry (``methods``) gathers
them, and everything that names an option learns it from there: ``SolverOptions`` (its
field, default and validation), ``ballchain simulate`` and ``ballchain sweep`` (the flag
and its help), the sweep's grid and table (the column), ``simulate --json`` and its key
list (``records.json_keys``), and the keywords of ``bc.simulate`` and ``bc.sweep``.  A
new option of one method is one ``MethodOption`` in that method's ``__init__`` (and the
code of the method that reads it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .errors import ParameterError

# the sweep table's column type of an option's value type
COLUMN_TYPES = {float: "float64", int: "int64", str: "string", bool: "bool"}


def number(name: str, value: Any) -> float:
    """``value`` as a float (ParameterError if it is not a number)."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None


def positive(at_most: float | None = None, unit: str = "", at_least: float | None = None, why: str = ""):
    """A check: a finite number > 0 (and ``at_least`` <= it <= ``at_most`` if given; ``unit``
    and ``why`` go into the messages)."""

    def check(name: str, value: Any) -> float:
        v = number(name, value)
        if not math.isfinite(v) or v <= 0.0:
            raise ParameterError(f"{name} must be finite and > 0, got {value!r}")
        if at_most is not None and v > at_most:
            raise ParameterError(f"{name} must be at most {at_most:g}{f' ({unit})' if unit else ''}, got {value!r}")
        if at_least is not None and v < at_least:
            raise ParameterError(f"{name} must be >= {at_least:g}{f' ({why})' if why else ''}, got {value!r}")
        return v

    return check


def non_negative(name: str, value: Any) -> float:
    """A check: a finite number >= 0."""
    v = number(name, value)
    if not (math.isfinite(v) and v >= 0.0):
        raise ParameterError(f"{name} must be finite and >= 0, got {value!r}")
    return v


def in_range(low: float, high: float, why: str | tuple[str, str] = ""):
    """A check: a number in [low, high] (``why``: what lies outside, for the message; a pair:
    what lies below, what lies above)."""

    def check(name: str, value: Any) -> float:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ParameterError(f"{name} must be a number in [{low:g}, {high:g}], got {value!r}") from None
        if math.isnan(v):  # (outside for no reason ``why`` gives)
            raise ParameterError(f"{name} must be a number in [{low:g}, {high:g}], got {value!r}")
        if not (low <= v <= high):
            said = (why[0] if v < low else why[1]) if isinstance(why, tuple) else why
            raise ParameterError(f"{name} must be in [{low:g}, {high:g}]{f' ({said})' if said else ''}, got {value!r}")
        return v

    return check


def one_of(choices) -> Callable[[str, Any], str]:
    """A check: one of ``choices`` (names; a dict's keys)."""
    allowed = tuple(choices)

    def check(name: str, value: Any) -> str:
        if value not in allowed:
            raise ParameterError(f"{name} must be one of {allowed}, got {value!r}")
        return value

    return check


@dataclass(frozen=True)
class MethodOption:
    """One option of a method.

    name: the ``SolverOptions`` field; also the keyword of ``bc.simulate`` and ``bc.sweep``,
        the key of ``simulate --json`` and the sweep table's column.
    type: the type of its value (float, int or str; None is allowed when ``default`` is).
    default: the ``SolverOptions`` default.  None with ``by_segments``: filled in when a run
        starts (``SolverOptions.for_segments``).
    help: what ``--help`` says of it, units included (and its default when it is not one value).
    check: ``check(name, value)`` -> the value, normalised; raises ParameterError with one line.
        A value of None is not checked (it means: the default).
    flag: its command-line flag (``simulate`` and ``sweep``); None: only a ``SolverOptions``
        field (no flag, keyword, JSON key nor column).
    json: what its ``simulate --json`` key holds (None: not in the summary).
    column: the meaning of its sweep-table column (None: not a sweep option).
    by_segments: the owner's default for an N-segment chain, ``by_segments(N)`` (with
        ``default`` None); another method's runs record ``unused`` unless its package states
        its own (``DEFAULTS``).
    unused: what runs of a method that neither owns nor sets it record (with ``by_segments``).
    run_key: ``run_key(options)`` -> its part of a sweep run's key (``sweeps.spec.run_id``);
        None: ``_NAME VALUE`` when it differs from its default, else nothing (a new option
        leaves the keys of the runs that do not set it as they were).
    key_among_inputs: its part of the key comes among the run's own inputs, before
        ``_until``, not at the key's end: the place of the options that were in every run's
        key before the methods stated their own (so that old tables' run ids, and with them
        resumption, stay as they were).  New options leave it False.
    """

    name: str
    type: type
    default: Any
    help: str
    check: Callable[[str, Any], Any]
    flag: str | None = None
    json: str | None = None
    column: str | None = None
    by_segments: Callable[[int], Any] | None = None
    unused: Any = None
    run_key: Callable[[Any], str] | None = None
    key_among_inputs: bool = False

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"option name {self.name!r} is not an identifier")
        if self.flag is not None and not self.flag.startswith("--"):
            raise ValueError(f"option {self.name!r}: its flag must start with '--', got {self.flag!r}")
        if self.type not in COLUMN_TYPES:
            raise ValueError(f"option {self.name!r}: type must be one of {tuple(t.__name__ for t in COLUMN_TYPES)}")

    def validated(self, value: Any) -> Any:
        """``value`` checked and normalised (None stays None: the default)."""
        return None if value is None else self.check(self.name, value)

    @property
    def column_type(self) -> str:
        """The sweep table's column type (``sweeps.table.COLUMNS``)."""
        return COLUMN_TYPES[self.type]

    @property
    def annotation(self):
        """The Python type of its values (``X | None`` when None is its default)."""
        return self.type | None if self.default is None else self.type

    def key(self, options) -> str:
        """Its part of the key of a sweep run with ``options`` (``run_key``; see there)."""
        if self.run_key is not None:
            return self.run_key(options)
        value = getattr(options, self.name)
        if value == self.default:
            return ""
        return f"_{self.name}{value:.12g}" if isinstance(value, float) else f"_{self.name}{value}"


def options_dataclass(base: type, name: str, module: str, registry, names=None) -> type:
    """The frozen dataclass ``name`` of ``module``: the fields of ``base`` (a frozen
    dataclass), then one per option of ``registry`` = (options by name, owner(name),
    help(name)) (the methods': ``methods.all_options``; the contact laws':
    ``contacts.registry``; ``names``: only those) with its type and default, given by
    name only; its docstring is ``base``'s and each option's help."""
    import textwrap
    from dataclasses import field, make_dataclass

    every, option_owner, option_help = registry
    opts = [o for o in every.values() if names is None or o.name in names]
    cls = make_dataclass(
        name,
        [(o.name, o.annotation, field(default=o.default)) for o in opts],
        bases=(base,),
        frozen=True,
        kw_only=True,
        namespace={"__module__": module},
    )
    cls.__doc__ = (
        (base.__doc__ or "")
        + "".join(
            "\n"
            + textwrap.fill(
                f"{o.name}: (``{option_owner(o.name)}``) {option_help(o.name)}",
                88,
                initial_indent="    ",
                subsequent_indent="        ",
            )  # fmt: skip
            for o in opts
        )
        + "\n"
    )
    return cls


def number_text(x, spec: str = ".6g") -> str:
    """A number of a run's summary as text ("n/a" if missing or not finite)."""
    return "n/a" if not isinstance(x, (int, float)) or not math.isfinite(x) else format(x, spec)
