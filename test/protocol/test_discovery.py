"""The distributed path search, run by the protocol's machines in memory, against the engine."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate, evaluate_pairs
from swazure_ros.core.evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    SWEET_PATH,
)
from swazure_ros.core.fit import LOCAL_LEAST_SQUARES, refine
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.hop_errors import hop_error, measured_vectors
from swazure_ros.core.neighbourhood import neighbourhood, without
from swazure_ros.core.observe import local_view, observations
from swazure_ros.core.paths import POLICIES
from swazure_ros.core.sensor import DECAYING, SWEET
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_sensor
from swazure_ros.protocol import loops
from swazure_ros.protocol.discovery import participant, together
from swazure_ros.protocol.discovery.buckets import bucket_width
from swazure_ros.protocol.discovery.estimate import (
    Found,
    Results,
    estimate,
    estimates_of,
    estimates_of_sources,
)
from swazure_ros.protocol.discovery.labels import LabelTable
from swazure_ros.protocol.discovery.messages import (
    ANY_VISIBLE,
    SWEET_ALL,
    SWEET_VISIBLE,
    Offer,
    RoundOffers,
)
from swazure_ros.protocol.discovery.reported import evaluation_of
from swazure_ros.protocol.discovery.search import PathSearch, SearchOptions, source_range
from swazure_ros.protocol.discovery.together import hear_together, pick_together
from swazure_ros.protocol.loops import RunOptions, discover
from swazure_ros.protocol.runs import next_block, next_block_size, source_blocks
from swazure_ros.sim.world import WorldSpec

from ..conftest import A, B, C, D, K, scene
from ..core.fits import stochastic_sensor


def run(hood, policy, **options):
    """One in-memory discovery run over ``hood``: {(source, target): Estimate}, and the outcome."""
    outcome = discover(
        observations(hood),
        hood.swarm.cloud_index,
        hood.sensor,
        hood.swarm.radius,
        policy,
        RunOptions(**options),
    )
    found = {(s, one.target): one for s, ones in outcome.estimates.items() for one in ones}
    return found, outcome


def test_bucket_width_is_one_hop_or_just_under_the_cheapest_hop(sensor):
    assert bucket_width(sensor, 0.5, "fewest-hops") == 1.0
    assert 6.0 - 1e-6 < bucket_width(sensor, 0.5, "shortest-length") < 6.0
    cheapest = hop_error(sensor, np.linspace(6.0, 30.0, 24_001), 0.5).min()  # near t = 7.19 cm
    assert 0.98 * cheapest < bucket_width(sensor, 0.5, "least-error") < cheapest
    with pytest.raises(ValueError, match="least-error needs a sensor whose every hop errs"):
        bucket_width(sensor.error_free(), 0.5, "least-error")


def test_least_error_refuses_a_sensor_whose_error_crosses_zero_in_its_sweet_range(sensor):
    # e(t) = 0.01 (t - 7): a sweet hop of 7 cm costs almost nothing, so a run would
    # take tens of thousands of rounds a hop (issue 36 saw 2,079 rounds).
    crossing = replace(sensor, error_coefficients=(0.01, -0.07), name="crossing")
    with pytest.raises(ValueError, match=r"would take about [\d,]+ rounds a hop"):
        bucket_width(crossing, 0.5, "least-error")
    assert bucket_width(crossing, 0.5, "shortest-length") > 0
    for calibrated in ("sensor-wide-calibrated.yaml", "sensor-standard-calibrated.yaml"):
        assert bucket_width(load_sensor(config_dir() / "cameras" / calibrated), 0.5, "least-error")


def test_scene_pairs_get_the_status_of_section_5(sensor):
    # A-C is blind; A-B-C is sweet but K blocks A-B; D is decaying to A and C.
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    found, _ = run(hood, "shortest-length")
    pair = found[(0, 2)]
    assert (pair.status, pair.reason) == (DECAYING_PATH, REASON_BLOCKED)
    assert pair.path == (0, 4, 2) and pair.radio_path == (0, 1, 2)


def test_estimate_orders_the_phases():
    hop = Found((0, 1, 2), 13.0, np.ones(3))
    assert estimate(2, hop, hop, None).status == SWEET_PATH
    assert estimate(2, None, hop, hop).reason == REASON_BLOCKED
    blocked = estimate(2, None, hop, None)
    assert (blocked.status, blocked.reason, blocked.hops) == (NO_PATH, REASON_BLOCKED, 0)
    assert estimate(2, None, None, None).reason == REASON_NO_SWEET_PATH


def test_results_hold_a_fit_s_sums_only_where_a_round_carried_them():
    def found(results, target, sums=None):
        unbiased, covariances = (None, None) if sums is None else sums
        results.add(
            np.array([target]),
            np.array([6.0]),
            np.array([0.1]),
            np.ones((1, 3)),
            (np.array([0, 2]), np.array([0, target])),
            unbiased,
            covariances,
        )

    plain = Results()
    found(plain, 5)
    found(plain, 3)
    # A run without a fit: no column of NaN for every result.
    assert sorted(plain.table) == [
        "errors",
        "lengths",
        "path_ids",
        "path_offsets",
        "targets",
        "vectors",
    ]
    assert plain.get(3).path == (0, 3) and plain.get(3).unbiased is None

    # Sums that come after a table was joined without them: the earlier results carry none.
    found(plain, 4, (np.full((1, 3), 2.0), np.eye(3)[None]))
    assert plain.table["targets"].tolist() == [3, 4, 5]
    assert plain.table["carried"].tolist() == [False, True, False]
    assert plain.get(5).covariance is None
    np.testing.assert_array_equal(plain.get(4).unbiased, [2.0, 2.0, 2.0])
    np.testing.assert_array_equal(plain.get(4).covariance, np.eye(3))


def assert_pairs_equal(found, engine, ids):
    """Every engine pair was found with the engine's status, reason, path and estimate."""
    assert len(found) == len(engine)
    for pair in range(len(engine)):
        source, target = int(ids[engine.source[pair]]), int(ids[engine.target[pair]])
        one = found[(source, target)]
        assert (one.status, one.reason) == (engine.status[pair], engine.reason[pair])
        assert one.path == tuple(int(ids[k]) for k in engine.path(pair))
        if one.status != NO_PATH:
            np.testing.assert_allclose(one.vector, engine.estimate[pair], rtol=0, atol=1e-9)
            # The labels' summed hop errors give the engine's predicted error.
            assert one.predicted_error == pytest.approx(engine.predicted_error[pair], rel=1e-9)


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("beta", [0.3, 0.5])
def test_every_pair_matches_the_engine(policy, beta):
    # torus:120 at 1.6 x has sweet, blocked and unreachable pairs at both betas.
    world = WorldSpec("torus:120", scale=1.6, beta=beta).build()
    engine = evaluate_pairs(world.hood, policy)
    assert len(engine) > 10_000 and (engine.reason == REASON_BLOCKED).sum() > 1000
    found, outcome = run(world.hood, policy)
    assert outcome.restarts == 0 and outcome.departed == frozenset()
    assert_pairs_equal(found, engine, world.ids)


