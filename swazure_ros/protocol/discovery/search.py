"""One FLS's path search in one phase: labels relaxed round by round, in buckets.

Every FLS runs a :class:`PathSearch` per phase of a discovery run. It holds
the FLS's best path label for each source: the path from the source to this
FLS, its hop count and length, and the measured hop vectors summed from the
source. In round k of a phase an FLS broadcasts the labels whose bucket is k
(:func:`.buckets.bucket_width`); its neighbours relax them through their own hop.

Buckets make every broadcast label final. Every hop adds one hop, at least
``sweet_min`` of length and at least the sensor's smallest hop error (the
least-error policy's cost), so a label can only be improved by a label of a
lower bucket, which was broadcast in an earlier round. Each FLS
therefore broadcasts each source's label once, and keeps, among equal costs,
the label whose sender has the smallest FLS id: the predecessor rule of
:mod:`...core.paths`, so the distributed search picks the core engine's paths.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...core import csr, jit
from ...core.arrays import FloatArray, IntArray
from ...core.observe import LocalView
from ...core.paths import FEWEST_HOPS, LEAST_ERROR, SHORTEST_LENGTH, check_policy
from ...core.sensor import BLIND, DECAYING, SWEET, Sensor
from .due import due_places
from .estimate import Results
from .heard import OffersHeard, offers_of
from .labels import (
    ERROR_FIRST,
    HOPS_FIRST,
    LENGTH_FIRST,
    Changes,
    HeardLabels,
    LabelTable,
)
from .links import Links, hop_fit
from .messages import ANY_VISIBLE, SWEET_ALL, SWEET_VISIBLE, Offer, RoundOffers, sender_rows

# What an FLS that is no source searches for: one read-only array for all of them.
_NO_TARGETS = np.zeros(0, dtype=np.int64)
_NO_TARGETS.flags.writeable = False

_COST_ORDER = {FEWEST_HOPS: HOPS_FIRST, SHORTEST_LENGTH: LENGTH_FIRST, LEAST_ERROR: ERROR_FIRST}


def hop_mask(view: LocalView, phase: int) -> NDArray[np.bool_]:
    """(K,) the neighbours of ``view`` that its FLS relays from in ``phase``."""
    sweet = view.range_class == SWEET
    if phase == SWEET_VISIBLE:
        return np.asarray(sweet & view.visible)
    if phase == SWEET_ALL:
        return np.asarray(sweet)
    if phase == ANY_VISIBLE:
        return np.asarray((sweet | (view.range_class == DECAYING)) & view.visible)
    raise ValueError(f"unknown discovery phase {phase}")


def reads_both_ends(sensor: Sensor) -> bool:
    """True when the two FLSs of a pair read its vector differently (noise, a camera).

    The published model's reading of j from i is the reverse of i's from j,
    to the bit: a receiver may take its own reading of the sender, reversed.
    """
    return sensor.noise is not None or sensor.camera is not None


@jit.kernel(cache=True, nogil=True)
def _labels_for(
    source: int,
    senders_wanted: IntArray,
    senders: IntArray,
    starts: IntArray,
    source_ids: IntArray,
) -> IntArray:
    """The labels of ``source`` offered by ``senders_wanted`` (sorted ids), sender by sender.

    ``senders``, ``starts`` and ``source_ids`` are a :class:`RoundOffers`'s;
    a sender offers each source's label once in a phase (it is final when
    sent), in increasing source order (``offer_from_message`` checks it).
    """
    found = np.empty(len(senders_wanted), dtype=np.int64)
    count = 0
    for row in sender_rows(senders_wanted, senders):
        if row < 0:
            continue
        low, high = starts[row], starts[row + 1]
        label = low + np.searchsorted(source_ids[low:high], source)
        if label < high and source_ids[label] == source:
            found[count] = label
            count += 1
    return found[:count]


@jit.kernel(cache=True, nogil=True)
def _labels_for_each(
    sources: IntArray,
    wanted_offsets: IntArray,
    senders_wanted: IntArray,
    senders: IntArray,
    starts: IntArray,
    source_ids: IntArray,
) -> tuple[IntArray, IntArray]:
    """:func:`_labels_for` of each of ``sources`` (S,) at once, its senders wanted
    ``senders_wanted[wanted_offsets[k]:wanted_offsets[k + 1]]``: (offsets (S + 1,), labels)."""
    offsets = np.zeros(len(sources) + 1, dtype=np.int64)
    found = np.empty(len(senders_wanted), dtype=np.int64)
    count = 0
    for at in range(len(sources)):
        low, high = wanted_offsets[at], wanted_offsets[at + 1]
        mine = _labels_for(sources[at], senders_wanted[low:high], senders, starts, source_ids)
        found[count : count + len(mine)] = mine
        count += len(mine)
        offsets[at + 1] = count
    return offsets, found[:count]


def hear_first(searches: Sequence[PathSearch], heard: RoundOffers) -> None:
    """What each of ``searches`` takes from ``heard`` before its relaxation, for all at once:
    its results (the labels of its source from its targets, found in one compiled pass)
    and its readings. :meth:`PathSearch.hear` of one search does the same."""
    wanting = []
    for one in searches:
        one._last_heard = heard
        if one._unfound:
            wanting.append(one)
    if wanting and len(heard.source_ids):
        missing = [one.targets[~one._found] for one in wanting]
        offsets, labels = _labels_for_each(
            np.array([one.fls_id for one in wanting], dtype=np.int64),
            csr.offsets(np.array([len(ids) for ids in missing], dtype=np.int64)),
            np.concatenate(missing),
            heard.senders,
            heard.starts,
            heard.source_ids,
        )
        # Their paths at once: a call per source cost the dragon's run 0.5 of its 8 s.
        path_offsets, path_ids = csr.take(heard.path_offsets, heard.path_ids, labels)
        for at in np.flatnonzero(np.diff(offsets)).tolist():
            low, high = int(offsets[at]), int(offsets[at + 1])
            paths = csr.span(path_offsets, path_ids, low, high)
            wanting[at]._take_results(heard, labels[low:high], paths)
    if len(heard.read_ids):
        for one in searches:
            one._take_readings(heard)


def _runs_source(fls_id: int, span: tuple[int, int], sources: IntArray | None) -> bool:
    """Whether FLS ``fls_id`` is one of a run's sources (``span``; ``sources``, sorted)."""
    if not span[0] <= fls_id < span[1]:
        return False
    return sources is None or sources[np.searchsorted(sources, fls_id)] == fls_id


