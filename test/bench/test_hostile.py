"""bench.hostile: the hostile soak's section, and what the swarm's key costs per message."""

from bench.hostile import hostile_lines, signing_costs

from .tables import check_shape


def test_the_hostile_section_counts_valid_queries_and_every_hostile_message():
    samples = [(0.0, 300.0), (5.0, 320.0)]
    counts = {"swazure: /swarm/host_0 inbound messages": {"dropped offer: forged": "9"}}
    lines = hostile_lines(600.0, (10, 0, 2), {"/swarm/radio": 1200, "/swarm/world": 30},
                          samples, counts)  # fmt: skip
    assert lines[0].endswith("malformed messages for 10 minutes")
    assert "Valid queries: 12: 10 right, 0 wrong, 2 unanswered within 120 s." in lines
    assert "Hostile messages sent: 1,230 (/swarm/radio 1,200, /swarm/world 30)." in lines
    assert "| /swarm/host_0 | dropped offer: forged | 9 |" in lines


def test_signing_costs_time_each_message_keyed_and_plain_and_a_rounds_share():
    lines = signing_costs("torus:200", count=20)
    [(header, rows)] = check_shape(lines)
    assert header[:2] == ["message", "bytes"] and len(rows) == 4
    assert all(float(cell) > 0 for row in rows for cell in row[2:])
    assert lines[-1].startswith("A round of the dragon (200 FLSs, one process) signs 200 offers")
