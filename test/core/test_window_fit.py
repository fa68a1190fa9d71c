"""A source's own fit: what it hears in its window, and the fit over it."""

import numpy as np
import pytest

from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.observe import observations
from swazure_ros.core.sensor import BLIND, DECAYING, SWEET, Sensor
from swazure_ros.core.window_fit import Heard, heard_in_window, window_fit

from .fits import torus_swarm


def test_a_source_hears_its_radio_neighbours_readings_of_each_other():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    seen = observations(hood)
    ids = np.arange(hood.swarm.size) + 1000  # FLS ids, not swarm indices
    pairs = hood.pairs
    for source in (0, 57, 199):
        mine = (pairs.first == source) | (pairs.second == source)
        radio = mine & np.isin(pairs.range_class, [BLIND, SWEET])
        others = np.where(pairs.first[radio] == source, pairs.second[radio], pairs.first[radio])
        window, heard = heard_in_window(seen, ids, source)
        assert window.tolist() == [1000 + source, *(1000 + np.sort(others)).tolist()]
        # Every reading is between window FLSs, a visible sweet or decaying pair, in both
        # directions where both FLSs are in the window.
        assert np.isin(heard.owner, window).all() and np.isin(heard.other, window).all()
        index = hood.pairs.index(heard.owner - 1000, heard.other - 1000)
        assert (index >= 0).all() and hood.visible[index].all()
        np.testing.assert_array_equal(heard.tracking, pairs.tracking[index])
        inside = np.isin(pairs.first, window - 1000) & np.isin(pairs.second, window - 1000)
        measured = inside & hood.visible & np.isin(pairs.range_class, [SWEET, DECAYING])
        assert len(heard.owner) == 2 * measured.sum()


def test_a_source_s_window_fit_of_exact_readings_gives_its_blind_neighbours_truth():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    seen = observations(hood)
    ids = np.arange(hood.swarm.size)
    points, pairs = hood.swarm.points, hood.pairs
    for source in (0, 57, 199):
        window, heard = heard_in_window(seen, ids, source)
        mine = ((pairs.first == source) | (pairs.second == source)) & (pairs.range_class == BLIND)
        targets = np.where(pairs.first[mine] == source, pairs.second[mine], pairs.first[mine])
        sweet = np.ones(len(targets), dtype=bool)
        estimate, covariance, used = window_fit(
            hood.sensor, hood.swarm.radius, window, heard, targets, sweet
        )
        joined = np.isfinite(estimate).all(axis=1)
        assert joined.mean() > 0.5 and used > 0
        np.testing.assert_allclose(
            estimate[joined], points[targets[joined]] - points[source], atol=1e-7
        )
        assert np.isfinite(covariance[joined]).all() and np.isnan(covariance[~joined]).all()


def test_a_reading_of_an_fls_out_of_the_window_is_refused():
    heard = Heard(
        np.array([10]), np.array([99]), np.array([SWEET], dtype=np.int8), np.array([6.5]),
        np.array([[7.0, 0.0, 0.0]]),
    )  # fmt: skip
    with pytest.raises(ValueError, match="FLS 99, which is not in the window"):
        window_fit(Sensor(6.0, 8.0, 8.0, 30.0), 0.5, np.array([10, 11]), heard, np.array([11]),
                   np.array([True]))  # fmt: skip
