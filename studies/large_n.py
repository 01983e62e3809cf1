"""t_fall/t_ff against N from sweep tables of any method: the table, a fit, a figure.

    python studies/large_n.py TABLE.parquet [TABLE.parquet ...] [--plot FIG.png] [--json]

Reads every landed run of the tables at one alpha and floor (``--alpha-deg 45``, ``--floor
all``) and the model's contact laws (the anchor, no restitution; rows with other laws are
left out) (``ballchain sweep`` output, any mix of methods and
N; rows are grouped by N, method, dt, rtol and engine; a run found in several tables,
the same ``run_id`` made by the same engine, counts once; ``--pool-engines A,B`` counts the
rows of the engines named as one where they ran different starts) and prints, per group: the runs, the
mean of t_fall/t_ff with its 95% bootstrap (BCa) interval, the fraction of runs faster
than free fall, and the medians of gamma measured (the floor's momentum record) and
inferred (from t_fall/t_ff), and how many of its runs did not land (status ``error``:
a broken run, e.g. books that do not close; they are left out of the rest), as a
Markdown table.  ``--events`` adds a second table:
per group, the mean lock, unlock and hold events per segment (a hold: the event-driven
method's accumulation rule, docs/model.md section 3; the time-stepper has none, and its
locks are the steps at which a hinge starts to take impulse) and the median share of the
run's energy lost at the hinges (E_lock/E0) and the books' imbalance (mean, largest).  ``--paired`` adds a third: each
time-stepping group against the event-driven group that stands for its N (``_fit_rank``),
on the starts both ran (the same spawn keys): the mean paired difference of t_fall/t_ff
and of E_lock/E0 (time-stepping - event-driven) with 95% bootstrap intervals, the same
for E_land/E0 and for both losses together (at the fall's end the chain lies at rest, so
their sum is nearly fixed: a method that books less to the hinges books more to the
landings), and the two-sample Kolmogorov-Smirnov p of t_fall/t_ff; where the exact method did not run, the
time-stepper against RATTLE at its default step (the "against" column names it).

Then a fit of the means against N, ratio(N) = r_inf + c N^(-p), weighted by their
standard errors, over one group (of two runs or more) at each N: the most exact
method's where several ran (the event-driven, then RATTLE, then the time-stepper;
``--fit-method timestep`` or ``rattle``: that one first), then
rows of a known engine, then the one with the most runs, then the smallest dt; r_inf's 95% interval comes from
refitting on bootstrap resamples of the runs.  ``--fit-each`` adds one such fit per
method through its own ensembles at its default step (RATTLE dt 0.05; the time-stepper
dt 0.01, theta 1/2 below N = 1024 and dt 0.02, theta 1 from there), where it has four
N: the limit by each method, where they overlap and beyond.  ``--plot`` draws the means with their
intervals against N (log axis), one ensemble per N and method (the one that would stand
for it), and the fit.  ``--cost`` adds the cost of
a fall per group (the median wall seconds of its runs, the time-stepper's median steps and
its cost per step and segment) and, per method, the exponent q of wall ~ N^q fitted to
the group that stands for each N from 64 up; ``--cost-plot`` draws those walls log-log.
The walls are those the sweeps measured, each run on one core of a 2-core machine with
a second run on the other core.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np
import pandas as pd
from scipy.optimize import curve_fit

from ballchain.sweeps.stats import mean_interval


def _median(g: pd.DataFrame, col: str) -> float:
    """The median of a column's finite values (NaN if it has none or is absent)."""
    x = g[col].to_numpy(float) if col in g else np.array([])
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else math.nan


def _start_keys(g: pd.DataFrame) -> pd.Series:
    """Each run's start: "seed:spawn key" (the spawn key alone where a table has no seed)."""
    keys = g["spawn_key"].astype(str)
    return g["seed"].astype(str) + ":" + keys if "seed" in g else keys


STEPPERS = ("timestep", "rattle")  # the methods with a step (dt), paired against the exact one


