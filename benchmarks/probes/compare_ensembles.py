"""Compare two ensembles of t_fall/t_ff written by benchmarks/probes/ensemble.py (e.g. before
and after a change): means with 95% confidence intervals, two-sample Kolmogorov-Smirnov
and Welch tests.

    python benchmarks/probes/ensemble.py --segments 64 --seeds 0-47 --floors all > after.jsonl
    python benchmarks/probes/compare_ensembles.py before.jsonl after.jsonl
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
from scipy import stats


def load(path):
    rows = [json.loads(line) for line in open(path) if line.startswith("{")]
    return [r for r in rows if r["ic"] == "random" and r["ratio"] is not None]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--key", default="ratio", help="ratio (t_fall/t_ff) or landed_ratio")
    a = ap.parse_args(argv)
    xs = []
    for path in (a.a, a.b):
        x = np.array([r[a.key] for r in load(path)], float)
        m, se = x.mean(), x.std(ddof=1) / math.sqrt(len(x))
        print(f"{path}: n = {len(x)}, mean {m:.4f} +- {se:.4f} (95% CI {m - 1.96 * se:.4f} .. {m + 1.96 * se:.4f})")
        xs.append(x)
    print(f"KS p = {stats.ks_2samp(*xs).pvalue:.3f}, Welch p = {stats.ttest_ind(*xs, equal_var=False).pvalue:.3f}")


if __name__ == "__main__":
    main()