def table_for(searches: Sequence[PathSearch]) -> LabelTable:
    """One table whose row k holds the labels of ``searches[k]``, fresh searches of one run
    and phase: empty but for each source's label of itself, at no cost (its path is
    itself, its vector 0). Made once for a process's FLSs that start together, not a
    table each to be merged when they first step together."""
    first = searches[0]
    table = LabelTable(
        np.array([one.fls_id for one in searches], dtype=np.int64),
        None,
        None,
        first.span,
        first.id_space,
        first.fits,
        sources=first.run_sources,
        row_hops=[one.relay_hops for one in searches],
    )
    rows = np.array([row for row, one in enumerate(searches) if one.is_source], dtype=np.int64)
    if len(rows):
        ids = table.mes[rows]
        places = table.add_many(rows, ids)
        table.hops[rows, places], table.length[rows, places] = 0.0, 0.0
        table.error[rows, places], table.pred[rows, places] = 0.0, ids
        if table.fits:
            table.unbiased[rows, places], table.covariance[rows, places] = 0.0, 0.0
    book = OffersHeard()  # its rows' offers heard: none yet
    for row, one in enumerate(searches):
        one.move_to(table, row, book)
    return table


def source_range(sources: IntArray | None, id_space: int) -> tuple[int, int]:
    """(first, end): the ids that an FLS keeps labels for in a run of ``sources`` (sorted).

    Every id when the run names no source (None); else the span of the named
    ones, whose labels a hash by source keeps, or a slot per source once a row
    would be as wide (:class:`.labels.LabelTable`): a run of a block of
    sources costs each FLS memory for that block only.
    """
    if sources is None or not len(sources):
        return 0, id_space
    return max(int(sources[0]), 0), min(int(sources[-1]) + 1, id_space)


