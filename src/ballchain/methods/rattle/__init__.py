"""Nonsmooth RATTLE: a second-order constrained step.  Its kernels, in the order a step
uses them: ``rows`` (the constraints in maximal coordinates), ``blocks`` (their block
LU), ``state`` (the bundles a step works on), ``stage1`` (positions), ``stage2`` (the
landings, velocities), ``rebounds`` (restitution within a step), ``books`` (what a step
booked), ``scheme`` (one step), ``frames`` (frames inside a step), ``stepper`` (the step
control and the compiled loop), ``codes``; ``driver``: a run.

Its kernels are compiled without numba's reference counts (``_nrt=False``: they borrow
the arrays of the bundles they are passed, ``jit`` module docstring), but for those that
make views (``scheme.motion_view``, ``rows_view``, ``scratch_view``, ``blocks.factors_view``),
the step that takes them (``scheme.rattle_step``) and the one that allocates
(``rebounds.impact_rates``).  The compiled loop (``stepper.run_steps``, called from Python)
borrows too: its Python wrapper then unboxes the fall's ~190 arrays without reference
counts.

What the method owns (plain data, importable without its kernels): its options
(``OPTIONS``), its default step (``DEFAULTS``: the step ``dt`` is the time-stepping
package's option) and the bounds its runs are audited against (``records.audit``).
"""

from __future__ import annotations

from ...options import MethodOption, non_negative, number_text, one_of
from ..bounds import AuditBounds

SUMMARY_COUNT = ("n_steps", "steps")  # what the summary's line of events counts (no event instants: steps)
OBSERVER = "driver.StepObserver"  # its runs can be watched step by step (``engine.simulate(observer=)``)

DEFAULT_DT = 0.05  # the step in units of t_ff / N when --dt is not given (the longest step)
STEP_ENERGY_TOL = 1e-7  # a step may change U + T by this much of E0 (else it is taken again, shorter)
# Audit bounds (records.audit): the method holds the floor and the limits at the position
# level, to its solver's tolerance (stage 1 meets every row to about 1e-10 b), so the depth,
# anchors and bends are held to the event-driven method's bounds; its energy error is
# second order in dt where the motion is smooth, and bounded, not drifting.
AUDIT = AuditBounds(energy_rtol=1e-2, depth_tol=1e-8, hinge_tol=1e-7)

# The values its runs take for options other packages state, when not given: ``dt`` (its
# step, used: named in that option's help) and ``theta`` (not used; recorded).
DEFAULTS = {"dt": DEFAULT_DT, "theta": 1.0}
USES = ("dt",)  # which of those it uses
DEFAULT_NOTES = {  # ... and what its users should know of the choice (in that option's help)
    "dt": "0.1 or 0.2 for ensembles at N >= 1024: fewer steps, the same agreement with the exact method "
    "at N = 1024 and 4096; not below for E_lock: at N = 512 the ceiling 0.2 puts it 0.009 E0 low on 317 pairs, "
    "the default 0.006; the ensembles behind these: docs/rattle.md and docs/notes/rattle-record.md",
}
CONTACTS = (  # the contact laws' parameters it honours away from their defaults (contacts.registry)
    "friction",
    "restitution_lock",
    "restitution_floor",
    "hinge_damping",
)
# ... and up to which value (measured against the event method on 16 starts at N = 64 and 128:
# docs/restitution.md): at E = 1 its locks lost 0.53 E0 where the law loses about 0.01 (steps in
# which Newton's law at several contacts created energy, taken again inelastic)
CONTACT_BOUNDS = {
    "restitution_lock": (
        0.75,
        "near an elastic limit its steps lose what the law gives back (E_lock 0.53 E0 at 1, against "
        "the exact method's 0.01)",
    )
}


LANDING_STEPS = ("whole", "cut")  # SolverOptions.landing_step: how a step in which a point lands is taken


def _landing_key(options) -> str:
    """A run's key names a landing step other than whole (the default of the tables written
    before cut became the default: their keys keep meaning what they meant)."""
    return "" if options.method != "rattle" or options.landing_step == "whole" else f"_landing{options.landing_step}"


def _etol_key(options) -> str:
    """A run's key names a bound that was set."""
    return "" if options.step_energy_tol is None else f"_etol{options.step_energy_tol:.6g}"


OPTIONS = (
    MethodOption(
        "step_energy_tol",
        float,
        None,
        "--method rattle: the most one step may change U + T without an impact, in units of E0, before it is "
        f"taken again shorter, as its h^3 error asks (its error control; the next step is sized the same way). Default {str(STEP_ENERGY_TOL).replace('e-0', 'e-')}; 0: no bound (fixed steps but "
        "for the turn limit).",
        non_negative,
        flag="--step-energy-tol",
        json="the RATTLE method's bound on a step's change of U + T, in E0 (null: its default)",
        column="the rattle method's bound on a step's change of U + T, in E0 (NaN: its default; not used by "
        "the others)",
        run_key=_etol_key,
    ),
    MethodOption(
        "landing_step",
        str,
        "cut",
        "How --method rattle takes a step in which a point lands: cut (the default: a step that would hold a "
        "touch ends just before it, the touch foreseen from the free points' heights and rates under gravity "
        "alone, so that the locks beside the point are released first; the landing then in a short step of "
        "its own, ending just after the touch; a landing not foreseen takes its step again so) or whole (the "
        "landing resolved at the step's end, with the velocity the point reached there, the locks beside it "
        "held through the touch: the default of earlier tables, whose E_lock comes out up to 0.006 E0 low). Only where "
        "points land to stay (no restitution at the floor, a floor that holds them); elsewhere both are whole.",
        one_of(LANDING_STEPS),
        flag="--landing-step",
        json="how the RATTLE method takes a step in which a point lands: whole or cut",
        column="how the rattle method takes a step in which a point lands: whole or cut (not used by the "
        "others; empty in tables written before the column: whole)",
        run_key=_landing_key,
    ),
)


def summary(s: dict) -> str:
    """The method and its accuracy setting, from a run's summary (the command line's line)."""
    dt, etol = s.get("dt"), s.get("step_energy_tol")
    bound = STEP_ENERGY_TOL if etol is None else etol
    return (
        f"nonsmooth RATTLE (experimental), dt = {number_text(dt)} t_ff/N at most, "
        + (
            f"a step changes U + T by at most {number_text(bound, '.3g')} E0"
            if bound
            else "no bound on a step's change of U + T"
        )
        + ("" if s.get("landing_step") == "cut" else ", landing steps whole")  # files before the key: whole
    )
