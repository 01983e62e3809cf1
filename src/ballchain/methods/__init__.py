"""The integration methods over the compiled core, by name (plain data: importable
without the compiled kernels).

A method is a module with ``run(setup, progress, stop) -> RunOutput`` (see
``methods/outputs.py``): it advances the chain from ``setup`` to the end of the fall and
fills the shared outputs (frames, trace, event log, books) from which ``engine``
builds the ``Result``.  To add one: a sub-package whose ``__init__`` (plain data, no
kernels) states the bounds its runs are audited against (``AUDIT``: ``bounds.AuditBounds``)
and the options it owns (``OPTIONS``: ``options.MethodOption``; ``DEFAULTS``, ``USES``: its
defaults of other methods' options), the contact laws' parameters it honours away from their
defaults (``CONTACTS``: ``contacts.registry``; others are refused in one line; ``CONTACT_VALUES``,
``CONTACT_BOUNDS``, ``CONTACT_EXCLUDES``: the values and pairs it takes of them, where not all),
``summary(s)`` (the command line's line naming the
method and its settings, from a run's summary), and a line here.  The command line, ``SolverOptions``,
the sweeps and the JSON keys learn the options from ``all_options``.
"""

from __future__ import annotations

import importlib

# name -> (module path relative to this package, what it is, its compiled entry kernel)
METHODS = {
    "event": (
        "event_driven.driver",
        "event-driven: Dormand-Prince 5(4) between events located to "
        "event_xtol, an exact impact and lock set at each event instant",
        "event_driven.events:run_events",
    ),
    "timestep": (
        "timestep.driver",
        "Moreau-Jean time-stepping: steps of dt t_ff/N, one velocity-level impact "
        "problem per step over the constraints that may become active (first order in dt)",
        "timestep.stepper:run_steps",
    ),
    "rattle": (
        "rattle.driver",
        "nonsmooth RATTLE: steps of dt t_ff/N, positions with the joints, limits and floor held "
        "at the position level, velocities with the inelastic impact law (second order in dt)",
        "rattle.stepper:run_steps",
    ),
}
METHOD_NAMES = tuple(METHODS)

# What each method's package owns (its options, their defaults and constants) lives there;
# the time-stepper's constants are also read from here (``timestep.stepper``, the tests).
from .timestep import DT_RULES, LANDING_STEP_RANGE, LONG_STEP, LONG_STEP_FROM, SHORT_STEP  # noqa: E402, F401


def method_package(name: str):
    """The package of the method ``name`` (its ``__init__``: plain data, no kernels)."""
    if name not in METHODS:
        raise KeyError(f"no method {name!r} (known: {', '.join(METHOD_NAMES)})")
    return importlib.import_module(f"{__name__}.{METHODS[name][0].split('.')[0]}")


def check_contacts(params, method: str) -> None:
    """Refuse, in one line, a contact law's parameter away from its default
    (``contacts.registry``) that ``method`` does not honour (its package's ``CONTACTS``; the
    reason from its ``CONTACT_REFUSALS`` where it states one), outside the values it takes
    (``CONTACT_VALUES``: name -> (values besides the default, why)), beyond the bound to
    which it was shown to (``CONTACT_BOUNDS``: name -> (bound, why)), or a pair of them it
    does not take together (``CONTACT_EXCLUDES``: ((a, b), where a's value, why))."""
    from ..contacts.registry import all_params
    from ..errors import ParameterError

    for name, p in all_params().items():
        value = getattr(params, name)
        bound = getattr(method_package(method), "CONTACT_BOUNDS", {}).get(name)
        if bound is not None and value > bound[0]:
            raise ParameterError(
                f"{p.flag} {value:g} is not honoured by --method {method}: {bound[1]}; it takes at most "
                f"{bound[0]:g} (--method event takes any)"
            )
        if value != p.default and name not in getattr(method_package(method), "CONTACTS", ()):
            takers = [m for m in METHODS if name in getattr(method_package(m), "CONTACTS", ())]
            why = getattr(method_package(method), "CONTACT_REFUSALS", {}).get(name)
            raise ParameterError(
                f"{p.flag} {value:g} is not honoured by --method {method} yet "
                + (f"({why})" if why else f"(only by: {', '.join(takers) or 'none'})")
                + f"; leave it at {p.default:g} or change the method"
            )
        values = getattr(method_package(method), "CONTACT_VALUES", {}).get(name)
        if values is not None and value != p.default and value not in values[0]:
            raise ParameterError(
                f"{p.flag} {value:g} is not honoured by --method {method} yet ({values[1]}); it takes "
                f"{_values_text(values[0], p.default)}"
            )
    moved = {name for name, p in all_params().items() if getattr(params, name) != p.default}
    for (a, b), where, why in getattr(method_package(method), "CONTACT_EXCLUDES", ()):
        if a in moved and b in moved and where(getattr(params, a)):
            pa, pb = all_params()[a], all_params()[b]
            raise ParameterError(
                f"{pa.flag} {getattr(params, a):g} with {pb.flag} {getattr(params, b):g} is not honoured by "
                f"--method {method} yet: {why}"
            )


