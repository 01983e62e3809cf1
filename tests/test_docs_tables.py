"""The tables the site generates from the code for hand-written pages (docs/_ext/generated_tables.py):
the contact laws' page's "which method takes which law" is the methods' registry, cell by cell,
and the page includes the fragment the build writes."""

import re
import sys
from pathlib import Path
from types import SimpleNamespace

from ballchain.contacts.registry import all_params
from ballchain.methods import METHOD_NAMES, honours

DOCS = Path(__file__).parents[1] / "docs"
sys.path.insert(0, str(DOCS / "_ext"))
from generated_tables import _method_laws, _write  # noqa: E402


def _cells(table: str) -> list[list[str]]:
    rows = [ln for ln in table.splitlines() if ln.startswith("|") and not ln.startswith("|---")]
    return [[c.strip() for c in row.strip().strip("|").split("|")] for row in rows]


def test_the_method_laws_table_is_the_registrys():
    """A row per method of the registry, a column per contact law's flag, each cell ``honours``."""
    head, *rows = _cells(_method_laws())
    params = list(all_params().values())
    assert head == ["method", *(f"`{p.flag}`" for p in params)]
    assert [row[0] for row in rows] == [f"`{m}`" for m in METHOD_NAMES]
    for method, row in zip(METHOD_NAMES, rows, strict=True):
        assert row[1:] == [honours(method, p.name) for p in params], method


def test_the_contact_laws_page_includes_the_fragment_the_build_writes(tmp_path):
    """The page's ``{include}`` names the file the build writes, and that file is the table."""
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "manifest.json").write_text((DOCS / "data" / "manifest.json").read_text())
    _write(SimpleNamespace(srcdir=str(tmp_path)))
    page = (DOCS / "contact-laws.md").read_text()
    (target,) = re.findall(r"^```\{include\} (generated/method-laws\.md\.inc)$", page, flags=re.M)
    assert (tmp_path / target).read_text() == _method_laws()