def _groups(df: pd.DataFrame) -> list[dict]:
    out = []
    keys = ["segments", "method", "dt", "theta", "dt_rule", "rtol", "engine"]
    for key, g in df.groupby(keys, dropna=False):
        x = g["ratio"].to_numpy(float)
        lo, hi = mean_interval(x)
        out.append(
            {
                "segments": int(key[0]),
                "method": key[1],
                "dt": float(key[2]) if key[1] in STEPPERS else None,
                "theta": float(key[3]) if key[1] == "timestep" else None,
                "dt_rule": key[4] if key[1] == "timestep" else None,
                "rtol": float(key[5]) if key[1] not in STEPPERS else None,
                "engine": "+".join(sorted(set(g["engine_made"]))) if "engine_made" in g else key[6],
                "engine_key": key[6],  # the engine it was grouped by (the pooled engines' label)
                "runs": len(x),
                "mean": float(np.mean(x)),
                "lo": float(lo),
                "hi": float(hi),
                "fast": float(np.mean(x < 1.0)),
                "gamma_measured": _median(g, "gamma_measured"),
                "gamma_inferred": _median(g, "gamma_inferred"),
                "ratios": x,
                "by_start": dict(  # (a start is its seed and spawn key: tables of two seeds pair start by start)
                    zip(
                        _start_keys(g),
                        zip(
                            x,
                            g["energy_lost_locking"] / g["energy_initial"],
                            g["energy_lost_landing"] / g["energy_initial"],
                            strict=True,
                        ),
                        strict=True,
                    )
                ),
                **{
                    f"{kind}_per_segment": float(np.mean(g[f"events_{kind}"] / g["segments"]))
                    for kind in ("lock", "unlock", "hold")
                },
                "e_lock": _median(g.assign(e_lock=g["energy_lost_locking"] / g["energy_initial"]), "e_lock"),
                "imbalance_mean": float(np.mean(g["energy_imbalance"] / g["energy_initial"])),
                "imbalance_max": float(np.max(np.abs(g["energy_imbalance"] / g["energy_initial"]))),
                "wall": _median(g, "wall_seconds"),
                "steps": _median(g, "n_steps"),
            }
        )
    return sorted(out, key=lambda r: (r["segments"], r["method"]))


def _paired(ts: dict, ev: dict, seed=20261125, n_boot=4000) -> dict | None:
    """Time-stepping minus event-driven on the starts both ran: t_fall/t_ff, E_lock/E0,
    E_land/E0 and their sum (the mean of each and its 95% bootstrap interval)."""
    from scipy.stats import ks_2samp

    keys = sorted(set(ts["by_start"]) & set(ev["by_start"]))
    if len(keys) < 2:
        return None
    d = np.array([[ts["by_start"][k][c] - ev["by_start"][k][c] for c in (0, 1, 2)] for k in keys])
    d = np.column_stack([d, d[:, 1] + d[:, 2]])  # (both losses: E_lock + E_land)
    rng = np.random.default_rng(seed)
    boot = d[rng.integers(0, len(d), (n_boot, len(d)))].mean(axis=1)
    lo, hi = np.quantile(boot, [0.025, 0.975], axis=0)
    ks = ks_2samp([ts["by_start"][k][0] for k in keys], [ev["by_start"][k][0] for k in keys]).pvalue
    return {"pairs": len(keys), "mean": d.mean(axis=0), "lo": lo, "hi": hi, "ks_p": float(ks)}


def _mean_text(g: dict) -> str:
    """The group's mean t_fall/t_ff and its 95% interval (one start: no interval)."""
    if g["runs"] < 2:
        return f"{g['mean']:.3f} (one start)"
    return f"{g['mean']:.3f} [{g['lo']:.3f}, {g['hi']:.3f}]"


def _stepper_label(g: dict) -> str:
    """A stepping method's group in the paired table: its step (the time-stepper's, as the
    pages quote it), the method's name first for the others."""
    return _step_label(g) if g["method"] == "timestep" else f"{g['method']}, {_step_label(g)}"


