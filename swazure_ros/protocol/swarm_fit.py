"""The swarm's own least-squares fit as rounds of a discovery run (docs/protocol.md).

A run whose estimator is ``swarm-fit`` goes on after discovery's phases with
the FIT phase: the solves of :mod:`~swazure_ros.core.swarm_fit`, round by
round. Each round every FLS sends one offer, heard by the FLSs it measures;
besides, each process tells the coordinator its FLSs' shares of the swarm's
sums (:class:`FitTally`), and the coordinator's next control carries the
sums back. :class:`FitSchedule` is the coordinator's part (which stage comes
next), :class:`FitPart` one FLS's. Their arithmetic is the engine's
(``core.swarm_fit``), so a run gives the engine's estimates.

Stages, each one round:

- LABELS: each FLS passes on the smallest id of its sweet part that it has
  heard of, until none changes (the parts decide which decaying hops join
  the fit; ``core.fit_measurements.joining``); the first round also carries its readings
  of the FLSs it measures, so that both ends of a pair hold both rows.
- POSITIONS: each FLS sends its position (before a solve, and after one,
  for the robust loss).
- WEIGH: each FLS weighs its pairs' rows at its neighbours' positions and
  says whether Huber's and the rejecting weights changed, and how far it moved.
- RESIDUAL: each FLS sets its weights (or draws the covariance's right
  sides), forms its residual and sends its preconditioned residual u.
- SUMS: each FLS forms its row of H u and its shares of (r, u) and (H u, u).
- STEP: with the swarm's sums, each FLS takes one step of conjugate
  gradients and sends its next u. SUMS and STEP alternate until the sums
  say the solve has settled.
- SHARE: each FLS sends its settled position and samples of every fit, for
  its radio neighbours that are sources.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from ..core import csr
from ..core.arrays import FloatArray, IntArray
from ..core.conjugate_gradients import (
    Floor,
    Iterate,
    advance,
    partial_dot,
    scalars,
    settled,
)
from ..core.exact_sums import swarm_sum
from ..core.fit_measurements import fit_layers
from ..core.lookup import sorted_rows
from ..core.measurement_graph import CONVERGED_CM, measured_rows
from ..core.observe import LocalView
from ..core.sensor import DECAYING, SWEET, Sensor
from ..core.swarm_edges import blocks_times
from ..core.swarm_fit import (
    COVARIANCE_SAMPLES,
    HUBER,
    REJECTING,
    UNIT,
    robust_decision,
    weights_for,
)
from .discovery.messages import (
    LABELS,
    POSITIONS,
    RESIDUAL,
    SAMPLES,
    SETTLED,
    SHARE,
    STALLED,
    STEP,
    SUMS,
    WEIGH,
    FitOffer,
    FitStep,
    RoundOffers,
)
from .fit_rows import FitLayer, OwnRows, own_rows, weigh

#: The robust modes whose weights a WEIGH round makes, for the coordinator to choose from.
WEIGHED = (HUBER, REJECTING)


class Settles(Protocol):
    """A solve stepped for several FLSs at once (:class:`..fit_together.Solve`)."""

    def settle(self) -> None:
        """Give each FLS its state back; they step alone from then on."""


#: The vectors of a round in which none of an FLS's neighbours was heard (read-only, shared).
NOTHING_HEARD = (np.zeros(0, dtype=np.int64), np.zeros((0, 3, 1)))
for _empty in NOTHING_HEARD:
    _empty.flags.writeable = False


@dataclass
class FitTally:
    """What a round's FLSs told the coordinator: shares of the sums, the robust loss's say."""

    sums: list[tuple[float, ...]] = field(default_factory=list)  # per process, per column
    moved: float = 0.0  # cm, the largest move of any FLS over the last solve
    huber_same: bool = True
    rejecting_same: bool = True

    def add(self, sums: Sequence[float], moved: float, same: tuple[bool, bool]) -> None:
        """Count one process's report."""
        if sums:
            self.sums.append(tuple(sums))
        self.moved = max(self.moved, moved)
        self.huber_same &= same[0]
        self.rejecting_same &= same[1]

    def totals(self) -> FloatArray:
        """The swarm's sums, each exact over the processes' (:func:`math.fsum`)."""
        if not self.sums:
            return np.zeros(0)
        return np.array([math.fsum(column) for column in zip(*self.sums, strict=True)])


