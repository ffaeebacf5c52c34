"""Tables quoted in README.md and docs/ equal the result files they come from.

A quoted table follows a line ``<!-- from: <path> -->`` (path relative to the repository root); every
line of the table must appear, in order and contiguous, in that file. Hand-pasted numbers cannot
drift from what the tool wrote.
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MARK = re.compile(r"^<!-- from: (\S+) -->\s*$")


def quoted_tables():
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        lines = doc.read_text().splitlines()
        for i, line in enumerate(lines):
            m = MARK.match(line)
            if not m:
                continue
            j = i + 1
            while j < len(lines) and not lines[j].startswith("|"):
                j += 1
            k = j
            while k < len(lines) and lines[k].startswith("|"):
                k += 1
            yield pytest.param(doc, m.group(1), lines[j:k], id=f"{doc.name}:{i + 1}")


@pytest.mark.parametrize("doc, source, table", list(quoted_tables()))
def test_quoted_table_equals_its_result_file(doc, source, table):
    path = ROOT / source
    assert path.is_file(), f"{doc.name}: quotes {source}, which does not exist"
    assert table, f"{doc.name}: no table after the marker for {source}"
    text = path.read_text().splitlines()
    starts = [i for i, ln in enumerate(text) if ln == table[0]]
    assert any(text[s : s + len(table)] == table for s in starts), f"{doc.name}: the table differs from {source}"


def test_there_are_quoted_tables():
    assert len(list(quoted_tables())) >= 3