def _step_label(g: dict) -> str:
    """The group's step (time-stepper) or tolerance (event-driven)."""
    if g["method"] not in STEPPERS:
        return f"rtol {g['rtol']:g}"
    if g["method"] != "timestep":
        return f"dt {g['dt']:g}"
    return (
        f"dt {g['dt']:g}"
        + ("" if g["theta"] == 0.5 else f", theta {g['theta']:g}")
        + ("" if g["dt_rule"] == "fixed" else f", {g['dt_rule']}")
    )


EXACTNESS = {"event": 2, "rattle": 1, "timestep": 0}  # the exact method, then second order, then first


def _fit_rank(g: dict, method: str, theta: float = 0.5) -> tuple:
    """Which group stands for its N in the fit: the method asked for (``--fit-method``)
    where it ran, then the most exact method that ran it (``EXACTNESS``), then the
    time-stepper's theta asked for (``--fit-theta``), then fixed steps (dt_rule), then rows
    of a known engine, then the most runs, then the finest step (smallest dt)."""
    g_theta = 0.5 if g["theta"] is None else g["theta"]
    fixed = g["dt_rule"] in (None, "fixed")
    return (
        g["method"] == method,
        EXACTNESS.get(g["method"], -1),
        g_theta == theta,
        fixed,
        g["engine"] != "unknown",
        g["runs"],
        -(g["dt"] or 0.0),
    )


def _best_per_n(groups: list[dict], method: str, theta: float = 0.5) -> dict:
    """At each N, the group that ranks first by ``_fit_rank(g, method, theta)``."""
    best = {}
    for g in groups:
        cur = best.get(g["segments"])
        if cur is None or _fit_rank(g, method, theta) > _fit_rank(cur, method, theta):
            best[g["segments"]] = g
    return best


def _cost_slopes(groups: list[dict]) -> dict:
    """Per method and step (dt, or rtol), the exponent q of wall ~ N^q: a least-squares
    line through the log median walls of one group per N (N >= 64; ``_best_per_n``:
    known engine, then the most runs), where three N or more have one."""
    out = {}
    for key in sorted({(g["method"], _step_label(g)) for g in groups}):
        same = [
            g
            for g in groups
            if (g["method"], _step_label(g)) == key and g["segments"] >= 64 and math.isfinite(g["wall"])
        ]
        best = _best_per_n(same, key[0])
        ns = sorted(best)
        if len(ns) >= 3:
            q, _ = np.polyfit(np.log(ns), np.log([best[n]["wall"] for n in ns]), 1)
            out[key] = {"q": float(q), "N": ns, "wall": [best[n]["wall"] for n in ns]}
    return out


