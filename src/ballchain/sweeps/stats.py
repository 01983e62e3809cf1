"""Statistics of a sweep table: per point (N, alpha, floor, and any other input that
varies), the mean, median and a 95% bootstrap interval of t_fall/t_ff and
t_landed/t_ff; the fraction of runs faster than free fall with its Wilson interval;
the optimal alpha per N with a paired bootstrap interval.

Only runs that reached the quantity count for it (a run stopped by ``--until`` has no
t_fall); ``n_runs`` and ``n_error`` say how many rows a point has and how many failed.
Bootstrap intervals use ``scipy.stats.bootstrap`` (BCa, 9999 resamples) with a fixed
seed, so the same table gives the same numbers; a point with fewer than
``MIN_INTERVAL_N`` values has no interval of its mean (``ci_low``, ``ci_high``: None).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..floors.registry import WATCHES_EVERY_POINT
from .table import POINT_KEYS as GROUP_KEYS  # what tells a point of the grid apart

CONFIDENCE = 0.95
N_RESAMPLES = 9999
SEED = 20261123
FAST = 1.0  # "faster than free fall": t_fall / t_ff < 1
# no bootstrap interval of a mean from fewer runs: below it the interval's coverage is far
# from its nominal 95% (with 2 runs the resamples see at most 3 distinct means)
MIN_INTERVAL_N = 5


def mean_interval(x, confidence: float = CONFIDENCE, seed: int = SEED) -> tuple[float, float]:
    """Bootstrap (BCa) interval of the mean of ``x``; (x, x) for constant data, NaN for
    fewer than two values."""
    from scipy import stats

    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return (math.nan, math.nan)
    if np.ptp(x) == 0.0:
        return (float(x[0]), float(x[0]))
    rng = np.random.default_rng(seed)
    with np.errstate(all="ignore"):
        res = stats.bootstrap(
            (x,), np.mean, confidence_level=confidence, n_resamples=N_RESAMPLES, method="BCa", random_state=rng
        )
    lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
    if not (math.isfinite(lo) and math.isfinite(hi)):  # BCa degenerate: fall back to percentiles
        res = stats.bootstrap(
            (x,),
            np.mean,
            confidence_level=confidence,
            n_resamples=N_RESAMPLES,
            method="percentile",
            random_state=np.random.default_rng(seed),
        )
        lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
    return lo, hi


def wilson_interval(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson score interval of a proportion k/n:
    (p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)."""
    from scipy.stats import norm

    if n == 0:
        return (math.nan, math.nan)
    z = float(norm.ppf(0.5 + confidence / 2.0))
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def _present_keys(df) -> list[str]:
    return [k for k in GROUP_KEYS if k in df.columns]


def point_stats(df) -> list[dict]:
    """One dict per point of the grid (see the module docstring)."""
    keys = _present_keys(df)
    out = []
    for values, g in df.groupby(keys, dropna=False, sort=True):
        row = dict(zip(keys, (v.item() if hasattr(v, "item") else v for v in values)))
        row["alpha_deg"] = math.degrees(row["alpha"])
        row["n_runs"] = int(len(g))
        row["n_error"] = int((g["status"] == "error").sum())
        for col in ("ratio", "landed_ratio"):
            x = g[col].to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            lo, hi = mean_interval(x) if x.size >= MIN_INTERVAL_N else (math.nan, math.nan)
            row[col] = {
                "n": int(x.size),
                "mean": float(np.mean(x)) if x.size else None,
                "median": float(np.median(x)) if x.size else None,
                "std": float(np.std(x, ddof=1)) if x.size > 1 else None,
                "ci_low": lo if math.isfinite(lo) else None,
                "ci_high": hi if math.isfinite(hi) else None,
            }
        x = g["ratio"].to_numpy(dtype=float)
        x = x[np.isfinite(x)]
        k = int(np.sum(x < FAST))
        lo, hi = wilson_interval(k, int(x.size))
        row["faster_than_free_fall"] = {
            "k": k,
            "n": int(x.size),
            "fraction": k / x.size if x.size else None,
            "ci_low": lo if math.isfinite(lo) else None,
            "ci_high": hi if math.isfinite(hi) else None,
        }
        out.append(row)
    return out


