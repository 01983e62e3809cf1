"""The kinds of the event log (plain data, importable without the compiled kernels).

Part of the model's rules (``rules`` re-exports them); kept apart so that the records,
plots and files can name the kinds without loading numba.
"""

from __future__ import annotations

# The event log's kinds (one row per constraint that acted at an event instant).
EVENT_KINDS = {
    1: "lock",
    2: "unlock",
    3: "landing",
    4: "top",
    5: "impulse",
    6: "release",
    7: "hold",
    8: "anchor",
    9: "bounce",
    10: "slip",
    11: "stick",
    12: "lift",
    13: "pin",
    14: "jam",
}
EVENT_MEANINGS = {
    "lock": "a free hinge reaches its limit and locks; impulse (Lambda, 0, 0), Lambda >= 0 (0: a touch)",
    "unlock": "a locked hinge's multiplier crosses zero in smooth motion and it unlocks; no impulse",
    "landing": "a point reaches the floor and is anchored; impulse: the floor's on the chain at that point",
    "top": "floor pivot only: the top end reaches z = 0 (t_fall); no change of state",
    "impulse": "a hinge locked before the instant takes an impulse (Lambda, 0, 0) and stays locked",
    "release": "a hinge at its limit (locked, or locking at this instant) leaves it at an impact",
    "hold": "a hinge held at its limit by a fallback rule instead of the law's outcome: the accumulation rule "
    "(a hinge returning too slowly to resolve), or, with restitution at the limit, a hinge that Newton's law would "
    "rebound kept at it (an impact the law would make create energy, taken inelastic; a rebound too short to "
    "resolve); impulse (Lambda, 0, 0) of either sign",
    "anchor": "a point anchored before the instant takes an impulse of the floor at an impact",
    "bounce": "a point reaches the floor and leaves it again (restitution at the floor); impulse: the floor's "
    "on the chain at that point",
    "slip": "finite friction: a point held by the floor starts to slide, the force that held it having left the "
    "friction cone; impulse: that force (x, y, z) over the step",
    "stick": "finite friction: a sliding point stops and is held where it is (the friction reversed it within a "
    "step); no impulse given",
    "lift": "a point held by the floor (finite friction, or a frictionless floor) is let go, the floor having "
    "pulled it (RATTLE; impulse: that force (x, y, z) over the step) or its force having crossed zero (the event "
    "method; no impulse)",
    "pin": "restitution at the floor: a point that lands and that Newton's law would bounce is anchored instead (on a "
    "frictionless floor: kept on it, sliding) by a fallback rule (its bounce would be too small to resolve: the accumulation limit of a series of bounces; or "
    "the impact's other contacts turned it back down); or, in the event method on a frictionless floor, a point that "
    "an impact would lift off the floor and that would land again slower than the accumulation threshold, kept on "
    "it (the floor's impulse on it of either sign); impulse and energy as a landing's",
    "jam": "finite friction: a point held by a fallback rule where the law gives no outcome the step can take: a "
    "landing or sliding point whose slide in the impact has no solution (Painleve's kind: the friction would press it "
    "into the floor harder than it is pressed), or the sliding points near a row that the stages could not meet even "
    "at their shortest step; no impulse given",
}
EVENT_CODES = {name: code for code, name in EVENT_KINDS.items()}
LOG_LOCK, LOG_UNLOCK, LOG_LANDING, LOG_TOP = (EVENT_CODES[k] for k in ("lock", "unlock", "landing", "top"))
LOG_IMPULSE, LOG_RELEASE, LOG_HOLD, LOG_ANCHOR = (EVENT_CODES[k] for k in ("impulse", "release", "hold", "anchor"))
LOG_BOUNCE = EVENT_CODES["bounce"]
LOG_SLIP, LOG_STICK, LOG_LIFT = (EVENT_CODES[k] for k in ("slip", "stick", "lift"))
LOG_PIN, LOG_JAM = EVENT_CODES["pin"], EVENT_CODES["jam"]
# the rows of a fallback rule, one that changes a law's outcome (``hold``: a hinge held at its
# limit instead of rebounding or leaving it; ``pin``: a point anchored instead of bouncing)
FALLBACK_KINDS = ("hold", "pin", "jam")
