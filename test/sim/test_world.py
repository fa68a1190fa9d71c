"""The simulated world: one FLS's senses in a moved world equal the whole world's.

Also in a world that lays out only a share's FLSs (a process of a swarm hosting
a share): its own FLSs' rows equal the whole world's, and any other FLS is
answered the same, on demand.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from swazure_ros.core.errors import UnknownFlsError
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.observe import local_view, neighbour_sets, observations
from swazure_ros.core.sensor import BLIND, SWEET
from swazure_ros.sim.world import WorldSpec

CALIBRATED = Path(__file__).parents[2] / "config" / "cameras" / "sensor-wide-calibrated.yaml"


def every_third(spec: WorldSpec) -> list[int]:
    """A share of the world's FLS ids: one in three."""
    return spec.fls_ids()[::3].tolist()


def assert_hops_read_at_once_as_one_by_one(world, truth, rng) -> int:
    """A path walk's hops through many FLSs (a neighbour each can see, any FLS, itself),
    read at once, equal the whole world worked out afresh; how many of them were read."""
    owners = rng.choice(world.ids, size=24, replace=False).tolist()
    others = []
    for k, fls in enumerate(owners):
        rows = truth.rows(world.index(fls))
        seen = world.ids[truth.other[rows][truth.measured_in(rows)]]
        if k % 8 == 0:
            others.append(fls)  # itself: never read
        elif k % 8 == 4 or not len(seen):
            others.append(int(rng.choice(world.ids)))  # any FLS, most out of reach
        else:
            others.append(int(rng.choice(seen)))  # one it can see
    read = 0
    for fls, other, hop in zip(
        owners, others, world.hop_measurements(owners, others), strict=True
    ):
        rows = truth.rows(world.index(fls))
        asked = truth.measured_in(rows) & (world.ids[truth.other[rows]] == other)
        np.testing.assert_array_equal(hop.target_ids, world.ids[truth.other[rows]][asked])
        np.testing.assert_array_equal(hop.range_class, truth.range_class[rows][asked])
        np.testing.assert_array_equal(hop.vector, truth.vector[rows][asked])
        np.testing.assert_array_equal(hop.tracking, truth.tracking[rows][asked])
        read += len(hop.target_ids)
    return read


@pytest.mark.parametrize("share", ["whole", "share", "share's pairs only"])
@pytest.mark.parametrize("sensor_file", [None, str(CALIBRATED)], ids=["published", "stochastic"])
def test_one_fls_senses_in_a_moved_world_what_the_whole_world_computed_afresh_gives(
    sensor_file, share
):
    spec = WorldSpec("torus:120", scale=1.6, beta=0.5, sensor_file=sensor_file)
    hosted_ids = every_third(spec) if share != "whole" else None
    world = spec.build(hosted_ids=hosted_ids, only_hosted_pairs=share == "share's pairs only")
    rng = np.random.default_rng(11)
    compared = changed = asked_few = hops_read = 0
    for step in range(12):
        moved = rng.choice(world.ids, size=int(rng.integers(1, 30)), replace=False)
        home = world.home.points
        world = world.moved(
            {
                int(fls): home[world.index(int(fls))]
                + rng.normal(scale=world.swarm.radius, size=3)
                for fls in moved
            }
        )
        if step % 3 == 2:
            assert world.hood.swarm is world.swarm  # worked out whole now and then
        truth = observations(neighbourhood(world.swarm, world.sensor))
        # A generator of its own: the draws below stay those the bounds were set for.
        hops = np.random.default_rng(100 + step)
        hops_read += assert_hops_read_at_once_as_one_by_one(world, truth, hops)
        for fls in rng.choice(world.ids, size=15, replace=False).tolist():
            index = world.index(fls)
            rows = truth.rows(index)
            visible = truth.measured_in(rows)
            # First a path walk's question, the FLS's few pairs alone: measured
            # neighbours, any neighbours, the farthest FLS and itself.
            neighbour_ids = world.ids[truth.other[rows]]
            offsets = world.swarm.points - world.swarm.points[index]
            of = [
                *neighbour_ids[visible][:3].tolist(),
                *rng.choice(neighbour_ids, size=2).tolist(),
                int(world.ids[np.argmax(np.einsum("ij,ij->i", offsets, offsets))]),
                fls,
            ]
            few = world.measurement(fls, of)
            asked = visible & np.isin(world.ids[truth.other[rows]], of)
            np.testing.assert_array_equal(few.target_ids, world.ids[truth.other[rows]][asked])
            np.testing.assert_array_equal(few.range_class, truth.range_class[rows][asked])
            np.testing.assert_array_equal(few.vector, truth.vector[rows][asked])
            np.testing.assert_array_equal(few.tracking, truth.tracking[rows][asked])
            asked_few += int(asked.sum())
            measured = world.measurement(fls)
            np.testing.assert_array_equal(
                measured.target_ids, world.ids[truth.other[rows]][visible]
            )
            np.testing.assert_array_equal(measured.vector, truth.vector[rows][visible])
            np.testing.assert_array_equal(measured.tracking, truth.tracking[rows][visible])
            sets, expected = world.neighbours(fls), neighbour_sets(truth, index)
            for name in ("blind", "sweet", "visible_sweet", "visible_decaying"):
                np.testing.assert_array_equal(
                    getattr(sets, name), world.ids[getattr(expected, name)]
                )
            view, expected_view = world.view(fls), local_view(truth, world.ids, index)
            np.testing.assert_array_equal(view.other, expected_view.other)
            np.testing.assert_array_equal(view.visible, expected_view.visible)
            np.testing.assert_array_equal(view.vector, expected_view.vector)
            compared += 1
            home_rows = world.home_seen.rows(index)
            changed += int(
                not np.array_equal(world.home_seen.visible[home_rows], truth.visible[rows])
            )
    assert compared == 12 * 15 and changed > 10  # the moves did change what FLSs see
    assert asked_few > 200  # measured pairs among those asked
    assert hops_read > 50  # hops read together, not only hops out of sight
    # Back home, the world is revision 0's again.
    back = world.moved({int(fls): world.home.points[world.index(int(fls))] for fls in world.ids})
    assert back.hood is world.home_hood and back.seen is world.home_seen


