"""The one-time compile of the kernels (a first run on a fresh machine), side by side.

    python benchmarks/compile_time.py                 # this checkout: policy off vs on
    python benchmarks/compile_time.py --base c4917c9  # a git revision vs this checkout
    python benchmarks/compile_time.py --reps 5
    python benchmarks/compile_time.py --breakdown     # one cold compile: LLVM time per library
    BALLCHAIN_OPTIMIZE_CALLEES=1 python benchmarks/compile_time.py --breakdown   # policy off
    python benchmarks/compile_time.py --run-pairs 10  # the default fall: policy off vs on
    python benchmarks/compile_time.py --functions     # one cold compile: seconds per kernel
    python benchmarks/compile_time.py --per-method    # each method's cold compile alone, and the run after it

Each compile is a fresh process with an empty numba cache (``NUMBA_CACHE_DIR`` in a
temporary directory) that imports ballchain and loads the kernels as the first run of
``ballchain simulate`` does (``engine.load_kernels``; for a revision from before it, the
smallest run through its CLI, ``simulate -N 4``); it reports wall and CPU seconds.
Without ``--base`` the two sides are this checkout with the compile policy of
``ballchain.jit`` switched off (``BALLCHAIN_OPTIMIZE_CALLEES=1``: numba as it always
compiles) and on; with ``--base`` the revision is checked out as a git worktree (removed
at the end).  The sides alternate (A, B, A, B, ...) so that the machine's drift hits both
alike; prints the machine, the versions, every compile, and the medians with their ratio.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from compare_revisions import base_worktree  # noqa: E402
from machine import machine_info  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

PROBE = """
import json, resource, time
t0 = time.perf_counter()
import ballchain
from ballchain import engine
import os
if hasattr(engine, "load_kernels"):
    method = os.environ.get("BALLCHAIN_PROBE_METHOD")
    cold = engine.load_kernels(method) if method else engine.load_kernels()
else:  # a revision from before load_kernels: the smallest run through its CLI
    import tempfile
    from ballchain.cli import app
    with tempfile.TemporaryDirectory() as d:
        try:
            app(["simulate", "-N", "4", "--output", d + "/x.h5"], standalone_mode=False)
        except SystemExit:
            pass
    cold = True  # the cache directory was empty
r = resource.getrusage(resource.RUSAGE_SELF)
try:
    from ballchain.jit import policy_active
    policy = policy_active()
except ImportError:  # a revision from before the policy
    policy = False
print(json.dumps({"wall": time.perf_counter() - t0, "cpu": r.ru_utime + r.ru_stime, "cold": cold,
                  "file": ballchain.__file__, "policy": policy}))
"""


BREAKDOWN = (
    """
import collections, os, time
import numba.core.codegen as cg
import ballchain.jit  # its policy wraps numba's methods first: time them as installed
llvm, count = collections.defaultdict(float), collections.Counter()
finalize = cg.CPUCodeLibrary.finalize
def timed(self):  # link, optimise and emit machine code: numba's LLVM work per library
    t = time.perf_counter()
    try:
        return finalize(self)
    finally:
        llvm[self.name] += time.perf_counter() - t
        count[self.name] += 1
cg.CPUCodeLibrary.finalize = timed
"""
    + PROBE
    + """
from ballchain import jit
cheap = set(jit.cheap_libraries()) if hasattr(jit, "cheap_libraries") else set()
print(f"wall {time.perf_counter() - t0:.1f} s; LLVM (finalize) {sum(llvm.values()):.1f} s over "
      f"{sum(count.values())} libraries; the rest is numba's front end (typing, lowering)")
for name, sec in sorted(llvm.items(), key=lambda kv: -kv[1])[:12]:
    print(f"  {sec:6.2f} s  {count[name]:3d}x  {name}  ({'cheap' if name in cheap else 'full'} pipeline)")
"""
)


FUNCTIONS = (
    """
import collections, os, time
from numba.core import event
class Compiles(event.Listener):  # numba's compile events nest: a callee inside its caller
    def __init__(self):
        self.stack, self.excl, self.incl, self.parent = [], collections.Counter(), collections.Counter(), {}
    def on_start(self, ev):
        f = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{f.__module__}.{f.__qualname__}" if f is not None else "?"
        self.parent.setdefault(name, self.stack[-1][0] if self.stack else None)
        self.stack.append([name, time.perf_counter(), 0.0])
    def on_end(self, ev):
        name, t, inner = self.stack.pop()
        dt = time.perf_counter() - t
        self.incl[name] += dt
        self.excl[name] += dt - inner
        if self.stack:
            self.stack[-1][2] += dt
