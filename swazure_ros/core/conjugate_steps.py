"""An iteration's vector work over a whole swarm at once: compiled, fused and in place.

The engine solves the swarm's conjugate gradients (:func:`.conjugate_gradients.solved`)
for every FLS at once, at a display's size 65,536 FLSs x 64 right sides: each
vector is 100 MB, and numpy's passes over them, each into a new array, cost
more than the sparse product itself (BENCHMARKS.md). These kernels do the same
arithmetic in the same order, so the same bits as
:func:`~.swarm_edges.blocks_times`, :func:`~.conjugate_gradients.partial_dot`,
the sparse product and :func:`~.conjugate_gradients.advance` (tested), in
fewer passes and into arrays the solve keeps.
"""

from __future__ import annotations

from . import jit
from .arrays import FloatArray, IntArray
from .swarm_edges import blocks_into


@jit.kernel(cache=True)
def dots_into(one: FloatArray, other: FloatArray, out: FloatArray) -> None:  # pragma: no cover
    """Each FLS's share of the K dot products of two vectors, into ``out``.

    Each axis's product added in the order numpy's sum over the axis adds
    them, (p0 + p1) + p2: the bits of
    :func:`~.conjugate_gradients.partial_dot`.

    Parameters
    ----------
    one, other : (N, 3, K) array of float
    out : (N, K) array of float
        Filled with the shares.
    """
    count, _, columns = one.shape
    for fls in range(count):
        for column in range(columns):
            out[fls, column] = (
                one[fls, 0, column] * other[fls, 0, column]
                + one[fls, 1, column] * other[fls, 1, column]
            ) + one[fls, 2, column] * other[fls, 2, column]


@jit.kernel(cache=True)
def scaled_with_shares(
    blocks: FloatArray, residual: FloatArray, scaled: FloatArray, shares: FloatArray
) -> None:  # pragma: no cover - compiled
    """U = M R by each FLS's block, and each FLS's share of (R, U), into ``scaled`` and ``shares``.

    Parameters
    ----------
    blocks : (N, 3, 3) array of float, cm^2
        Each FLS's block of M.
    residual : (N, 3, K) array of float, cm^-1
        R.
    scaled : (N, 3, K) array of float, cm
        Filled with U, as :func:`~.swarm_edges.blocks_times` gives it.
    shares : (N, K) array of float
        Filled with ``partial_dot(R, U)``.
    """
    blocks_into(blocks, residual, scaled)
    dots_into(residual, scaled, shares)


@jit.kernel(cache=True, parallel=True)
def product_into(
    starts: IntArray, columns: IntArray, values: FloatArray, vector: FloatArray, image: FloatArray
) -> None:  # pragma: no cover - compiled
    """W = H V, H in CSR, into ``image``.

    Each row of W is added up from zero over its columns in their order, as
    scipy's CSR product adds it (``csr_matvecs``), so the same bits.

    Parameters
    ----------
    starts, columns, values : arrays
        H (R, C) in CSR: ``indptr``, ``indices`` and ``data``, cm^-2.
    vector : (C, K) array of float, cm
        V.
    image : (R, K) array of float, cm^-1
        Filled with W.
    """
    count = vector.shape[1]
    # Rows on every thread: each row is its own sum, so the bits are the same.
    for row in jit.prange(image.shape[0]):
        for column in range(count):
            image[row, column] = 0.0
        for entry in range(starts[row], starts[row + 1]):
            value = values[entry]
            other = columns[entry]
            for column in range(count):
                image[row, column] += value * vector[other, column]


@jit.kernel(cache=True)
def image_with_shares(
    starts: IntArray,
    columns: IntArray,
    values: FloatArray,
    scaled: FloatArray,
    image: FloatArray,
    shares: FloatArray,
) -> None:  # pragma: no cover - compiled
    """W = H U (:func:`product_into`) and each FLS's share of (W, U), into ``image`` and
    ``shares``.

    Parameters
    ----------
    starts, columns, values : arrays
        H (3N, 3N) in CSR: ``indptr``, ``indices`` (sorted in each row) and
        ``data``, cm^-2.
    scaled : (3N, K) array of float, cm
        U, each FLS's three rows in turn.
    image : (3N, K) array of float, cm^-1
        Filled with W.
    shares : (N, K) array of float
        Filled with ``partial_dot(W, U)``.
    """
    product_into(starts, columns, values, scaled, image)
    shape = (shares.shape[0], 3, scaled.shape[1])
    dots_into(image.reshape(shape), scaled.reshape(shape), shares)


@jit.kernel(cache=True, parallel=True)
def advance_in_place(
    position: FloatArray,
    residual: FloatArray,
    search: FloatArray,
    image: FloatArray,
    scaled: FloatArray,
    scaled_image: FloatArray,
    alpha: FloatArray,
    beta: FloatArray,
) -> None:  # pragma: no cover - compiled
    """One step of every FLS, X, R, P and S overwritten by their next values.

    P = U + beta P, S = W + beta S, X = X + alpha P, R = R - alpha S: each
    entry as :func:`~.conjugate_gradients.advance` computes it.

    Parameters
    ----------
    position, residual, search, image : (N, 3, K) arrays of float
        X (cm), R (cm^-1), P (cm), S (cm^-1); overwritten.
    scaled, scaled_image : (N, 3, K) arrays of float
        U (cm) and W (cm^-1).
    alpha, beta : (K,) arrays of float
        The step lengths and conjugations.
    """
    count, _, columns = scaled.shape
    for fls in jit.prange(count):
        for axis in range(3):
            for column in range(columns):
                step, turn = alpha[column], beta[column]
                new_search = scaled[fls, axis, column] + turn * search[fls, axis, column]
                new_image = scaled_image[fls, axis, column] + turn * image[fls, axis, column]
                search[fls, axis, column] = new_search
                image[fls, axis, column] = new_image
                position[fls, axis, column] = position[fls, axis, column] + step * new_search
                residual[fls, axis, column] = residual[fls, axis, column] - step * new_image
