"""Whether a swarm's spacing fits its sensor, why a run has no path, and the fitting scale."""

import numpy as np
import pytest

from swazure_ros.core.clouds import builtin_points
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.spacing import fitting_scale, likely_unit, run_advice, spacing_advice


def summary_of(swarm, sensor):
    return evaluate(swarm, sensor, "fewest-hops").summary


def test_a_small_shape_needs_the_scale_that_takes_it_past_its_blind_range(sensor):
    # 500 points at the published spacing span less than the sweet range's reach.
    swarm = make_swarm(builtin_points("sphere:500") / 100.0, beta=0.5)
    assert fitting_scale(swarm, sensor) == 150.0


def test_a_shape_written_in_metres_needs_a_scale_of_100(sensor):
    # Large enough that its spacing, not its size, sets the factor.
    swarm = make_swarm(builtin_points("sphere:2000") / 100.0, beta=0.5)
    assert fitting_scale(swarm, sensor) == 100.0
    assert likely_unit(100.0) == "metres"


def test_a_shape_written_in_millimetres_needs_a_tenth(sensor):
    swarm = make_swarm(builtin_points("sphere:2000") * 10.0, beta=0.5)
    assert fitting_scale(swarm, sensor) == 0.1
    assert likely_unit(0.1) == "millimetres"


def test_a_shape_at_the_published_density_fits_as_it_is(sensor):
    assert fitting_scale(make_swarm(builtin_points("sphere:2000"), beta=0.5), sensor) == 1.0
    assert likely_unit(1.0) is None


def test_the_fitting_scale_gives_a_small_torus_a_path_for_every_blind_pair(sensor):
    points = builtin_points("torus:120")
    swarm = make_swarm(points, beta=0.5)
    assert summary_of(swarm, sensor).pairs.no_path_pct == 100.0
    factor = fitting_scale(swarm, sensor)
    scaled = summary_of(make_swarm(points * factor, beta=0.5), sensor).pairs
    assert scaled.blind_pairs > 0 and scaled.no_path_pct == 0.0, factor


def test_an_explicit_radius_stays_as_the_cloud_is_scaled(sensor):
    points = builtin_points("torus:120")
    swarm = make_swarm(points, radius=0.1)
    factor = fitting_scale(swarm, sensor)
    # The radius does not grow with the cloud: a larger one, a larger factor.
    assert fitting_scale(make_swarm(points, radius=0.28), sensor) > factor
    scaled = summary_of(make_swarm(points * factor, radius=0.1), sensor).pairs
    assert scaled.blind_pairs > 0 and scaled.no_path_pct < 100.0, factor


def test_the_factor_refuses_a_swarm_of_one(sensor):
    swarm = make_swarm(builtin_points("torus:120"), beta=0.5)
    one = type(swarm)(
        swarm.points[:1], swarm.radius, swarm.dmin, swarm.beta, swarm.cloud_index[:1], 0
    )
    with pytest.raises(ValueError, match="at least 2 FLSs"):
        fitting_scale(one, sensor)


def test_a_run_whose_pairs_are_all_too_close_to_see_says_why_and_the_scale(sensor):
    swarm = make_swarm(builtin_points("torus:120") / 100.0, beta=0.5)
    advice = run_advice(summary_of(swarm, sensor), swarm, sensor)
    assert advice is not None
    assert "no pair of FLSs is a hop the sensor measures" in advice.reason
    assert advice.factor == fitting_scale(swarm, sensor) == 340.0
    # Before the run, from the geometry alone, the same.
    assert spacing_advice(swarm, sensor) == advice


def test_a_run_with_paths_has_no_advice(sensor):
    swarm = make_swarm(builtin_points("torus:120") * 5.0, beta=0.5)
    assert run_advice(summary_of(swarm, sensor), swarm, sensor) is None
    assert spacing_advice(swarm, sensor) is None


def test_a_cloud_beyond_the_sensor_s_reach_is_unreachable_and_needs_a_smaller_scale(sensor):
    swarm = make_swarm(builtin_points("cube:8") * 100.0, radius=0.5)
    summary = summary_of(swarm, sensor)
    assert summary.pairs.blind_pairs == 0
    advice = run_advice(summary, swarm, sensor)
    assert advice is not None and "unreachable" in advice.reason
    assert advice.factor is not None and advice.factor < 0.5
    assert spacing_advice(swarm, sensor) == advice


def test_a_swarm_whose_every_blind_pair_is_blocked_says_so_and_names_no_scale(sensor):
    # A filled lattice of touching FLSs: each hides the ones behind it.
    swarm = make_swarm(builtin_points("cube:216") * 3.0, beta=0.5)
    summary = summary_of(swarm, sensor)
    assert summary.pairs.blocked_pairs == summary.pairs.blind_pairs > 0
    advice = run_advice(summary, swarm, sensor)
    assert advice is not None and advice.reason.startswith("every blind pair is blocked")
    assert advice.factor is None
    assert spacing_advice(swarm, sensor) is None  # hops there are: the spacing fits


def test_a_swarm_with_no_blind_pair_says_there_is_nothing_to_compute(sensor):
    # Neighbours 7 cm apart, sweet; every other pair decaying.
    swarm = make_swarm(builtin_points("cube:27") * (7.2 / 0.65), radius=0.1)
    summary = summary_of(swarm, sensor)
    assert summary.pairs.blind_pairs == 0
    advice = run_advice(summary, swarm, sensor)
    assert advice is not None and "no pair of FLSs is blind" in advice.reason
    assert np.isclose(summary.pairs.no_path_pct, 0.0)
