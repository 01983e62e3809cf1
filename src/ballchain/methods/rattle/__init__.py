"""Nonsmooth RATTLE: a second-order constrained step (``stepper``: the compiled step and
loop; ``rows``: the constraints in maximal coordinates; ``driver``: a run).

What the method owns (plain data, importable without its kernels): its default step and
the bounds its runs are audited against (``records.audit``).
"""

from __future__ import annotations

from ..bounds import AuditBounds

DEFAULT_DT = 0.05  # the step in units of t_ff / N when --dt is not given (the longest step)
STEP_ENERGY_TOL = 1e-7  # a step may change U + T by this much of E0 (else it is halved)
# Audit bounds (records.audit): the method holds the floor and the limits at the position
# level, to its solver's tolerance (stage 1 meets every row to about 1e-12 b), so the depth,
# anchors and bends are held to the event-driven method's bounds; its energy error is
# second order in dt where the motion is smooth, and bounded, not drifting.
AUDIT = AuditBounds(energy_rtol=1e-2, depth_tol=1e-8, hinge_tol=1e-7)
