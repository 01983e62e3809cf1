"""One full fall at large N, with its progress logged (the N = 4096 benchmark).

    python benchmarks/big_fall.py --segments 4096 --log big_fall.log

Prints the machine, then a line every few percent of progress (wall seconds, t/t_ff,
landed segments, event rows) and the summary of the run (JSON) at the end.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

from machine import machine_info  # noqa: E402  (benchmarks/machine.py)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=4096)
    ap.add_argument("--alpha", default="pi/4")
    ap.add_argument("--frames-per-tff", type=float, default=10.0)
    ap.add_argument("--log", default=None, help="also append the lines to this file")
    a = ap.parse_args(argv)
    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions, parse_angle

    out = [sys.stdout] + ([open(a.log, "a")] if a.log else [])

    def say(text):
        for f in out:
            print(text, file=f, flush=True)

    say(machine_info())
    simulate(ChainParams(segments=4), InitialCondition(), SolverOptions())  # compile
    t0 = time.perf_counter()
    last = [-1.0]

    def progress(frac, info):
        if frac - last[0] >= 0.02:
            last[0] = frac
            say(
                f"{time.perf_counter() - t0:9.1f} s  t/t_ff = {info.get('t_over_tff', math.nan):.4f}  "
                f"landed {info.get('landed')}  event rows {info.get('events')}"
            )

    r = simulate(
        ChainParams(segments=a.segments, alpha=parse_angle(a.alpha)),
        InitialCondition(),
        SolverOptions(frames_per_tff=a.frames_per_tff),
        progress=progress,
    )
    say(json.dumps(r.summary()))


if __name__ == "__main__":
    main()
