"""
A fall and its plots
====================

Simulate one fall (a small chain, so that it runs in a second), read its summary, and draw
the figures ``ballchain plot`` writes: the top end against free fall, and the energy books.
"""

import ballchain as bc
from ballchain.plots import energy_figure, fall_figure

r = bc.simulate(segments=16, alpha="45deg", ic="helix", eps=0.02)
print(r.status, f"t_fall / t_ff = {r.t_fall / r.t_ff:.4f}")
print(r.event_counts())
print(f"energy books: imbalance = {r.energy['imbalance'] / r.energy['initial']:.2e} of E0")

# %%
# The top end against free fall:
fall = fall_figure(r)

# %%
# Where the energy goes: potential to kinetic, lost at the hinges (locking) and at the floor:
energy = energy_figure(r)

# %%
# The event log as a table:
r.events_table().head(10)
