"""The integration methods over the compiled core, by name (plain data: importable
without the compiled kernels).

A method is a module with ``run(setup, progress, stop) -> RunOutput`` (see
``methods/outputs.py``): it advances the chain from ``setup`` to the end of the fall and
fills the shared outputs (frames, trace, event log, books) from which ``engine``
builds the ``Result``.  To add one: a sub-package whose ``__init__`` states the bounds
its runs are audited against (``AUDIT``: ``bounds.AuditBounds``), and a line here.
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

# How the time-stepping method sizes its steps (``SolverOptions.dt_rule``) -> the code its
# compiled step reads (``timestep.stepper._step_by_rule``).
DT_RULES = {"fixed": 0, "landing": 1}
LANDING_STEP_RANGE = 4.0  # dt_rule "landing": a step within this factor of dt t_ff / N, either way

# The time-stepping method's step when not given (``SolverOptions.dt``, ``.theta``: None).
SHORT_STEP = (0.01, 0.5)  # (dt in t_ff / N, theta): agrees with the exact method at N = 64-256
LONG_STEP = (0.02, 1.0)  # ... at N = 1024, 2048 and 4096, where the short step falls early from 2048 on
LONG_STEP_FROM = 1024  # N from which the default is the long step


def default_step(method: str, segments: int) -> tuple[float, float]:
    """(dt, theta) of a run that does not set them: for the time-stepping method the long
    step (dt = 0.02, theta = 1) from N = LONG_STEP_FROM on and the short one (dt = 0.01,
    theta = 1/2) below; the event-driven method does not use them (the short step's values
    are recorded)."""
    if method == "rattle":
        from .rattle import DEFAULT_DT

        return DEFAULT_DT, 1.0
    return LONG_STEP if method == "timestep" and segments >= LONG_STEP_FROM else SHORT_STEP


def audit_bounds(name: str):
    """The ``bounds.AuditBounds`` that the method ``name`` states (its package's ``AUDIT``)."""
    module = METHODS[name][0].split(".")[0]
    return importlib.import_module(f"{__name__}.{module}").AUDIT


def method_runner(name: str):
    """The ``run`` function of the method ``name`` (imported on first use)."""
    module = METHODS[name][0]
    return importlib.import_module(f"{__name__}.{module}").run


def entry_kernel(name: str):
    """The compiled loop of the method ``name`` (its numba dispatcher: whether it is
    compiled or cached says whether a run will compile first)."""
    module, attr = METHODS[name][2].split(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), attr)