@dataclass(frozen=True)
class SearchOptions:
    """How one FLS searches in each phase of a discovery run (see :class:`PathSearch`)."""

    policy: str
    width: float  # cost per round (buckets.bucket_width)
    id_space: int  # FLS ids are below it
    hop_errors: FloatArray | None = None  # (K,), expected error of the hop to each neighbour
    fit: tuple[Sensor, float] | None = None  # the sensor and the FLSs' radius, cm
    both_ends: bool = False
    sources: IntArray | None = None  # (S,) the run's sources, sorted ids; None: every FLS
    reach: float = math.inf  # the pass's rounds (buckets.reach_rounds): later labels are not sent


#: Where the hops of a phase come from: a view and the expected error of the hop to each of
#: its neighbours (None: none), made when first called.
ViewOf = Callable[[], tuple[LocalView, FloatArray | None]]


class RelayHops:
    """The hops one FLS relays from in ``phase``, not from the ``departed``, and its
    readings of them: made when its labels' table needs them (:class:`.labels.RowHops`).

    The neighbours relayed from are sorted by id (a view lists them so), each with
    the hop sender -> FLS, which the FLS's camera measures the other way round.
    ``view_of``, if given, gives the view and its hop errors in place of ``view``
    and ``options.hop_errors``, when the hops are first needed: a decaying phase's
    rows, which a display's share lays out only when a label of the phase reaches
    one of its FLSs.
    """

    def __init__(
        self,
        view: LocalView,
        phase: int,
        departed: frozenset[int],
        options: SearchOptions,
        view_of: ViewOf | None = None,
    ) -> None:
        # The view holds the world's rows in place: keeping it costs nothing.
        self.phase, self.departed, self.options = phase, departed, options
        self._view_of = view_of
        self._neighbours = None if view_of is not None else (view, options.hop_errors)
        # Counted when the table first needs it: an FLS that no label reaches in a phase
        # (a torus's in SD_vis, where every pair has a sweet path in sight) never does.
        self._count: int | None = None

    @property
    def view(self) -> LocalView:
        """The view it relays over (taken now if it was left for later)."""
        return self._taken()[0]

    def _taken(self) -> tuple[LocalView, FloatArray | None]:
        if self._neighbours is None:
            assert self._view_of is not None
            self._neighbours, self._view_of = self._view_of(), None
        return self._neighbours

    def _mask(self) -> NDArray[np.bool_]:
        view = self.view
        mask = hop_mask(view, self.phase)
        return mask & ~np.isin(view.other, list(self.departed)) if self.departed else mask

    def _rows(self) -> IntArray:
        rows = np.flatnonzero(self._mask())
        return rows[np.argsort(self.view.other[rows], kind="stable")]

    def count(self) -> int:
        """How many hops it relays from."""
        if self._count is None:
            self._count = int(np.count_nonzero(self._mask()))
        return self._count

    def fill(self, links: Links, start: int) -> None:
        """Write its hops into ``links`` from ``start`` on."""
        (view, errors), rows, end = self._taken(), self._rows(), start + self.count()
        links.ids[start:end] = view.other[rows]
        links.weights[start:end] = view.distance[rows]
        links.errors[start:end] = 0.0 if errors is None else errors[rows]
        if self.options.both_ends:  # the sender's own reading comes with its first offer
            links.vectors[start:end] = np.nan
        else:
            links.vectors[start:end] = -view.vector_at(rows)

    def readings(self) -> tuple[IntArray, FloatArray]:
        """The FLS's readings of the neighbours it relays from: (ids, vectors, cm)."""
        rows = self._rows()
        own = self.view.vector_at(rows)
        read = np.isfinite(own).all(axis=1)
        return np.asarray(self.view.other[rows][read], dtype=np.int64), own[read]


