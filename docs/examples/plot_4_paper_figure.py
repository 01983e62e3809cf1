"""
One of the paper's figures
==========================

``ballchain paper`` redraws the paper's Figs. 2-7. Fig. 7 needs no simulation: the force
of the floor on a rod pivoting on it, from its closed form (``ballchain.theory``).
"""

from ballchain.plots.paper import fig7_pivot_rod

figure = fig7_pivot_rod(n=21)
