"""The Markdown tables a bench section renders, read back for its smoke test."""

from __future__ import annotations


def cells(line: str) -> list[str]:
    """The cells of one table line, stripped."""
    return [cell.strip() for cell in line.split("|")[1:-1]]


def tables(lines: list[str]) -> list[tuple[list[str], list[list[str]]]]:
    """Every table in ``lines``: its column names and its rows' cells."""
    found: list[tuple[list[str], list[list[str]]]] = []
    for k, line in enumerate(lines):
        if line.startswith("| ---") and k > 0:
            found.append((cells(lines[k - 1]), []))
        elif line.startswith("|") and found and k > 0 and lines[k - 1].startswith("|"):
            found[-1][1].append(cells(line))
    return found


def check_shape(lines: list[str]) -> list[tuple[list[str], list[list[str]]]]:
    """Every table in ``lines``, after checking each row has as many cells as the header."""
    found = tables(lines)
    assert found, "no table"
    for header, rows in found:
        assert all(len(row) == len(header) for row in rows), (header, rows)
    return found
