"""The swarm's conjugate gradients: sums over the swarm, exact in any order."""

import numpy as np

from swazure_ros.core.conjugate_gradients import partial_dot, swarm_sum


def test_the_swarm_s_sums_are_the_same_in_any_order():
    rng = np.random.default_rng(4)
    one, other = rng.normal(size=(500, 3, 2)) * 1e6, rng.normal(size=(500, 3, 2))
    shares = partial_dot(one, other)
    shuffled = shares[rng.permutation(500)]
    assert swarm_sum(shares).tolist() == swarm_sum(shuffled).tolist()