def test_sources_estimating_a_few_at_a_time_match_the_engine(monkeypatch):
    # A process's sources make their estimates in blocks of so many targets at most.
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    monkeypatch.setattr(participant, "TARGETS_AT_ONCE", 1000)
    made = []
    original = participant.estimates_of_sources

    def counted(targets, *args):
        made.append(sum(len(mine) for mine in targets))
        return original(targets, *args)

    monkeypatch.setattr(participant, "estimates_of_sources", counted)
    found, _ = run(world.hood, "shortest-length")
    assert_pairs_equal(found, evaluate_pairs(world.hood, "shortest-length"), world.ids)
    assert len(made) > 5 and sum(made) == len(found)
    assert all(1000 <= count < 1000 + len(world.ids) for count in made[:-1])


@pytest.mark.parametrize("policy", POLICIES)
def test_under_a_noisy_sensor_each_hop_is_the_near_end_s_reading_as_the_engine_sums_it(policy):
    # The two FLSs of a pair read it with different draws: the swarm must sum the
    # reading of the FLS a hop starts at (spec, section 5), as the engine does.
    world = WorldSpec("torus:120", scale=2.0, beta=0.5).build()
    engine = evaluate(world.swarm, stochastic_sensor(mean_error=0.03), policy)
    found, outcome = run(engine.hood, policy)
    assert outcome.restarts == 0
    assert_pairs_equal(found, engine.pairs, world.ids)
    # The far ends' readings, reversed, sum to other numbers: the check can tell.
    swarm, sensor = engine.hood.swarm, engine.hood.sensor
    pair = int(np.flatnonzero(engine.pairs.status == SWEET_PATH)[0])
    path = np.asarray(engine.pairs.path(pair))
    far = -measured_vectors(sensor, swarm.points, swarm.radius, path[1:], path[:-1]).sum(axis=0)
    assert np.abs(far - engine.pairs.estimate[pair]).max() > 1e-6


