"""scripts/bench.py: how a run of some sections is merged into BENCHMARKS.md."""

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "bench.py"


def bench():
    spec = importlib.util.spec_from_file_location("bench", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_section_with_two_headings_replaces_both_and_stays_once_when_run_again():
    existing = (
        "# Benchmarks\n\n## Core engine\n\nold engine\n\n## Heuristics\n\nold\n\n"
        "## Swarm\n\nkept\n"
    )
    fresh = [["## Core engine", "", "stamp", "", "new engine", "", "## Heuristics", "", "new", ""]]
    once = bench().merged(existing, fresh)
    assert once.count("## Heuristics") == 1 and "old" not in once
    assert once.index("## Core engine") < once.index("## Heuristics") < once.index("## Swarm")
    assert "kept" in once
    assert bench().merged(once, fresh) == once
