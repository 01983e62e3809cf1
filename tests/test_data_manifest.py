"""docs/data/manifest.json, the provenance of the committed tables: every table of
docs/data is in it, with the rows and the engines the table itself holds."""

import json
from pathlib import Path

import pandas as pd
import pytest

DATA = Path(__file__).parents[1] / "docs" / "data"
MANIFEST = json.loads((DATA / "manifest.json").read_text())["tables"]


def test_every_table_is_in_the_manifest_and_every_entry_is_a_table():
    assert set(MANIFEST) == {p.name for p in DATA.glob("*.parquet")}


@pytest.mark.parametrize("name", sorted(MANIFEST))
def test_the_manifest_states_the_tables_rows_and_engines(name):
    entry, table = MANIFEST[name], pd.read_parquet(DATA / name, columns=["engine"])
    assert entry["rows"] == len(table)
    assert set(entry["engines"]) == set(table["engine"])
    assert entry["commands"] and entry["feeds"] and entry["committed_in"]