@pytest.mark.parametrize("policy", POLICIES)
def test_evaluation_of_the_estimates_equals_the_engine(policy):
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    _, outcome = run(world.hood, policy)
    distributed = evaluation_of(world.hood, policy, outcome.estimates)
    engine = evaluate(world.swarm, world.sensor, policy)
    assert distributed.summary == replace(engine.summary, seconds=None)
    np.testing.assert_array_equal(distributed.pairs.nodes, engine.pairs.nodes)
    np.testing.assert_allclose(distributed.pairs.estimate, engine.pairs.estimate, atol=1e-9)


def test_a_silent_fls_departs_and_the_run_equals_the_engine_without_it():
    policy = "shortest-length"
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    engine = evaluate_pairs(world.hood, policy)
    # The FLS that relays the most of the engine's paths never answers.
    inner = np.concatenate([engine.path(pair)[1:-1] for pair in range(len(engine))])
    silent_index = int(np.bincount(inner.astype(np.int64)).argmax())
    silent = int(world.ids[silent_index])
    found, outcome = run(world.hood, policy, stopped=[silent])
    assert outcome.departed == frozenset({silent}) and outcome.restarts == 1
    expected = evaluate_pairs(without(world.hood, np.array([silent_index])), policy)
    keep = (expected.source != silent_index) & (expected.target != silent_index)
    ids = world.ids
    assert len(found) == int(keep.sum())
    changed = 0
    for pair in np.flatnonzero(keep).tolist():
        key = (int(ids[expected.source[pair]]), int(ids[expected.target[pair]]))
        one = found[key]
        assert (one.status, one.reason) == (expected.status[pair], expected.reason[pair])
        assert one.path == tuple(int(ids[k]) for k in expected.path(pair))
        changed += one.path != tuple(int(ids[k]) for k in engine.path(pair))
    assert changed > 0  # the silent FLS mattered


def test_on_demand_a_source_answers_for_its_one_target():
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    engine = evaluate_pairs(world.hood, "fewest-hops")
    pair = int(np.flatnonzero(engine.hops >= 2)[0])
    source, target = (int(world.ids[engine.source[pair]]), int(world.ids[engine.target[pair]]))
    found, _outcome = run(world.hood, "fewest-hops", sources=[source], targets=[target])
    assert list(found) == [(source, target)]
    assert found[(source, target)].path == tuple(int(world.ids[k]) for k in engine.path(pair))


@pytest.mark.parametrize("policy", POLICIES)
def test_runs_of_source_blocks_together_equal_the_engine(policy):
    # Every source's search is its own: three runs of a third of the sources each
    # give the one run's pairs, and each FLS keeps labels for its run's block only.
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    engine = evaluate_pairs(world.hood, policy)
    blocks = source_blocks(world.ids.tolist(), per_run=45)
    assert [len(block) for block in blocks] == [40, 40, 40]
    found = {}
    for block in blocks:
        part, outcome = run(world.hood, policy, sources=block)
        assert {source for source, _ in part} <= set(block) and outcome.restarts == 0
        found.update(part)
    assert_pairs_equal(found, engine, world.ids)


def test_a_run_tells_the_memory_its_labels_took_and_the_next_block_sized_by_it_fits():
    # A spread-out torus: a search reaches a part of the swarm. A run of 20 sources spread
    # over the ids tells what its labels took at most; a block sized by it stays within
    # the memory, and the blocks' pairs are the engine's.
    world = WorldSpec("torus:400", scale=4.0, beta=0.5).build()
    engine = evaluate_pairs(world.hood, "shortest-length")
    block, left = next_block(world.ids.tolist(), 20)
    first, outcome = run(world.hood, "shortest-length", sources=block)
    assert outcome.label_bytes > 0
    memory = 10 * outcome.label_bytes
    size = next_block_size(20, outcome.label_bytes, label_memory=memory)
    assert size == 100
    block, left = next_block(left, size)
    second, after = run(world.hood, "shortest-length", sources=block)
    assert outcome.label_bytes < after.label_bytes <= memory
    rest, _ = run(world.hood, "shortest-length", sources=left)
    assert_pairs_equal({**first, **second, **rest}, engine, world.ids)


