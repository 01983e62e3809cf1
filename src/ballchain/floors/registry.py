"""The floor models by name (plain data: importable without the compiled kernels).

A floor model is one module of this package that answers, in compiled code, which points
the floor watches, the event function that watches them, which points touch at an event
instant, and what a touch creates (``floors/__init__.py`` dispatches on the code).  To add
one: a new module with the same functions, a line here, a branch in each dispatcher of
``floors/__init__.py``, and its tests.
"""

from __future__ import annotations

# name -> (code, module, what it means)
FLOORS = {
    "all": (0, "anchor_all", "every point that reaches the floor is stopped and anchored there"),
    "pivot": (
        1,
        "pivot",
        "the paper read literally: only the bottom airborne segment meets the floor, "
        "its upper end anchors when it lies flat",
    ),
}
FLOOR_MODELS = tuple(FLOORS)  # the names ChainParams.floor accepts
FLOOR_CODES = {name: code for name, (code, _, _) in FLOORS.items()}
# floor models that watch every free point (no point may pass below the floor)
WATCHES_EVERY_POINT = ("all",)
FLOOR_ALL = FLOOR_CODES["all"]
FLOOR_PIVOT = FLOOR_CODES["pivot"]

# what a touch creates (the only kind so far): the point is held where it touched by three
# rows (dynamics.ROW_ANCHOR_*), a segment with both ends held is landed (W = 0, at rest),
# the projection keeps the point at its anchor, and the contact never ends
CONTACT_FIXED = 0
