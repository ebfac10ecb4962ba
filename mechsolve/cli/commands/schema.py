"""``mechsolve schema``: the JSON Schema of the mechanism file, for editors."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.cli.kit import EPILOG_NO_CHECK, Command, writing

SCHEMA_FILE = "mechanism.schema.json"


def shipped_path() -> Path:
    """Where the installed package keeps the schema."""
    from importlib.resources import files

    return Path(str(files("mechsolve.analyses.schema").joinpath(SCHEMA_FILE)))


@click.command("schema", cls=Command, epilog=EPILOG_NO_CHECK)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write the schema to this file instead of printing it.",
)
@click.option(
    "--path",
    "show_path",
    is_flag=True,
    help="Print where the installed package keeps the schema (for an editor's modeline).",
)
def schema(output: Path | None, show_path: bool) -> None:
    """Print the JSON Schema (draft-07) of the mechanism file. With an editor that runs the
    YAML language server (VS Code's YAML extension, Neovim, Helix, Emacs lsp-mode...), the
    first line

    \b
        # yaml-language-server: $schema=mechanism.schema.json

    in a mechanism file gives completion, hover help and checks of every key (the path is
    relative to the YAML file, or absolute: see --path)."""

    here = shipped_path()
    if show_path:
        click.echo(str(here))
        return
    text = here.read_text(encoding="utf-8")
    if output is None:
        click.echo(text, nl=False)
        return
    from mechsolve.base.atomic import write_text

    with writing(output):
        write_text(output, text)
    click.echo(f"wrote {output}")
