"""The event-driven method: Dormand-Prince 5(4) between events (``integrator``), the event
handler at each event instant (``events``), how event functions are watched (``watch``),
and the Python driver of a run (``driver``).

Its kernels, and the core's they call, are compiled without numba's reference counts
(``_nrt=False``: they borrow the arrays of the bundles they are passed, ``jit`` module
docstring), but for those that allocate their scratch (``dopri.dense_state``,
``dopri.floor_impulse_dense``, ``locate.event_value``; in the core ``blocks.factor_general``,
``impacts.lock_set`` and the dense fallbacks of the impact problem).

What the method owns (plain data, importable without its kernels): its options
(``OPTIONS``: the integrator's tolerance, how exactly event times are located, and the
accumulation rule's thresholds) and the bounds its runs are audited against
(``records.audit``), round-off's: its every event is located and resolved exactly.
"""

from __future__ import annotations

import math

from ...errors import ParameterError
from ...options import MethodOption, number_text, positive
from ..bounds import AuditBounds

AUDIT = AuditBounds(energy_rtol=1e-8, depth_tol=1e-8, hinge_tol=1e-7)
# the contact laws' parameters it honours away from their defaults (contacts.registry)
CONTACTS = ("friction", "restitution_lock", "restitution_floor", "hinge_damping")
# ... the only values it takes of some of them besides the default, and why not the others
# (``methods.check_contacts`` names the reason): friction 0, the frictionless floor (``slides``)
CONTACT_VALUES = {
    "friction": (
        (0.0,),
        "a finite friction's stick and slip are not events of it yet: --method rattle takes it",
    ),
}
# ... and the pairs it refuses where the first takes the values a test names, with the reason
CONTACT_EXCLUDES = ()

# what a run's summary line of events counts beside them (the command line's): its event instants
SUMMARY_COUNT = ("n_instants", "instants")

RTOL_MIN = 1e-14  # the tightest integrator tolerance double precision can honour


def _rtol(name: str, value) -> float:
    """A relative tolerance: in (0, 1) and no tighter than RTOL_MIN."""
    try:
        r = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number in (0, 1), got {value!r}") from None
    if not math.isfinite(r) or not (0.0 < r < 1.0):
        raise ParameterError(f"{name} must be finite and in (0, 1), got {value!r}")
    if r < RTOL_MIN:
        raise ParameterError(
            f"{name} {value!r} is below what double precision can honour "
            f"(at least {RTOL_MIN:g}: the state is O(1) and its round-off ~1e-16 per step)"
        )
    return r


OPTIONS = (
    MethodOption(
        "rtol",
        float,
        1e-10,
        "Relative tolerance of the integrator, in (0, 1) (the event method's Dormand-Prince 5(4); atol = rtol "
        "on the nondimensional state, whose entries are O(1)).",
        _rtol,
        flag="--rtol",
        json="the event-driven integrator's relative tolerance",
        column="integrator tolerance",
        # in every run's key since the first tables, whatever its method, at its own place
        run_key=lambda options: f"_rtol{options.rtol:.6g}",
        key_among_inputs=True,
    ),
    MethodOption(
        "event_xtol",
        float,
        1e-13,
        "The tolerance of event times, in units of sqrt(b/g).",
        positive(),
    ),
    MethodOption(
        "hold_rate",
        float,
        1e-6,
        "The accumulation threshold (sqrt(g/b) for a hinge's bend rate, sqrt(g b) for a point's speed): a hinge released at an event instant that "
        "accelerates back to its limit and would return slower than this is held at its limit, a "
        "point bouncing off the floor (--restitution-floor) that would come back slower is anchored, "
        "and a point that an impact lifts off a frictionless floor (--friction 0) and that would land "
        "again slower is kept on it (the limit of the converging series of impacts it would start; "
        "docs/model.md shows that results converge as it goes to zero).",
        positive(),
        flag="--hold-rate",
        json="the event-driven integrator's accumulation threshold (sqrt(g/b) at a hinge, sqrt(g b) at the floor)",
        column="accumulation threshold",
    ),
    MethodOption(
        "hold_rate_floor",
        float,
        None,
        "The accumulation threshold at the floor alone (sqrt(g b)): a point bouncing off the floor "
        "(--restitution-floor), or lifted off a frictionless one (--friction 0), that would come back "
        "slower than this is anchored (kept on it); the hinges keep --hold-rate's. Default: "
        "--hold-rate's value (one threshold for both).",
        positive(),
        flag="--hold-rate-floor",
        json="the event-driven integrator's accumulation threshold at the floor, sqrt(g b) (null: --hold-rate's)",
        column="accumulation threshold at the floor (NaN: the accumulation threshold's)",
    ),
    MethodOption(
        "hold_apex",
        float,
        1e-11,
        "The resolution limit of the same rule: a released hinge whose excursion away from its limit "
        "(v^2 / 2|a|, in units of the bend function g = cos) would stay below this is held too (it "
        "cannot be resolved in double precision; at least 1e-12).",
        positive(at_least=1e-12, why="the round-off band of the bend function"),
    ),
)


def summary(s: dict) -> str:
    """The method and its accuracy setting, from a run's summary (the command line's line)."""
    return f"event-driven, rtol {number_text(s.get('rtol'), '.3g')}"
