"""
The interactive view
====================

``ballchain view run.h5 --out fall.html`` writes this view to one HTML file that opens
offline; here it is embedded: drag to orbit, use the slider or play.  The chain is drawn
in true proportions; ``--stretch K`` (``view_figure(r, stretch=K)``) draws horizontal
lengths K times longer, and the title says so.
"""

import ballchain as bc
from ballchain.plots.view import view_figure

r = bc.simulate(segments=16, alpha="45deg", eps=0.05)
fig = view_figure(r, frames=40)


class Embedded:
    """The figure as HTML with plotly.js inside (the page then works offline too)."""

    def _repr_html_(self):
        return fig.to_html(full_html=False, include_plotlyjs=True)


Embedded()