def _print_cost(groups: list[dict], slopes: dict) -> None:
    """The cost table: median wall per fall, the time-stepper's steps and cost per step
    and segment, and the fitted exponents."""
    print(
        "\n| N | method | dt (t_ff/N) / rtol | engine | runs | median wall per fall (s) | median steps | ns / step / segment |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for g in groups:
        per = ""
        if g["method"] in STEPPERS and g["steps"] > 0:
            per = f"{1e9 * g['wall'] / g['steps'] / g['segments']:.0f}"
        steps = f"{g['steps']:.0f}" if g["method"] in STEPPERS else ""
        print(
            f"| {g['segments']} | {g['method']} | {_step_label(g)} | {g['engine']} | {g['runs']} | {g['wall']:.3g} "
            f"| {steps} | {per} |"
        )
    for (method, step), sl in slopes.items():
        print(f"\ncost of a fall by {method} ({step}): wall ~ N^{sl['q']:.2f} over N = {sl['N']}")


def _cost_figure(slopes: dict, path: str) -> None:
    """Median wall per fall against N, log-log, each method with its fitted line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for (method, step), sl in slopes.items():
        marker = "o" if method == "event" else "s"
        ns, wall = np.array(sl["N"], float), np.array(sl["wall"])
        label = f"{'event-driven' if method == 'event' else 'time-stepping'}, {step}"
        (pts,) = ax.loglog(ns, wall, marker, label=f"{label} (median of the starts)")
        c = np.exp(np.mean(np.log(wall) - sl["q"] * np.log(ns)))
        ax.loglog(ns, c * ns ** sl["q"], "--", lw=1, color=pts.get_color(), label=f"{label}: N^{sl['q']:.2f}")
    _save(fig, ax, "wall seconds per fall (one core)", "cost of a fall, alpha = 45 deg, floor all", path)


def _style(ax, ylabel: str, title: str) -> None:
    """Log-2 N axis, labels, legend."""
    ax.set_xscale("log", base=2)
    ax.set_xlabel("N (segments)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)


def _save(fig, ax, ylabel: str, title: str, path: str) -> None:
    """``_style``d; the figure written to path."""
    _style(ax, ylabel, title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def _default_contacts(df: pd.DataFrame) -> pd.Series:
    """The rows run with the model's contact laws (the anchor, no restitution): a table
    with other laws (``--friction``, ``--restitution-*``) holds other falls, not the
    model's large-N limit.  Tables written before those columns ran the defaults."""
    keep = pd.Series(True, index=df.index)
    for col, default in (("friction", math.inf), ("restitution_floor", 0.0), ("restitution_lock", 0.0)):
        if col in df:
            keep &= df[col].isna() | (df[col] == default)
    return keep


def _own_per_n(groups: list[dict], method: str) -> dict:
    """At each N, the method's ensemble of two runs or more at its default step (RATTLE's
    dt; the time-stepper's ``default_step(N)``, the short one below N = 1024 and the long
    one from there, fixed; the exact method any rtol) that ranks first (``_fit_rank``: a
    known engine, then the most runs)."""
    from ballchain.methods.rattle import DEFAULT_DT
    from ballchain.methods.timestep import default_step

    def default(g: dict) -> bool:
        if g["method"] == "rattle":
            return g["dt"] == DEFAULT_DT
        if g["method"] == "timestep":
            return (g["dt"], g["theta"]) == default_step(g["segments"]) and g["dt_rule"] == "fixed"
        return True

    return _best_per_n([g for g in groups if g["method"] == method and g["runs"] >= 2 and default(g)], method)


def _fits_each(groups: list[dict]) -> list[dict]:
    """One fit of the limit per method through its own ensembles only (``_own_per_n``),
    where it has four N (the main fit joins them: ``_fit_rank``)."""
    out = []
    for method in ("event", "rattle", "timestep"):
        by_n = _own_per_n(groups, method)
        ns = sorted(by_n)
        if len(ns) < 4:
            continue
        popt, ci, nb = _fit(ns, [by_n[n]["ratios"] for n in ns])
        out.append(
            {
                "method": method,
                "step": _step_label(by_n[ns[-1]]),
                "N": ns,
                "runs": [by_n[n]["runs"] for n in ns],
                "r_inf": float(popt[0]),
                "c": float(popt[1]),
                "p": float(popt[2]),
                "r_inf_95": ci,
                "boot": nb,
            }
        )
    return out


def _runs_of_methods(ns: list[int], by_n: dict) -> list[str]:
    """Which method carries which N, as runs: ["event 16-4096", "rattle 8192", ...]."""
    out, start = [], 0
    for i in range(1, len(ns) + 1):
        if i == len(ns) or by_n[ns[i]]["method"] != by_n[ns[start]]["method"]:
            span = f"{ns[start]}" if i - 1 == start else f"{ns[start]}-{ns[i - 1]}"
            out.append(f"{by_n[ns[start]]['method']} {span}")
            start = i
    return out


def _law(n, r_inf, c, p):
    return r_inf + c * n ** (-p)


def _fit(ns, ratio_sets, seed=20261125, n_boot=400):
    """r_inf, c, p of the means (weights: their standard errors) and r_inf's 95% interval
    from fits to bootstrap resamples of the runs at each N."""
    ns = np.asarray(ns, float)
    means = np.array([np.mean(x) for x in ratio_sets])
    se = np.array([np.std(x, ddof=1) / math.sqrt(len(x)) for x in ratio_sets])
    p0 = (means[-1], (means[0] - means[-1]) * ns[0] ** 0.5, 0.5)
    bounds = ([0.0, -np.inf, 0.05], [2.0, np.inf, 3.0])
    popt, _ = curve_fit(_law, ns, means, p0=p0, sigma=se, absolute_sigma=True, bounds=bounds, maxfev=20000)
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(n_boot):
        m = np.array([np.mean(rng.choice(x, len(x))) for x in ratio_sets])
        try:
            b, _ = curve_fit(_law, ns, m, p0=popt, sigma=se, bounds=bounds, maxfev=20000)
            boot.append(b[0])
        except RuntimeError:
            continue
    lo, hi = np.quantile(boot, [0.025, 0.975]) if boot else (math.nan, math.nan)
    return popt, (float(lo), float(hi)), len(boot)


def _pool_engines(df: pd.DataFrame, engines: list[str]) -> pd.DataFrame:
    """The rows of ``engines`` grouped as one engine where they share N, method and step
    and ran different starts (a group names the engines its rows were made by, "A+B");
    where some start was run by two of them, each engine keeps its own group (a start
    would count twice).  A group's label names only the engines that made its rows."""
    df = df.assign(engine_made=df["engine"])
    step = ["segments", "method", "dt", "theta", "dt_rule", "rtol"]
    for _, g in df[df["engine"].isin(engines)].groupby(step, dropna=False):
        if g["run_id"].duplicated().any():  # (the same run_id by two engines)
            continue
        made = set(g["engine"])
        df.loc[g.index, "engine"] = "+".join(e for e in engines if e in made)
    return df


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tables", nargs="+")
    ap.add_argument("--plot", help="figure of t_fall/t_ff against N")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--events", action="store_true", help="also the events per segment and E_lock/E0")
    ap.add_argument("--paired", action="store_true", help="also time-stepping against event-driven on the same starts")
    ap.add_argument(
        "--fit-method",
        default="event",
        choices=["event", "timestep", "rattle"],
        help="the method whose rows stand for an N in the fit where several ran (default: event, the exact one)",
    )
    ap.add_argument(
        "--fit-each",
        action="store_true",
        help="also one fit per method, through its own ensembles at its default step (where it has four N)",
    )
    ap.add_argument(
        "--fit-theta",
        type=float,
        default=0.5,
        help="the time-stepper's theta whose rows stand for an N in the fit where several ran (default 0.5)",
    )
    ap.add_argument("--cost", action="store_true", help="also the cost of a fall: median wall, steps, exponent")
    ap.add_argument("--cost-plot", help="figure of the median wall per fall against N (log-log)")
    ap.add_argument("--alpha-deg", type=float, default=45.0, help="the alpha of the rows used (degrees)")
    ap.add_argument("--floor", default="all", help="the floor model of the rows used")
    ap.add_argument(
        "--pool-engines",
        default="",
        help="comma-separated engines whose rows count as one group where they share N, method and step and "
        "ran different starts (engines that differ in round-off-level details, said in the docs)",
    )
    args = ap.parse_args()
    df = pd.concat([pd.read_parquet(t) for t in args.tables], ignore_index=True)
    if "method" not in df:
        df["method"] = "event"
    df["method"] = df["method"].fillna("event")
    if "dt" not in df:
        df["dt"] = math.nan
    df["dt"] = df["dt"].where(df["method"].isin(STEPPERS), math.nan)
    if "theta" not in df:  # (tables written before the column: the update was theta = 1/2)
        df["theta"] = math.nan
    df["theta"] = df["theta"].fillna(0.5).where(df["method"] == "timestep", math.nan)
    if "dt_rule" not in df:  # (tables written before the column: every step was dt t_ff/N)
        df["dt_rule"] = None
    # empty (NaN, or "": a sweep that extends an older table fills its rows so) means fixed
    rule = df["dt_rule"].where(df["dt_rule"].notna() & (df["dt_rule"] != ""), "fixed")
    df["dt_rule"] = rule.where(df["method"] == "timestep", "")
    df["engine"] = df["engine"].fillna("unknown") if "engine" in df else "unknown"
    if "run_id" in df:  # a run in several tables (the same run by the same engine) counts once
        df = df.drop_duplicates(subset=["run_id", "engine"])
    df = df[(np.abs(df["alpha_deg"] - args.alpha_deg) < 1e-6) & (df["floor"] == args.floor)]
    df = df[_default_contacts(df)]
    if args.pool_engines:
        df = _pool_engines(df, [e.strip() for e in args.pool_engines.split(",") if e.strip()])
    ok = (df["status"] == "landed") & np.isfinite(df["ratio"])
    keys = ["segments", "method", "dt", "theta", "dt_rule", "rtol", "engine"]
    bad = df[~ok].assign(rtol=df["rtol"].where(~df["method"].isin(STEPPERS), math.nan))
    failed = bad.fillna({"dt": -1.0, "theta": -1.0, "rtol": -1.0}).groupby(keys).size().to_dict()
    df = df[ok]
    if df.empty:
        sys.exit("no landed runs in the tables")
    groups = _groups(df)
    for g in groups:  # the runs of the group that did not land (status error: a broken run, books not closed)
        where = (
            g["segments"], g["method"], g["dt"] or -1.0, g["theta"] or -1.0, g["dt_rule"] or "", g["rtol"] or -1.0,
            g["engine_key"],
        )  # fmt: skip
        g["failed"] = int(failed.get(where, 0))
    # the fit: at each N one group, chosen by _fit_rank
    by_n = _best_per_n([g for g in groups if g["runs"] >= 2], args.fit_method, args.fit_theta)
    ns = sorted(by_n)
    fit = None
    if len(ns) >= 4:
        popt, ci, nb = _fit(ns, [by_n[n]["ratios"] for n in ns])
        fit = {
            "r_inf": float(popt[0]),
            "c": float(popt[1]),
            "p": float(popt[2]),
            "r_inf_95": ci,
            "boot": nb,
            "N": ns,
            "methods": _runs_of_methods(ns, by_n),
        }
    fits = _fits_each(groups) if args.fit_each else []
    if args.json:
        hidden = ("ratios", "by_start")
        groups_out = [{k: v for k, v in g.items() if k not in hidden} for g in groups]
        print(json.dumps({"groups": groups_out, "fit": fit, "fits_each": fits}))
    else:
        print(
            "| N | method | dt (t_ff/N) / rtol | engine | runs | t_fall/t_ff [95%] | faster than free fall "
            "| gamma measured | gamma inferred | runs not landed |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|")
        for g in groups:
            print(
                f"| {g['segments']} | {g['method']} | {_step_label(g)} | {g['engine']} | {g['runs']} | {_mean_text(g)} "
                f"| {g['fast']:.2f} | {g['gamma_measured']:.2f} | {g['gamma_inferred']:.2f} | {g['failed']} |"
            )
        if args.events:
            print(
                "\n| N | method | dt (t_ff/N) / rtol | runs | locks / N | unlocks / N | holds / N | E_lock/E0 (median) "
                "| imbalance/E0: mean | max abs |"
            )
            print("|---|---|---|---|---|---|---|---|---|---|")
            for g in groups:
                print(
                    f"| {g['segments']} | {g['method']} | {_step_label(g)} | {g['runs']} | {g['lock_per_segment']:.1f} "
                    f"| {g['unlock_per_segment']:.1f} | {g['hold_per_segment']:.1f} | {g['e_lock']:.3f} "
                    f"| {g['imbalance_mean']:+.2g} | {g['imbalance_max']:.2g} |"
                )
        if args.paired:
            best_event = _best_per_n([g for g in groups if g["method"] == "event"], "event")
            best_rattle = _own_per_n(groups, "rattle")  # (where the exact method did not run)
            print(
                "\n| N | time-stepping | engine | against (event-driven; else RATTLE) | pairs | t_fall/t_ff: difference [95%] "
                "| KS p | E_lock/E0: difference [95%] | E_land/E0: difference [95%] | both losses: difference [95%] |"
            )
            print("|---|---|---|---|---|---|---|---|---|---|")
            for g in groups:
                ev = best_event.get(g["segments"])
                if ev is None and g["method"] == "timestep":
                    ev = best_rattle.get(g["segments"])
                pr = _paired(g, ev) if g["method"] in STEPPERS and ev else None
                if pr:
                    m, lo, hi = pr["mean"], pr["lo"], pr["hi"]
                    ref = _step_label(ev) if ev["method"] == "event" else _stepper_label(ev)
                    print(
                        f"| {g['segments']} | {_stepper_label(g)} | {g['engine']} | {ref}, {ev['engine']} "
                        f"| {pr['pairs']} | {m[0]:+.4f} [{lo[0]:+.4f}, {hi[0]:+.4f}] | {pr['ks_p']:.2f} "
                        f"| {m[1]:+.4f} [{lo[1]:+.4f}, {hi[1]:+.4f}] | {m[2]:+.4f} [{lo[2]:+.4f}, {hi[2]:+.4f}] "
                        f"| {m[3]:+.5f} [{lo[3]:+.5f}, {hi[3]:+.5f}] |"
                    )
        if args.cost:
            _print_cost(groups, _cost_slopes(groups))
        if fit:
            print(
                f"\nfit over N = {fit['N']}: t_fall/t_ff = {fit['r_inf']:.3f} + {fit['c']:.3g} N^-{fit['p']:.2f}; "
                f"r_inf 95% [{fit['r_inf_95'][0]:.3f}, {fit['r_inf_95'][1]:.3f}] ({fit['boot']} bootstrap refits; "
                f"{', '.join(fit['methods'])})"
            )
        if fits:
            print("\n| method | step | N | starts at each N | r_inf [95%] | c | p |")
            print("|---|---|---|---|---|---|---|")
            for f in fits:
                print(
                    f"| {f['method']} | {f['step']} | {f['N'][0]}-{f['N'][-1]} ({len(f['N'])} N) "
                    f"| {', '.join(str(r) for r in f['runs'])} "
                    f"| {f['r_inf']:.3f} [{f['r_inf_95'][0]:.3f}, {f['r_inf_95'][1]:.3f}] | {f['c']:.3g} | {f['p']:.2f} |"
                )
    if args.cost_plot:
        _cost_figure(_cost_slopes(groups), args.cost_plot)
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        names = {"event": "event-driven", "timestep": "time-stepping", "rattle": "RATTLE"}
        marks = {"event": ("o", 0.96, "C0"), "timestep": ("s", 1.0, "C1"), "rattle": ("^", 1.04, "C2")}
        fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.2))
        for ax, n_min in zip(axes, (0, 512), strict=True):
            for method, (marker, shift, color) in marks.items():
                own = _own_per_n(groups, method)  # (one ensemble per N: its default step)
                gs = [own[n] for n in sorted(own) if n >= n_min]
                if not gs:
                    continue
                x = np.array([g["segments"] for g in gs]) * shift
                y = np.array([g["mean"] for g in gs])
                err = np.array([[g["mean"] - g["lo"] for g in gs], [g["hi"] - g["mean"] for g in gs]])
                ax.errorbar(x, y, yerr=err, fmt=marker, color=color, capsize=3, label=names[method])
            if fit:
                xs = np.geomspace(max(min(ns), n_min / 1.5), 16 * max(ns), 200)
                ax.plot(xs, _law(xs, fit["r_inf"], fit["c"], fit["p"]), "k--", lw=1, label="fit r_inf + c N^-p")
                ax.axhspan(*fit["r_inf_95"], color="0.85", zorder=0, label="r_inf, 95%")
            if n_min:
                for f in fits:  # each method's own fit
                    xs = np.geomspace(n_min / 1.5, 16 * max(ns if fit else f["N"]), 200)
                    ax.plot(
                        xs, _law(xs, f["r_inf"], f["c"], f["p"]), ":", lw=1.2, color=marks[f["method"]][2],
                        label=f"{names[f['method']]} alone: r_inf {f['r_inf']:.3f}",
                    )  # fmt: skip
            else:
                ax.axhline(1.0, color="0.5", lw=0.8)
            title = "alpha = 45 deg, floor all, random starts" if not n_min else f"N >= {n_min}, each method's fit"
            _style(ax, "t_fall / t_ff", title)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)


if __name__ == "__main__":
    main()