@pytest.mark.parametrize("every", [1, 3])
def test_an_fls_keeps_labels_for_the_run_s_sources_only(every):
    # A block of consecutive ids (every 1) or spread over them (every 3rd id).
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    ids = world.ids
    view = local_view(observations(world.hood), ids, 5)
    sources = ids[10 : 10 + 10 * every : every]
    first, end = source_range(sources, int(ids[-1]) + 1)
    assert (first, end) == (int(sources[0]), int(sources[-1]) + 1)
    options = SearchOptions("shortest-length", 1.0, int(ids[-1]) + 1, sources=sources)
    search = PathSearch(view, SWEET_ALL, options)
    # A neighbour it relays from offers labels of sources inside and outside the run,
    # one of them inside its span (every 3rd id: not the run's).
    sender = int(search.links.ids[0])
    offered = np.array([int(ids[0]), first, int(ids[11]), int(ids[13]), end - 1, int(ids[60])])
    offer = Offer(
        source_ids=offered,
        hops=np.ones(6, dtype=np.int64),
        lengths=np.full(6, 7.0),
        errors=np.zeros(6),
        vectors=np.zeros((6, 3)),
        path_offsets=np.arange(0, 13, 2),
        path_ids=np.stack([offered, np.full(6, sender)], axis=1).ravel(),
    )
    search.hear(RoundOffers.of([(sender, offer)]))
    kept = (
        [first, int(ids[11]), int(ids[13]), end - 1]
        if every == 1
        else [first, int(ids[13]), end - 1]
    )
    assert search.sources.tolist() == kept
    assert source_range(None, 120) == (0, 120)


def test_an_fls_keeps_labels_only_for_the_sources_whose_search_reached_it():
    # One source of a spread-out torus, two rounds: its label has gone two hops, and no
    # FLS beyond them holds a label at all (none holds a slot per source of the swarm).
    world = WorldSpec("torus:400", scale=4.0, beta=0.5).build()
    seen, ids = observations(world.hood), world.ids
    width = bucket_width(world.sensor, world.swarm.radius, "shortest-length")
    options = SearchOptions("shortest-length", width, int(ids[-1]) + 1)
    views = [local_view(seen, ids, row) for row in range(len(ids))]
    source = 0
    searches = [
        PathSearch(view, SWEET_VISIBLE, options, view.blind if row == source else None)
        for row, view in enumerate(views)
    ]
    for round_ in range(2):
        pick_together(searches, round_, np.zeros(0, dtype=np.int64))
        offers = [one.offer(round_) for one in searches]
        hear_together(searches, RoundOffers.of(list(zip(ids.tolist(), offers, strict=True))))
    held = np.array([len(one.sources) for one in searches])
    assert set(held.tolist()) == {0, 1}  # one label at most: the one source's
    reached = np.flatnonzero(held)
    assert 1 < len(reached) < len(ids) // 2
    longest_hop = max(one.links.weights.max() for one in searches if len(one.links.weights))
    apart = np.linalg.norm(world.swarm.points[reached] - world.swarm.points[source], axis=1)
    assert apart.max() <= 2 * longest_hop + 1e-9
    # The process's one table holds no more; a row holds a few places, not one per FLS.
    table = searches[0].table
    assert table.occupied.sum() == held.sum() and table.width < len(ids) // 4


