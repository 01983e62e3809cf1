"""Figures of ballchain results (matplotlib; never imported by the engine).

``run``: the figures of any single run (``ballchain plot RESULT --out DIR``).
"""

from .run import (
    FIGURES,
    energy_figure,
    fall_figure,
    floor_figure,
    lock_map_figure,
    pile_figure,
    plot_run,
)

__all__ = ["FIGURES", "energy_figure", "fall_figure", "floor_figure", "lock_map_figure", "pile_figure",
           "plot_run"]