class PathSearch:
    """One FLS's labels in one phase of a discovery run.

    ``options.id_space`` bounds the FLS ids (ids are below it);
    ``options.sources`` the ids of the run's sources, sorted (all ids by
    default; one array for every FLS of a run, not copied). The FLS keeps a
    label only for a source whose search reached it (:mod:`.labels`): its
    memory grows with the searches through it, not with the swarm.
    ``targets`` makes this FLS a source that searches for them; ``departed``
    FLSs are not relayed from.
    ``options.hop_errors`` (K,) is the expected error of the hop to each neighbour of
    ``view`` (core.hop_errors.hop_error), which labels sum as they sum lengths.
    ``options.fit`` (the sensor and the FLSs' radius, cm), given in a fitting run,
    makes labels also sum each hop less its known bias, and its covariance.
    With ``options.both_ends``, a hop sender -> this FLS is the sender's own reading,
    which the sender's first offer of the phase carries
    (:func:`reads_both_ends`); else this FLS's reading of the sender, reversed.
    """

    def __init__(
        self,
        view: LocalView,
        phase: int,
        options: SearchOptions,
        targets: IntArray | None = None,
        departed: frozenset[int] = frozenset(),
        view_of: ViewOf | None = None,
    ) -> None:
        self.fls_id = view.fls_id
        self.span = source_range(options.sources, options.id_space)
        self.order = _COST_ORDER[check_policy(options.policy)]
        self.width = options.width
        # Buckets this pass relays: from where the pass before paused, below its reach.
        self.resumed, self.reach = 0.0, options.reach
        hops = RelayHops(view, phase, departed, options, view_of)
        # This FLS's readings of the neighbours it relays to, sent once when both ends read:
        # with its first offer, if it makes one (an FLS no label reaches makes none).
        self._readings: RelayHops | None = hops if options.both_ends else None
        self.fit = options.fit
        self.fits = options.fit is not None
        self.id_space, self.run_sources = options.id_space, options.sources
        self.relay_hops = hops  # how its table makes its links, when it first needs them
        # Its labels: a row of a table made when first needed, with the other FLSs of its
        # process that start with it (.together), or of its own (row 0). Its hops are made
        # when the table first needs them.
        self._table: LabelTable | None = None
        self.row = 0
        self.book = OffersHeard()  # the offers its labels came through, as its table's rows'
        self._last_heard: RoundOffers | None = None  # the offers this search heard last
        # (round, its offer) picked with the other FLSs of its process.
        self._picked: tuple[int, Offer] | None = None
        wanted = _NO_TARGETS if targets is None else np.asarray(targets, dtype=np.int64)
        if len(wanted) > 1 and not (wanted[1:] > wanted[:-1]).all():
            wanted = np.unique(wanted)  # a view's blind neighbours come sorted already
        # Sorted ids, not a set: a race car's 3,720 sources held 2 M Python ints (169 MB).
        self.targets: IntArray = wanted
        self._found = np.zeros(len(self.targets), dtype=bool)  # by target, as targets
        self._unfound = len(self.targets)  # targets whose result has not come
        self._open = len(self.targets)  # of those, the ones not shown out of reach either
        self._out_of_reach = np.zeros(len(self.targets), dtype=bool)  # shown by a pass (resume)
        self.results = Results()
        self.is_source = targets is not None
        if self.is_source and not _runs_source(self.fls_id, self.span, options.sources):
            raise ValueError(f"FLS {self.fls_id} is a source that is not one of the run's")

    @property
    def table(self) -> LabelTable:
        """The table that holds its labels, as row :attr:`row` (made now if not yet)."""
        if self._table is None:
            self._table = table_for([self])
        return self._table

    @property
    def fresh(self) -> bool:
        """True until its labels have a table: it has relaxed and sent nothing yet."""
        return self._table is None

    def move_to(self, table: LabelTable, row: int, book: OffersHeard) -> None:
        """Its labels are now row ``row`` of ``table``, whose offers heard are ``book``
        (:mod:`.together`); its links, the table's row ``row``'s."""
        self._table, self.row, self.book = table, row, book

    @property
    def links(self) -> Links:
        """The hops it relays from, sorted by sender id (made now if not yet)."""
        return self.table.rows_links.row(self.row)

    @property
    def sources(self) -> IntArray:
        """The sources it holds a label of, sorted: those whose search reached it."""
        return self.table.sources_of(self.row, self.table.places(self.row))

    def label(self, name: str) -> NDArray[np.generic]:
        """Column ``name`` of its labels (``hops``, ``length``, ``pred``, ``via_link``,
        ``sent``, ...) by source (:class:`.labels.LabelTable`)."""
        return np.asarray(getattr(self.table, name)[self.row, self.table.places(self.row)])

    @property
    def finished(self) -> bool:
        """True when this FLS, as a source, has a result for every target."""
        return len(self.targets) > 0 and not self._open

    def resume(self, reach: float, exhausted: IntArray) -> None:
        """Go on in the phase's next pass, from the bucket where this pass paused up to
        ``reach``; its labels stay. ``exhausted`` (sorted ids) are the sources whose search
        labelled every FLS it could reach in the pass that ended.

        As a source, it searches no more for a target shown out of reach (it
        then counts as :attr:`finished`, and its search is closed): every
        target, when its own search is one of those; a target whose search is,
        without its label having reached this FLS, as hops join FLSs both ways.
        """
        self.resumed, self.reach = self.reach, reach
        missing = ~(self._found | self._out_of_reach)
        exhausted = np.asarray(exhausted, dtype=np.int64)
        if sender_rows(np.array([self.fls_id]), exhausted)[0] >= 0:
            self._out_of_reach |= missing
        elif missing.any():
            unreached = (sender_rows(self.targets, exhausted) >= 0) & (
                sender_rows(self.targets, self.sources) < 0
            )
            self._out_of_reach |= missing & unreached
        self._open = int(np.count_nonzero(~(self._found | self._out_of_reach)))

    def close(self, sources: IntArray) -> None:
        """Stop relaying the labels of ``sources`` (their searches ended)."""
        self.table.close(sources)

    def offer(self, round_: int) -> Offer:
        """The labels due in round ``round_`` (each is final); they count as sent.

        Picked here, or with the other FLSs of a process (:func:`.together.pick_together`).
        """
        picked, self._picked = self._picked, None
        offer = picked[1] if picked is not None and picked[0] == round_ else self._pick(round_)
        offer.finished = self.finished
        offer.reading_ids, offer.reading_vectors = self._first_readings()
        return offer

    def _pick(self, round_: int) -> Offer:
        """Its offer of round ``round_``, picked alone."""
        table, row = self.table, self.row
        bucket = self.resumed + round_
        mine, due, unsent, beyond_rows, beyond = due_places(
            table, row, self.order, self.width, bucket, self.reach
        )
        if not table.direct:  # by source, as sent
            due = due[np.argsort(table.keys[row, due], kind="stable")]
        table.sent[row, due] = True
        # Beyond the reach, every label below it sent, the unsent are held, none pending.
        pending = len(due) < unsent[0] and bucket < self.reach
        return offers_of(
            table, self.book, np.array([row]), (mine, due), (beyond_rows, beyond), [pending]
        )[0]

    def _first_readings(self) -> tuple[IntArray, FloatArray]:
        """This FLS's readings, for its first offer of the phase only; none after."""
        if self._readings is None:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
        hops, self._readings = self._readings, None
        return hops.readings()

    def _take_results(
        self, heard: RoundOffers, labels: IntArray, paths: tuple[IntArray, IntArray]
    ) -> None:
        """Record the results that ``labels`` of ``heard`` (this source's, from targets) bring,
        with their ``paths`` (offsets, ids); ``labels`` are one or more."""
        targets = heard.senders_of(labels)
        rows = np.searchsorted(self.targets, targets)
        self._found[rows] = True
        self._unfound -= len(labels)
        self._open -= int(np.count_nonzero(~self._out_of_reach[rows]))
        self.results.add(
            targets,
            heard.lengths[labels],
            heard.errors[labels],
            heard.vectors[labels],
            paths,
            heard.unbiased[labels] if self.fits else None,
            heard.covariances[labels] if self.fits else None,
        )

    def hear(self, heard: RoundOffers) -> None:
        """Take a round's offers at once: record results, relax labels through the hops.

        Each source's label becomes the best of its own and every candidate
        (a heard label plus the hop from its sender) under the order
        (primary cost, secondary cost, sender id). That order is total, so the
        outcome is the one of hearing the offers one by one, in any order.
        Offers already heard with the other FLSs of a process
        (:func:`.together.hear_together`) are not heard again.
        """
        if self._last_heard is heard:
            return
        self._hear_first(heard)
        if not len(heard.source_ids):  # no label to relax: its hops need not be made
            return
        rows = np.array([self.row])
        starts, changes = self.table.relax(rows, self.order, heard_labels(heard))
        take_changes(self.table, self.book, self.fit, heard, rows, starts, changes)

    def _hear_first(self, heard: RoundOffers) -> None:
        """What hearing ``heard`` takes before the relaxation: results and readings."""
        self._last_heard = heard
        if self._unfound:
            # A target's label of this source: its result (a sender offers a label once).
            missing = self.targets[~self._found]
            mine = _labels_for(self.fls_id, missing, heard.senders, heard.starts, heard.source_ids)
            if len(mine):
                paths = csr.take(heard.path_offsets, heard.path_ids, mine)
                self._take_results(heard, mine, paths)
        if len(heard.read_ids):
            self._take_readings(heard)

    def _take_readings(self, heard: RoundOffers) -> None:
        """The readings ``heard`` brings of the hops to this FLS, from their senders."""
        senders, readings = heard.readings_of(self.fls_id)
        if len(senders):
            # The senders' own readings of the hops to this FLS.
            links = self.links
            rows = np.searchsorted(links.ids, senders)
            known = (rows < len(links.ids)) & (
                links.ids[np.minimum(rows, len(links.ids) - 1)] == senders
            )
            links.vectors[rows[known]] = readings[known]


