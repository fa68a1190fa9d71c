"""The swarm's conjugate gradients: its sums in any order, its steps compiled or not."""

import numpy as np

from swazure_ros.core.conjugate_gradients import Iterate, advance, partial_dot
from swazure_ros.core.exact_sums import swarm_sum

from .interpreting import interpreted


def test_the_swarm_s_sums_are_the_same_in_any_order():
    rng = np.random.default_rng(4)
    one, other = rng.normal(size=(500, 3, 2)) * 1e6, rng.normal(size=(500, 3, 2))
    shares = partial_dot(one, other)
    shuffled = shares[rng.permutation(500)]
    assert swarm_sum(shares).tolist() == swarm_sum(shuffled).tolist()


def test_an_iteration_s_dots_and_steps_are_the_same_bits_compiled_and_interpreted():
    # A process of FLSs steps them together compiled; an FLS of its own, interpreted.
    rng = np.random.default_rng(8)

    def vector():
        return rng.normal(size=(30, 3, 4)) * 10.0 ** rng.integers(-6, 6, size=(30, 3, 4))

    iterate = Iterate(vector(), vector(), vector(), vector(), rng.random(4), rng.random(4))
    scaled, image = vector(), vector()
    gamma, alpha, beta = rng.random(4), rng.random(4), rng.random(4)
    for one, other in ((scaled, image), (iterate.residual[::-1], scaled)):
        assert partial_dot(one, other).tobytes() == (
            interpreted(partial_dot, one, other).tobytes()
        )
    compiled = advance(iterate, scaled, image, gamma, alpha, beta)
    python = interpreted(advance, iterate, scaled, image, gamma, alpha, beta)
    for name in ("position", "residual", "search", "image"):
        assert getattr(compiled, name).tobytes() == getattr(python, name).tobytes(), name
    assert compiled.search[2, 1, 3] == scaled[2, 1, 3] + beta[3] * iterate.search[2, 1, 3]
