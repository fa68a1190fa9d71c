"""Relay choice and relayed samples (spec, section 9).

The swarm of every test: source 0 at the origin, relay 1 in its sweet range
on the x axis, and target 2, blind to the source and in the relay's sweet
range; r = 0.5 cm, so tracking distances are centre distances minus 1 cm.
"""

import numpy as np
import pytest

from swazure_ros.core.hop_errors import measured_vectors
from swazure_ros.core.relay import RELAY_OK, choose_relay, relay_sample
from swazure_ros.files.sensors import load_sensor

RADIUS = 0.5
HOME = np.array([[0.0, 0.0, 0.0], [8.0, 0.0, 0.0], [2.5, 5.5, 0.0]])


@pytest.fixture(scope="module")
def sensor():
    return load_sensor()


def test_the_relay_is_the_sweet_neighbour_that_sees_the_target(sensor):
    assert choose_relay(sensor, HOME, RADIUS, 0, 2) == 1
    # Without a relay in between, nobody sees the target for the source.
    assert choose_relay(sensor, HOME[[0, 2]], RADIUS, 0, 1) is None


def test_a_relayed_sample_is_the_sum_of_the_two_measured_hops(sensor):
    status, vector = relay_sample(sensor, HOME, RADIUS, 0, 1, 2)
    hops = measured_vectors(sensor, HOME, RADIUS, [0, 1], [1, 2])
    assert status == RELAY_OK
    assert np.allclose(vector, hops.sum(axis=0))
    status, vector = relay_sample(sensor.error_free(), HOME, RADIUS, 0, 1, 2)
    assert np.allclose(vector, HOME[2] - HOME[0])