def take_changes(
    table: LabelTable,
    book: OffersHeard,
    fit: tuple[Sensor, float] | None,
    heard: RoundOffers,
    rows: IntArray,
    starts: IntArray,
    changes: Changes,
) -> None:
    """Labels of ``table`` bettered by ``heard`` (the relaxation of ``rows`` gave ``starts``
    and ``changes``): the offers, labels and links their paths and vectors are read from
    follow the winners.

    ``fit`` (the sensor and the FLSs' radius, cm) in a fitting run: the labels'
    unbiased sums and covariances follow too.
    """
    if not len(changes.places):
        return
    changed = np.repeat(rows, np.diff(starts))
    _follow(
        changed, changes.places, changes.labels, changes.links, book.key(heard),
        table.via_offers, table.via_label, table.via_link,
    )  # fmt: skip
    if fit is not None:
        links = table.link_starts[changed] + changes.links  # into the table's links
        sensor, radius = fit
        hop = table.links.vectors[links]
        unbiased, covariance = hop_fit(sensor, radius, hop, table.links.weights[links])
        table.unbiased[changed, changes.places] = heard.unbiased[changes.labels] + unbiased
        table.covariance[changed, changes.places] = heard.covariances[changes.labels] + covariance


@jit.kernel(cache=True, nogil=True)
def _follow(
    rows: IntArray, places: IntArray, labels: IntArray, links: IntArray, key: int,
    via_offers: IntArray, via_label: IntArray, via_link: IntArray,
) -> None:  # fmt: skip
    """The labels at (``rows``, ``places``) of a table (its columns ``via_offers``,
    ``via_label``, ``via_link``) won through heard ``labels`` of the offers ``key`` and
    their rows' ``links`` (each within its row): what their paths and vectors are read
    from when they are sent (:func:`.heard.offers_of`). One compiled pass: numpy scatters
    millions of changes a round into (F, R) columns several times slower."""
    for change in range(len(places)):
        row, place = rows[change], places[change]
        via_offers[row, place], via_label[row, place] = key, labels[change]
        via_link[row, place] = links[change]


def heard_labels(heard: RoundOffers) -> HeardLabels:
    """The labels of ``heard`` as the relaxation reads them (:mod:`.labels`)."""
    return HeardLabels(
        heard.senders, heard.starts, heard.source_ids, heard.hops, heard.lengths, heard.errors
    )


def phase_targets(phase: int, blind: IntArray, sweet_results: Results) -> IntArray:
    """A source's targets in ``phase``: blind neighbours (in SD_vis: without S_vis path)."""
    blind = np.asarray(blind, dtype=np.int64)
    if phase == ANY_VISIBLE:
        return blind[sweet_results.rows(blind) < 0]
    return blind


def radio_window(view: LocalView) -> IntArray:
    """(W,) the FLSs an FLS hears: itself, then its radio neighbours (blind and sweet), ids."""
    radio = np.isin(view.range_class, (BLIND, SWEET))
    return np.concatenate([[view.fls_id], view.other[radio]]).astype(np.int64)
