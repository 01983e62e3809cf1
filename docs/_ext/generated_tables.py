"""Tables generated from the code at build time: the result file's HDF5 layout (from
``ballchain.records.files``) and the sweep table's columns (from
``ballchain.sweeps.table.COLUMNS``), written as markdown pages the site includes."""

from __future__ import annotations

from pathlib import Path


def _hdf5_layout() -> str:
    from ballchain.records import files
    from ballchain.records.result import QUANTITY, unit_of

    rows = [
        "# The result file (HDF5)",
        "",
        f"One HDF5 file per run, format `{files.FORMAT_NAME}` version {files.FORMAT_VERSION}, written by",
        "`ballchain simulate --output` or `bc.save`. Generated from `ballchain.records.files` at build time.",
        "",
        "Root attributes: `format`, `format_version`, `package_version`, `version`, `engine` (the engine's",
        "fingerprint), `units`, `created`, `status`, `message`, `seed`, and the parameters as JSON",
        "(`params_json`, `ic_json`, `options_json`, `energy_json`); groups `params`, `ic`, `options` hold",
        "one attribute per field.",
        "",
        "| group | dataset | quantity | unit (nondimensional) | unit (SI) | meaning |",
        "|---|---|---|---|---|---|",
    ]
    for group, names in files.GROUPS.items():
        for name in names:
            q = QUANTITY.get(name, "1")
            text = str(files.DESCRIPTIONS.get(name, name)).replace("|", "\\|")
            rows.append(f"| `/{group}` | `{name}` | {q} | {unit_of(name, 'nondimensional')} | "
                        f"{unit_of(name, 'SI')} | {text} |")  # fmt: skip
    rows += ["", "Frame conventions (the `conventions` attribute of `/frames`):", "", "```text",
             str(files.CONVENTIONS), "```", ""]  # fmt: skip
    return "\n".join(rows)


def _sweep_columns() -> str:
    from ballchain.sweeps.table import COLUMNS

    rows = [
        "# The sweep table (Parquet)",
        "",
        "One row per run, written by `ballchain sweep` and returned by `bc.sweep` as a pandas DataFrame.",
        "Generated from `ballchain.sweeps.table.COLUMNS` at build time (the same text is in the file's",
        "Parquet metadata).",
        "",
        "| column | type | meaning |",
        "|---|---|---|",
    ]
    for name, (kind, meaning) in COLUMNS.items():
        text = str(meaning).replace("|", "\\|")
        rows.append(f"| `{name}` | {kind} | {text} |")
    return "\n".join(rows) + "\n"


def _write(app) -> None:
    out = Path(app.srcdir) / "generated"
    out.mkdir(exist_ok=True)
    for name, text in (("hdf5-layout.md", _hdf5_layout()), ("sweep-columns.md", _sweep_columns())):
        path = out / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)


def setup(app):
    app.connect("builder-inited", _write)
    return {"parallel_read_safe": True, "version": "1"}
