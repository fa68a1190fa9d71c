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
