"""Figures of a sweep table: t_fall/t_ff (and t_landed/t_ff) against alpha, one line per N
with its 95% bootstrap band of the mean, one panel per floor model; the free-fall time
(ratio 1) and the Hamm-Geminard bound of a chain with no floor pull (0.7468) marked."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from ..theory import hamm_geminard_time_ratio  # noqa: E402


def alpha_figure(points: list[dict], column: str = "ratio", optimal: list[dict] | None = None) -> Figure:
    """``points``: ``stats.point_stats`` rows.  One panel per floor; per N the mean of
    ``column`` against alpha (degrees), the interval as a band, the per-N optimum marked."""
    floors = sorted({p["floor"] for p in points}) or ["all"]
    fig, axes = plt.subplots(1, len(floors), figsize=(5.5 * len(floors), 4.2), squeeze=False, sharey=True)
    label = {"ratio": "t_fall / t_ff", "landed_ratio": "t_landed / t_ff"}[column]
    for ax, fl in zip(axes[0], floors):
        ns = sorted({p["segments"] for p in points if p["floor"] == fl})
        for i, n in enumerate(ns):
            rows = sorted(
                (p for p in points if p["floor"] == fl and p["segments"] == n and p[column]["mean"] is not None),
                key=lambda p: p["alpha"],
            )
            if not rows:
                continue
            a = np.array([p["alpha_deg"] for p in rows])
            m = np.array([p[column]["mean"] for p in rows])
            lo = np.array([np.nan if p[column]["ci_low"] is None else p[column]["ci_low"] for p in rows])
            hi = np.array([np.nan if p[column]["ci_high"] is None else p[column]["ci_high"] for p in rows])
            nrun = max(p[column]["n"] for p in rows)
            ax.plot(a, m, "o-", color=f"C{i}", ms=3, lw=1.2, label=f"N = {n} ({nrun} runs per alpha)", gid=f"N{n}")
            ax.fill_between(a, lo, hi, color=f"C{i}", alpha=0.25, lw=0, gid=f"band-N{n}")
            for o in optimal or []:
                if (
                    o.get("floor") == fl
                    and o.get("segments") == n
                    and o.get("alpha_deg") is not None
                    and column == "ratio"
                    and o.get("n_alpha", 0) > 1
                ):
                    ax.errorbar(
                        [o["alpha_deg"]],
                        [o["mean"]],
                        xerr=[[o["alpha_deg"] - o["ci_low_deg"]], [o["ci_high_deg"] - o["alpha_deg"]]],
                        fmt="*",
                        color=f"C{i}",
                        ms=10,
                        capsize=3,
                        gid=f"optimum-N{n}",
                    )
        ax.axhline(1.0, color="k", ls="--", lw=0.8, label="free fall")
        if column == "ratio":
            ax.axhline(hamm_geminard_time_ratio(0.0), color="0.5", ls=":", lw=0.8, label="Hamm-Geminard, gamma = 0")
        ax.set(xlabel="alpha (deg)", title=f"floor {fl}")
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel(f"{label} (mean, 95% interval)")
    fig.tight_layout()
    return fig


def segments_figure(points: list[dict], column: str = "ratio", min_sizes: int = 2) -> Figure:
    """Per (alpha, floor) measured at ``min_sizes`` N or more: the mean of ``column``
    against N with its 95% band, free fall (1) marked: where the chain starts to beat
    free fall."""
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    keys = sorted({(p["alpha_deg"], p["floor"]) for p in points})
    i = 0
    for a, fl in keys:
        rows = sorted(
            (p for p in points if p["alpha_deg"] == a and p["floor"] == fl and p[column]["mean"] is not None),
            key=lambda p: p["segments"],
        )
        if len(rows) < max(2, min_sizes):
            continue
        n = np.array([p["segments"] for p in rows])
        m = np.array([p[column]["mean"] for p in rows])
        lo = np.array([np.nan if p[column]["ci_low"] is None else p[column]["ci_low"] for p in rows])
        hi = np.array([np.nan if p[column]["ci_high"] is None else p[column]["ci_high"] for p in rows])
        ax.plot(n, m, "o-", color=f"C{i}", ms=3, label=f"alpha = {a:.4g} deg, floor {fl}", gid=f"a{a:g}-{fl}")
        ax.fill_between(n, lo, hi, color=f"C{i}", alpha=0.25, lw=0)
        i += 1
    ax.axhline(1.0, color="k", ls="--", lw=0.8, label="free fall")
    ax.set_xscale("log", base=2)
    ax.set(xlabel="N (segments)", ylabel="t_fall / t_ff (mean, 95% interval)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def write_segments_figure(points, path, column: str = "ratio") -> None:
    sizes = {}
    for p in points:
        sizes.setdefault((p["alpha_deg"], p["floor"]), set()).add(p["segments"])
    # the series measured at three sizes or more when there are any (fewer lines, clearer)
    fig = segments_figure(points, column, 3 if any(len(v) >= 3 for v in sizes.values()) else 2)
    try:
        fig.savefig(path, dpi=150, bbox_inches="tight")
    finally:
        plt.close(fig)


def write_alpha_figure(points, path, optimal=None, column: str = "ratio") -> None:
    fig = alpha_figure(points, column, optimal)
    try:
        fig.savefig(path, dpi=150, bbox_inches="tight")
    finally:
        plt.close(fig)
