"""Regenerate the example outputs in README.md from real runs of the commands they show.

Each output block in the README follows a marker line ``<!-- output: NAME -->``
and is an excerpt of what ``swazure`` printed: the lines that :data:`BLOCKS`
keeps, in order, with ``...`` where lines were left out. ``--check`` runs the
same commands and exits 1 when a block no longer matches what they print, up
to the figures that differ from run to run (seconds, MB, memory); the test
suite runs it (test/test_readme.py), so the README cannot go stale unseen.

    .venv/bin/python scripts/readme_outputs.py           # rewrite README.md's blocks
    .venv/bin/python scripts/readme_outputs.py --check   # exit 1 if they are stale
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
MARKER = re.compile(r"^<!-- output: (?P<name>[\w-]+) -->$")
#: Figures that differ from run to run on one machine: times, sizes, memory, and the rounds
#: and messages of a discovery whose round restarted under load.
VOLATILE = re.compile(r"\d+(?:\.\d+)? (?:s|MB|rounds|messages)\b|\(\d+(?: \+ \d+)*\)")


@dataclass(frozen=True)
class Block:
    """One example output: the ``swazure`` arguments, and the lines kept, by their start."""

    name: str
    arguments: tuple[str, ...]
    kept: tuple[str, ...]  # a printed line is kept when it starts with one of these


#: The examples of "The two commands": make demo's three commands (Makefile).
BLOCKS = (
    Block(
        "demo-evaluate",
        ("evaluate", "--cloud", "torus", "--beta", "0.5", "--policy", "shortest-length"),
        (
            "torus: beta",
            "FLSs (removed)",
            "ordered blind pairs",
            "sweet path",
            "distance error, %",
        ),
    ),
    Block(
        "demo-spawn",
        (
            "spawn",
            "--cloud",
            "torus",
            "--beta",
            "0.5",
            "--policy",
            "shortest-length",
            "--compute-all",
            "--quiet",
        ),
        (
            "swarm up:",
            "torus: beta",
            "engine:",
            " " * 30,
            "ordered blind pairs",
            "sweet path",
            "pairs identical",
        ),
    ),
    Block(
        "demo-track",
        (
            "track",
            "--cloud",
            "config/track/trio.xyz",
            "--scale",
            "1",
            "--radius",
            "0.5",
            "--source",
            "0",
            "--target",
            "2",
            "--trajectory",
            "circle:0.5,4,-1,1,0",
            "--duration",
            "6",
            "--communication-delay",
            "0.3",
            "--every",
            "1",
        ),
        (
            "FLS 0 tracks",
            "estimator",
            "raw",
            "filtered",
            "predicted",
            "identical to the core's loop",
        ),
    ),
)


def excerpt(printed: str, kept: Sequence[str]) -> list[str]:
    """The lines of ``printed`` that start with one of ``kept``, ``...`` where lines were cut."""
    lines, skipped = [], False
    for line in printed.splitlines():
        if line.startswith(tuple(kept)):
            if skipped and lines:
                lines.append("...")
            lines.append(line.rstrip())
            skipped = False
        else:
            skipped = True
    return lines


def run(block: Block) -> list[str]:
    """Run ``swazure`` with the block's arguments; its excerpt. SystemExit if it failed."""
    done = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *block.arguments],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise SystemExit(f"readme_outputs: swazure {block.arguments[0]} failed: {tail}")
    return excerpt(done.stdout, block.kept)


def blocks_in(text: str) -> dict[str, tuple[int, int]]:
    """Each marked block in ``text``: name -> (first, end) of the lines inside its fence."""
    lines = text.splitlines()
    found = {}
    for index, line in enumerate(lines):
        match = MARKER.match(line)
        if match is None:
            continue
        if index + 1 >= len(lines) or not lines[index + 1].startswith("```"):
            raise SystemExit(f"readme_outputs: no code block after {line}")
        end = next(k for k in range(index + 2, len(lines)) if lines[k].startswith("```"))
        found[match["name"]] = (index + 2, end)
    return found


def masked(lines: Sequence[str]) -> list[str]:
    """``lines`` with the figures that differ from run to run replaced by ``#``."""
    return [VOLATILE.sub("#", line) for line in lines]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a block is stale")
    parser.add_argument("--readme", type=Path, default=README, help="the README (default ours)")
    parser.add_argument(
        "--only", nargs="+", choices=[block.name for block in BLOCKS], help="these blocks only"
    )
    args = parser.parse_args(argv)
    chosen = [block for block in BLOCKS if args.only is None or block.name in args.only]
    try:
        text = args.readme.read_text()
    except OSError as err:
        raise SystemExit(f"readme_outputs: {args.readme}: {err.strerror or err}") from None
    spans = blocks_in(text)
    missing = [block.name for block in chosen if block.name not in spans]
    if missing:
        raise SystemExit(f"readme_outputs: no marker for {', '.join(missing)} in {args.readme}")
    lines = text.splitlines()
    stale = []
    # From the last block up, so that earlier spans keep their line numbers.
    for block in sorted(chosen, key=lambda one: spans[one.name][0], reverse=True):
        first, end = spans[block.name]
        fresh = run(block)
        if masked(lines[first:end]) != masked(fresh):
            stale.append(block.name)
        lines[first:end] = fresh
    if args.check:
        if stale:
            print(f"README.md: stale output of {', '.join(sorted(stale))}", file=sys.stderr)
            return 1
        print(f"README.md: {len(chosen)} outputs match fresh runs")
        return 0
    sys.path.insert(0, str(REPO))
    from swazure_ros.core.results import atomic_write

    new = "\n".join(lines) + "\n"
    atomic_write(args.readme, lambda tmp: tmp.write_text(new))
    print(f"README.md: {len(chosen)} outputs regenerated ({len(stale)} had changed)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
