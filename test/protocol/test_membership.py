"""Who takes part in a swarm's next run: departed, gone, back, and the radios to hear."""

from __future__ import annotations

from swazure_ros.protocol.membership import Membership


def own_radio(fls_id: int) -> str:
    return f"fls_{fls_id}"


def radio_fls(name: str) -> int | None:
    prefix, _, digits = name.partition("_")
    return int(digits) if prefix == "fls" and digits.isdigit() else None


def members(hosts: int, radios: set[str]) -> Membership:
    membership = Membership(hosts, own_radio=own_radio, radio_fls=radio_fls)
    membership.radios |= radios
    return membership


def test_an_fls_that_is_its_own_radio_takes_its_radio_with_it_when_gone_and_back():
    membership = members(3, {"fls_3", "fls_4", "host_0"})
    assert membership.lose({3}) == 1
    assert membership.hosts == 2 and membership.radios == {"fls_4", "host_0"}
    assert membership.departed == membership.gone == {3}
    membership.take_back({3}, in_run=False)
    assert membership.hosts == 3 and membership.departed == membership.gone == set()


def test_an_fls_of_a_packed_process_leaves_its_radio_to_the_others():
    membership = members(1, {"host_0"})
    assert membership.lose({5, 6}) == 0
    assert membership.hosts == 1 and membership.radios == {"host_0"}
    assert membership.departed == {5, 6}


def test_a_radio_speaks_for_the_flss_heard_through_it_and_the_fls_it_is():
    membership = members(2, set())
    membership.hear("host_0", [1, 2])
    membership.hear("host_0", [3])
    assert membership.voices("host_0") == {1, 2, 3}
    assert membership.voices("fls_9") == {9}
    assert membership.voices("host_1") == set()


def test_a_signed_message_made_after_the_departure_brings_its_flss_back():
    membership = members(1, {"host_0"})
    membership.hear("host_0", [1, 2])
    membership.settle([1, 2])  # a run went on without them: departed, on the graph still
    assert membership.departed == {1, 2} and membership.gone == set()
    assert membership.back_by("host_0", signed=0) == set()  # signed before: stale
    assert membership.back_by("host_0", signed=2**62) == {1, 2}
    assert membership.back_by("host_1", signed=2**62) == set()  # not their radio


def test_an_fls_gone_from_the_graph_is_not_back_by_what_its_radio_says():
    membership = members(1, {"host_0"})
    membership.hear("host_0", [1, 2])
    membership.settle([1, 2])
    membership.lose({2})
    assert membership.back_by("host_0", signed=2**62) == {1}


def test_flss_back_during_a_run_stay_out_of_its_departed_when_it_settles():
    membership = members(1, {"host_0"})
    membership.settle([4])
    membership.take_back({4}, in_run=True)
    assert membership.departed == set()
    # The run under way was made without FLS 4: its end lists it, and it stays back.
    membership.settle([4, 5])
    assert membership.departed == {5}
    # The next run's end is its own.
    membership.settle([4])
    assert membership.departed == {4}


def test_radios_seen_are_counted_up_to_the_hosts_and_never_a_gone_fls_s():
    membership = members(2, set())
    membership.lose({7})
    membership.see_radios(["fls_7", "fls_3"])
    assert membership.radios == {"fls_3"}
    membership.see_radios(["host_0", "host_1"])
    assert len(membership.radios) == 2 and "fls_3" in membership.radios
    # Known, an FLS's own radio leaves with it.
    assert membership.lose({3}) == 1 and membership.hosts == 1
