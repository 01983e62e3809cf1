"""The event-driven method: Dormand-Prince 5(4) between events (``integrator``), the event
handler at each event instant (``events``), how event functions are watched (``watch``),
and the Python driver of a run (``driver``)."""