def test_a_share_world_lays_out_its_own_flss_rows_only_and_they_equal_the_whole_worlds():
    spec = WorldSpec("torus:120", scale=1.6, beta=0.5)
    whole, hosted_ids = spec.build(), every_third(spec)
    share = spec.build(hosted_ids=hosted_ids)
    hosted = whole.indices(hosted_ids)
    # About a third of the rows: what a process of three holds.
    assert len(share.seen.other) == sum(len(whole.seen.other[whole.seen.rows(i)]) for i in hosted)
    assert 0.25 < len(share.seen.other) / len(whole.seen.other) < 0.42
    for index in range(whole.swarm.size):
        rows, share_rows = whole.seen.rows(index), share.seen.rows(index)
        if index in hosted:
            for name in ("other", "range_class", "visible", "vector", "tracking", "distance"):
                np.testing.assert_array_equal(
                    getattr(share.seen, name)[share_rows], getattr(whole.seen, name)[rows]
                )
        else:
            assert share_rows.start == share_rows.stop
        fls = int(whole.ids[index])
        np.testing.assert_array_equal(share.measurement(fls).vector, whole.measurement(fls).vector)


def test_a_share_world_of_its_own_pairs_holds_those_alone_and_its_rows_are_the_whole_worlds():
    # What a further process of a swarm builds: no pair between two FLSs it does not host.
    spec = WorldSpec("torus:400", scale=1.6, beta=0.5)
    whole, hosted_ids = spec.build(), every_third(spec)
    lean = spec.build(hosted_ids=hosted_ids, only_hosted_pairs=True)
    hosted = np.zeros(whole.swarm.size, dtype=bool)
    hosted[whole.indices(hosted_ids)] = True
    pairs = whole.hood.pairs
    kept = hosted[pairs.first] | hosted[pairs.second]
    # Counted: exactly the whole world's pairs that touch a hosted FLS, and far fewer.
    assert len(lean.hood.pairs) == int(kept.sum()) < 0.7 * len(pairs)
    for name in ("first", "second", "distance", "tracking", "range_class"):
        np.testing.assert_array_equal(getattr(lean.hood.pairs, name), getattr(pairs, name)[kept])
    np.testing.assert_array_equal(lean.hood.visible, whole.hood.visible[kept])
    for name in ("other", "range_class", "visible", "vector", "tracking", "distance"):
        np.testing.assert_array_equal(
            getattr(lean.seen, name), getattr(spec.build(hosted_ids=hosted_ids).seen, name)
        )
    assert lean.only_hosted_pairs and not spec.build(hosted_ids=hosted_ids).only_hosted_pairs


