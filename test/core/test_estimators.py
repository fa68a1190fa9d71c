"""Central differences of relayed samples (spec, section 9)."""

import numpy as np

from swazure_ros.core.estimators import central_differences


def test_central_differences_are_exact_for_a_parabola():
    times = np.arange(10) * 0.1
    positions = np.outer(times**2, [1.0, 0.0, -2.0]) + np.outer(times, [0.0, 3.0, 0.0])
    differences = central_differences(times, positions)
    assert np.allclose(differences.velocity_times, times[1:-1])
    assert np.allclose(
        differences.velocity, np.outer(2 * times[1:-1], [1, 0, -2]) + np.array([0, 3, 0])
    )
    assert np.allclose(differences.acceleration_times, times[2:-2])
    assert np.allclose(differences.acceleration, [2.0, 0.0, -4.0])
