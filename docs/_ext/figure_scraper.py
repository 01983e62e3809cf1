"""A sphinx-gallery image scraper for the matplotlib ``Figure`` objects that ballchain's
plotting functions return (they are not pyplot figures, so the standard scraper does not
see them): every Figure bound to a name of the example after a code block is shown once."""

from __future__ import annotations


def figure_scraper(block, block_vars, gallery_conf):
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    seen = block_vars.setdefault("_ballchain_seen", set())
    paths = []
    image_paths = block_vars["image_path_iterator"]
    for value in list(block_vars["example_globals"].values()):
        if isinstance(value, Figure) and id(value) not in seen:
            seen.add(id(value))
            path = next(image_paths)
            value.savefig(path, dpi=90)
            paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"])
