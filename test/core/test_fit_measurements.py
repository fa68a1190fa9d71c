"""Which measurements a fit takes, and the outliers that test it."""

from functools import partial

import numpy as np

from swazure_ros.core.fit_measurements import fit_groups, fit_pairs, with_outliers
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.sensor import SWEET, Sensor

from .fits import exact, stochastic_sensor, torus_swarm


def test_the_fit_uses_the_sweet_hops_and_only_the_decaying_hops_that_join_parts():
    hood = neighbourhood(torus_swarm(0.3, "helix"), Sensor(6.0, 8.0, 8.0, 30.0))
    pairs = hood.pairs
    sweet_only, joined = fit_pairs(hood, links=False), fit_pairs(hood)
    assert (pairs.range_class[sweet_only] == SWEET).all() and hood.visible[joined].all()
    links = np.setdiff1d(joined, sweet_only)
    part = hood.sweet_visible.components()
    assert len(links) > 0
    assert (part[pairs.first[links]] != part[pairs.second[links]]).all()


def test_with_outliers_repeats_and_turns_by_the_angle_asked():
    measured = exact([0, 1, 2] * 30, [1, 2, 0] * 30, np.tile([[7.0, 0, 0]], (90, 1)))
    turn = partial(with_outliers, measured, 0.5, 30.0, seed=2)
    first, second = turn(), turn()
    np.testing.assert_array_equal(first.vectors, second.vectors)
    moved = (first.vectors != measured.vectors).any(axis=1)
    cosine = (first.vectors[moved] @ [1.0, 0, 0]) / 7.0
    np.testing.assert_allclose(cosine, np.cos(np.radians(30.0)))


def test_a_deterministic_sensor_s_pairs_take_two_fits_a_stochastic_one_s_one():
    sweet, rows, linked = np.array([True, False]), np.array([True, False]), np.array([True, True])
    deterministic = fit_groups(Sensor(6.0, 8.0, 8.0, 30.0), sweet, rows, linked)
    assert [(p.tolist(), r.tolist()) for p, r in deterministic] == [
        ([True, False], [True, False]),
        ([False, True], [True, True]),
    ]
    (pairs, taken), *more = fit_groups(stochastic_sensor(), sweet, rows, linked)
    assert more == [] and pairs.tolist() == [True, True] and taken.tolist() == [True, True]
