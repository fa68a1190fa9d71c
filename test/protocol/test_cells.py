"""protocol.cells: every FLS within radio reach lies in the 27 cells an FLS hears."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.neighbours import neighbour_pairs
from swazure_ros.core.sensor import SWEET
from swazure_ros.protocol.cells import (
    DECAYING_BAND,
    SWEET_BAND,
    Cells,
    Tuner,
    band_of,
    cell_name,
    radio_cells,
)
from swazure_ros.protocol.discovery.messages import PHASES


def test_a_cell_holds_its_lower_faces_not_its_upper_ones():
    cells = Cells(10.0)
    points = np.array([[0, 0, 0], [9.99, 10, -0.01], [-10, 25, 30]], dtype=float)
    assert cells.of(points).tolist() == [[0, 0, 0], [0, 1, -1], [-1, 2, 3]]


def test_around_one_cell_are_27_cells():
    around = Cells(1.0).around(np.array([[0, 0, 0]]))
    assert len(around) == 27
    assert np.abs(around).max() == 1


def test_around_two_neighbouring_cells_each_cell_once():
    assert len(Cells(1.0).around(np.array([[0, 0, 0], [1, 0, 0]]))) == 36


def test_cell_names_are_topic_tokens():
    assert cell_name((3, -1, 0)) == "c3_m1_0"
    assert cell_name(np.array([-12, 0, 7])) == "cm12_0_7"


def test_an_edge_that_is_no_number_is_refused():
    with pytest.raises(ValueError, match="cell's edge"):
        Cells(float("nan"))


def test_every_neighbour_pair_is_heard_through_the_cells(sensor):
    swarm = make_swarm(np.random.default_rng(5).uniform(0, 150, (300, 3)), radius=0.5)
    pairs = neighbour_pairs(swarm, sensor)
    assert len(pairs) > 100
    cells = radio_cells(sensor, swarm.radius)[DECAYING_BAND]
    # Cells no larger than needed: the shape spans several of them.
    assert len(np.unique(cells.of(swarm.points), axis=0)) > 8
    for first, second in zip(pairs.first[:200], pairs.second[:200]):
        one, other = swarm.points[[first]], swarm.points[[second]]
        assert cells.heard_by(one, other)[0] and cells.heard_by(other, one)[0]


def test_every_sweet_pair_is_heard_through_the_sweet_cells(sensor):
    swarm = make_swarm(np.random.default_rng(6).uniform(0, 60, (400, 3)), radius=0.5)
    pairs = neighbour_pairs(swarm, sensor)
    sweet = pairs.select(pairs.range_class == SWEET)
    assert len(sweet) > 50
    cells = radio_cells(sensor, swarm.radius)[SWEET_BAND]
    assert cells.size < radio_cells(sensor, swarm.radius)[DECAYING_BAND].size / 3
    for first, second in zip(sweet.first, sweet.second):
        one, other = swarm.points[[first]], swarm.points[[second]]
        assert cells.heard_by(one, other)[0] and cells.heard_by(other, one)[0]


def test_the_sweet_phases_travel_in_sweet_cells_the_last_in_decaying_ones():
    assert [band_of(phase) for phase in PHASES] == [SWEET_BAND, SWEET_BAND, DECAYING_BAND]


def _tuner() -> Tuner:
    # Cells of 10 cm in one band; this process hosts FLSs 1 and 2, another FLSs 5 and 7.
    return Tuner({SWEET_BAND: Cells(10.0)}, np.array([1, 2]))


IDS = np.array([1, 2, 5, 7])
POINTS = np.array([[1.0, 1, 1], [2, 2, 2], [15, 1, 1], [35, 1, 1]])  # cells x = 0, 0, 1, 3


def test_a_tuning_hears_the_cells_around_its_flss_that_hold_another_processs():
    tuning = _tuner().tune(IDS, POINTS)
    assert tuning is not None
    assert tuning.mine == {(SWEET_BAND, 0, 0, 0)}
    assert tuning.heard == {(SWEET_BAND, 1, 0, 0)}  # FLS 5's; FLS 7's cell is 3 away
    assert tuning.audible[SWEET_BAND].tolist() == [1, 2, 5]
    assert tuning.cell_of(SWEET_BAND, 2) == (SWEET_BAND, 0, 0, 0)
    assert tuning.cell_of(SWEET_BAND, 5) is None  # another process's
    # A round's senders at once: ids past its own, before them, and between.
    asked = np.array([2, 9, 1, 5, 0], dtype=np.int64)
    assert tuning.cells_of(SWEET_BAND, asked) == [
        (SWEET_BAND, 0, 0, 0), None, (SWEET_BAND, 0, 0, 0), None, None
    ]  # fmt: skip


def test_a_block_of_senders_is_grouped_by_cell_as_each_is_placed_alone():
    # Three of the process's FLSs in two cells, and two ids not its own.
    cells = {SWEET_BAND: Cells(10.0)}
    ids = np.array([1, 2, 3, 5], dtype=np.int64)
    tuning = Tuner(cells, np.array([1, 2, 3])).tune(ids, POINTS[[0, 2, 1, 3]])
    assert tuning is not None
    asked = np.array([3, 9, 2, 1, 5], dtype=np.int64)
    groups, unplaced = tuning.rows_by_cell(SWEET_BAND, asked)
    alone = tuning.cells_of(SWEET_BAND, asked)
    assert [(cell, rows.tolist()) for cell, rows in groups] == [
        ((SWEET_BAND, 0, 0, 0), [0, 3]), ((SWEET_BAND, 1, 0, 0), [2])
    ]  # fmt: skip
    assert all(alone[row] == cell for cell, rows in groups for row in rows.tolist())
    assert unplaced.tolist() == [1, 4] and alone[1] is None and alone[4] is None
    assert tuning.rows_by_cell(SWEET_BAND, np.array([9], dtype=np.int64))[0] == []


def test_moves_within_cells_change_no_tuning_and_a_move_across_one_does():
    tuner = _tuner()
    first = tuner.tune(IDS, POINTS)
    within = POINTS + np.array([0.5, 0.5, 0.5])  # every FLS stays in its cell
    assert tuner.tune(IDS, within) is None
    across = within.copy()
    across[3] = [25.0, 1, 1]  # FLS 7 comes to cell x = 2: worked out anew, still unheard
    again = tuner.tune(IDS, across)
    assert first is not None and again is not None
    assert (again.mine, again.heard) == (first.mine, first.heard)
    assert again.audible[SWEET_BAND].tolist() == [1, 2, 5]
    across[1] = [11.0, 1, 1]  # this process's FLS 2 moves to cell x = 1
    tuning = tuner.tune(IDS, across)
    assert tuning is not None
    assert tuning.mine == {(SWEET_BAND, 0, 0, 0), (SWEET_BAND, 1, 0, 0)}
    assert tuning.heard == {(SWEET_BAND, 1, 0, 0), (SWEET_BAND, 2, 0, 0)}
    assert tuning.audible[SWEET_BAND].tolist() == [1, 2, 5, 7]
    assert tuning.cell_of(SWEET_BAND, 2) == (SWEET_BAND, 1, 0, 0)


def test_a_tuning_of_a_share_is_what_its_flss_cells_and_the_others_say_one_by_one():
    rng = np.random.default_rng(3)
    points = rng.uniform(-60.0, 60.0, (400, 3))
    ids = np.arange(400) * 3  # ids are not rows
    local = ids[rng.random(400) < 0.3]
    cells = {SWEET_BAND: Cells(8.6), DECAYING_BAND: Cells(31.0)}
    tuning = Tuner(cells, local).tune(ids, points)
    assert tuning is not None
    here = np.isin(ids, local)
    for band, band_cells in cells.items():
        placed = band_cells.of(points)
        own = {tuple(cell) for cell in placed[here].tolist()}
        near = [
            any(np.abs(np.array(cell) - np.array(other)).max() <= 1 for other in own)
            for cell in placed.tolist()
        ]
        assert tuning.audible[band].tolist() == ids[near].tolist()
        assert {cell[1:] for cell in tuning.mine if cell[0] == band} == own
        others = {tuple(cell) for cell, yes in zip(placed.tolist(), near) if yes}
        others &= {tuple(cell) for cell in placed[~here].tolist()}
        assert {cell[1:] for cell in tuning.heard if cell[0] == band} == others
        row = int(np.flatnonzero(here)[0])
        assert tuning.cell_of(band, int(ids[row])) == (band, *placed[row].tolist())
