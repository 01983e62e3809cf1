"""A sphinx-gallery image scraper for the matplotlib ``Figure`` objects that ballchain's
plotting functions return (they are not pyplot figures, so the standard scraper does not
see them): every Figure bound to a name of the example after a code block is shown once,
and a pyplot figure is left to sphinx-gallery's own matplotlib scraper (each drawn once)."""

from __future__ import annotations


def figures_to_draw(names: dict, seen: set) -> list:
    """The Figures bound in ``names`` not drawn yet (``seen``: their ids, updated), pyplot's
    own figures left out (the matplotlib scraper draws those)."""
    from matplotlib._pylab_helpers import Gcf
    from matplotlib.figure import Figure

    seen.update(id(m.canvas.figure) for m in Gcf.get_all_fig_managers())
    out = []
    for value in list(names.values()):
        if isinstance(value, Figure) and id(value) not in seen:
            seen.add(id(value))
            out.append(value)
    return out


def figure_scraper(block, block_vars, gallery_conf):
    from sphinx_gallery.scrapers import figure_rst

    seen = block_vars.setdefault("_ballchain_seen", set())
    paths = []
    image_paths = block_vars["image_path_iterator"]
    for figure in figures_to_draw(block_vars["example_globals"], seen):
        path = next(image_paths)
        figure.savefig(path, dpi=90)
        paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"])
