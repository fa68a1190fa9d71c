"""The swarm's fit's edges: each measured pair as two directed edges, one into each end."""

import numpy as np
import pytest

from swazure_ros.core.swarm_edges import blocks_times, edges_of

from .fits import exact
from .interpreting import interpreted


def test_a_pair_measured_from_one_end_only_is_refused():
    with pytest.raises(ValueError, match="both ends"):
        edges_of(2, exact([0], [1], [[7.0, 0, 0]]))


def test_blocks_times_a_stack_is_the_same_bits_compiled_interpreted_and_block_by_block():
    # An FLS multiplies its one block (interpreted), the engine every FLS's (compiled).
    rng = np.random.default_rng(3)
    blocks = rng.normal(size=(40, 3, 3)) * 10.0 ** rng.integers(-8, 8, size=(40, 3, 3))
    vectors = rng.normal(size=(40, 3, 5)) * 10.0 ** rng.integers(-8, 8, size=(40, 3, 5))
    compiled = blocks_times(blocks, vectors)
    assert compiled.tobytes() == interpreted(blocks_times, blocks, vectors).tobytes()
    one_by_one = [interpreted(blocks_times, blocks[[i]], vectors[[i]]) for i in range(40)]
    assert compiled.tobytes() == np.concatenate(one_by_one).tobytes()
    assert compiled[7, 1, 2] == pytest.approx(blocks[7, 1] @ vectors[7, :, 2], rel=1e-12, abs=0)
