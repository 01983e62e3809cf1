"""The same falls with two revisions of ballchain, side by side: wall time, evaluations,
event instants, and the cost per evaluation.

    python benchmarks/compare_revisions.py --base HEAD~1 --segments 64,128 --seeds 0-7
    python benchmarks/compare_revisions.py --base HEAD~1 --segments 512 --seeds 0-1
    python benchmarks/compare_revisions.py --base HEAD~1 --segments 128 --helix --reps 5
    python benchmarks/compare_revisions.py --base 3d40ceb --segments 512 --seeds 0-3 --method rattle

``--base`` is checked out as a git worktree (in a temporary directory, removed at the
end); the other side is this checkout.  Each revision compiles its kernels once (a
first fall at N = 8, not timed), then the falls run alternately (base, head, base,
head, ...), one process each, so that the machine's drift hits both alike.  Falls are
chaotic: a change of round-off gives another fall, so compare medians over several
starts (random family, ``--seeds``), never one fall; ``--helix`` runs the default start
instead (one fall: ``--reps`` of it).  ``--reps R`` runs every fall R times (alternating)
and keeps the shortest wall time (the machine's noise only adds).  Prints the machine,
the versions and a Markdown table (medians over the starts; totals per event instant).
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
from machine import machine_info  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def seeds(spec: str) -> list[int]:
    if "-" in spec:
        a, b = spec.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in spec.split(",")]


@contextlib.contextmanager
def base_worktree(rev: str):
    """The revision ``rev`` checked out as a git worktree in a temporary directory (its
    path), removed on exit."""
    wt = Path(tempfile.mkdtemp(prefix="ballchain-base-")) / "tree"
    subprocess.run(["git", "worktree", "add", "--detach", str(wt), rev], cwd=ROOT, check=True, capture_output=True)
    try:
        yield wt
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(wt)], cwd=ROOT, capture_output=True)


def fall(src: Path, args: list[str]) -> dict:
    """One fall in a fresh process importing ballchain from ``src``; its JSON summary."""
    env = dict(os.environ, PYTHONPATH=str(src))
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run(
            [
                sys.executable,
                "-m",
                "ballchain.cli",
                "simulate",
                *args,
                "--output",
                str(Path(tmp) / "fall.h5"),
                "--json",
            ],
            env=env,
            capture_output=True,
            text=True,
        )
    if out.returncode != 0:
        raise SystemExit(f"fall failed ({src}): {out.stderr.strip().splitlines()[-1:]}")
    r = json.loads(out.stdout)
    r.setdefault("n_instants", float("nan"))  # revisions before event instants were counted: nan
    return r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="git revision to compare against (e.g. HEAD~1)")
    ap.add_argument("--segments", default="64,128")
    ap.add_argument("--alpha", default="pi/4")
    ap.add_argument("--floor", default="all")
    ap.add_argument("--seeds", default="0-7", help="random starts: 0-7 or 1,4,9")
    ap.add_argument("--helix", action="store_true", help="the default helix start instead of random starts")
    ap.add_argument("--reps", type=int, default=1, help="runs of each fall; the shortest wall time is kept")
    ap.add_argument("--method", default="event", help="the method of both sides (a time-stepper: steps, not instants)")
    args = ap.parse_args()
    if args.reps < 1:
        ap.error("--reps must be >= 1")
    rev = subprocess.run(
        ["git", "rev-parse", "--short", args.base], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()
    head = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()
    dirty = subprocess.run(
        ["git", "status", "--porcelain", "src"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    print(machine_info())
    print(
        f"base {rev}, head {head}{' + uncommitted changes' if dirty else ''}; alpha {args.alpha}, "
        f"floor {args.floor}, {'helix start' if args.helix else 'random starts ' + args.seeds}, "
        f"shortest of {args.reps} run(s) each"
    )
    with base_worktree(args.base) as wt:
        sides = {"base": wt / "src", "head": ROOT / "src"}
        for src in sides.values():  # compile (or load) each side's kernels, untimed
            fall(src, ["-N", "8", "--method", args.method])
        rows = []
        for n in [int(s) for s in args.segments.split(",")]:
            res = {"base": [], "head": []}
            for seed in [None] if args.helix else seeds(args.seeds):
                start = ["--ic", "helix"] if seed is None else ["--ic", "random", "--seed", str(seed)]
                best = {}
                for _ in range(args.reps):
                    for side, src in sides.items():
                        r = fall(
                            src,
                            [
                                "-N",
                                str(n),
                                "--alpha",
                                args.alpha,
                                "--floor",
                                args.floor,
                                "--method",
                                args.method,
                                *start,
                            ],
                        )
                        if side not in best or r["wall_seconds"] < best[side]["wall_seconds"]:
                            best[side] = r
                for side, r in best.items():
                    res[side].append(r)
                    print(
                        f"  N={n} {'helix' if seed is None else f'seed={seed}'} {side}: {r['wall_seconds']:.2f} s, "
                        f"t_fall/t_ff {r['ratio'] if r['ratio'] is None else format(r['ratio'], '.4f')} ({r['status']}), {r['n_evals']} evaluations, {r['n_instants']} instants",
                        flush=True,
                    )
            rows.append((n, res))
        print()
        if args.method != "event":
            _steps_table(rows)
            return
        print(
            "| N | starts | median wall base (s) | median wall head (s) | head / base | "
            "median us per evaluation base / head | median instants base / head | "
            "us per instant base / head | evaluations per instant base / head |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for n, res in rows:
            wb = statistics.median(r["wall_seconds"] for r in res["base"])
            wh = statistics.median(r["wall_seconds"] for r in res["head"])
            eb = statistics.median(1e6 * r["wall_seconds"] / r["n_evals"] for r in res["base"])
            eh = statistics.median(1e6 * r["wall_seconds"] / r["n_evals"] for r in res["head"])
            ib = statistics.median(r["n_instants"] for r in res["base"])
            ih = statistics.median(r["n_instants"] for r in res["head"])
            per = {}
            for side in ("base", "head"):
                inst = sum(r["n_instants"] for r in res[side])
                per[side] = (
                    1e6 * sum(r["wall_seconds"] for r in res[side]) / inst,
                    sum(r["n_evals"] for r in res[side]) / inst,
                )
            print(
                f"| {n} | {len(res['base'])} | {wb:.2f} | {wh:.2f} | {wh / wb:.2f} | {eb:.1f} / {eh:.1f} | "
                f"{ib:.0f} / {ih:.0f} | {per['base'][0]:.0f} / {per['head'][0]:.0f} | "
                f"{per['base'][1]:.1f} / {per['head'][1]:.1f} |"
            )


def _steps_table(rows) -> None:
    """A time-stepper's table: walls, steps and ns per segment and step (medians)."""
    print(
        "| N | starts | median wall base (s) | median wall head (s) | head / base | median steps base / head | "
        "ns per segment and step base / head |"
    )
    print("|---|---|---|---|---|---|---|")
    for n, res in rows:
        med = {side: statistics.median(r["wall_seconds"] for r in res[side]) for side in res}
        steps = {side: statistics.median(r["n_steps"] for r in res[side]) for side in res}
        per = {
            side: sum(r["wall_seconds"] for r in res[side]) / sum(r["n_steps"] for r in res[side]) / n * 1e9
            for side in res
        }
        print(
            f"| {n} | {len(res['base'])} | {med['base']:.2f} | {med['head']:.2f} | {med['head'] / med['base']:.2f} | "
            f"{steps['base']:.0f} / {steps['head']:.0f} | {per['base']:.0f} / {per['head']:.0f} |"
        )


if __name__ == "__main__":
    main()
