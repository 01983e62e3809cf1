"""The gallery's scraper of ballchain's Figures (docs/_ext/figure_scraper.py): each
figure of an example is drawn once; pyplot's are left to sphinx-gallery's own scraper."""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

sys.path.insert(0, str(Path(__file__).parents[1] / "docs" / "_ext"))
from figure_scraper import figures_to_draw  # noqa: E402


def test_each_figure_once_and_pyplot_figures_left_to_pyplots_scraper():
    pyplot_fig, _ = plt.subplots()
    own = Figure()
    names = {"fig": pyplot_fig, "own": own, "again": own, "n": 3}
    seen: set = set()
    try:
        assert figures_to_draw(names, seen) == [own]
        assert figures_to_draw(names, seen) == []  # the next code block: not drawn again
        other = Figure()
        assert figures_to_draw({**names, "other": other}, seen) == [other]
    finally:
        plt.close(pyplot_fig)
