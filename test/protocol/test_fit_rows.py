"""An FLS's own rows of its fit: made for many FLSs in one pass, the bits of each alone."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.conjugate_gradients import system_of
from swazure_ros.core.measurement_graph import Measurements
from swazure_ros.core.swarm_edges import edges_of, weighted
from swazure_ros.core.swarm_fit import HUBER, UNIT, noise_flows
from swazure_ros.protocol import fit_rows
from swazure_ros.protocol.discovery.messages import SAMPLES
from swazure_ros.protocol.fit_rows import FitLayer, own_rows, weigh


def star(fls_id: int, neighbours: list[int], seed: int) -> FitLayer:
    """FLS ``fls_id``'s layer: each neighbour measured from both ends (hop vectors about
    5 cm, made-up covariances), with made-up Huber weights."""
    rng = np.random.default_rng(seed)
    ids = np.array(sorted([fls_id, *neighbours]), dtype=np.int64)
    slot = int(np.searchsorted(ids, fls_id))
    local = np.searchsorted(ids, neighbours)
    mine = np.full(len(local), slot)
    first, second = np.concatenate([mine, local]), np.concatenate([local, mine])
    vectors = rng.normal(0.0, 5.0, (len(first), 3))
    roots = rng.normal(0.0, 0.3, (len(first), 3, 3)) + np.eye(3)
    covariance = roots @ np.swapaxes(roots, 1, 2)
    measured = Measurements(first, second, vectors, covariance, np.linalg.inv(covariance))
    layer = FitLayer(ids, slot, measured, np.ones(len(first)), np.zeros((3, 1)),
                     np.zeros((3, 0)))  # fmt: skip
    layer.candidates = {HUBER: rng.uniform(0.2, 1.0, len(first))}
    return layer


@pytest.mark.parametrize("mode", [UNIT, HUBER, SAMPLES])
@pytest.mark.parametrize("at_once", [fit_rows.ROWS_AT_ONCE, 7])
def test_rows_made_together_are_each_fls_s_rows_made_alone(monkeypatch, mode, at_once):
    monkeypatch.setattr(fit_rows, "ROWS_AT_ONCE", at_once)
    layers = [star(4, [1, 9, 12], 1), star(9, [4], 2), star(2, [], 3), star(12, [4, 7, 30, 31], 4)]
    for layer in layers:
        weigh(layer, mode)
    together = own_rows(layers, samples=8)
    for layer, made in zip(layers, together, strict=True):
        [alone] = own_rows([layer], samples=8)
        # Alone: the FLS's rows of the core's system of its measurements, as weighed.
        final = weighted(edges_of(len(layer.ids), layer.measured), layer.measured, layer.weights)
        flows = noise_flows(final, layer.measured, layer.weights, 8, layer.ids)
        system = system_of(final, flows if mode == SAMPLES else None)
        own = slice(3 * layer.slot, 3 * layer.slot + 3)
        np.testing.assert_array_equal(alone.rows.toarray(), system.matrix[own].toarray())
        np.testing.assert_array_equal(alone.preconditioner, system.preconditioner[layer.slot])
        np.testing.assert_array_equal(alone.right, system.right[layer.slot])
        assert made.rows.shape == alone.rows.shape == (3, 3 * len(layer.ids))
        for name in ("data", "indices", "indptr"):
            np.testing.assert_array_equal(getattr(made.rows, name), getattr(alone.rows, name))
        np.testing.assert_array_equal(made.preconditioner, alone.preconditioner)
        np.testing.assert_array_equal(made.right, alone.right)
        assert made.right.shape == (3, 8 if mode == SAMPLES else 1)
    # An FLS with no pair keeps the identity: its unknowns stay put.
    np.testing.assert_array_equal(together[2].preconditioner, np.eye(3))
    # The rows are the FLS's own: its diagonal block's inverse is its preconditioner.
    first = together[0]
    slot = layers[0].slot
    block = first.rows.toarray()[:, 3 * slot : 3 * slot + 3]
    np.testing.assert_allclose(np.linalg.inv(block), first.preconditioner, rtol=1e-12)