def _values_text(values, default) -> str:
    """The values a method takes of a law's parameter, its default last: "0 or inf"."""
    return " or ".join(f"{v:g}" for v in (*values, default))


def honours(method: str, name: str) -> str:
    """What ``--method method`` takes of the contact law's parameter ``name`` (its package's
    ``CONTACTS``, ``CONTACT_VALUES`` and ``CONTACT_BOUNDS``, as ``check_contacts`` enforces
    them): ``"any"`` value, ``"up to B"`` (refused beyond the bound B), ``"A or B"`` (those
    values only, the default last) or ``"refused"`` (away from its default).  The cells of
    the "Which method when" table of the README and the site's index."""
    pkg = method_package(method)
    if name not in getattr(pkg, "CONTACTS", ()):
        return "refused"
    values = getattr(pkg, "CONTACT_VALUES", {}).get(name)
    if values is not None:
        from ..contacts.registry import all_params

        return _values_text(values[0], all_params()[name].default)
    bound = getattr(pkg, "CONTACT_BOUNDS", {}).get(name)
    return f"up to {bound[0]:g}" if bound is not None else "any"


def method_takes(method: str, name: str) -> bool:
    """Whether runs of ``method`` read the option ``name``: it owns it, or uses it (its
    package's ``USES``)."""
    return option_owner(name) == method or name in getattr(method_package(method), "USES", ())


def check_options(options, segments: int = 1, filled: bool = False) -> None:
    """Refuse, in one line, an option of another method that ``options.method`` neither owns
    nor uses (``method_takes``) given a value (not None nor its default), so that a
    method's option given to another is never silently ignored.  The one check of the
    command line (``inputs.build_inputs``), ``bc.simulate`` (``engine.simulate``) and the
    sweeps (``sweeps.spec``).  ``filled``: ``options`` are those of a run
    (``SolverOptions.for_segments``, as a result records them), which also hold the value
    such runs record when it is not given (``method_default``)."""
    from ..errors import ParameterError

    method = options.method
    for name, opt in all_options().items():
        value = getattr(options, name)
        if value is None or method_takes(method, name):
            continue
        if value == opt.default or (filled and value == method_default(method, name, segments)):
            continue
        owner = option_owner(name)
        takers = [owner] + [m for m in METHODS if m != owner and method_takes(m, name)]
        shown = f"{value:g}" if isinstance(value, float) else str(value)
        raise ParameterError(
            f"{opt.flag or name} {shown} is an option of --method {' and '.join(takers)}, not used by --method "
            f"{method}: leave it out or change the method"
        )


def steps_per_tff(options, segments: int) -> float | None:
    """The steps a run of ``options`` with N = ``segments`` takes per t_ff of the fall, for the
    methods that take ``dt`` (steps of dt t_ff/N: N / dt; RATTLE's dt is a ceiling, its steps
    may be shorter; ``dt_rule`` landing scales them within ``LANDING_STEP_RANGE``); None for the
    others (the event method sizes its own steps).  What a warning of an absurd run reads."""
    if not method_takes(options.method, "dt"):
        return None
    return segments / options.for_segments(segments).dt


