"""Pages generated from the code at build time: the command-line reference (from the
typer app itself: every command and option with the help ``--help`` prints), the result
file's HDF5 layout (from ``ballchain.records.files``) and the sweep table's columns (from
``ballchain.sweeps.table.COLUMNS``), written as markdown pages the site includes; and tables
a hand-written page includes (a ``.md.inc`` fragment, not a page of its own, read by the
page's ``{include}`` directive): which method takes which contact law (from the methods'
registry, ``ballchain.methods.honours``), on the contact laws' page."""

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
        "The root's attributes; groups `params`, `ic`, `options` hold one attribute per field as well.",
        "",
        "| attribute | what it holds |",
        "|---|---|",
        *(f"| `{name}` | {_cell(text)} |" for name, text in files.ROOT_ATTRS.items()),
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


def _method_laws() -> str:
    """The table of which method takes which contact law: a row per method of the registry, a
    column per contact law's parameter (its flag), each cell what ``honours`` says ("any", "up
    to B" or "refused")."""
    from ballchain.contacts.registry import all_params
    from ballchain.methods import METHOD_NAMES, honours

    params = list(all_params().values())
    rows = [
        "| method | " + " | ".join(f"`{p.flag}`" for p in params) + " |",
        "|---|" + "---|" * len(params),
        *(f"| `{m}` | " + " | ".join(honours(m, p.name) for p in params) + " |" for m in METHOD_NAMES),
    ]
    return "\n".join(rows) + "\n"


def _cell(text: str) -> str:
    """Plain text in a markdown table cell: one line, its markup characters escaped."""
    text = " ".join(str(text).split())
    for ch in ("\\", "|", "*", "<", ">", "`"):
        text = text.replace(ch, "\\" + ch)
    return text


def _command_sections(cmd, ctx, path: list[str]) -> list[str]:
    """The section of one command (its usage, help and options, as ``--help`` gives them)
    and those of its subcommands, in the order the app declares them."""
    import typer

    rows = [f"{'#' * min(len(path) + 1, 4)} `{' '.join(path)}`", ""]
    if cmd.help:
        rows += [" ".join(cmd.help.split()), ""]
    rows += ["```text", cmd.get_usage(ctx).removeprefix("Usage: "), "```", ""]
    records = [r for p in cmd.params if not getattr(p, "hidden", False) and (r := p.get_help_record(ctx))]
    if records:
        rows += ["| option or argument | what it does |", "|---|---|"]
        rows += [f"| `{names}` | {_cell(text)} |" for names, text in records]
        rows.append("")
    for name, sub in getattr(cmd, "commands", {}).items():
        if not getattr(sub, "hidden", False):
            rows += _command_sections(sub, typer.Context(sub, info_name=name, parent=ctx), [*path, name])
    return rows


def _cli_reference() -> str:
    import typer

    from ballchain.cli import app

    root = typer.main.get_command(app)
    ctx = typer.Context(root, info_name="ballchain")
    rows = [
        "# Command-line reference",
        "",
        "Every command of `ballchain` and every option, with the help `ballchain COMMAND --help` prints:",
        "generated from the command-line program itself when this site is built, so it cannot drift from it.",
        "Errors in the input end in one line `error: ...` on stderr with exit code 2; `--json` prints one",
        "JSON object on stdout (its keys: [the JSON keys](json-keys.md)).",
        "",
    ]
    sections = _command_sections(root, ctx, ["ballchain"])
    rows += ["## `ballchain`", "", *sections[2:]]
    return "\n".join(rows)


def _json_keys() -> str:
    from ballchain.records.json_keys import PAGES

    rows = [
        "# The JSON keys",
        "",
        "The keys of the objects `--json` prints (one object on stdout), each with what it holds: a",
        "contract, extended and never renamed. Generated from `ballchain.records.json_keys` at build time;",
        "a test checks those lists against the objects the commands print. `ballchain theory ... --json`",
        "prints its inputs and results under the names of its options.",
        "",
    ]
    for title, keys in PAGES:
        rows += [f"## `{title}`", "", "| key | what it holds |", "|---|---|"]
        rows += [f"| `{k}` | {_cell(v)} |" for k, v in keys.items()]
        rows.append("")
    return "\n".join(rows)


def _provenance(srcdir: Path) -> str:
    import json

    manifest = json.loads((srcdir / "data" / "manifest.json").read_text())
    rows = [
        "# Provenance of the committed tables",
        "",
        " ".join(manifest["about"].split()),
        "Rendered from `docs/data/manifest.json` at build time. How the numbers were reached,",
        "what was tried and rerun, is in [the lab notes](../lab-notes.md).",
        "",
    ]
    for name, t in manifest["tables"].items():
        engines = ", ".join(f"`{e}` ({c or 'commit not recorded'})" for e, c in t["engines"].items())
        rows += [f"## `{name}`", "", f"{t['rows']} rows; engines {engines}; added in commit {t['committed_in']}.",
                 "", "```bash", *t["commands"], "```", "", "Feeds: " + "; ".join(t["feeds"]) + ".", ""]  # fmt: skip
    return "\n".join(rows)


def _write(app) -> None:
    out = Path(app.srcdir) / "generated"
    out.mkdir(exist_ok=True)
    pages = (
        ("cli.md", _cli_reference()),
        ("json-keys.md", _json_keys()),
        ("provenance.md", _provenance(Path(app.srcdir))),
        ("hdf5-layout.md", _hdf5_layout()),
        ("sweep-columns.md", _sweep_columns()),
        ("method-laws.md.inc", _method_laws()),  # (included by contact-laws.md)
    )
    for name, text in pages:
        path = out / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)


def setup(app):
    app.connect("builder-inited", _write)
    return {"parallel_read_safe": True, "version": "1"}
