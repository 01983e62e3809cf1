"""Moreau-Jean time-stepping: ``stepper`` (the compiled step and loop), ``driver`` (a run).

What the method owns (plain data, importable without its kernels): the bounds its runs
are audited against (``records.audit``).  Its error is first order in its step: the
imbalance and depth are its own error, checked against bounds that a broken run exceeds
(a chain through the floor, a blown-up step) and a sound one does not at the default dt;
past half of them a run is warned.  Its bends pass their limits within a step by up to
w h sin(alpha) in the cosine (w the bend's rate: near the pile w ~ 2 v / b,
v ~ 2 sqrt(N) sqrt(g b), and h = dt t_ff / N = 2 dt / sqrt(N) sqrt(b / g): about 6 dt); its
projection puts them back, but not when that would move a point further than 0.1 b (it is
then undone), and it can push a neighbour past.  Sound falls keep them within 5 dt (0.10 at
N = 1024, dt 0.02, the worst of 16 starts; 0.09 at dt 0.04), so the bound is per unit dt.
"""

from ..bounds import AuditBounds

AUDIT = AuditBounds(energy_rtol=0.1, depth_tol=0.1, hinge_tol=0.0, hinge_per_dt=15.0, warn_near=True)
