"""Radio cells over real DDS: two packed processes hear only the cells around their FLSs."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from swazure_ros.app.compute import compute_all
from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.share import shares
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.evaluate import evaluate, evaluate_pairs
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.heuristics.result import MOVE_OBSTRUCTING, MOVE_SOURCE
from swazure_ros.core.observe import observations
from swazure_ros.core.sensor import BLIND, SWEET
from swazure_ros.protocol.cells import BANDS, DECAYING_BAND, SWEET_BAND, radio_cells
from swazure_ros.protocol.discovery.reported import evaluation_of
from swazure_ros.protocol.runs import SHARE_LABEL_MEMORY
from swazure_ros.ros.plumbing.names import RADIO_TOPIC, WALKS_TOPIC, host_name, radio_topic
from swazure_ros.sim.world import WorldSpec

from ..waits import PATIENCE, wait_until
from .helpers import interrupt_ros2
from .programs.test_programs import ros2_tools, start  # noqa: F401
from .test_discovery import (  # noqa: F401
    assert_matches_engine,
    assert_moves_match_engine,
    by_pair,
    params,
)

# 396 FLSs on a torus 120 cm across: eight sweet cells along a diameter.
WORLD = WorldSpec("torus:400", scale=12, beta=0.3)
POLICY = "shortest-length"


def topics(band: str, cells) -> set[str]:
    return {f"/swarm/{radio_topic(band, cell)}" for cell in np.asarray(cells).reshape(-1, 3)}


def walk_topics(radio: set[str]) -> set[str]:
    """The path walks' topics of the decaying band's cells among ``radio``'s topics."""
    prefix = f"/swarm/{RADIO_TOPIC}/{DECAYING_BAND}/"
    return {
        f"/swarm/{WALKS_TOPIC}/{topic.removeprefix(prefix)}"
        for topic in radio
        if topic.startswith(prefix)
    }


def expected_topics(world_spec: WorldSpec, parts: int) -> tuple[list[set[str]], set[str]]:
    """Per share, the radio topics it must hear; and every topic some FLS sends on.

    A share hears the cells around its FLSs' that hold an FLS of another share:
    offers (and path walks) between its own FLSs never cross DDS.
    """
    assigned = world_spec.assigned()
    grids = radio_cells(world_spec.sensor(), assigned.radius)
    heard: list[set[str]] = []
    for share in shares(assigned, parts):
        mine = np.isin(assigned.cloud_index, share)
        heard.append(set())
        for band in BANDS:
            cells = grids[band]
            around = topics(band, cells.around(cells.of(assigned.points[mine])))
            heard[-1] |= around & topics(band, cells.of(assigned.points[~mine]))
    sent = {
        f"/swarm/{radio_topic(band, cell)}"
        for band in BANDS
        for cell in np.unique(grids[band].of(assigned.points), axis=0)
    }
    return heard, sent


def cell_readers(swarm: RunningSwarm, kind: str) -> tuple[list[str], dict[str, set[str]]]:
    """The cells' topics under ``/swarm/<kind>/``, and per node, those it reads."""
    node = swarm.host.host_node
    cells = [
        name for name, _ in node.get_topic_names_and_types()
        if name.startswith(f"/swarm/{kind}/")
    ]  # fmt: skip
    readers: dict[str, set[str]] = {}
    for topic in cells:
        for endpoint in node.get_subscriptions_info_by_topic(topic):
            readers.setdefault(endpoint.node_name, set()).add(topic)
    return cells, readers


def test_two_processes_hear_only_their_cells_offers_yet_equal_the_engine(domain, params):  # noqa: F811
    heard, sent = expected_topics(WORLD, 2)
    # The shape is wide enough that neither share hears every cell that carries offers.
    assert all(sent - topics for topics in heard)
    config = SwarmConfig(WORLD, processes=2, domain_id=domain, params_file=str(params))
    with RunningSwarm.start(config) as swarm:
        result = swarm.discover(POLICY)
        world = swarm.world
        engine = evaluate_pairs(world.hood, POLICY)
        assert_matches_engine(world, by_pair(result.outcome.estimates), engine)

        # What any observer of the graph sees: who reads each radio and walks topic.
        radio, readers = cell_readers(swarm, RADIO_TOPIC)
        walks, walk_readers = cell_readers(swarm, WALKS_TOPIC)
        for index in range(2):
            assert readers[host_name(index)] == heard[index], index
            assert walk_readers[host_name(index)] == walk_topics(heard[index]), index
        assert set(radio) >= sent
        assert set(walks) == walk_topics(sent)

        # The first process heard its own FLSs' offers as they were sent, and over DDS
        # some of the other process's, not all.
        radio = swarm.host.radio
        sent = result.traffic.messages[RADIO_TOPIC]
        assert 0 < radio.offers_here < sent
        assert 0 < radio.offers_heard < sent - radio.offers_here


