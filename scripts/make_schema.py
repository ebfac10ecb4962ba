"""Regenerate the shipped JSON Schema of the mechanism file from mechsolve.model.keys.

python scripts/make_schema.py          # writes mechsolve/analyses/schema/mechanism.schema.json
python scripts/make_schema.py --check  # exit 1 if the shipped file is out of date
"""

from __future__ import annotations

import sys

from mechsolve.analyses.schema import build as schema
from mechsolve.base.atomic import write_text


def main(argv: list[str]) -> int:
    if "--check" in argv:
        same = schema.SHIPPED.exists() and schema.SHIPPED.read_text("utf-8") == schema.text()
        print(f"{schema.SHIPPED}: {'up to date' if same else 'OUT OF DATE (run this script)'}")
        return 0 if same else 1
    print(f"wrote {write_text(schema.SHIPPED, schema.text())}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
