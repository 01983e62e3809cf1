"""``ballchain paper``: run what the paper's figures need (cached) and draw them.

Runs are cached as result files under ``<out>/cache/``, named by a hash of everything
that determines them (parameters, initial condition, options, package version and the
engine's source, ``engine_fingerprint``): a second call reuses them, a changed engine
does not.  The figures are ``plots.paper``'s.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Callable
from pathlib import Path

from . import __version__
from .engine import simulate
from .model import ChainParams, InitialCondition, SolverOptions
from .provenance import engine_fingerprint
from .records.files import ResultFileError, load_result, save_result
from .records.result import Result


@dataclasses.dataclass(frozen=True)
class PaperSetup:
    """What the figures are drawn for: the main chain (Figs. 2-4, 6), the alpha series
    (Fig. 5, also placed on Fig. 6) and the solver options."""

    segments: int = ChainParams.segments
    alpha: float = ChainParams.alpha
    floor: str = ChainParams.floor
    ic: InitialCondition = InitialCondition()
    alpha_segments: int = 256
    alphas: tuple = (math.pi / 6, math.pi / 4, math.pi / 3, math.pi / 2, math.pi)
    rtol: float = SolverOptions.rtol
    frames_per_tff: float = SolverOptions.frames_per_tff
    rod_grid: int = 41

    def __post_init__(self):
        ChainParams(segments=self.segments, alpha=self.alpha, floor=self.floor)  # validates
        ChainParams(segments=self.alpha_segments, floor=self.floor)
        for a in self.alphas:
            ChainParams(segments=2, alpha=a)


QUICK = dict(segments=12, alpha_segments=16, alphas=(math.pi / 4, math.pi / 2, math.pi), rod_grid=11)


def _key(params: ChainParams, ic: InitialCondition, options: SolverOptions) -> str:
    blob = json.dumps(
        [params.to_dict(), ic.to_dict(), options.to_dict(), __version__, engine_fingerprint()],
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def cached_run(
    params: ChainParams,
    ic: InitialCondition,
    options: SolverOptions,
    cache: Path,
    note: Callable[[str], None] = lambda s: None,
) -> Result:
    """The run of these inputs: loaded from ``cache`` if it was made before, else simulated
    and saved there."""
    path = Path(cache) / f"run-{_key(params, ic, options)}.h5"
    if path.exists():
        try:
            return load_result(path)
        except ResultFileError:
            path.unlink()  # damaged: run again
    note(f"running N = {params.segments}, alpha = {math.degrees(params.alpha):.4g} deg, floor {params.floor}")
    r = simulate(params, ic, options)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_result(r, path, force=True)
    return r


def paper_figures(
    setup: PaperSetup, out_dir, formats=("png", "pdf"), note: Callable[[str], None] = lambda s: None
) -> list[Path]:
    """Run (or reuse) what the figures need and write fig2 ... fig7 in ``formats``."""
    from .plots import paper as pp
    from .plots.run import write_figures

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cache = out / "cache"
    opts = SolverOptions(rtol=setup.rtol, frames_per_tff=setup.frames_per_tff)
    main = cached_run(
        ChainParams(segments=setup.segments, alpha=setup.alpha, floor=setup.floor), setup.ic, opts, cache, note
    )
    series = [
        cached_run(ChainParams(segments=setup.alpha_segments, alpha=a, floor=setup.floor), setup.ic, opts, cache, note)
        for a in setup.alphas
    ]
    figures = {
        "fig2_strobe": lambda: pp.fig2_strobe(main),
        "fig3_lock_map": lambda: pp.fig3_lock_map(main),
        "fig4_pile": lambda: pp.fig4_pile(main),
        "fig5_alpha": lambda: pp.fig5_alpha(series),
        "fig6_hamm_geminard": lambda: pp.fig6_hamm_geminard([main] + series),
        "fig7_pivot_rod": lambda: pp.fig7_pivot_rod(n=setup.rod_grid),
    }
    return write_figures(figures, out, formats, note)