c = Compiles()
event.register("numba:compile", c)
"""
    + PROBE
    + """
work = sum(c.excl.values())
def chain(name):  # the compiles that must follow one another down to this one, innermost first
    out = []
    while name is not None:
        out.append(name)
        name = c.parent[name]
    return out
longest = max((chain(name) for name in c.excl), key=lambda ch: sum(c.excl[x] for x in ch))
span = sum(c.excl[x] for x in longest)
print(f"wall {time.perf_counter() - t0:.1f} s; {len(c.excl)} compiled functions, {work:.1f} s compiling them")
for name, sec in sorted(c.excl.items(), key=lambda kv: -kv[1])[: int(os.environ.get("BALLCHAIN_TOP", "15"))]:
    print(f"  {sec:6.2f} s own  {c.incl[name]:6.2f} s with its callees  {name}")
print(f"longest chain of compiles that must follow one another: {span:.1f} s "
      f"({' <- '.join(x.rpartition('.')[2] for x in longest)})")
print(f"no split over two processes compiles faster than max(that chain, half the work) = "
      f"{max(span, work / 2):.1f} s, before starting the processes and compiling shared callees twice")
"""
)


def cold_compile(src: Path, extra_env: dict) -> dict:
    """Compile the kernels of ``src`` in a fresh process with an empty cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=cache, **extra_env)
        out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"compile failed ({src}): {out.stderr.strip().splitlines()[-3:]}")
    rec = json.loads(out.stdout.strip().splitlines()[-1])
    if not rec["cold"] or not rec["file"].startswith(str(src)):
        raise SystemExit(f"not a cold compile of {src}: {rec}")
    return rec


