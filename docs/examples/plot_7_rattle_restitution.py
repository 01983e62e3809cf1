"""
RATTLE with a contact law: restitution at the bend limit
========================================================

The model's hinge locks when it reaches its bend limit: a perfectly inelastic impact.
Newton's restitution there (``restitution_lock=E``: the hinge rebounds from its limit at
E times the rate it closed with; :doc:`/contact-laws`) is one of the laws the RATTLE method
honours (``method="rattle"``).  Here the same small chain (N = 32, alpha = 45 deg) falls
from the same four random starts with the model's lock (E = 0) and with E = 0.5: a hinge
that rebounds comes back to its limit, and the falls take more lock events.  Single falls
are chaotic; the results page :doc:`/restitution` measures the law on 16 starts.
"""

import matplotlib.pyplot as plt
import numpy as np

import ballchain as bc

LAWS = {"E = 0 (the model's lock)": {}, "E = 0.5": {"restitution_lock": 0.5}}
STARTS = range(4)
N = 32

runs = {
    name: [
        bc.simulate(segments=N, alpha="45deg", ic="random", seed=2026, spawn_key=k, method="rattle", **law)
        for k in STARTS
    ]
    for name, law in LAWS.items()
}
for name, rs in runs.items():
    for k, r in zip(STARTS, rs):
        e = r.energy
        print(
            f"{name:25s} start {k}: {r.status}, t_fall/t_ff = {r.t_fall / r.t_ff:.3f}, "
            f"lock events {r.event_counts().get('lock', 0)}, E_lock/E0 = {e['lost_locking'] / e['initial']:.3f}, "
            f"books {e['imbalance'] / e['initial']:+.1e} E0"
        )

# %%
# The lock events of the first start as the fall goes on, and each start's lock events
# per segment under both laws:
fig, (count, per_start) = plt.subplots(1, 2, figsize=(9, 3.8))
for (name, rs), colour in zip(runs.items(), ("C0", "C3")):
    r = rs[0]
    t = np.sort(np.asarray(r.event_t)[np.asarray(r.events_table()["kind"] == "lock")])
    count.step(t / r.t_ff, np.arange(1, t.size + 1), where="post", color=colour, label=name)
    per_start.plot(list(STARTS), [r.event_counts().get("lock", 0) / N for r in rs], "o", color=colour, label=name)
count.set_xlabel("t / t_ff")
count.set_ylabel("lock events so far")
count.set_title("start 0")
count.legend(fontsize=8)
per_start.set_xlabel("start (spawn key)")
per_start.set_ylabel("lock events per segment")
per_start.set_xticks(list(STARTS))
per_start.set_title(f"N = {N}, RATTLE")
fig.tight_layout()
plt.show()