def test_a_process_makes_the_hops_its_flss_relay_from_only_once_a_label_comes():
    # SD_vis on a torus: with no source searching, no label comes and no FLS holds a hop
    # (on a display's share, tens of millions). Once one source searches, the process's
    # FLSs hold theirs: each one's sweet and decaying neighbours in sight, by id.
    world = WorldSpec("torus:120", scale=2.5, beta=0.5).build()
    seen, ids = observations(world.hood), world.ids
    width = bucket_width(world.sensor, world.swarm.radius, "shortest-length")
    options = SearchOptions("shortest-length", width, int(ids[-1]) + 1)
    views = [local_view(seen, ids, row) for row in range(len(ids))]
    for source in (None, 0):
        searches = [
            PathSearch(view, ANY_VISIBLE, options, view.blind if row == source else None)
            for row, view in enumerate(views)
        ]
        for round_ in range(2):
            pick_together(searches, round_, np.zeros(0, dtype=np.int64))
            offers = [one.offer(round_) for one in searches]
            hear_together(searches, RoundOffers.of(list(zip(ids.tolist(), offers, strict=True))))
        table = searches[0].table
        assert all(one.table is table for one in searches)
        assert table.rows_links.made == (source is not None)
    assert sum(len(one.sources) for one in searches) > 1  # the source's labels went out
    decaying = 0
    for view, one in zip(views, searches, strict=True):
        kind = view.range_class
        rows = np.flatnonzero(view.visible & ((kind == SWEET) | (kind == DECAYING)))
        assert one.links.ids.tolist() == view.other[rows].tolist()
        np.testing.assert_array_equal(one.links.weights, view.distance[rows])
        np.testing.assert_array_equal(one.links.vectors, -view.vector_at(rows))
        decaying += int(np.count_nonzero(kind[rows] == DECAYING))
    assert decaying > 0


def test_a_search_relays_nothing_beyond_its_pass_s_reach_and_names_its_source_cut_short():
    # One source of a spread-out torus, a pass that reaches two rounds: its labels go two
    # rounds' worth of hops; an FLS that holds one beyond does not send it but says so, and
    # the pass ends (nothing pending) with the source's targets, two sweet hops away, unfound.
    # The next pass, reaching twice as far, resumes the search from there and finds them.
    world = WorldSpec("torus:400", scale=4.0, beta=0.5).build()
    seen, ids = observations(world.hood), world.ids
    width = bucket_width(world.sensor, world.swarm.radius, "shortest-length")
    reach = 2
    options = SearchOptions("shortest-length", width, int(ids[-1]) + 1, reach=reach)
    views = [local_view(seen, ids, row) for row in range(len(ids))]
    source = 0
    searches = [
        PathSearch(view, SWEET_ALL, options, view.blind if row == source else None)
        for row, view in enumerate(views)
    ]
    said_beyond = np.zeros(len(ids), dtype=np.int64)

    for round_ in range(reach + 1):
        offers = [one.offer(round_) for one in searches]
        for row, offer in enumerate(offers):
            assert len(offer) == 0 or round_ < reach
            assert offer.beyond_ids.tolist() in ([], [int(ids[source])])
            assert len(offer.beyond_ids) == 0 or round_ == reach
            said_beyond[row] += len(offer.beyond_ids)
        hear_together(searches, RoundOffers.of(list(zip(ids.tolist(), offers, strict=True))))
    assert not any(offer.pending for offer in offers)
    assert 0 < said_beyond.sum() < len(ids) // 2
    assert len(searches[source].targets) > 0 and not searches[source].finished
    longest_hop = max(one.links.weights.max() for one in searches if len(one.links.weights))
    for row, one in enumerate(searches):
        if len(one.sources):  # sent below the reach, or held beyond it (said so)
            (length,) = one.label("length")
            assert (length >= reach * width) == bool(said_beyond[row])
            assert length < reach * width + longest_hop
    # The next pass: the search goes on where it paused, as one never paused would.
    for one in searches:
        one.resume(2 * reach, np.zeros(0, dtype=np.int64))
    unpaused = [
        PathSearch(
            view,
            SWEET_ALL,
            replace(options, reach=2 * reach),
            view.blind if row == source else None,
        )
        for row, view in enumerate(views)
    ]
    for round_ in range(2 * reach + 1):
        for group in (searches, unpaused):
            at = round_ - reach if group is searches else round_
            if at < 0:
                continue
            offers = [one.offer(at) for one in group]
            hear_together(group, RoundOffers.of(list(zip(ids.tolist(), offers, strict=True))))
    assert len(searches[source].results) > 0
    for name, values in unpaused[source].results.table.items():
        np.testing.assert_array_equal(searches[source].results.table[name], values)