# Every pair of this torus has a sweet path in sight: its decaying phase relays nothing.
ALL_SWEET_IN_SIGHT = WorldSpec("torus:400", scale=3, beta=0.5)


@pytest.mark.parametrize(
    "spec", [WORLD, ALL_SWEET_IN_SIGHT], ids=["decaying phase relays", "every pair sweet in sight"]
)
def test_every_process_holds_only_its_own_flss_pairs_and_rows_yet_the_run_equals_the_engine(
    domain,
    params,  # noqa: F811
    spec,
):
    # The launcher too: plain Swazure's comparison with the engine goes block by block.
    config = SwarmConfig(
        spec, processes=3, domain_id=domain, params_file=str(params), whole_world=False
    )
    with RunningSwarm.start(config) as swarm:
        computed = compute_all(swarm, POLICY)
        shares_ids = swarm.processes.shares
        held = [swarm.world.held(), *swarm.processes.held()]
        # Each share holds its own FLSs' labels: three of them hold what each of two does.
        assert swarm.label_memory == 3 * SHARE_LABEL_MEMORY
    assert computed.record.comparison is not None and computed.record.comparison.identical
    assert computed.evaluation is None  # no process held every pair's results
    world = spec.build()  # the whole swarm's, built here to count against
    engine = evaluate(world.swarm, world.sensor, POLICY).summary
    assert computed.record.summary.pairs.blind_pairs == engine.pairs.blind_pairs > 1_000
    # A decaying phase searches for the pairs without a sweet path in sight.
    assert (engine.pairs.no_sweet_path_pairs > 0) == (spec is WORLD), engine.pairs
    pairs = world.hood.pairs
    near_pair = pairs.tracking < world.sensor.sweet_max
    seen = observations(world.hood)
    rows_of = np.diff(seen.indptr)  # each FLS's rows in the whole swarm
    near_rows_of = np.bincount(  # and its blind and sweet ones
        np.repeat(np.arange(world.swarm.size), rows_of),
        weights=np.isin(seen.range_class, (BLIND, SWEET)),
        minlength=world.swarm.size,
    ).astype(int)
    assert len(held) == len(shares_ids) == 3
    decaying_laid_out = []
    for share, count in zip(shares_ids, held, strict=True):
        mine = world.indices(share)
        hosted = np.zeros(world.swarm.size, dtype=bool)
        hosted[mine] = True
        touching = hosted[pairs.first] | hosted[pairs.second]
        own_rows, own_near_rows = int(rows_of[mine].sum()), int(near_rows_of[mine].sum())
        assert count.owners == np.count_nonzero(rows_of[mine])
        # Counted: its own FLSs' rows as the whole swarm's have them, no other FLS's (a
        # share of a third holds under half the rows): the blind and sweet ones, and the
        # decaying ones once a label of the decaying phase reached one of its FLSs. And
        # exactly the whole's pairs that have an FLS of the share at one end, the
        # blind and sweet ones until the decaying ones were asked for.
        laid_out = count.rows != own_near_rows
        assert count.rows == own_near_rows + (own_rows if laid_out else 0), count
        assert own_near_rows < own_rows < 0.5 * rows_of.sum()
        assert count.pairs == int((touching if laid_out else touching & near_pair).sum())
        decaying_laid_out.append(laid_out)
    # Only where the decaying phase relays.
    assert any(decaying_laid_out) == (spec is WORLD), decaying_laid_out


