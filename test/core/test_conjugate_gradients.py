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


def test_a_sparse_product_on_every_thread_is_scipy_s_to_the_bit():
    from scipy.sparse import random as sparse_random

    from swazure_ros.core.conjugate_gradients import sparse_times

    rng = np.random.default_rng(11)
    # Rectangular, as a process's rows of H over the values it heard; entries and values
    # spread over twelve decades, so that any other order of the sums shows in the bits.
    matrix = sparse_random(300, 420, density=0.05, format="csr", random_state=3)
    matrix.data *= 10.0 ** rng.integers(-6, 6, size=matrix.nnz)
    for columns in (1, 5):
        vector = rng.normal(size=(420, columns)) * 10.0 ** rng.integers(-6, 6, (420, columns))
        assert sparse_times(matrix, vector).tobytes() == np.asarray(matrix @ vector).tobytes()
        wide = matrix.copy()
        wide.indptr, wide.indices = wide.indptr.astype(np.int64), wide.indices.astype(np.int64)
        assert sparse_times(wide, vector).tobytes() == np.asarray(matrix @ vector).tobytes()
    # Rows of H with no entry (an FLS that heard none): zeros.
    empty = matrix[:0].copy()
    assert sparse_times(empty, vector).shape == (0, 5)