def default_fall(cache: str, extra_env: dict) -> dict:
    """The default ``ballchain simulate`` in a fresh process with the given numba cache."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), NUMBA_CACHE_DIR=cache, **extra_env)
    code = (
        "import sys; from ballchain.cli import app; "
        "sys.argv = ['ballchain', 'simulate', '--json', '--output', sys.argv[1], '--force']; app()"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(Path(cache) / "fall.h5")], env=env, capture_output=True, text=True
    )
    if out.returncode != 0:
        raise SystemExit(f"the default fall failed: {out.stderr.strip().splitlines()[-3:]}")
    return json.loads(out.stdout)


def run_pairs(pairs: int) -> None:
    """The machine code that runs is the outer kernel's: is the default fall as fast with
    the policy as without it?  Each side compiles into its own cache, then the falls
    alternate (off, on / on, off), one process each; prints every pair and the median
    ratio of wall_seconds."""
    sides = {"policy off": {"BALLCHAIN_OPTIMIZE_CALLEES": "1"}, "policy on": {}}
    with tempfile.TemporaryDirectory() as off, tempfile.TemporaryDirectory() as on:
        caches = {"policy off": off, "policy on": on}
        for name, env in sides.items():
            rec = default_fall(caches[name], env)  # compiles
            print(f"  {name}: compiled; t_fall/t_ff {rec['ratio']:.4f}, {rec['n_evals']} evaluations", flush=True)
        ratios, walls = [], {name: [] for name in sides}
        for i in range(pairs):
            order = list(sides) if i % 2 == 0 else list(sides)[::-1]
            wall = {name: default_fall(caches[name], sides[name])["wall_seconds"] for name in order}
            for name in sides:
                walls[name].append(wall[name])
            ratios.append(wall["policy on"] / wall["policy off"])
            print(
                f"  pair {i + 1}: off {wall['policy off']:.2f} s, on {wall['policy on']:.2f} s, ratio {ratios[-1]:.3f}",
                flush=True,
            )
    print(
        f"\nmedian wall: off {statistics.median(walls['policy off']):.2f} s, "
        f"on {statistics.median(walls['policy on']):.2f} s; ratios (on / off) "
        f"{min(ratios):.2f} to {max(ratios):.2f}, median {statistics.median(ratios):.3f}"
    )


def per_method(reps: int) -> None:
    """Each method's cold compile alone (a fresh process, an empty cache, the method's
    kernels as its first run loads them), ``reps`` times, the methods in turn; after each,
    the same in a second process on the cache it filled (what every later run pays).
    Prints every compile and the medians of wall and CPU seconds per method."""
    from ballchain.methods import METHODS

    src = ROOT / "src"
    got = {m: {"cpu": [], "wall": [], "after": []} for m in METHODS}
    for rep in range(reps):
        for m in METHODS:
            with tempfile.TemporaryDirectory() as cache:
                env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=cache, BALLCHAIN_PROBE_METHOD=m)
                runs = [
                    subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True) for _ in "12"
                ]
            for out in runs:
                if out.returncode != 0:
                    raise SystemExit(f"{m}: {out.stderr.strip().splitlines()[-3:]}")
            cold, warm = (json.loads(out.stdout.strip().splitlines()[-1]) for out in runs)
            if not cold["cold"] or warm["cold"]:
                raise SystemExit(f"{m}: not a cold compile then a cached load: {cold}, {warm}")
            got[m]["cpu"].append(cold["cpu"])
            got[m]["wall"].append(cold["wall"])
            got[m]["after"].append(warm["wall"])
            print(
                f"  rep {rep + 1} {m}: cold {cold['wall']:.1f} s wall, {cold['cpu']:.1f} s CPU; "
                f"the run after it {warm['wall']:.1f} s",
                flush=True,
            )
    print("\n| method | cold compile, CPU s (median) | wall s (median) | the run after it, wall s (median) |")
    print("|---|---|---|---|")
    for m, g in got.items():
        med = {k: statistics.median(v) for k, v in g.items()}
        print(f"| {m} | {med['cpu']:.1f} | {med['wall']:.1f} | {med['after']:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", help="git revision to compare with this checkout (default: the policy off vs on)")
    ap.add_argument("--reps", type=int, default=3, help="cold compiles per side (alternating)")
    ap.add_argument(
        "--breakdown", action="store_true", help="one cold compile of this checkout: LLVM seconds per library, the rest"
    )
    ap.add_argument(
        "--functions",
        action="store_true",
        help="one cold compile of this checkout: compile seconds per kernel, and the least a "
        "compile split over two processes could take",
    )
    ap.add_argument(
        "--run-pairs",
        type=int,
        metavar="P",
        help="instead: P pairs of default falls compiled with the policy off and on",
    )
    ap.add_argument("--per-method", action="store_true", help="each method's cold compile alone, and the run after it")
    args = ap.parse_args()
    print(machine_info())
    if args.per_method:
        per_method(args.reps)
        return
    if args.run_pairs:
        run_pairs(args.run_pairs)
        return
    if args.breakdown or args.functions:
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), NUMBA_CACHE_DIR=cache)
            subprocess.run([sys.executable, "-c", BREAKDOWN if args.breakdown else FUNCTIONS], env=env, check=True)
        return
    head = ROOT / "src"
    with contextlib.ExitStack() as stack:
        if args.base:
            wt = stack.enter_context(base_worktree(args.base))
            sides = [(f"base {args.base}", wt / "src", {}), ("this checkout", head, {})]
        else:
            sides = [("policy off", head, {"BALLCHAIN_OPTIMIZE_CALLEES": "1"}), ("policy on", head, {})]
        times: dict[str, list] = {name: [] for name, _, _ in sides}
        for rep in range(args.reps):
            for name, src, env in sides:
                rec = cold_compile(src, env)
                times[name].append(rec)
                print(
                    f"  rep {rep + 1}  {name:<24} wall {rec['wall']:6.1f} s   cpu {rec['cpu']:6.1f} s"
                    f"   policy {'on' if rec['policy'] else 'off'}",
                    flush=True,
                )
    print("\n| side | median wall (s) | median CPU (s) | compiles |\n|---|---|---|---|")
    med = {}
    for name, recs in times.items():
        med[name] = statistics.median(r["wall"] for r in recs)
        print(f"| {name} | {med[name]:.1f} | {statistics.median(r['cpu'] for r in recs):.1f} | {len(recs)} |")
    a, b = (med[name] for name, _, _ in sides)
    print(f"\nratio (second / first): {b / a:.2f}")


if __name__ == "__main__":
    main()