def test_a_share_world_lets_its_pairs_go_and_makes_the_same_again_when_an_fls_moves():
    # What a further process of a packed swarm builds: in plain discovery nothing asks for
    # its pairs once its FLSs' observations are laid out.
    spec = WorldSpec("torus:400", scale=1.6, beta=0.5)
    hosted_ids = every_third(spec)
    held = spec.build(hosted_ids=hosted_ids, only_hosted_pairs=True)
    lean = spec.build(hosted_ids=hosted_ids, only_hosted_pairs=True, pairs_on_demand=True)
    assert lean.home_neighbourhood.held is None
    fls = hosted_ids[5]
    # Its FLSs' senses and its counts come without the pairs.
    assert lean.held() == held.held()
    np.testing.assert_array_equal(lean.measurement(fls).vector, held.measurement(fls).vector)
    mine, theirs = vars(lean.neighbours(fls)), vars(held.neighbours(fls))
    for name in theirs:
        np.testing.assert_array_equal(mine[name], theirs[name])
    assert lean.home_neighbourhood.held is None
    # A move asks for them: made again, the same pairs, and the same senses after it.
    aside = {fls: held.position(fls) + np.array([0.0, 0.0, 0.4])}
    moved, moved_held = lean.moved(aside), held.moved(aside)
    for name in ("first", "second", "distance", "tracking", "range_class"):
        np.testing.assert_array_equal(
            getattr(moved.hood.pairs, name), getattr(moved_held.hood.pairs, name)
        )
    assert lean.home_neighbourhood.held is not None
    np.testing.assert_array_equal(moved.seen.other, moved_held.seen.other)
    np.testing.assert_array_equal(
        moved.measurement(fls).vector, moved_held.measurement(fls).vector
    )
    back = moved.moved({fls: held.position(fls)})
    assert back.seen is lean.home_seen and back.hood is lean.home_hood


@pytest.mark.parametrize("hosting", ["every FLS", "a share"])
def test_a_world_of_blind_and_sweet_rows_answers_as_the_whole_and_lays_out_the_rest_when_asked(
    hosting,
):
    # What a process of a display lays out: most of its rows are decaying ones, which only
    # a decaying phase's relays read.
    spec = WorldSpec("torus:400", scale=1.6, beta=0.5)
    hosted_ids = every_third(spec) if hosting == "a share" else None
    whole = spec.build(hosted_ids=hosted_ids)
    near = spec.build(
        hosted_ids=hosted_ids,
        only_hosted_pairs=True,
        pairs_on_demand=True,
        decaying_on_demand=True,
    )
    ids = spec.fls_ids() if hosted_ids is None else np.asarray(hosted_ids)
    # Counted: its FLSs' blind and sweet rows alone, without their decaying rows in sight
    # (a fifth of this small torus's; nine in ten at torus:30000, docs/swarm.md).
    near_rows = int(np.isin(whole.seen.range_class, (BLIND, SWEET)).sum())
    assert near.held().rows == len(near.seen.other) == near_rows
    assert near_rows < 0.85 * len(whole.seen.other)
    assert near.home_neighbourhood.held is None
    for fls in ids[::7].tolist():
        # The view a run starts from: the whole's blind and sweet rows, the same bits.
        mine, theirs = near.near_view(fls), whole.view(fls)
        kept = np.isin(theirs.range_class, (BLIND, SWEET))
        np.testing.assert_array_equal(mine.other, theirs.other[kept])
        np.testing.assert_array_equal(mine.range_class, theirs.range_class[kept])
        np.testing.assert_array_equal(mine.visible, theirs.visible[kept])
        np.testing.assert_array_equal(mine.distance, theirs.distance[kept])
        np.testing.assert_array_equal(mine.vector, theirs.vector[kept])
    # One FLS's answers, decaying neighbours included, without laying out the rest.
    fls = int(ids[5])
    sets, expected = vars(near.neighbours(fls)), vars(whole.neighbours(fls))
    for name in expected:
        np.testing.assert_array_equal(sets[name], expected[name])
    assert len(expected["visible_decaying"])
    assert near.measurement(fls).same_as(whole.measurement(fls))
    walked = [int(expected["visible_decaying"][0])]  # a walk's next hop, a decaying one
    assert near.measurement(fls, walked).same_as(whole.measurement(fls, walked))
    assert len(near.measurement(fls, walked).target_ids) == 1
    assert near.home_neighbourhood.full_seen is None
    # A decaying phase's view: every hosted FLS's rows laid out at once, the whole's.
    view, theirs = near.view(fls), whole.view(fls)
    for name in ("other", "range_class", "visible", "distance", "vector"):
        np.testing.assert_array_equal(getattr(view, name), getattr(theirs, name))
    assert near.home_neighbourhood.full_seen is not None
    assert near.held().rows == len(whole.seen.other) + near_rows
    # Laid out, or worked out whole anyway: no view without them is offered.
    assert near.near_view(fls) is None and whole.near_view(fls) is None


def test_a_share_of_ids_the_swarm_does_not_hold_is_refused():
    spec = WorldSpec("torus:120", scale=1.6, beta=0.5)
    with pytest.raises(UnknownFlsError, match="hosted FLSs not in this swarm"):
        spec.build(hosted_ids=[0, 10**6])


def test_every_revision_scans_line_of_sight_on_revision_0_s_cells():
    # The readings are the same on any cells (the test above compares a moved world's
    # with a neighbourhood worked out afresh); revision 0's spare measuring the spacing.
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    cell = neighbourhood(world.home, world.sensor).grid.cell
    squeezed = world.placed(world.ids[:60], 0.5 * world.swarm.points[:60])
    assert world.sight_cell == squeezed.sight_cell == cell > 0
    assert neighbourhood(squeezed.swarm, world.sensor).grid.cell != cell  # its own differs
