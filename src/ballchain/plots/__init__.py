"""Figures of ballchain results (matplotlib; never imported by the engine).

``run``: the figures of any single run (``ballchain plot RESULT --out DIR``).
``animate``: the animation of a run, .mp4 or .gif (``ballchain animate RESULT --out fall.mp4``).
``paper``: the paper's figures (``ballchain paper``).
``sweep``: a sweep table's statistics against alpha and N (``ballchain stats --plot``).
"""

from .animate import AnimationError, ChainAnimation, animation_figure, frame_indices, write_animation
from .run import (
    FIGURES,
    energy_figure,
    fall_figure,
    floor_figure,
    gamma_figure,
    lock_map_figure,
    pile_figure,
    plot_run,
)
from .titles import run_title

__all__ = [
    "AnimationError",
    "ChainAnimation",
    "animation_figure",
    "frame_indices",
    "write_animation",
    "FIGURES",
    "energy_figure",
    "fall_figure",
    "floor_figure",
    "gamma_figure",
    "lock_map_figure",
    "pile_figure",
    "plot_run",
    "run_title",
]
