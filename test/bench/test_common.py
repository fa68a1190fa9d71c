"""bench.common: how a run of some sections is merged into BENCHMARKS.md."""

from bench.common import merged


def test_a_section_with_two_headings_replaces_both_and_stays_once_when_run_again():
    existing = (
        "# Benchmarks\n\n## Core engine\n\nold engine\n\n## Heuristics\n\nold\n\n"
        "## Swarm\n\nkept\n"
    )
    fresh = [["## Core engine", "", "stamp", "", "new engine", "", "## Heuristics", "", "new", ""]]
    once = merged(existing, fresh)
    assert once.count("## Heuristics") == 1 and "old" not in once
    assert once.index("## Core engine") < once.index("## Heuristics") < once.index("## Swarm")
    assert "kept" in once
    assert merged(once, fresh) == once
