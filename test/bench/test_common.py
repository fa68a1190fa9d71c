"""bench.common: how a run of some sections is merged into BENCHMARKS.md."""

import errno
import socket

import pytest

from bench.common import BENCH_DOMAINS, DOMAIN_PORT_BASE, held_domains, merged, stamped


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


def test_sections_that_share_a_heading_each_replace_their_own_subsection():
    # Two sections under "## Under load": a run of either keeps the other's subsection.
    existing = (
        "# Benchmarks\n\n## Core engine\n\nengine\n\n## Under load\n\n### Slow, not dead\n\n"
        "old slow\n\n### Exits over 100 runs\n\nold exits\n\n## Swarm\n\nkept\n"
    )
    body = ["## Under load", "", "### Exits over 100 runs", "", "new exits", ""]
    fresh = [stamped(body, "stamp")]
    once = merged(existing, fresh)
    assert "old exits" not in once and "new exits" in once and "old slow" in once
    assert once.count("## Under load") == 1 and once.count("### Exits over 100 runs") == 1
    assert once.index("### Slow, not dead") < once.index("### Exits over 100 runs")
    assert once.index("## Under load") < once.index("## Swarm")
    # The stamp is the subsection's, not the shared heading's.
    assert once.index("### Exits over 100 runs") < once.index("stamp") < once.index("new exits")
    assert merged(once, fresh) == once
    # Both run at once, into a file that has neither: one heading, both subsections.
    other = stamped(["## Under load", "", "### Slow, not dead", "", "new slow", ""], "stamp 2")
    both = merged("# Benchmarks\n\n## Swarm\n\nkept\n", [other, *fresh])
    assert both.count("## Under load") == 1 and "new slow" in both and "new exits" in both


def test_a_section_of_its_own_heading_is_replaced_whole_with_its_stamp_after_the_heading():
    body = ["## Camera", "", "new text", "", "### Calibrated", "", "new table", ""]
    once = merged("## Camera\n\nold text\n\n### Gone\n\nold\n", [stamped(body, "stamp")])
    assert "old" not in once and "### Gone" not in once
    assert once.split("\n")[4:8] == ["## Camera", "", "stamp", ""]


def bound(port: int) -> socket.socket:
    holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        holder.bind(("", port))
    except OSError:
        holder.close()
        raise
    return holder


def test_the_bench_holds_its_domain_ids_as_the_tests_hold_theirs_while_it_runs():
    # An id out of DDS's range (250) that no run holds: its port alone is what is held.
    with held_domains((250,)):
        with pytest.raises(OSError) as held:
            bound(DOMAIN_PORT_BASE + 250)
        assert held.value.errno == errno.EADDRINUSE
    bound(DOMAIN_PORT_BASE + 250).close()  # let go after
    # Its own ids are the tests' kind (within 1..232).
    assert all(0 < domain <= 232 for domain in BENCH_DOMAINS)
