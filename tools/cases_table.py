"""Write docs/cases.md's table of case-file keys from `fsivsp.config.keys.KEYS` (between its markers).

    python tools/cases_table.py          # rewrite the table
    python tools/cases_table.py --check  # exit 1 if the page differs from KEYS (tests/config/test_keys.py does this)
"""
from __future__ import annotations

import sys
from pathlib import Path

from fsivsp.config.keys import markdown

PAGE = Path(__file__).resolve().parents[1] / "docs" / "cases.md"
BEGIN, END = "<!-- keys:begin -->\n", "\n<!-- keys:end -->"


def rendered(text: str) -> str:
    """``text`` (the page) with the table between its markers replaced by `markdown`'s."""
    head, rest = text.split(BEGIN)
    return head + BEGIN + markdown() + END + rest.split(END)[1]


if __name__ == "__main__":
    text = PAGE.read_text()
    if "--check" in sys.argv[1:]:
        sys.exit(0 if rendered(text) == text else 1)
    PAGE.write_text(rendered(text))
