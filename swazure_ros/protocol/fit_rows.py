"""An FLS's rows of its part of the swarm's fit, and its own rows made for many FLSs at once.

A RESIDUAL round of the FIT phase (:mod:`.swarm_fit`) has each FLS weigh its
pairs for the coming solve and make its own rows of its local system: its
three rows of ``H``, its diagonal block's inverse and its right sides (its
measurements' flows, or the covariance's draws of their noise), from its
record of the fit, a :class:`FitLayer`. :func:`own_rows` makes them for one
FLS alone or for a process's FLSs at once (:mod:`.fit_together`), with the
same bits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.arrays import FloatArray, IntArray
from ..core.conjugate_gradients import Floor, Iterate, system_of
from ..core.measurement_graph import Measurements
from ..core.swarm_edges import edges_of, weighted
from ..core.swarm_fit import HUBER, REJECTING, noise_flows
from .discovery.messages import SAMPLES


@dataclass
class FitLayer:
    """One FLS's rows of one fit: its pairs' measurements over its local ids, and its solve."""

    ids: IntArray  # (L,), itself and the FLSs it measures in this fit, ascending
    slot: int  # its own place among them
    measured: Measurements  # both rows of each of its pairs, over local indices
    weights: FloatArray  # (2 x pairs,), the weights its last solve had
    position: FloatArray  # (3, 1), cm, its own x
    samples: FloatArray  # (3, K), cm, its own covariance samples
    sampling: bool = False  # the solve under way is the covariance's
    rows: Any = None  # its three rows of H (scipy.sparse CSR over the local columns)
    preconditioner: FloatArray | None = None  # (3, 3), cm^2: its diagonal block's inverse
    iterate: Iterate | None = None
    scaled: FloatArray = field(default_factory=lambda: np.zeros((3, 1)))  # u, its own
    image: FloatArray = field(default_factory=lambda: np.zeros((3, 1)))  # its row of H u
    floor: Floor | None = None  # the solve's lowest residuals, and its own x at them
    before: FloatArray = field(default_factory=lambda: np.zeros((3, 1)))  # x before the solve
    candidates: dict[int, FloatArray] = field(default_factory=dict)


#: The measured rows of the FLSs whose systems :func:`own_rows` makes in one pass. The
#: dragon's 1,147 FLSs in one pass (40,000 rows; the covariance's 64 draws, 60 MB a
#: temporary) took 6.0 s of its RESIDUAL rounds, against 4.4-4.8 s FLS by FLS: fresh
#: pages fault on this machine. 1,024 to 4,096 rows a pass took 2.9-3.1 s (2026-12-04).
ROWS_AT_ONCE = 2048


@dataclass(frozen=True)
class OwnRows:
    """An FLS's own rows of its fit's normal equations, over its local ids."""

    rows: Any  # scipy.sparse CSR (3, 3L), cm^-2: its three rows of H
    preconditioner: FloatArray  # (3, 3), cm^2: its diagonal block's inverse
    right: FloatArray  # (3, K), cm^-1: its right sides


def weigh(layer: FitLayer, mode: int) -> None:
    """Set ``layer``'s weights for a solve in ``mode`` (a RESIDUAL's), and whether it samples."""
    if mode in (HUBER, REJECTING):
        layer.weights = layer.candidates[mode]
    layer.sampling = mode == SAMPLES


def own_rows(layers: Sequence[FitLayer], samples: int) -> list[OwnRows]:
    """Each FLS's own rows of its local system for the solve its layer is weighed for.

    Each FLS's system is its own, over its local ids; the layers' systems are
    made as block-diagonal systems (each layer's indices offset past the
    last's), :data:`ROWS_AT_ONCE` measured rows a pass, and each FLS takes
    its rows from its pass's. Every step is row by row or block by block
    (edges sorted within a block, flows and noise edge by edge, sums per FLS
    in edge order, 3 x 3 inverses one by one), so an FLS's rows are, bit for
    bit, those of its system made alone: a process's FLSs made together
    (:mod:`.fit_together`) send what each sends alone.

    Parameters
    ----------
    layers : sequence of FitLayer
        Weighed (:func:`weigh`), all sampling or none.
    samples : int
        The covariance's draws, K, when sampling.

    Returns
    -------
    list of OwnRows
        In the order of ``layers``.
    """
    made: list[OwnRows] = []
    begin, held = 0, 0
    for end, layer in enumerate(layers, start=1):
        held += len(layer.measured)
        if held >= ROWS_AT_ONCE or end == len(layers):
            made += _own_rows_block(layers[begin:end], samples)
            begin, held = end, 0
    return made


def stacked(layers: Sequence[FitLayer]) -> tuple[Measurements, IntArray, IntArray]:
    """``layers``' measured rows as one block-diagonal set: each layer's local indices
    offset past the last layer's ids.

    Returns
    -------
    measured : Measurements
        Every layer's rows, layer after layer.
    bases : (F,) array of int
        Where each layer's local indices start.
    sizes : (F,) array of int
        Each layer's local ids.
    """
    sizes = np.array([len(layer.ids) for layer in layers], dtype=np.int64)
    bases = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    counts = [len(layer.measured) for layer in layers]
    offsets = np.repeat(bases, counts)
    measured = Measurements(
        np.concatenate([layer.measured.first for layer in layers]) + offsets,
        np.concatenate([layer.measured.second for layer in layers]) + offsets,
        np.concatenate([layer.measured.vectors for layer in layers]),
        np.concatenate([layer.measured.covariance for layer in layers]),
        np.concatenate([layer.measured.information for layer in layers]),
    )
    return measured, bases, sizes


def _own_rows_block(layers: Sequence[FitLayer], samples: int) -> list[OwnRows]:
    """:func:`own_rows` of ``layers``, one block-diagonal system."""
    from scipy.sparse import csr_matrix

    measured, bases, sizes = stacked(layers)
    weights = np.concatenate([layer.weights for layer in layers])
    edges = edges_of(int(sizes.sum()), measured)
    final = weighted(edges, measured, weights)
    if layers[0].sampling:
        ids = np.concatenate([layer.ids for layer in layers])
        system = system_of(final, noise_flows(final, measured, weights, samples, ids))
    else:
        system = system_of(final)
    matrix, made = system.matrix, []
    for layer, base, size in zip(layers, bases.tolist(), sizes.tolist(), strict=True):
        own = base + layer.slot
        begin, end = matrix.indptr[3 * own], matrix.indptr[3 * own + 3]
        rows = csr_matrix(
            (matrix.data[begin:end].copy(), matrix.indices[begin:end] - 3 * base,
             matrix.indptr[3 * own : 3 * own + 4] - begin),
            shape=(3, 3 * size),
        )  # fmt: skip
        made.append(OwnRows(rows, system.preconditioner[own], system.right[own]))
    return made