def test_ros2_topic_echo_of_a_cell_shows_what_its_flss_send(ros2_tools, domain, params):  # noqa: F811
    spec = WorldSpec("torus:120", scale=1.6, beta=0.5)
    assigned = spec.assigned()
    cells = radio_cells(spec.sensor(), assigned.radius)[SWEET_BAND]
    where = cells.of(assigned.points)
    cell = where[0]
    inside = set(assigned.cloud_index[(where == cell).all(axis=1)].tolist())
    assert 0 < len(inside) < len(assigned.cloud_index)
    topic = f"/swarm/{radio_topic(SWEET_BAND, cell)}"
    config = SwarmConfig(spec, domain_id=domain, params_file=str(params), authenticate=False)
    printed: list[str] = []
    sent = 0  # offers the swarm's runs sent, over every cell

    def senders() -> list[int]:
        return [int(line) for line in list(printed) if line.strip().isdigit()]

    with RunningSwarm.start(config) as swarm:
        # A person watching one cell: its offers cross DDS because someone now reads them.
        # Every offer, as docs/protocol.md says to ask: echo's default (sensor_data) keeps
        # the last 5, so an echo that prints behind a round's burst drops offers (with
        # it, one FLS went unshown for three runs in a loaded clone's suite, 2026-12-07).
        echo = start("topic", "echo", topic, "swazure_interfaces/msg/PathOffer",
                     "--qos-reliability", "reliable", "--qos-history", "keep_all",
                     "--field", "sender_id")  # fmt: skip
        reader = threading.Thread(target=lambda: printed.extend(echo.stdout), daemon=True)
        reader.start()
        try:
            node = swarm.host.host_node
            assert wait_until(
                lambda: node.count_subscribers(topic) >= 1, PATIENCE, lambda: swarm.spin(0.1)
            )

            # The echo's reader matched to the cell's writer, not only seen: seconds on a
            # loaded machine. Matched, the writer counts every reader the graph shows.
            def matched() -> bool:
                writers = [one for one in node.publishers if one.topic_name == topic]
                readers = node.count_subscribers(topic)
                return bool(writers) and all(
                    one.get_subscription_count() >= readers for one in writers
                )

            assert wait_until(matched, PATIENCE, lambda: swarm.spin(0.1))
            # The writer's side of the match is all the graph shows: the echo's side can
            # follow a few rounds later (its reader then starts at the writer's next
            # offer), and on a loaded machine the echo prints seconds behind. So the
            # swarm runs until the echo has shown every FLS of the cell, a run at a time.
            for _ in range(6):
                sent += swarm.discover(POLICY).traffic.messages[RADIO_TOPIC]
                if wait_until(lambda: inside <= set(senders()), 30.0, lambda: swarm.spin(0.1)):
                    break
        finally:
            interrupt_ros2(echo)  # as Ctrl-C would
            reader.join(timeout=PATIENCE)
            echo.stdout.close()
    assert set(senders()) == inside, "".join(printed)[-2000:]
    assert len(senders()) <= sent


@pytest.mark.parametrize("technique", [MOVE_OBSTRUCTING, MOVE_SOURCE])
def test_moves_that_cross_cells_made_by_two_processes_equal_the_engine(domain, params, technique):  # noqa: F811
    world_spec = WorldSpec("torus:400", scale=12, beta=0.5)
    world = world_spec.build()
    engine, plan = run_technique(evaluate(world.swarm, world.sensor, POLICY), technique, 10)
    # Some moves take an FLS into another cell of each band, where it is heard from then on.
    for cells in radio_cells(world.sensor, world.swarm.radius).values():
        assert (cells.of(plan.move_from) != cells.of(plan.move_to)).any(axis=1).sum() > 50
    config = SwarmConfig(world_spec, processes=2, domain_id=domain, params_file=str(params))
    with RunningSwarm.start(config) as swarm:
        plain = swarm.discover(POLICY)
        found = evaluation_of(swarm.world.hood, POLICY, plain.outcome.estimates)
        moved = swarm.make_moves(found, technique, threshold=10, timeout=300)
        assert moved.outcome.walks == plan.resolved.sum() > 100
        assert_moves_match_engine(moved, engine, plan)
        # Walks went on from FLS to FLS of the first process, and to the other's over DDS.
        radio = swarm.host.radio
        assert radio.walks_here > 0 and radio.walks_sent > 0, (radio.walks_here, radio.walks_sent)