def test_a_source_shows_a_target_out_of_reach_once_either_search_has_run_to_its_end(sensor):
    # A 5 x 5 grid 7 cm apart (sweet to its four neighbours at radius 0.5 cm) and a pendant
    # 6 cm above its middle FLS: blind to it, decaying to every other FLS, no sweet hop.
    # Their searches for each other in a pass of two rounds: the pendant's ends at once,
    # never reaching the middle FLS; the middle FLS's is cut short by the reach.
    grid = [[7.0 * x, 7.0 * y, 0.0] for x in range(5) for y in range(5)]
    swarm = make_swarm([*grid, [14.0, 14.0, 6.0]], radius=0.5)
    seen, ids = observations(neighbourhood(swarm, sensor)), np.arange(26)
    middle, pendant = 12, 25
    options = SearchOptions("shortest-length", bucket_width(sensor, 0.5, "shortest-length"), 26,
                            reach=2)  # fmt: skip
    views = [local_view(seen, ids, row) for row in range(26)]
    assert views[pendant].blind.tolist() == [middle] and views[middle].blind.tolist() == [pendant]

    def pass_zero() -> tuple[list[PathSearch], set[int]]:
        searches = [PathSearch(view, SWEET_ALL, options, view.blind) for view in views]
        cut_short = set()
        for round_ in range(3):
            offers = [one.offer(round_) for one in searches]
            cut_short.update(int(source) for offer in offers for source in offer.beyond_ids)
            hear_together(searches, RoundOffers.of(list(zip(ids.tolist(), offers, strict=True))))
        return searches, cut_short

    searches, cut_short = pass_zero()
    assert middle in cut_short and pendant not in cut_short
    assert not searches[middle].finished
    searches[middle].resume(4, np.array(sorted(set(range(26)) - cut_short)))
    assert searches[middle].finished  # the pendant's search ran to its end without it
    # Told of no search that ran to its end, the middle FLS searches on for the pendant.
    searches, _ = pass_zero()
    searches[middle].resume(4, np.zeros(0, dtype=np.int64))
    assert not searches[middle].finished


@pytest.mark.parametrize("reach", [np.inf, 3], ids=["unbounded", "three rounds"])
def test_flss_stepped_together_offer_and_end_as_each_stepping_alone_would(reach):
    # Every FLS of a small torus a source, by the rounds of a phase: one set picks its
    # labels and hears each round's offers together (as a process steps its FLSs), the
    # other one by one.
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    seen, ids = observations(world.hood), world.ids
    width = bucket_width(world.sensor, world.swarm.radius, "shortest-length")
    options = SearchOptions("shortest-length", width, int(ids[-1]) + 1, reach=reach)

    def searches() -> list[PathSearch]:
        views = [local_view(seen, ids, row) for row in range(len(ids))]
        return [PathSearch(view, SWEET_VISIBLE, options, view.blind) for view in views]

    together, alone = searches(), searches()
    cut_short = 0
    for round_ in range(12):
        pick_together(together, round_, np.zeros(0, dtype=np.int64))
        offers = [one.offer(round_) for one in together]
        for offer, theirs in zip(offers, [one.offer(round_) for one in alone], strict=True):
            assert offer.pending == theirs.pending
            for name in ("source_ids", "lengths", "vectors", "path_offsets", "path_ids",
                         "beyond_ids"):  # fmt: skip
                np.testing.assert_array_equal(getattr(offer, name), getattr(theirs, name))
        cut_short += sum(len(offer.beyond_ids) for offer in offers)
        heard = RoundOffers.of(list(zip(ids.tolist(), offers, strict=True)))
        hear_together(together, heard)
        for one in alone:
            one.hear(heard)
    assert sum(len(one.results) for one in together) > 0
    assert (cut_short > 0) == np.isfinite(reach)
    for mine, theirs in zip(together, alone, strict=True):
        np.testing.assert_array_equal(mine.sources, theirs.sources)
        for name in ("hops", "length", "pred", "sent", "via_offers", "via_link"):
            np.testing.assert_array_equal(mine.label(name), theirs.label(name))
        np.testing.assert_array_equal(mine.label("via_label"), theirs.label("via_label"))
        for name, values in mine.results.table.items():
            np.testing.assert_array_equal(values, theirs.results.table[name])
    # Their estimates made at once are those each source makes alone, found as sweet
    # (one phase's results), or as decaying with a radio path (another's).
    none = Results()
    targets = [one.targets for one in together]
    for phases in ((0, None, None), (None, 0, 0)):
        results = [tuple(none if at is None else one.results for at in phases)
                   for one in together]  # fmt: skip
        at_once = estimates_of_sources(targets, results, options.id_space, world.sensor)
        for mine, wanted, (sweet, radio, decaying) in zip(at_once, targets, results, strict=True):
            assert len(mine) == len(wanted)
            theirs = estimates_of(wanted, sweet, radio, decaying, world.sensor)
            for name in ("targets", "status", "reason", "path_offsets", "path_ids", "length",
                         "vector", "radio_offsets", "radio_ids", "predicted_error"):  # fmt: skip
                np.testing.assert_array_equal(getattr(mine, name), getattr(theirs, name))
        statuses = np.concatenate([mine.status for mine in at_once])
        assert len(np.unique(statuses)) == 2  # found and not found


