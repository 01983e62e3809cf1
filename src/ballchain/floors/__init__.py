"""The floor models: what the floor watches, what a touch creates, when it ends.

``registry`` names them (plain data), one module per model holds its compiled answers
(``anchor_all``, ``pivot``), and ``dispatch`` is the one place that branches on the
model's code.
"""

from .registry import CONTACT_FIXED, FLOOR_ALL, FLOOR_CODES, FLOOR_MODELS, FLOOR_PIVOT, FLOORS

__all__ = ["FLOORS", "FLOOR_MODELS", "FLOOR_CODES", "FLOOR_ALL", "FLOOR_PIVOT", "CONTACT_FIXED"]
