"""The three methods side by side in one process, on the same starts: the speed table of
docs/rattle.md and the README's "Which method when".

    python benchmarks/method_speed.py                                  # N = 128 and 1024, 3 starts
    python benchmarks/method_speed.py --segments 1024 --starts 5
    python benchmarks/method_speed.py --segments 4096 --methods rattle,timestep --starts 1
    python benchmarks/method_speed.py --methods event,rattle,rattle:dt=0.1:step_energy_tol=1e-6
    python benchmarks/method_speed.py --segments 512 --methods rattle,rattle:landing_step=whole
    python benchmarks/method_speed.py --floor pivot                    # the floor "pivot"

A method may carry options (``method:option=value:...``, SolverOptions' names): a row of
its own, beside the same method at its defaults.

Random starts of seed 2026 (spawn keys 0, 1, ...), alpha = pi/4, floor all (or --floor), one frame per
t_ff (frames do not change a fall), every method at its defaults.  The methods take turns
on each start (their order rotating from start to start), so that the machine's drift
hits all alike.  Falls are chaotic: a start's fall differs between the methods, and so does
its work, so the table gives medians over the starts: wall seconds per fall, steps per
fall (the time-steppers), ns per segment and step, the books' largest |imbalance| / E0
over the starts, and the ratios of the walls (medians of the per-start ratios).  Machine
and versions are printed first.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from machine import machine_info  # noqa: E402

from ballchain.engine import load_kernels, simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402

METHODS = ("event", "timestep", "rattle")


def _value(text: str) -> float | str:
    """An option's value: a number where it reads as one ('1e-6'), else the word ('cut')."""
    try:
        return float(text)
    except ValueError:
        return text


def _setting(spec: str) -> tuple[str, dict]:
    """'rattle:dt=0.1:step_energy_tol=1e-6' -> ('rattle', {'dt': 0.1, 'step_energy_tol': 1e-6});
    'rattle:landing_step=cut' -> ('rattle', {'landing_step': 'cut'})."""
    method, *options = spec.split(":")
    return method, {k: _value(v) for k, v in (o.split("=", 1) for o in options)}


def _fall(n: int, key: int, spec: str, floor: str = "all"):
    method, options = _setting(spec)
    start = InitialCondition(kind="random", seed=2026, spawn_key=(key,))
    return simulate(
        ChainParams(segments=n, alpha=math.pi / 4, floor=floor),
        start,
        SolverOptions(method=method, frames_per_tff=1, **options),
    )


def _books(r) -> float:
    """|imbalance| / E0 of a fall's energy books (initial - potential - kinetic - losses)."""
    return abs(r.energy["imbalance"]) / r.energy["initial"]


def _ratio(runs: dict, other: str, m: str) -> str:
    """The median over the starts of the method ``other``'s wall over ``m``'s."""
    if other not in runs or other == m:
        return ""
    return f"{statistics.median(o.wall_seconds / r.wall_seconds for o, r in zip(runs[other], runs[m])):.1f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--segments", default="128,1024")
    ap.add_argument("--starts", type=int, default=3)
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--floor", default="all", choices=("all", "pivot"))
    a = ap.parse_args()
    methods = a.methods.split(",")
    print(machine_info())
    print(f"floor {a.floor}")
    for m in methods:
        load_kernels(_setting(m)[0])
        _fall(8, 0, m, a.floor)  # compiled (or loaded) before any fall is timed
    print(
        "\n| N | method | starts | wall per fall (s) | steps per fall | ns / segment / step | books, largest \\|imbalance\\| / E0 | status | event wall / its | timestep wall / its |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in (int(x) for x in a.segments.split(",")):
        runs = {m: [] for m in methods}
        for key in range(a.starts):
            for m in methods[key % len(methods) :] + methods[: key % len(methods)]:
                r = _fall(n, key, m, a.floor)
                runs[m].append(r)
                print(f"  N = {n}, start {key}, {m}: {r.wall_seconds:.2f} s, {r.status}", file=sys.stderr, flush=True)
        for m in methods:
            rs = runs[m]
            wall = statistics.median(r.wall_seconds for r in rs)
            steps = statistics.median(r.n_steps for r in rs) if m != "event" else None
            per = statistics.median(r.wall_seconds / r.n_steps / n * 1e9 for r in rs) if steps else None
            status = ", ".join(sorted({r.status for r in rs}))
            books = max(_books(r) for r in rs)

            print(
                f"| {n} | {m} | {len(rs)} | {wall:.2f} | {'' if steps is None else f'{steps:.0f}'} "
                f"| {'' if per is None else f'{per:.0f}'} | {books:.1e} | {status} | {_ratio(runs, 'event', m)} | {_ratio(runs, 'timestep', m)} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