def process_sums(partials: Sequence[FloatArray]) -> tuple[float, ...]:
    """One process's sums of its FLSs' shares, exact per column: each of ``partials`` is
    one FLS's (P,), or a block of FLSs' (k, P)."""
    if not partials:
        return ()
    return tuple(swarm_sum(np.concatenate([np.atleast_2d(one) for one in partials])).tolist())


class FitSchedule:
    """The coordinator's part of the FIT phase: which stage follows which, from the sums.

    As :func:`~swazure_ros.core.swarm_fit.swarm_solve` goes, per fit of
    ``layers`` (``core.fit_measurements.fit_layers``): a solve with unit weights, the
    robust loss's reweighted solves (:func:`~swazure_ros.core.swarm_fit.robust_decision`),
    then the covariance's solve with ``samples`` right sides; SHARE last.
    """

    def __init__(self, layers: tuple[bool, ...], samples: int = COVARIANCE_SAMPLES) -> None:
        self.layers = layers
        self.samples = samples
        self.step = FitStep()
        self.iterations: list[list[int]] = [[] for _ in layers]
        self._scale = np.zeros(0)
        self._floor = Floor.start(np.zeros((1, 1, 0)))
        self._solving = UNIT  # the mode of the solve under way
        self._rejecting = False
        self._after_solve = False  # the next POSITIONS is followed by WEIGH

    def first(self) -> FitStep:
        """The phase's first round (again, after a restart: the positions stay the FLSs')."""
        self.step = FitStep()
        self.iterations = [[] for _ in self.layers]
        self._rejecting = self._after_solve = False
        return self.step

    def after(self, tally: FitTally, quiet: bool) -> FitStep | None:
        """The next round's step once a round has closed; None: the phase is over.

        ``quiet``: no FLS's label changed (the LABELS rounds' end).
        """
        step, layer = self.step, self.step.layer
        if step.stage == SHARE:
            return None
        if step.stage == LABELS:
            nxt = step if not quiet else FitStep(POSITIONS, 0)
        elif step.stage == POSITIONS:
            nxt = FitStep(WEIGH if self._after_solve else RESIDUAL, layer, self._solving)
        elif step.stage == WEIGH:
            nxt = self._weighed(tally, layer)
        elif step.stage == RESIDUAL:
            self._scale = tally.totals()
            self._floor = Floor.start(np.zeros((1, 1, len(self._scale))))
            nxt = FitStep(SUMS, layer, step.mode)
        elif step.stage == STEP:
            nxt = FitStep(SUMS, layer, step.mode)
        else:  # SUMS
            sums = tally.totals()
            count = len(sums) // 2
            self._floor = self._floor.after(sums[:count], self._floor.position)
            if settled(sums[:count], self._scale):
                nxt = replace(self._solved(layer), ended=SETTLED)
            elif self._floor.stalled:
                nxt = replace(self._solved(layer), ended=STALLED)
            else:
                self.iterations[layer][-1] += 1
                nxt = FitStep(STEP, layer, step.mode, tuple(sums.tolist()))
        if nxt.stage == RESIDUAL:
            self.iterations[nxt.layer].append(0)
        self.step = nxt
        return nxt

    def _solved(self, layer: int) -> FitStep:
        if self._solving == SAMPLES:
            return self._next_layer(layer)
        self._after_solve = True
        return FitStep(POSITIONS, layer)

    def _weighed(self, tally: FitTally, layer: int) -> FitStep:
        solves = len(self.iterations[layer])
        if self._solving != UNIT and tally.moved <= CONVERGED_CM:
            # Huber's loss has settled: from here on, measurements far out are rejected.
            self._rejecting = True
        mode = robust_decision(self._rejecting, tally.huber_same, tally.rejecting_same, solves)
        if mode is None:
            if not self.samples:
                return self._next_layer(layer)
            self._solving = SAMPLES
            return FitStep(RESIDUAL, layer, SAMPLES)
        self._rejecting = mode == REJECTING
        self._solving = mode
        return FitStep(RESIDUAL, layer, mode)

    def _next_layer(self, layer: int) -> FitStep:
        self._solving, self._rejecting, self._after_solve = UNIT, False, False
        if layer + 1 < len(self.layers):
            return FitStep(POSITIONS, layer + 1)
        return FitStep(SHARE, layer)


