"""bench.replay: the replay soak's section from its queries, replays and counters."""

from bench.replay import replay_lines


def test_the_replay_section_counts_the_queries_and_replays_and_shows_only_the_drops():
    samples = [(0.0, 300.0), (5.0, 320.0), (10.0, 310.0)]
    values = {"accepted world": "3", "dropped world: replayed": "7"}
    counts = {"swazure: /swarm/host_0 inbound messages": values}
    lines = replay_lines(600.0, "1,234", (40, 0, 1), ["replayed 1,234 messages"] * 3, samples,
                         counts)  # fmt: skip
    assert lines[0].startswith("## Replay of an earlier swarm: valid queries for 10 minutes")
    assert "(1,234 messages)" in " ".join(lines)
    assert "Valid queries: 41: 40 right, 0 wrong, 1 unanswered within 120 s." in lines
    assert "Replays of the earlier swarm: 3 (replayed 1,234 messages)." in lines
    assert "| /swarm/host_0 | dropped world: replayed | 7 |" in lines
    assert not any("accepted world" in line for line in lines)
