"""Generate ``causalsplat/reason/data/knowledge.json`` from ``knowledge.toml``.

The TOML file is the knowledge table people write and review; the package reads the JSON
form (the same document, see :func:`causalsplat.reason.knowledge.knowledge_json`) because
parsing TOML is most of what loading the table costs a cold ``causalsplat ask``.

Usage::

    python scripts/make_knowledge_json.py [-o PATH]

Re-run it whenever ``knowledge.toml`` changes: a test fails while the shipped JSON does not
match the TOML. The output is deterministic.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DATA = Path(__file__).resolve().parent.parent / "causalsplat" / "reason" / "data"


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(DATA.parents[2]))
    from causalsplat.reason.knowledge import knowledge_json

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-i", "--input", type=Path, default=DATA / "knowledge.toml")
    parser.add_argument("-o", "--output", type=Path, default=DATA / "knowledge.json")
    args = parser.parse_args(argv)
    text = knowledge_json(args.input.read_text(encoding="utf-8"), source=str(args.input))
    args.output.write_text(text, encoding="utf-8")
    print(f"wrote {args.output}: {len(text.encode())} bytes", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