def method_options(name: str) -> tuple:
    """The options the method ``name`` owns (its package's ``OPTIONS``: ``options.MethodOption``)."""
    return tuple(getattr(method_package(name), "OPTIONS", ()))


def all_options() -> dict:
    """Every method's options by name, in the registry's order (methods, then each one's
    ``OPTIONS``): what ``SolverOptions``, the command line, the sweeps and the JSON keys
    learn them from.  An option belongs to one method: a name stated twice is an error."""
    out: dict = {}
    for method in METHODS:
        for opt in method_options(method):
            if opt.name in out:
                raise ValueError(f"option {opt.name!r} is stated by two methods ({option_owner(opt.name)}, {method})")
            out[opt.name] = opt
    return out


def option_names(command: str) -> list[str]:
    """The methods' options that ``ballchain COMMAND`` takes as flags (and ``bc.simulate``,
    ``bc.sweep`` as keywords): for ``simulate`` those with a flag, for ``sweep`` those of
    them with a sweep column."""
    return [
        name
        for name, opt in all_options().items()
        if opt.flag is not None and (command != "sweep" or opt.column is not None)
    ]


def option_owner(name: str) -> str:
    """The method whose package states the option ``name``."""
    for method in METHODS:
        if any(opt.name == name for opt in method_options(method)):
            return method
    raise KeyError(f"no method states an option {name!r}")


def method_default(method: str, name: str, segments: int):
    """The value a run of ``method`` with N = ``segments`` takes for the option ``name`` when
    it is not given: its package's own (``DEFAULTS``), else the owner's default for N
    (``by_segments``) for the owner's runs, else the option's ``unused`` value (recorded,
    not used); an option without ``by_segments`` keeps its ``default``."""
    opt = all_options()[name]
    own = getattr(method_package(method), "DEFAULTS", {})
    if name in own:
        value = own[name]
        return value(segments) if callable(value) else value
    if opt.by_segments is None:
        return opt.default
    return opt.by_segments(segments) if option_owner(name) == method else opt.unused


def option_help(name: str) -> str:
    """The ``--help`` text of the option ``name``: its own, and the defaults of the other
    methods that use it (their package's ``DEFAULTS`` and ``USES``, with a word on the
    choice from its ``DEFAULT_NOTES``)."""
    text = all_options()[name].help
    for method in METHODS:
        pkg = method_package(method)
        if name in getattr(pkg, "USES", ()) and name in getattr(pkg, "DEFAULTS", {}):
            value = pkg.DEFAULTS[name]
            text += f" --method {method}: default {value:g}" if not callable(value) else f" --method {method}: by N"
            note = getattr(pkg, "DEFAULT_NOTES", {}).get(name)
            text += f" ({note})." if note else "."
    return text


def default_step(method: str, segments: int) -> tuple[float, float]:
    """(dt, theta) of a run of ``method`` that does not set them (``method_default``): for
    the time-stepping method the long step (dt = 0.02, theta = 1) from N = LONG_STEP_FROM
    on and the short one (dt = 0.01, theta = 1/2) below; the RATTLE method its own
    (``rattle.DEFAULTS``); the event-driven method does not use them (the short step's
    values are recorded)."""
    return method_default(method, "dt", segments), method_default(method, "theta", segments)


def audit_bounds(name: str):
    """The ``bounds.AuditBounds`` that the method ``name`` states (its package's ``AUDIT``)."""
    return method_package(name).AUDIT


def method_runner(name: str):
    """The ``run`` function of the method ``name`` (imported on first use)."""
    module = METHODS[name][0]
    return importlib.import_module(f"{__name__}.{module}").run


def entry_kernel(name: str):
    """The compiled loop of the method ``name`` (its numba dispatcher: whether it is
    compiled or cached says whether a run will compile first)."""
    module, attr = METHODS[name][2].split(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), attr)
