"""The return codes of the RATTLE method's compiled loop (``stepper.run_steps``) and of
one step (``scheme.rattle_step``): 0 and positive, the loop returns to Python for a reason
of its own; negative, a step that failed (taken again shorter where it may be) or a run
that cannot go on (``driver.ERROR_MESSAGES``)."""

from __future__ import annotations

# run_steps codes (negative: the run cannot go on)
RT_STOP, RT_BUFFER, RT_RETURN, RT_LANDED, RT_MAX_STEPS = 0, 2, 11, 10, 5
ERR_NEWTON, ERR_ACTIVE_SET, ERR_STEP_ENERGY, ERR_STEP_NAN, ERR_NAN = -1, -2, -3, -4, -6
ERR_REBOUND = -8  # a step's rebounds created energy (Newton's law at several contacts, some held): taken
#   again with its impacts inelastic (as the event method takes such an impact; not returned by run_steps)
ERR_MERGED = -7  # a landing and a lock beside it in one step: taken again halved (not returned by run_steps)
ERR_FRICTION = -9  # a sliding point's friction force reversed it within the step and created energy (beyond the
#   step's bound): taken again at the same size with the point held from the step's start (``friction.hold_reversed``;
#   not returned by run_steps)
