"""Moreau-Jean time-stepping: ``stepper`` (the compiled step and loop), ``driver`` (a run).
Its kernels are compiled without numba's reference counts (``_nrt=False``, ``jit`` module
docstring).

What the method owns (plain data, importable without its kernels): its options
(``OPTIONS``: the step, its position update and how it sizes its steps, with the
constants they are read with) and the bounds its runs are audited against
(``records.audit``).  Its error is first order in its step: the
imbalance and depth are its own error, checked against bounds that a broken run exceeds
(a chain through the floor, a blown-up step) and a sound one does not at the default dt;
past half of them a run is warned.  Its bends pass their limits within a step by up to
w h sin(alpha) in the cosine (w the bend's rate: near the pile w ~ 2 v / b,
v ~ 2 sqrt(N) sqrt(g b), and h = dt t_ff / N = 2 dt / sqrt(N) sqrt(b / g): about 6 dt); its
projection puts them back, but not when that would move a point further than 0.1 b (it is
then undone), and it can push a neighbour past.  Sound falls keep them within 5 dt (0.10 at
N = 1024, dt 0.02, the worst of 16 starts; 0.09 at dt 0.04), so the bound is per unit dt.
"""

from __future__ import annotations

from ...options import MethodOption, in_range, number_text, one_of, positive
from ..bounds import AuditBounds

SUMMARY_COUNT = ("n_steps", "steps")  # what the summary's line of events counts (no event instants: steps)

# The contact laws' parameters it honours away from their defaults (contacts.registry):
# Newton's restitution at the bend limit, in Moreau-Jean's form (stepper._solve); the hinges' damping,
# an explicit kick in the free velocity (stepper._free_velocity).
CONTACTS = ("restitution_lock", "hinge_damping")
# ... and why it refuses the others (``check_contacts`` names the reason).  Restitution at the
# floor is in the kernels (stepper._aim_rebounds, _leave_floor, _let_go: a rod's bounces are
# Newton's to first order, tests/test_timestep_restitution.py; _hold_sinking: the projection
# holds at the floor a bouncing point it would push below it), but on whole chains some falls
# still break their anchors (benchmarks/probes/timestep_bounce.py; docs/restitution-floor.md,
# finding 6).
CONTACT_REFUSALS = {
    "restitution_floor": "some falls of a bouncing chain break their anchors (4 of 48 at N = 128: "
    "benchmarks/probes/timestep_bounce.py; docs/restitution-floor.md); the event method and RATTLE take it",
}
CONTACT_BOUNDS = {
    "restitution_lock": (
        0.75,
        "near an elastic limit its steps lose what the law gives back (E_lock 0.65 E0 above the exact "
        "method's at 1, and two of 32 falls broke their books)",
    )
}

AUDIT = AuditBounds(energy_rtol=0.1, depth_tol=0.1, hinge_tol=0.0, hinge_per_dt=15.0, warn_near=True)

# How the method sizes its steps (``SolverOptions.dt_rule``) -> the code its compiled step
# reads (``stepper._step_by_rule``).
DT_RULES = {"fixed": 0, "landing": 1}
LANDING_STEP_RANGE = 4.0  # dt_rule "landing": a step within this factor of dt t_ff / N, either way

# The step when not given (``SolverOptions.dt``, ``.theta``: None).
SHORT_STEP = (0.01, 0.5)  # (dt in t_ff / N, theta): agrees with the exact method at N = 64-256
LONG_STEP = (0.02, 1.0)  # ... at N = 1024, 2048 and 4096, where the short step falls early from 2048 on
LONG_STEP_FROM = 1024  # N from which the default is the long step


def default_step(segments: int) -> tuple[float, float]:
    """(dt, theta) of a run of this method that does not set them: the long step from
    N = LONG_STEP_FROM on, the short one below."""
    return LONG_STEP if segments >= LONG_STEP_FROM else SHORT_STEP


def _dt_key(options) -> str:
    """A run's key names its method and step (those of the event method: neither)."""
    return "" if options.method == "event" else f"_{options.method}_dt{options.dt:.12g}"


def _theta_key(options) -> str:
    """... and theta unless it is 1/2 (as before the option existed)."""
    return "" if options.method == "event" or options.theta == SHORT_STEP[1] else f"_theta{options.theta:.12g}"


def _dt_rule_key(options) -> str:
    """... and a rule other than fixed."""
    return "" if options.method == "event" or options.dt_rule == "fixed" else f"_{options.dt_rule}"


def _by_step(name: str, part: int, help: str, check, json: str, column: str, run_key) -> MethodOption:
    """An option whose default is part ``part`` of the step by N (``default_step``: 0 dt,
    1 theta), filled in when a run starts; the event method records the short step's."""
    return MethodOption(
        name,
        float,
        None,
        f"{help} Default: {SHORT_STEP[part]:g} below N = {LONG_STEP_FROM}, {LONG_STEP[part]:g} from N = "
        f"{LONG_STEP_FROM} on.",
        check,
        flag=f"--{name}",
        json=json,
        column=column,
        by_segments=lambda n: default_step(n)[part],
        unused=SHORT_STEP[part],
        run_key=run_key,
    )


OPTIONS = (
    _by_step(
        "dt",
        0,
        "The time step of --method timestep, in units of t_ff/N (N segments).",
        positive(at_most=4.0, unit="units of t_ff/N"),
        json="the time-stepper's step in t_ff / N",
        column="time step of the timestep method, units of t_ff/N (not used by the event method)",
        run_key=_dt_key,
    ),
    _by_step(
        "theta",
        1,
        "The position update of --method timestep, in [0.5, 1]: the axes turn at theta w+ + (1 - theta) w, "
        "w and w+ the rates before and after a step's impulses.",
        in_range(
            0.5,
            1.0,
            ("below 1/2 the step is unstable", "above 1 the axes would turn at rates beyond those after the impulses"),
        ),
        json="the time-stepper's position update",
        column="position update of the timestep method (axes turn at theta w+ + (1 - theta) w; not used by the "
        "event method; empty in tables written before the column: 0.5)",
        run_key=_theta_key,
    ),
    MethodOption(
        "dt_rule",
        str,
        "fixed",
        "How --method timestep sizes its steps: fixed (every step --dt t_ff/N) or landing (--dt t_ff/N times "
        "the speed of free fall at t_ff over the airborne chain's mean fall speed, within a factor "
        f"{LANDING_STEP_RANGE:g}: each landing gets as many steps at every speed).",
        one_of(DT_RULES),
        flag="--dt-rule",
        json="how the time-stepper sizes its steps: fixed or landing",
        column="how the timestep method sizes its steps: fixed (dt t_ff/N) or landing (scaled by the speed of "
        "free fall at t_ff over the airborne chain's mean fall speed); empty in tables written before the "
        "column: fixed",
        run_key=_dt_rule_key,
    ),
)


def summary(s: dict) -> str:
    """The method and its accuracy setting, from a run's summary (the command line's line)."""
    return (
        f"time-stepping (Moreau-Jean, experimental), dt = {number_text(s.get('dt'))} t_ff/N, theta = {number_text(s.get('theta'))}, "
        f"steps {s.get('dt_rule') or 'fixed'}"
    )
