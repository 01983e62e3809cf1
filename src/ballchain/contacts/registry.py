"""The contact laws by name, and the parameters each states (plain data: importable
without the compiled kernels).

A contact law says what a constraint that reaches its limit does: today's, stated here
once, are Newton's restitution at an impact (``newton``: the rate after an impact that
acts on a row is -e times the rate before) and Coulomb's friction at the floor
(``coulomb``: mu inf, the default, is the anchor, a point that touches the floor is held
where it touched, for good: ``floors.registry.CONTACT_FIXED``; mu 0 a frictionless floor;
a finite mu stick and slip within the cone).  Each law is
one module of this package (its kernels, which the methods call) and a line here: its
parameters (``options.MethodOption`` data: the ``ChainParams`` field, its check, flag,
help, sweep column and JSON key), from which ``ChainParams``, the command line, the sweep
and the JSON keys learn them.  A method states which parameters it honours away from their
defaults (``CONTACTS`` in its package); a run that asks another is refused in one line
(``methods.check_contacts``).
"""

from __future__ import annotations

from ..options import MethodOption, in_range


def _friction(name: str, value) -> float:
    """A friction coefficient: 0 (frictionless), a finite mu > 0 (stick and slip) or inf
    (the anchor)."""
    return in_range(0.0, float("inf"), "a negative friction coefficient")(name, value)


def _damping(name: str, value) -> float:
    """A viscous coefficient: finite and >= 0 (0: free hinges)."""
    from ..errors import ParameterError

    v = in_range(0.0, float("inf"), "a negative one would feed energy into the bending")(name, value)
    if v == float("inf"):
        raise ParameterError(f"{name} must be finite (an infinite one would freeze every hinge), got {value!r}")
    return v


# what a restitution outside [0, 1] would mean: below, above
_OUTSIDE_0_1 = (
    "a negative one would carry the contact on through its limit",
    "a rebound faster than the approach creates energy",
)

# law -> (module, what it is, the parameters it states)
LAWS = {
    "newton": (
        "newton",
        "Newton's restitution: an impact that acts on a row (a hinge at its limit) leaves it "
        "separating at e times the rate it closed with; the impulse never pulls (e = 0: the "
        "inelastic lock)",
        (
            MethodOption(
                "restitution_lock",
                float,
                0.0,
                "Newton's restitution at the bend limit, in [0, 1]: a hinge that reaches its limit rebounds at "
                "this fraction of the rate it closed with (0: it locks, the model's law; 1: nothing is lost).",
                in_range(0.0, 1.0, _OUTSIDE_0_1),
                flag="--restitution-lock",
                json="Newton's restitution at the bend limit (0: the hinge locks)",
                column="Newton's restitution at the bend limit (0: the hinge locks; empty in tables written "
                "before the column: 0)",
            ),
            MethodOption(
                "restitution_floor",
                float,
                0.0,
                "Newton's restitution at the floor, in [0, 1]: a point that lands leaves the floor again at "
                "this fraction of the vertical velocity it landed with, its sliding stopped (0: it is "
                "anchored, the model's law; a point that would come back slower than the accumulation "
                "threshold is anchored). Floor all only.",
                in_range(0.0, 1.0, _OUTSIDE_0_1),
                flag="--restitution-floor",
                json="Newton's restitution at the floor (0: a landing point is anchored)",
                column="Newton's restitution at the floor (0: a landing point is anchored; empty in tables "
                "written before the column: 0)",
            ),
        ),
    ),
    "coulomb": (
        "coulomb",
        "Coulomb's friction between the floor and the points on it: mu inf holds a point that "
        "touches the floor where it touched (the anchor, for good); mu 0 lets it slide, pressed by "
        "the floor's normal force alone, and leave the floor again when that force would pull; a "
        "finite mu holds it while the force lies within the cone and lets it slide beyond",
        (
            MethodOption(
                "friction",
                float,
                float("inf"),
                "Coulomb's friction coefficient between the floor and the points on it: inf (a point that "
                "touches the floor is anchored there, the model's law), 0 (a frictionless floor: points "
                "slide on it, the bottom end too, and lift off when the floor would pull) or a finite value "
                "(stick and slip: a point is held where it touched while the force holding it lies within "
                "the friction cone, its tangential part at most MU times its normal part F_n, slides against "
                "MU F_n beyond it, and lifts off when the floor "
                "would pull; the bend limits also hold at the pile). Below inf the run ends when every point "
                "has touched the floor. Floor all only.",
                _friction,
                flag="--friction",
                json="Coulomb's friction coefficient at the floor (null: inf, a touching point is anchored)",
                column="Coulomb's friction coefficient at the floor (inf: a touching point is anchored; empty "
                "in tables written before the column: inf)",
            ),
        ),
    ),
    "damping": (
        "damping",
        "Viscous damping at the hinges, a smooth law: a torque -C times the rate at which each hinge "
        "bends, on the two segments it joins (rods have no spin: the bend angle is all a hinge can "
        "change); it removes C thetadot^2 of power at every hinge, booked as lost_damping "
        "(C = 0: free hinges)",
        (
            MethodOption(
                "hinge_damping",
                float,
                0.0,
                "Viscous damping at every hinge, C >= 0 in units of m g b sqrt(b/g) (N m s with SI units): a "
                "torque -C times the rate at which the hinge bends acts on the two segments it joins, and the "
                "power it removes is booked as lost_damping (0: free hinges, the model's law).",
                _damping,
                flag="--hinge-damping",
                json="the hinges' viscous damping coefficient C, m g b sqrt(b/g) (0: free hinges)",
                column="the hinges' viscous damping coefficient C, m g b sqrt(b/g) (0: free hinges; empty in "
                "tables written before the column: 0)",
            ),
        ),
    ),
}


