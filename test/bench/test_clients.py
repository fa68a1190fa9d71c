"""bench.clients: what the soaks report of a running swarm's counters."""

from bench.clients import soak_counts


def test_a_soaks_counts_give_memory_and_every_counter_or_only_the_drops():
    samples = [(0.0, 300.0), (5.0, 320.0), (10.0, 310.0)]
    values = {"accepted world": "3", "dropped world: forged": "7"}
    counts = {"swazure: /swarm/host_0 inbound messages": values}
    every = soak_counts(samples, "soak.png", counts)
    assert "300 MB at the start, 310 MB at the end (max 320 MB)" in every[0]
    assert "| /swarm/host_0 | accepted world | 3 |" in every
    drops = soak_counts(samples, "soak.png", counts, dropped_only=True)
    assert "| /swarm/host_0 | dropped world: forged | 7 |" in drops
    assert not any("accepted" in line for line in drops)
