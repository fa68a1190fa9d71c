"""A process's FLSs solving together: the FIT phase's rounds, each at once for all of them.

A solve of the swarm's fit (:mod:`.swarm_fit`) is hundreds of rounds that
alternate SUMS (each FLS's row of ``H u`` from its neighbours' ``u``, and its
shares of two dot products) and STEP (each FLS's conjugate-gradient step from
the swarm's sums). Stepped one FLS at a time, each round costs a process a
Python call per FLS. :func:`fit_together` does the round for a process's FLSs
at once: their rows of ``H`` stacked in one sparse matrix over the values
heard, their iterates stacked as the engine stacks the swarm's
(:mod:`~swazure_ros.core.conjugate_gradients`). Each FLS's offer is a row
of what the round returns (:class:`FitRows`, which the process's radio keeps
as one block), and it is, bit for bit, what stepping it alone gives: the
same entries of ``H`` summed in the same order, and the same elementwise
arithmetic (``core.swarm_edges.blocks_times`` gives one block's bits for a
stack too). A RESIDUAL round, where each FLS makes its own rows of its local
system and starts its solve, makes every FLS's system in one block-diagonal
pass (:func:`~.fit_rows.own_rows`), with the same bits; a WEIGH round weighs
every FLS's pairs in one pass over their rows stacked. In the other rounds
(LABELS, POSITIONS, SHARE) each FLS steps alone, from what the process read
for all of them at once (:func:`take_together`).

While a solve is stepped together its state lives in one :class:`Solve`; the
FLSs' own records (:class:`~.swarm_fit.FitPart`) get it back when a round
of another stage comes, or the process's FLSs change (:func:`settle`).
Anything unusual (an offer of another size, an FLS that heard no neighbour, a
round whose offers carry labels or readings) is left to each FLS alone.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from dataclasses import dataclass
from operator import attrgetter
from typing import Any, NamedTuple

import numpy as np

from ..core import csr
from ..core.arrays import FloatArray, IntArray
from ..core.conjugate_gradients import (
    Floor,
    Iterate,
    advance,
    partial_dot,
    scalars,
    sparse_times,
)
from ..core.swarm_edges import blocks_times
from ..core.swarm_fit import weights_for
from .discovery.messages import RESIDUAL, STEP, SUMS, WEIGH, FitStep, RoundOffers
from .fit_rows import FitLayer, own_rows, stacked
from .swarm_fit import NOTHING_HEARD, WEIGHED, FitPart


@dataclass
class Solve:
    """The solve under way at F FLSs of one process, stacked in their order.

    ``matrix`` holds their rows of ``H`` (3F rows) over the values an
    iteration reads: the U ids ``others`` (what was heard from each), then
    each FLS's own value (column block U + f), so that an FLS whose own offer
    the process did not hear still reads its own.
    """

    parts: list[FitPart]
    layers: list[FitLayer]
    matrix: Any  # scipy.sparse CSR (3F, 3(U + F))
    others: IntArray  # (U,), sorted
    preconditioner: FloatArray  # (F, 3, 3), cm^2
    iterate: Iterate  # (F, 3, K) each
    scaled: FloatArray  # (F, 3, K), cm: u
    image: FloatArray  # (F, 3, K), cm^-1: H u
    floor: Floor

    def settle(self) -> None:
        """Give each FLS its state back (its record then steps alone), and leave them."""
        it, floor = self.iterate, self.floor
        for row, (part, layer) in enumerate(zip(self.parts, self.layers, strict=True)):
            at = slice(row, row + 1)
            layer.iterate = Iterate(it.position[at], it.residual[at], it.search[at],
                                    it.image[at], it.gamma, it.alpha)  # fmt: skip
            layer.scaled = self.scaled[row]
            layer.image = self.image[row]
            layer.floor = Floor(floor.gamma, floor.position[at], floor.since)
            if layer.sampling:
                layer.samples = it.position[row]
            else:
                layer.position = it.position[row]
            part.together = None
            part.said = None


class FitRows(NamedTuple):
    """A SUMS or STEP round's offers of F FLSs made together, a row each (FitOffer's fields)."""

    values: FloatArray  # (F, V): each FLS's vector, flat (V = 0 in SUMS)
    partials: FloatArray  # (F, P): each FLS's shares of the swarm's sums (P = 0 in STEP)


def fit_together(
    parts: Sequence[FitPart], step: FitStep | None, heard: RoundOffers | None
) -> FitRows | None:
    """Step ``parts`` (one process's FLSs, in one run) through the round of ``step`` at once.

    Returns a SUMS or STEP round's offers, a row per FLS of ``parts`` in their
    order: what each FLS stepping alone would offer (``discovery.messages.FitBlock``
    carries them). A RESIDUAL starts every FLS's solve from rows made in one
    pass (:func:`_residuals`), a WEIGH weighs every FLS's pairs in one
    (:func:`_weighed`), and each FLS then finds its offer made
    (:meth:`FitPart.on_round` sends it): None. ``step`` None, or another stage:
    the solve's state goes back to each FLS, which steps on alone from what
    was heard, read for all (:func:`take_together`); None.
    """
    if step is not None and step.stage in (RESIDUAL, WEIGH) and not step.ended and parts:
        settle(parts)
        (_residuals if step.stage == RESIDUAL else _weighed)(parts, step, heard)
        return None
    if step is None or step.stage not in (SUMS, STEP) or step.ended:
        settle(parts)
        if step is not None:  # each FLS then steps alone, what it heard read already
            take_together(parts, heard)
        return None
    solve = _solve_of(parts)
    if solve is None:
        return None
    if step.stage == SUMS:
        made = _sums(solve, heard)
    else:
        made = _step(solve, np.asarray(step.sums, dtype=np.float64), heard)
    if made is None:  # a round each FLS takes alone
        settle(parts)
    return made


def _residuals(parts: Sequence[FitPart], step: FitStep, heard: RoundOffers | None) -> None:
    """A RESIDUAL round for ``parts`` at once: each FLS hears ``heard`` and weighs its
    layer, then every FLS's own rows come from one pass (:func:`.fit_rows.own_rows`)
    and each starts its solve from them, as :meth:`FitPart.on_round` does alone."""
    samples = {part.samples_count for part in parts}
    if len(samples) != 1:
        return  # FLSs that draw differently (never in one swarm): each starts alone
    take_together(parts, heard)
    layers = [part.weighed(step) for part in parts]
    made = own_rows(layers, samples.pop())
    for part, layer, own in zip(parts, layers, made, strict=True):
        part.said = (step, part.start_solve(layer, own))


def _weighed(parts: Sequence[FitPart], step: FitStep, heard: RoundOffers | None) -> None:
    """A WEIGH round for ``parts`` at once: each FLS hears ``heard``, then every FLS's pairs
    are weighed in one pass over their rows stacked (each row's weight is its own: the
    same bits), and each makes its offer from its own, as :meth:`FitPart.on_round` does."""
    take_together(parts, heard)
    layers = [part.layer_of(step) for part in parts]
    measured = stacked(layers)[0]
    positions = np.concatenate(
        [part.weigh_positions(layer) for part, layer in zip(parts, layers, strict=True)]
    )
    weights = {mode: weights_for(measured, positions, mode) for mode in WEIGHED}
    bounds = csr.offsets(np.array([len(layer.measured) for layer in layers], dtype=np.int64))
    for index, (part, layer) in enumerate(zip(parts, layers, strict=True)):
        rows = slice(bounds[index], bounds[index + 1])
        own = {mode: weights[mode][rows].copy() for mode in WEIGHED}
        part.said = (step, part.weighed_offer(layer, own))


def take_together(parts: Sequence[FitPart], heard: RoundOffers | None) -> None:
    """Each of ``parts`` keeps what ``heard`` says of the FLSs it measures, read for all at
    once: the labels and vectors each would take alone (:meth:`FitPart.take`).

    A round whose offers carry readings (the first LABELS round), or vectors of
    more than one size (a forgery the key let through: each FLS judges its own
    neighbours'), each FLS takes alone.
    """
    if heard is None or len(parts) < 2 or len(heard.read_ids):
        for part in parts:
            part.take(heard)
        return
    labelled = bool((heard.fit_labels >= 0).any())
    vectors = bool(len(heard.fit_values))
    if not labelled and not vectors:
        return  # nothing an FLS keeps: each finds so itself, cheaply
    wanted = [part.measured_ids for part in parts]
    every = np.concatenate(wanted)
    ids, row_of = np.unique(every, return_inverse=True)
    labels, offsets, values = heard.fit_of(ids)
    sizes = np.diff(offsets)
    if len(np.unique(sizes[sizes > 0])) > 1:
        for part in parts:
            part.take(heard)
        return
    bounds = csr.offsets(np.array([len(one) for one in wanted], dtype=np.int64))
    their_labels = labels[row_of] if labelled else None
    if vectors:
        # One copy of every FLS's vectors, each FLS's a slice: the heard ones, in its order.
        sent = sizes[row_of] > 0
        columns = int(sizes.max(initial=3)) // 3
        block = values.reshape(-1, 3, columns)[(np.cumsum(sizes > 0) - 1)[row_of[sent]]]
        heard_ids = every[sent]
        sent_bounds = np.concatenate([[0], np.cumsum(sent)])[bounds]
    for index, part in enumerate(parts):
        low, high = bounds[index], bounds[index + 1]
        said = None if their_labels is None else their_labels[low:high]
        kept = None
        if vectors:
            first, last = sent_bounds[index], sent_bounds[index + 1]
            kept = (heard_ids[first:last], block[first:last]) if last > first else NOTHING_HEARD
        part.took(heard, said, kept)


def settle(parts: Sequence[FitPart]) -> None:
    """Give every solve that any of ``parts`` takes part in back to its FLSs' records."""
    for solve in {id(part.together): part.together for part in parts if part.together}.values():
        solve.settle()


def _solve_of(parts: Sequence[FitPart]) -> Solve | None:
    """The solve ``parts`` step together: kept from the last round, or gathered anew."""
    first = parts[0].together if parts else None
    if (
        isinstance(first, Solve)
        and len(first.parts) == len(parts)
        # The same FLSs, each still in the same solve: looked at in C, once per round.
        and all(map(operator.is_, first.parts, parts))
        and all(map(operator.is_, map(attrgetter("solving"), parts), first.layers))
    ):
        return first
    settle(parts)
    layers = [part.solving for part in parts]
    if not layers or any(layer is None or layer.iterate is None for layer in layers):
        return None
    kept = [layer for layer in layers if layer is not None]
    if len({(layer.sampling, layer.scaled.shape[1]) for layer in kept}) != 1:
        return None
    solve = _gathered(list(parts), kept)
    for part in parts:
        part.together = solve
    return solve


def _gathered(parts: list[FitPart], layers: list[FitLayer]) -> Solve:
    """A solve stacked from each FLS's record of it."""
    from scipy.sparse import csr_matrix

    others = np.unique(np.concatenate([layer.ids for layer in layers]))
    columns, data, counts = [], [], []
    for row, layer in enumerate(layers):
        rows = layer.rows
        local, axis = np.divmod(rows.indices, 3)
        block = np.searchsorted(others, layer.ids[local])
        block[local == layer.slot] = len(others) + row
        columns.append(3 * block + axis)
        data.append(rows.data)
        counts.append(np.diff(rows.indptr))
    indptr = np.concatenate([[0], np.cumsum(np.concatenate(counts))])
    matrix = csr_matrix(
        (np.concatenate(data), np.concatenate(columns), indptr),
        shape=(3 * len(layers), 3 * (len(others) + len(layers))),
    )
    iterates, floors, blocks = [], [], []
    for layer in layers:
        assert layer.iterate is not None and layer.floor is not None
        assert layer.preconditioner is not None
        iterates.append(layer.iterate)
        floors.append(layer.floor)
        blocks.append(layer.preconditioner)
    first = iterates[0]
    return Solve(
        parts,
        layers,
        matrix,
        others,
        np.stack(blocks),
        Iterate(
            np.concatenate([one.position for one in iterates]),
            np.concatenate([one.residual for one in iterates]),
            np.concatenate([one.search for one in iterates]),
            np.concatenate([one.image for one in iterates]),
            first.gamma,
            first.alpha,
        ),
        np.stack([layer.scaled for layer in layers]),
        np.stack([layer.image for layer in layers]),
        Floor(floors[0].gamma, np.concatenate([one.position for one in floors]), floors[0].since),
    )


def _quiet(heard: RoundOffers | None) -> bool:
    """Whether ``heard`` carries nothing an FLS keeps but the stage's vectors."""
    return heard is None or (not len(heard.read_ids) and not (heard.fit_labels >= 0).any())


def _sums(solve: Solve, heard: RoundOffers | None) -> FitRows | None:
    """Each FLS's row of ``H u`` from the u heard and its own, and its shares of the sums."""
    if heard is None or not _quiet(heard) or not len(heard.fit_values):
        return None
    count, _, columns = solve.scaled.shape
    if not np.isin(np.diff(heard.fit_offsets), (0, 3 * columns)).all():
        return None  # an offer of another size: each FLS judges its own (the odd one out)
    _, offsets, values = heard.fit_of(solve.others)
    sizes = np.diff(offsets)
    vector = np.zeros((len(solve.others) + count, 3, columns))
    heard_from = len(solve.others)
    vector[:heard_from][sizes > 0] = values.reshape(-1, 3, columns)
    vector[heard_from:] = solve.scaled
    image = sparse_times(solve.matrix, vector.reshape(-1, columns))
    solve.image = image.reshape(count, 3, columns)
    shares = np.concatenate(
        [partial_dot(solve.iterate.residual, solve.scaled),
         partial_dot(solve.image, solve.scaled)], axis=1,
    )  # fmt: skip
    # Each FLS's record keeps the vectors it heard before this round: no stage reads them
    # before a round with vectors replaces them, so they are not copied out FLS by FLS.
    return FitRows(np.zeros((count, 0)), shares)


def _step(solve: Solve, sums: FloatArray, heard: RoundOffers | None) -> FitRows | None:
    """Each FLS's conjugate-gradient step from the swarm's ``sums``, and its next u."""
    if not _quiet(heard) or (heard is not None and len(heard.fit_values)):
        return None
    half = len(sums) // 2
    gamma, delta = sums[:half], sums[half:]
    solve.floor = solve.floor.after(gamma, solve.iterate.position)
    alpha, beta = scalars(solve.iterate, gamma, delta)
    solve.iterate = advance(solve.iterate, solve.scaled, solve.image, gamma, alpha, beta)
    solve.scaled = blocks_times(solve.preconditioner, solve.iterate.residual)
    flat = solve.scaled.reshape(len(solve.parts), -1)
    return FitRows(flat, np.zeros((len(solve.parts), 0)))