def optimal_alpha(df, column: str = "ratio", seed: int = SEED, n_resamples: int = 2000) -> list[dict]:
    """Per (N, floor, ...): the alpha of the smallest mean ``column`` and its bootstrap
    interval, over the alphas with at least half as many runs as the best-filled one.  Paired bootstrap: the runs are resampled by their start (run_index), the
    same starts for every alpha, as the sweep draws them."""
    keys = [k for k in _present_keys(df) if k != "alpha"]
    out = []
    rng = np.random.default_rng(seed)
    for values, g in df.groupby(keys, dropna=False, sort=True):
        table = g.pivot_table(index="run_index", columns="alpha", values=column, aggfunc="first")
        counts = table.notna().sum(axis=0)
        # an alpha with too few runs (a point still running) would decide by noise: left out
        table = table.loc[:, counts >= max(2, 0.5 * counts.max())] if len(counts) else table
        alphas = table.columns.to_numpy(dtype=float)
        m = table.to_numpy(dtype=float)  # (starts, alphas), NaN where a run has no value
        row = dict(zip(keys, (v.item() if hasattr(v, "item") else v for v in values)))
        row["n_alpha"] = int(alphas.size)
        row["n_starts"] = int(m.shape[0])
        with np.errstate(all="ignore"):
            means = np.nanmean(m, axis=0) if m.size else np.array([])
        if alphas.size == 0 or not np.any(np.isfinite(means)):
            row.update(alpha=None, alpha_deg=None, mean=None, ci_low_deg=None, ci_high_deg=None)
            out.append(row)
            continue
        best = int(np.nanargmin(means))
        picks = np.empty(n_resamples)
        for b in range(n_resamples):
            idx = rng.integers(0, m.shape[0], m.shape[0])
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # an alpha with no value in a resample
                mb = np.nanmean(m[idx], axis=0)
            picks[b] = alphas[np.nanargmin(mb)] if np.any(np.isfinite(mb)) else np.nan
        picks = picks[np.isfinite(picks)]
        lo, hi = np.quantile(picks, [(1 - CONFIDENCE) / 2, (1 + CONFIDENCE) / 2], method="inverted_cdf")
        row.update(
            alpha=float(alphas[best]),
            alpha_deg=math.degrees(alphas[best]),
            mean=float(means[best]),
            ci_low_deg=math.degrees(lo),
            ci_high_deg=math.degrees(hi),
            share_best=float(np.mean(picks == alphas[best])),
        )
        out.append(row)
    return out


def table_stats(path) -> dict:
    """The statistics of a sweep table (the ``ballchain stats --json`` object)."""
    import pandas as pd

    from .table import read_table

    df = pd.DataFrame(read_table(path, what="table"))
    return _finite(
        {
            "table": str(path),
            "rows": int(len(df)),
            # the engines that made the rows (a table of several mixes numerical realizations)
            "engines": sorted({str(e) or "unknown" for e in df["engine"]}) if "engine" in df and len(df) else [],
            "status": {str(k): int(v) for k, v in df["status"].value_counts().items()} if len(df) else {},
            "points": point_stats(df) if len(df) else [],
            "optimal_alpha": optimal_alpha(df) if len(df) else [],
            "books": books_stats(df),
            "not_landed": not_landed(df),
        }
    )


def not_landed(df) -> list[dict]:
    """The runs of a table that did not land, each with its status and message (what
    stopped it: the time cap, with the state it was in, or a broken model), in table order."""
    if not len(df) or "status" not in df:
        return []
    rows = df[df["status"] != "landed"]
    msg = rows["message"] if "message" in rows else [""] * len(rows)
    return [
        {"run_id": str(r), "status": str(st), "message": "" if m is None else str(m)}
        for r, st, m in zip(rows["run_id"], rows["status"], msg)
    ]


def books_stats(df) -> dict:
    """How well the landed runs closed their books: the largest |imbalance| / E0 and
    the deepest point below the floor (b) among the runs whose floor watches every point
    (under floor ``pivot`` the chain passes through the floor by design: NaN if no run
    has such a floor), per method (each run has checked its own against the method's
    bounds; a run that failed them says status error)."""
    out = {}
    if not len(df) or "energy_imbalance" not in df:
        return out
    landed = df[df["status"] == "landed"]
    methods = landed["method"].fillna("event") if "method" in landed else ["event"] * len(landed)
    for method, g in landed.groupby(list(methods)):
        imb = (g["energy_imbalance"].abs() / g["energy_initial"]).to_numpy(float)
        watched = g[g["floor"].isin(WATCHES_EVERY_POINT)] if "floor" in g else g
        depth = watched["max_depth"].to_numpy(float) if "max_depth" in g else np.array([])
        out[str(method)] = {
            "runs": int(len(g)),
            "worst_imbalance": float(np.nanmax(imb)) if np.isfinite(imb).any() else math.nan,
            "deepest": float(np.nanmax(depth)) if np.isfinite(depth).any() else math.nan,
        }
    return out


def _finite(obj):
    """NaN and infinities -> None (JSON has no NaN; ``until`` NaN means: until landed)."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj
