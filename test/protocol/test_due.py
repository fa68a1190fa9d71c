"""Which labels are due in a round: every row at once as each row alone, in row order."""

from __future__ import annotations

import numpy as np

from swazure_ros.protocol.discovery.due import due_places
from swazure_ros.protocol.discovery.labels import LENGTH_FIRST, LabelTable
from swazure_ros.protocol.discovery.links import Links


def _table(rows: int, sources: int) -> LabelTable:
    none = Links(np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros((0, 3)))
    return LabelTable(
        np.arange(100, 100 + rows), np.zeros(rows + 1, np.int64), none, (0, sources), sources,
        fits=False, need=sources,
    )  # fmt: skip


def _labelled(rows: int = 300, sources: int = 16) -> LabelTable:
    """Rows of a direct table, some places found at lengths 0-4 cm, some sent, one closed."""
    table = _table(rows, sources)
    assert table.direct
    rng = np.random.default_rng(7)
    found = rng.random((rows, sources)) < 0.6
    table.length[found] = np.floor(rng.random(int(found.sum())) * 5)
    table.hops[found] = 1.0
    table.sent[:] = found & (rng.random((rows, sources)) < 0.2)
    table.close(np.array([3]))
    return table


def _expected(table: LabelTable, round_: float, reach: float):
    unsent = np.isfinite(table.hops) & ~table.sent
    unsent[:, 3] = False  # closed
    due = unsent & (np.floor(table.length / 1.0) <= round_) & (np.floor(table.length) < reach)
    return np.nonzero(due), unsent.sum(axis=1), np.nonzero(unsent)


def test_every_row_s_due_labels_come_row_by_row_each_by_place():
    table = _labelled()
    rows, places, unsent, held_rows, held_places = due_places(
        table, None, LENGTH_FIRST, 1.0, 2.0, 4
    )
    (due_rows, due_at), counts, _ = _expected(table, 2.0, 4)
    assert rows.tolist() == due_rows.tolist() and places.tolist() == due_at.tolist()
    assert unsent.tolist() == counts.tolist()
    assert len(held_rows) == len(held_places) == 0  # the pass's reach is not reached


def test_at_the_reach_every_unsent_label_is_held_and_none_beyond_it_is_due():
    table = _labelled()
    rows, places, _, held_rows, held_places = due_places(table, None, LENGTH_FIRST, 1.0, 3.0, 3)
    (due_rows, due_at), _, (unsent_rows, unsent_at) = _expected(table, 3.0, 3)
    assert rows.tolist() == due_rows.tolist() and places.tolist() == due_at.tolist()
    assert held_rows.tolist() == unsent_rows.tolist()
    assert held_places.tolist() == unsent_at.tolist()


def test_one_row_alone_picks_what_it_picks_among_all():
    table = _labelled()
    every, at_every, *_ = due_places(table, None, LENGTH_FIRST, 1.0, 1.0, 4)
    for row in (0, 17, 299):
        rows, places, unsent, *_ = due_places(table, row, LENGTH_FIRST, 1.0, 1.0, 4)
        assert (rows == row).all()
        assert places.tolist() == at_every[every == row].tolist()
        assert len(unsent) == 1
