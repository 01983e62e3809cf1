"""
A small sweep and its statistics
================================

A grid of falls (two N, three alpha, five random starts each) as a pandas table, one row
per run, and the statistics ``ballchain stats`` computes: means with 95 % bootstrap
intervals (none from fewer than five runs).  Real studies use 16 to 64 starts per point
(the studies in these pages).
"""

import matplotlib.pyplot as plt

import ballchain as bc

table = bc.sweep(segments=[8, 12], alpha=["30deg", "45deg", "60deg"], runs=5, seed=1, workers=1)
print(table[["segments", "alpha_deg", "run_index", "ratio", "landed_ratio", "status"]])

# %%
s = bc.stats(table)
fig, ax = plt.subplots(figsize=(6, 3.5))
for n in (8, 12):
    pts = [p for p in s["points"] if p["segments"] == n]
    a = [p["alpha_deg"] for p in pts]
    m = [p["ratio"]["mean"] for p in pts]
    lo = [p["ratio"]["mean"] - p["ratio"]["ci_low"] for p in pts]
    hi = [p["ratio"]["ci_high"] - p["ratio"]["mean"] for p in pts]
    ax.errorbar(a, m, yerr=[lo, hi], marker="o", capsize=3, label=f"N = {n} ({pts[0]['ratio']['n']} runs each)")
ax.axhline(1.0, color="k", lw=0.8, ls="--")
ax.set_xlabel("alpha (deg)")
ax.set_ylabel("t_fall / t_ff")
ax.legend()
plt.show()