# The rules between the laws and the floor model, stated once as data (``check_laws`` applies
# them; ``ChainParams`` calls it): a parameter away from its default that needs a floor model
# watching every point, with the physical reason ...
NEEDS_EVERY_POINT_WATCHED = {
    "restitution_floor": "a point that rebounds must be watched again",
    "friction": "a point that slides must be watched",
}
# ... and pairs of parameters that cannot both leave their defaults where the first takes
# the values a test names, with the reason
EXCLUDES = (
    (
        ("friction", "restitution_floor"),
        lambda mu: 0.0 < mu < float("inf"),
        "a point that bounces off a floor of finite friction is not built yet (a frictionless floor, 0, takes it)",
    ),
)


def check_laws(params, every_point_floors) -> None:
    """Refuse, in one line with its reason, a combination of the laws' parameters (and the
    floor model) that the rules above exclude (``params``: a ``ChainParams``;
    ``every_point_floors``: the floor models that watch every point)."""
    from ..errors import ParameterError

    prms = all_params()
    moved = {name for name, p in prms.items() if getattr(params, name) != p.default}
    for name in sorted(moved & set(NEEDS_EVERY_POINT_WATCHED), key=list(prms).index):
        if params.floor not in every_point_floors:
            raise ParameterError(
                f"{name} {getattr(params, name):g} needs floor {' or '.join(every_point_floors)} "
                f"({NEEDS_EVERY_POINT_WATCHED[name]}; floor {params.floor} watches only the bottom airborne segment)"
            )
    for (a, b), where, why in EXCLUDES:
        if a in moved and b in moved and where(getattr(params, a)):
            raise ParameterError(
                f"{a} {getattr(params, a):g} with {b} {getattr(params, b):g}: {why} (set one of them to its default)"
            )


def all_params() -> dict:
    """Every contact law's parameters by name, in the registry's order."""
    out: dict = {}
    for _, (_, _, params) in LAWS.items():
        for p in params:
            out[p.name] = p
    return out


def law_of(name: str) -> str:
    """The law that states the parameter ``name``."""
    for law, (_, _, params) in LAWS.items():
        if any(p.name == name for p in params):
            return law
    raise KeyError(f"no contact law states a parameter {name!r}")


def law_param_help(name: str) -> str:
    """What ``--help`` says of the parameter ``name``."""
    return all_params()[name].help
