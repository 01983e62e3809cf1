"""The event-driven method: Dormand-Prince 5(4) between events (``integrator``), the event
handler at each event instant (``events``), how event functions are watched (``watch``),
and the Python driver of a run (``driver``).

What the method owns (plain data, importable without its kernels): the bounds its runs
are audited against (``records.audit``), round-off's: its every event is located and
resolved exactly.
"""

from ..bounds import AuditBounds

AUDIT = AuditBounds(energy_rtol=1e-8, depth_tol=1e-8, hinge_tol=1e-7)