@pytest.mark.parametrize("stepped", ["together", "alone"])
def test_the_sources_a_round_closes_are_closed_before_its_offers_are_relaxed(monkeypatch, stepped):
    # A ROUND names the sources finished by the offers its FLSs hear with it. No FLS
    # sends a label of those again, so relaxing the offers' labels of them would be work
    # for nothing: every table is closed to them before it relaxes, and the run still
    # equals the engine. (On the tori most searches end with their phase; on the helix
    # many end while the others go on, and the rounds that name them carry their labels.)
    world = WorldSpec("helix:150", beta=0.5).build()
    closing: list[np.ndarray | None] = [None]  # the sources the control in hand closes
    closings, relaxed, closed_heard = [0], [0], [0]

    def step(recipients, control, heard):
        closing[0] = None
        if control.command == participant.ROUND and len(control.finished) and heard:
            closed_heard[0] += int(np.isin(heard.source_ids, control.finished).sum())
            closing[0], closings[0] = control.finished, closings[0] + 1
        if stepped == "together":
            return step_together(recipients, control, heard)
        return participant.Stepped()  # each FLS on its own, as in a process of its own

    def relax_checked(relax):
        def checked(table, *args):
            if closing[0] is not None:
                assert len(table.closed) and table.closed[closing[0]].all()
                relaxed[0] += 1
            return relax(table, *args)

        return checked

    step_together = participant.step_together
    monkeypatch.setattr(loops, "step_together", step)
    monkeypatch.setattr(together, "relax_together", relax_checked(together.relax_together))
    monkeypatch.setattr(LabelTable, "relax", relax_checked(LabelTable.relax))
    found, outcome = run(world.hood, "shortest-length")
    assert closings[0] >= 2 and closed_heard[0] > 100 and relaxed[0] > 0
    assert outcome.departed == frozenset()
    assert_pairs_equal(found, evaluate_pairs(world.hood, "shortest-length"), world.ids)


@pytest.mark.parametrize("noisy", [False, True], ids=["published", "stochastic"])
def test_each_source_s_own_fit_equals_the_engine_s_window_fit(noisy):
    # torus:120 at beta 0.3 has sweet and decaying pairs, and pairs beyond a window.
    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    sensor = stochastic_sensor(mean_error=0.03) if noisy else world.sensor
    policy = "shortest-length"
    engine = refine(evaluate(world.swarm, sensor, policy), LOCAL_LEAST_SQUARES)
    hood = engine.hood
    found, outcome = run(hood, policy, estimator=LOCAL_LEAST_SQUARES)
    assert engine.summary.fit.path_fallback_pairs > 0
    pairs, ids = engine.pairs, world.ids
    assert len(found) == len(pairs)
    for pair in range(len(pairs)):
        one = found[(int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))]
        assert one.status == pairs.status[pair]
        if one.status == NO_PATH:
            assert one.covariance is None
            continue
        assert one.estimator == LOCAL_LEAST_SQUARES
        np.testing.assert_allclose(one.vector, pairs.estimate[pair], rtol=0, atol=1e-9)
        np.testing.assert_allclose(one.covariance, pairs.covariance[pair], rtol=1e-9, atol=1e-12)
    # The same run's estimates, evaluated as the engine evaluates its own.
    distributed = evaluation_of(hood, policy, outcome.estimates)
    np.testing.assert_allclose(distributed.pairs.covariance, pairs.covariance, rtol=1e-9)
    np.testing.assert_allclose(distributed.pairs.predicted_error, pairs.predicted_error, rtol=1e-9)