class FitPart:
    """One FLS's part of the FIT phase: controls and heard offers in, its offers out.

    ``view``: what it measures (its camera readings, its neighbours' range
    classes and tracking distances); ``departed``: FLSs that take no part;
    ``start``: per fit, its position from an earlier run (a warm start).
    """

    def __init__(
        self,
        view: LocalView,
        sensor: Sensor,
        radius: float,
        departed: frozenset[int],
        start: Sequence[FloatArray] | None = None,
        samples: int = COVARIANCE_SAMPLES,
    ) -> None:
        self.view = view
        self.fls_id = view.fls_id
        self.sensor = sensor
        self.radius = radius
        self.samples_count = samples
        self.layers_links = fit_layers(sensor)
        measured = (
            view.visible
            & ((view.range_class == SWEET) | (view.range_class == DECAYING))
            & view.read
            & ~np.isin(view.other, list(departed))
        )
        self._measured = np.flatnonzero(measured)  # rows of the view: whom it measures
        self._sweet_rows = np.flatnonzero(view.range_class[self._measured] == SWEET)
        self.label = self.fls_id
        # Per FLS it measures (measured_ids' order): the label it last said (-1: none), and
        # its reading of this FLS (cm) where heard.
        self._neighbour_labels = np.full(len(self._measured), -1, dtype=np.int64)
        self._their_readings = np.zeros((len(self._measured), 3))
        self._reading_heard = np.zeros(len(self._measured), dtype=bool)
        self._taken: RoundOffers | None = None  # the offers last taken, not taken twice
        # The FLSs it measures that sent a vector in the last round that had any (their
        # positions, or their u), sorted, and those vectors (S, 3, K).
        self._heard_ids, self._heard_block = NOTHING_HEARD
        self._start = start
        self.layers: list[FitLayer | None] = [None] * len(self.layers_links)
        self._first = True
        self.solving: FitLayer | None = None  # the layer whose solve is under way
        # A round done for the process's FLSs at once (protocol.fit_together): its step and
        # this FLS's offer; and the solve it is stepped in, which holds its state meanwhile.
        self.said: tuple[FitStep, FitOffer] | None = None
        self.together: Settles | None = None

    # -- rounds -------------------------------------------------------------------------

    def take_said(self, step: FitStep) -> FitOffer | None:
        """This FLS's offer in the round of ``step`` made with the process's other FLSs
        (:mod:`.fit_together`), heard included; None when it was not. Taken once."""
        said, self.said = self.said, None
        return said[1] if said is not None and said[0] is step else None

    def on_round(self, step: FitStep, heard: RoundOffers | None) -> FitOffer:
        """This FLS's offer in the round of ``step``, after taking ``heard`` (a RoundOffers)."""
        said = self.take_said(step)
        if said is not None:
            return said
        if self.together is not None:
            self.together.settle()
        self.take(heard)
        if step.ended == STALLED and self.solving is not None:
            # The solve stalled at rounding's floor: every FLS takes its best iterate.
            self._take_best(self.solving)
        if step.stage == LABELS:
            return self._labels_round()
        layer = self._layer(step.layer)
        if step.stage == POSITIONS:
            return FitOffer(values=layer.position.ravel().copy())
        if step.stage == WEIGH:
            return self._weigh(layer)
        if step.stage == RESIDUAL:
            return self._residual(layer, step.mode)
        if step.stage == SUMS:
            return self._sums(layer)
        if step.stage == STEP:
            return self._step(layer, np.asarray(step.sums, dtype=np.float64))
        return FitOffer(values=self.shared())

    @property
    def measured_ids(self) -> IntArray:
        """(M,) the FLSs it measures, ascending: the neighbours whose offers it hears."""
        return self.view.other[self._measured]

    def shared(self) -> FloatArray:
        """Per fit: its settled position (3,) and its samples (3, K), flat."""
        pieces = []
        for index in range(len(self.layers)):
            layer = self._layer(index)
            pieces += [layer.position.ravel(), layer.samples.ravel()]
        return np.concatenate(pieces)

    def take(self, heard: RoundOffers | None) -> None:
        """Keep what ``heard`` says of the FLSs this one measures: labels, readings, vectors."""
        if heard is None or heard is self._taken:
            return
        if len(heard.read_ids):
            self.took_readings(*heard.readings_of(self.fls_id))
        labelled = bool((heard.fit_labels >= 0).any())
        if not labelled and not len(heard.fit_values):
            self._taken = heard
            return  # a round whose offers say nothing to neighbours (WEIGH, SUMS)
        wanted = self.measured_ids
        labels, offsets, values = heard.fit_of(wanted)
        if not len(heard.fit_values):
            self.took(heard, labels if labelled else None, None)
            return  # a LABELS round: the vectors heard before stay
        # A round's vectors replace those of the last: a neighbour not heard counts as 0.
        counts = np.diff(offsets)
        if not (counts > 0).any():
            self.took(heard, labels if labelled else None, NOTHING_HEARD)
            return
        # Every sender of a round sends as many values, one (3, K) block each; a sender
        # that sent another number (a forgery the key let through) is not heard.
        size = int(np.bincount(counts[counts > 0]).argmax())
        sent = counts == size
        rows = csr.ragged_indices(offsets[:-1][sent], counts[sent])
        block = values[rows].reshape(int(sent.sum()), 3, size // 3)
        self.took(heard, labels if labelled else None, (wanted[sent], block))

    def took_readings(self, readers: IntArray, vectors: FloatArray) -> None:
        """Keep ``readers``' readings (R, 3), cm, of this FLS: those of FLSs it measures."""
        rows, found = sorted_rows(self.measured_ids, np.asarray(readers, dtype=np.int64))
        self._their_readings[rows[found]] = vectors[found]
        self._reading_heard[rows[found]] = True

    def took(
        self,
        heard: RoundOffers,
        labels: IntArray | None,
        vectors: tuple[IntArray, FloatArray] | None,
    ) -> None:
        """Keep what ``heard`` says to this FLS, read here (:meth:`take`) or for a process's
        FLSs at once (:func:`..fit_together.take_together`): its neighbours' ``labels``
        (M,), -1 where none; the ``vectors`` heard (their senders, sorted, and (S, 3, K)),
        which replace those of the last round with any. None: the round had none."""
        self._taken = heard
        if labels is not None:
            np.copyto(self._neighbour_labels, labels, where=labels >= 0)
        if vectors is not None:
            self._heard_ids, self._heard_block = vectors

    def _labels_round(self) -> FitOffer:
        heard = self._neighbour_labels[self._sweet_rows]
        label = int(heard[heard >= 0].min(initial=self.label))
        changed = label != self.label or self._first
        self.label = label
        readings = None
        if self._first:
            self._first = False
            own = self.view.other[self._measured].astype(np.int64)
            readings = (own, self.view.vector_at(self._measured))
        return FitOffer(label=label, changed=changed, readings=readings)

    # -- one fit --------------------------------------------------------------------------

    def _layer(self, index: int) -> FitLayer:
        layer = self.layers[index]
        if layer is None:
            layer = self.layers[index] = self._build(index)
        return layer

    def _build(self, index: int) -> FitLayer:
        """This FLS's rows of fit ``index``: its pairs, both rows each, in local indices."""
        view, rows = self.view, self._measured
        chosen = view.range_class[rows] == SWEET
        if self.layers_links[index]:
            # A decaying hop joins the fit where it joins two sweet parts.
            joins = self._neighbour_labels != self.label
            chosen |= (view.range_class[rows] == DECAYING) & joins
        # Both rows of a pair: only where the neighbour's reading of this FLS was heard.
        kept = chosen & self._reading_heard
        rows = rows[kept]
        others = view.other[rows].astype(np.int64)
        ids = np.sort(np.append(others, self.fls_id))
        slot = int(np.searchsorted(ids, self.fls_id))
        local = np.searchsorted(ids, others)
        count = len(rows)
        mine = np.full(count, slot, dtype=np.int64)
        theirs = self._their_readings[kept]
        first = np.concatenate([mine, local])
        second = np.concatenate([local, mine])
        raw = np.concatenate([view.vector_at(rows), theirs])
        tracking = np.tile(view.distance[rows], 2)
        measured = measured_rows(self.sensor, self.radius, first, second, raw, tracking)
        position = np.zeros((3, 1))
        if self._start is not None and index < len(self._start):
            position[:, 0] = np.nan_to_num(self._start[index])
        return FitLayer(ids, slot, measured, np.ones(2 * count), position, np.zeros((3, 0)))

    def _local(self, layer: FitLayer, own: FloatArray) -> FloatArray:
        """The vector (L, 3, K) over the local ids: its own ``own`` (3, K), the heard ones."""
        columns = own.shape[1]
        local = np.zeros((len(layer.ids), 3, columns))
        heard_ids, block = self._heard_ids, self._heard_block
        if len(heard_ids) and block.shape[2] == columns:
            rows, found = sorted_rows(heard_ids, layer.ids)
            local[found] = block[rows[found]]
        local[layer.slot] = own
        return local

    def _weigh(self, layer: FitLayer) -> FitOffer:
        positions = self.weigh_positions(layer)
        candidates = {mode: weights_for(layer.measured, positions, mode) for mode in WEIGHED}
        return self.weighed_offer(layer, candidates)

    def layer_of(self, step: FitStep) -> FitLayer:
        """The layer (the fit) that ``step`` works on, made at its first ask."""
        return self._layer(step.layer)

    def weigh_positions(self, layer: FitLayer) -> FloatArray:
        """The positions (L, 3), cm, of ``layer``'s local ids that its weights are made at:
        its own, and its neighbours' as heard."""
        return self._local(layer, layer.position)[:, :, 0]

    def weighed_offer(self, layer: FitLayer, candidates: dict[int, FloatArray]) -> FitOffer:
        """Keep ``candidates``, ``layer``'s weights (2 x pairs,) per robust mode of
        :data:`WEIGHED`; its WEIGH round's offer: whether they changed, how far it moved."""
        layer.candidates = candidates
        same = (
            bool(np.array_equal(layer.candidates[HUBER], layer.weights)),
            bool(np.array_equal(layer.candidates[REJECTING], layer.weights)),
        )
        moved = float(np.abs(layer.position - layer.before).max(initial=0.0))
        return FitOffer(moved=moved, same=same)

    def _residual(self, layer: FitLayer, mode: int) -> FitOffer:
        weigh(layer, mode)
        return self.start_solve(layer, own_rows([layer], self.samples_count)[0])

    def weighed(self, step: FitStep) -> FitLayer:
        """The layer of RESIDUAL ``step``, weighed for its solve (:func:`.fit_rows.weigh`)."""
        layer = self._layer(step.layer)
        weigh(layer, step.mode)
        return layer

    def start_solve(self, layer: FitLayer, own: OwnRows) -> FitOffer:
        """Start the solve of ``layer`` (weighed for it: :func:`weigh`) from its rows
        ``own``: its RESIDUAL round's offer."""
        layer.rows, layer.preconditioner = own.rows, own.preconditioner
        if layer.sampling:
            start = layer.samples = np.zeros((3, self.samples_count))
        else:
            start = layer.position
        layer.before = start.copy()
        layer.floor = Floor.start(start[None])
        self.solving = layer
        right = own.right
        # Every FLS starts the covariance's solve at zero: its residual is its right side.
        residual = right.copy() if layer.sampling else (
            right - self._own_product(layer, self._local(layer, start))
        )  # fmt: skip
        columns = start.shape[1]
        zeros = np.zeros((1, 3, columns))
        layer.iterate = Iterate(start[None].copy(), residual[None], zeros, zeros,
                                np.zeros(columns), np.zeros(columns))  # fmt: skip
        scale = partial_dot(right[None], blocks_times(own.preconditioner, right)[None])
        return self._send_scaled(layer, partials=scale[0])

    def _own_product(self, layer: FitLayer, local: FloatArray) -> FloatArray:
        """Its three rows of H times the local vector (L, 3, K): (3, K)."""
        count, _, columns = local.shape
        return np.asarray(layer.rows @ local.reshape(3 * count, columns), dtype=np.float64)

    def _send_scaled(self, layer: FitLayer, partials: FloatArray) -> FitOffer:
        assert layer.preconditioner is not None and layer.iterate is not None
        block = layer.preconditioner
        layer.scaled = blocks_times(block, layer.iterate.residual[0])
        return FitOffer(values=layer.scaled.ravel().copy(), partials=partials)

    def _take_best(self, layer: FitLayer) -> None:
        assert layer.floor is not None
        best = layer.floor.position[0]
        if layer.sampling:
            layer.samples = best
        else:
            layer.position = best

    def _sums(self, layer: FitLayer) -> FitOffer:
        assert layer.iterate is not None
        image = self._own_product(layer, self._local(layer, layer.scaled))
        layer.image = image
        residual, scaled = layer.iterate.residual, layer.scaled[None]
        shares = np.concatenate(
            [partial_dot(residual, scaled)[0], partial_dot(image[None], scaled)[0]]
        )
        return FitOffer(partials=shares)

    def _step(self, layer: FitLayer, sums: FloatArray) -> FitOffer:
        assert layer.iterate is not None
        count = len(sums) // 2
        gamma, delta = sums[:count], sums[count:]
        assert layer.floor is not None
        layer.floor = layer.floor.after(gamma, layer.iterate.position)
        alpha, beta = scalars(layer.iterate, gamma, delta)
        layer.iterate = advance(
            layer.iterate, layer.scaled[None], layer.image[None], gamma, alpha, beta
        )
        if layer.sampling:
            layer.samples = layer.iterate.position[0]
        else:
            layer.position = layer.iterate.position[0]
        return self._send_scaled(layer, partials=np.zeros(0))
