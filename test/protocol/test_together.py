"""A process's FLSs stepped together: one table from their start, its rows relaxed on its
cores as in one call."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.observe import local_view, observations
from swazure_ros.protocol.discovery.buckets import bucket_width
from swazure_ros.protocol.discovery.labels import LENGTH_FIRST, HeardLabels, LabelTable
from swazure_ros.protocol.discovery.links import Links
from swazure_ros.protocol.discovery.messages import SWEET_VISIBLE, RoundOffers
from swazure_ros.protocol.discovery.search import PathSearch, SearchOptions
from swazure_ros.protocol.discovery.together import (
    PARALLEL_ROWS,
    hear_together,
    open_labels,
    pick_together,
    relax_together,
)
from swazure_ros.sim.world import WorldSpec

SOURCES = 40  # the run's sources are ids 0..39; the FLSs are 1000.., the senders 2000..


def direct_table(flss, sources=None, need=None):
    """FLS 1000 + k relays from senders 2000 + k % 10 and 2000 + 3k % 10, hop 5 + (k % 7) / 2;
    the run's sources are ``sources`` (sorted ids), or every id below SOURCES; rows of
    ``need`` labels (default: a slot per source)."""
    own = [sorted({2000 + k % 10, 2000 + 3 * k % 10}) for k in range(flss)]
    ids = np.array([sender for one in own for sender in one], dtype=np.int64)
    weights = np.concatenate([np.full(len(one), 5 + (k % 7) / 2) for k, one in enumerate(own)])
    return LabelTable(
        np.arange(1000, 1000 + flss),
        np.concatenate([[0], np.cumsum([len(one) for one in own])]).astype(np.int64),
        Links(ids, weights, np.zeros(len(ids)), np.zeros((len(ids), 3))),
        (0, SOURCES),
        SOURCES,
        fits=False,
        need=need or (SOURCES if sources is None else len(sources)),
        sources=sources,
    )


def offers(shift):
    """Sender 2000 + j offers 20 sources from 8 (j % 5) on, each (j + shift) % 3 + 1 cm long:
    equal costs through several senders, which the smallest sender id wins."""
    senders = np.arange(2000, 2010)
    sources = [np.arange(8 * (j % 5), min(8 * (j % 5) + 20, SOURCES)) for j in range(10)]
    lengths = [np.full(len(one), (j + shift) % 3 + 1.0) for j, one in enumerate(sources)]
    total = sum(len(one) for one in sources)
    return HeardLabels(
        senders,
        np.concatenate([[0], np.cumsum([len(one) for one in sources])]).astype(np.int64),
        np.concatenate(sources),
        np.ones(total, dtype=np.int64),
        np.concatenate(lengths),
        np.zeros(total),
    )


@pytest.mark.parametrize("closed", [[], [0, 9, 17, 39]], ids=["open", "four closed"])
@pytest.mark.parametrize("flss", [3, 3 * PARALLEL_ROWS], ids=["few", "many"])
def test_a_process_s_rows_relaxed_on_its_cores_change_as_one_call_changes_them(flss, closed):
    # With sources closed, their labels are dropped before the rows are relaxed
    # (open_labels), and each change still names its label among those heard.
    shared, alone = direct_table(flss), direct_table(flss)
    for table in (shared, alone):
        table.close(np.array(closed, dtype=np.int64))
    assert shared.direct  # a slot per source: the layout relaxed on the cores
    rows = np.arange(flss, dtype=np.int64)
    changed = 0
    for shift in range(3):  # later rounds better some labels and leave the rest
        starts, changes = relax_together(shared, rows, LENGTH_FIRST, offers(shift))
        expected_starts, expected = alone.relax(rows, LENGTH_FIRST, offers(shift))
        np.testing.assert_array_equal(starts, expected_starts)
        for mine, theirs in zip(changes, expected, strict=True):
            np.testing.assert_array_equal(mine, theirs)
        changed += len(changes.places)
    assert changed > flss  # every row changed, some more than once
    assert not shared.found()[:, closed].any()  # a direct row: a source's place is its id
    for name in ("hops", "length", "pred"):
        np.testing.assert_array_equal(getattr(shared, name), getattr(alone, name))


@pytest.mark.parametrize("need", [None, 1], ids=["slots", "a hash widened"])
@pytest.mark.parametrize("flss", [3, 3 * PARALLEL_ROWS], ids=["few", "many"])
def test_a_spread_run_s_labels_are_the_whole_run_s_for_its_sources_in_their_slots(flss, need):
    # Sources 1, 3, 5, ..., 39: each label goes to its source's rank among them, and a
    # label of any other id is no label of the run's; a hash (its rows widen to a slot per
    # source as labels come) keeps the same labels.
    run = np.arange(1, SOURCES, 2)
    spread, whole = direct_table(flss, run, need), direct_table(flss)
    assert spread.direct is (need is None)
    assert (spread.slots is None) is (need is not None)  # a hash keeps no slot for every id
    rows = np.arange(flss, dtype=np.int64)
    for shift in range(3):
        relax_together(spread, rows, LENGTH_FIRST, offers(shift))
        relax_together(whole, rows, LENGTH_FIRST, offers(shift))
    assert spread.direct and spread.width == len(run)
    for name in ("hops", "length", "pred"):
        np.testing.assert_array_equal(getattr(spread, name), getattr(whole, name)[:, run])
    assert np.isfinite(spread.length).any(axis=0).all()  # every source of the run heard
    np.testing.assert_array_equal(spread.sources_of(rows, np.arange(len(run))), run)


def test_the_labels_of_closed_sources_are_dropped_and_the_rest_keep_their_senders():
    heard = offers(0)
    kept_heard, kept = open_labels(heard, np.zeros(0, dtype=bool))
    assert kept_heard is heard and kept is None  # nothing closed: the labels themselves
    closed = np.zeros(SOURCES, dtype=bool)
    closed[8:16] = True  # sender 2000's labels are sources 0..19, sender 2005's too
    kept_heard, kept = open_labels(heard, closed)
    np.testing.assert_array_equal(kept_heard.source_ids, heard.source_ids[kept])
    assert not closed[kept_heard.source_ids].any()
    assert len(kept) == len(heard.source_ids) - closed[heard.source_ids].sum()
    for sender in range(len(heard.senders)):
        mine = slice(kept_heard.starts[sender], kept_heard.starts[sender + 1])
        theirs = heard.source_ids[heard.starts[sender] : heard.starts[sender + 1]]
        np.testing.assert_array_equal(kept_heard.source_ids[mine], theirs[~closed[theirs]])
        np.testing.assert_array_equal(kept_heard.lengths[mine], heard.lengths[kept[mine]])


@pytest.mark.parametrize("fits", [False, True], ids=["paths", "fitting"])
def test_flss_that_start_a_phase_together_share_one_table_and_label_as_alone(fits, monkeypatch):
    # torus:120 spread out, every third FLS a source. Started together, the process's FLSs
    # hold no table until their first step, then one, made for them (no table of their own
    # merged): each source's row holds its own label at no cost, through itself. Four
    # rounds on, every FLS's labels and every source's results are those of the same
    # searches stepped one by one, each in a table of its own.
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    seen, ids = observations(world.hood), world.ids
    width = bucket_width(world.sensor, world.swarm.radius, "shortest-length")
    fit = (world.sensor, world.swarm.radius) if fits else None
    options = SearchOptions("shortest-length", width, int(ids[-1]) + 1, fit=fit)
    views = [local_view(seen, ids, row) for row in range(len(ids))]

    def started() -> list[PathSearch]:
        return [
            PathSearch(view, SWEET_VISIBLE, options, view.blind if row % 3 == 0 else None)
            for row, view in enumerate(views)
        ]

    together_, alone = started(), started()
    assert all(one.fresh for one in together_)
    merges, merged = [], LabelTable.merged.__func__
    counted = classmethod(lambda cls, parts: merges.append(len(parts)) or merged(cls, parts))
    monkeypatch.setattr(LabelTable, "merged", counted)
    for round_ in range(4):
        pick_together(together_, round_, np.zeros(0, dtype=np.int64))
        if round_ == 0:
            table = together_[0].table
            assert table.size == len(ids)
            assert all(one.table is table and one.row == row for row, one in enumerate(together_))
            for row, one in enumerate(together_):
                assert one.sources.tolist() == ([int(ids[row])] if row % 3 == 0 else [])
                if row % 3 == 0:
                    assert one.label("length").tolist() == [0.0]
                    assert one.label("pred").tolist() == [int(ids[row])]
        for group in (together_, alone):
            offers = [one.offer(round_) for one in group]
            heard = RoundOffers.of(list(zip(ids.tolist(), offers, strict=True)))
            if group is together_:
                hear_together(group, heard)
            else:
                for one in group:
                    one.hear(heard)
    assert not merges  # the together run's one table was made whole, never merged
    assert len({id(one.table) for one in alone}) == len(ids)
    assert sum(len(one.results) for one in together_) > 0
    for shared, own in zip(together_, alone, strict=True):
        assert shared.sources.tolist() == own.sources.tolist()
        for name in ("hops", "length", "error", "pred", "sent"):
            np.testing.assert_array_equal(shared.label(name), own.label(name))
        for name, values in own.results.table.items():
            np.testing.assert_array_equal(shared.results.table[name], values)
