"""MkDocs hooks of the documentation site (mkdocs.yml: ``hooks``).

* The file reference (``docs/reference/file.md``) gets its tables of keys generated from
  the key table the parser and the JSON Schema read (:mod:`mechsolve.analyses.schema.reference`)
  where the page has the marker line ``<!-- generated: keys -->``: the page cannot drift.
* The benchmarks page gets ``benchmarks/README.md`` (the numbers measured on the project's
  machine) where it has ``<!-- generated: benchmarks -->``, with its picture and the raw
  output beside it, so that the numbers live in one file.
* The "Guides" section of the navigation lists the pages of ``docs/guide/``: the index
  first, then the guides in the order of ``GUIDES``, then any other page there.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# the pages document this checkout (its key table, its commands), whatever is installed
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
BENCH = ROOT / "benchmarks"
BENCH_FILES = ("work-precision.png", "results.txt")
GUIDES = (
    "dynamics-multibody.md",
    "synthesis-optimisation.md",
    "friction.md",
    "shaking-balancing.md",
    "units.md",
    "drawing.md",
)
KEYS_MARK = "<!-- generated: keys -->"
BENCH_MARK = "<!-- generated: benchmarks -->"


def on_config(config, **kwargs):
    """Fill the navigation's "Guides" section with the guide pages that exist."""
    guide = Path(config["docs_dir"]) / "guide"
    if not guide.is_dir():
        return config
    found = {p.name for p in guide.glob("*.md")}
    order = [n for n in ("index.md", *GUIDES) if n in found]
    order += sorted(found - set(order))
    for entry in config["nav"] or ():
        if isinstance(entry, dict) and "Guides" in entry:
            entry["Guides"] = [f"guide/{n}" for n in order]
    return config


def on_files(files, config, **kwargs):
    """The benchmarks' picture and raw output, beside the page that quotes them."""
    from mkdocs.structure.files import File

    for name in BENCH_FILES:
        files.append(File.generated(config, f"benchmarks/{name}", abs_src_path=str(BENCH / name)))
    return files


def on_page_markdown(markdown, page, **kwargs):
    """The generated parts of the file reference and of the benchmarks page."""
    if KEYS_MARK in markdown:
        from mechsolve.analyses.schema import reference

        markdown = markdown.replace(KEYS_MARK, reference.markdown(title=None))
    if BENCH_MARK in markdown:
        text = (BENCH / "README.md").read_text(encoding="utf-8")
        text = text.split("\n", 1)[1]  # its own title: the page has one
        for name in BENCH_FILES:  # its links point beside it
            text = re.sub(rf"\]\({re.escape(name)}\)", f"](benchmarks/{name})", text)
        # the project's history, which a reader of the site cannot see
        text = re.sub(r" \(issue \d+\)|issue \d+; ", "", text)
        text = text.replace("Seed 004's start-up", "The motor start-up (motor-linkage.yaml)")
        text = text.replace("(seed 004)", "(motor-linkage.yaml)")
        markdown = markdown.replace(BENCH_MARK, re.sub(r"^#", "##", text, flags=re.M))
    return markdown
