"""One FLS's state machine over whole discovery runs.

:class:`Participant` takes the coordinator's :class:`~.messages.Control`
messages and the neighbours' offers, and returns broadcasts and reports. The
FLS nodes and the in-memory loop (:mod:`..loops`) both drive it. A run
(:class:`FlsRun`) goes phase after phase, one :class:`~.search.PathSearch`
each, and ends in the source's estimates, fitted when the run fits.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ...core.arrays import FloatArray, IntArray
from ...core.evaluation import ABORTED, DECAYING_PATH, REASON_COORDINATOR_LOST, SWEET_PATH
from ...core.fit import LOCAL_LEAST_SQUARES, PATH, SWARM_FIT
from ...core.hop_errors import hop_error
from ...core.observe import LocalView, NearView
from ...core.sensor import Sensor
from ...core.window_fit import Heard, window_fit
from ..fit_shares import fitted_estimates
from ..fit_together import FitRows, fit_together
from ..readings import ReadingsBook
from ..swarm_fit import FitPart
from .buckets import bucket_width, reach_rounds
from .estimate import Estimate, Estimates, Results, estimates_of, estimates_of_sources
from .messages import (
    ANY_VISIBLE,
    END,
    FIT,
    PHASES,
    ROUND,
    START,
    SWEET_VISIBLE,
    Broadcast,
    Control,
    FitBlock,
    Report,
    RoundOffers,
    fit_offer,
)
from .search import (
    PathSearch,
    SearchOptions,
    ViewOf,
    phase_targets,
    radio_window,
    reads_both_ends,
)
from .together import close_together, hear_together, pick_together

#: Discovery runs an FLS takes part in at once, at most: its coordinator runs one at a
#: time, and a run id that a peer made up must not hold memory for ever.
RUNS_KEPT = 4


@dataclass(frozen=True)
class RunView:
    """What one FLS's run knows of its neighbours.

    ``view`` holds its blind and sweet neighbours at least, and ``hop_errors``
    (K,) the expected error of the hop to each. ``whole``, if given, gives the
    view with its decaying neighbours too and their hop errors, taken when the
    decaying phase first relays or the FIT phase starts: on a display most
    rows are decaying ones, which a share lays out on demand.
    """

    view: LocalView
    hop_errors: FloatArray | None = None
    whole: ViewOf | None = None


class FlsRun:
    """One FLS's part of one discovery run, phase after phase.

    ``targets`` are the FLS's targets as a source: its blind neighbours by
    default, none when it is not a source of the run. ``seen``: what it knows
    of its neighbours (:class:`RunView`).
    """

    def __init__(
        self,
        seen: RunView,
        policy: str,
        width: float,
        id_space: int,
        targets: IntArray | None,
        fit: tuple[Sensor, float] | None = None,
        both_ends: bool = False,
        sources: IntArray | None = None,
        estimator: str | None = None,
    ) -> None:
        self.view = seen.view
        self._whole = seen.whole
        self._whole_taken: tuple[LocalView, FloatArray | None] | None = None
        self.sources = sources
        self.hop_errors = seen.hop_errors
        self.fit = fit
        self.both_ends = both_ends
        self.estimator = estimator or (PATH if fit is None else LOCAL_LEAST_SQUARES)
        # The swarm's fit (a run whose estimator is swarm-fit), from its FIT phase on.
        self.fit_part: FitPart | None = None
        self.policy = policy
        self.width = width
        self.id_space = id_space
        self.targets = targets
        self.results: dict[int, Results] = {phase: Results() for phase in PHASES}
        self.search: PathSearch | None = None
        self.departed: frozenset[int] = frozenset()
        # Its estimates at END, made with the other FLSs of its process (and the sensor).
        self._made: tuple[Sensor | None, Estimates] | None = None
        # Its estimates from the swarm's fit, made so too.
        self._fitted: tuple[Sensor, Estimates] | None = None

    def start_fit(
        self, sensor: Sensor, radius: float, departed: frozenset[int], warm: Sequence[FloatArray]
    ) -> FitPart:
        """Begin (or restart) the FIT phase, from ``warm`` positions (per fit) if any."""
        self.departed = departed
        self.search = None
        before = self.fit_part
        if before is not None:  # a restart: from where the solves had come
            warm = [layer.position[:, 0] for layer in before.layers if layer is not None]
        self.fit_part = FitPart(self.whole_view()[0], sensor, radius, departed, warm or None)
        return self.fit_part

    def whole_view(self) -> tuple[LocalView, FloatArray | None]:
        """Its view with every neighbour, decaying ones too, and their hop errors (taken
        once, when first asked for)."""
        if self._whole_taken is None:
            whole = self._whole
            self._whole_taken = (self.view, self.hop_errors) if whole is None else whole()
        return self._whole_taken

    def swarm_fitted(self, sensor: Sensor, heard: RoundOffers | None) -> Estimates:
        """The estimates with each pair's vector from the swarm's fit (its SHARE round):
        made with the other FLSs of its process (:func:`step_together`), or made here
        (:func:`..fit_shares.fitted_estimates`). A target whose share was not heard
        keeps its path."""
        made, self._fitted = self._fitted, None
        if made is not None and made[0] is sensor:
            return made[1]
        estimates = self.estimates(sensor)
        part = self.fit_part
        if part is None or heard is None or not len(estimates):
            return estimates
        return fitted_estimates([estimates], [part.shared()], sensor, heard)[0]

    def start(
        self,
        phase: int,
        departed: frozenset[int],
        reach: float = math.inf,
        reach_pass: int = 0,
        exhausted: IntArray | None = None,
    ) -> PathSearch:
        """Begin (or restart) pass ``reach_pass`` of ``phase``, relaying ``reach`` rounds.

        A first pass drops the phase's earlier results and labels. A later
        pass resumes the searches where the last paused (``exhausted``: the
        sources whose search it ran to the end; :meth:`.search.PathSearch.resume`).
        """
        self.departed = departed
        last = self.search
        if reach_pass > 0 and last is not None and last.results is self.results[phase]:
            last.resume(reach, np.zeros(0, dtype=np.int64) if exhausted is None else exhausted)
            return last
        targets = None
        if self.targets is not None:
            wanted = phase_targets(phase, self.targets, self.results[SWEET_VISIBLE])
            if departed:  # most runs: none, and an isin of nothing costs as much
                wanted = wanted[~np.isin(wanted, list(departed))]
            targets = wanted if len(wanted) else None
        options = SearchOptions(
            self.policy,
            self.width,
            self.id_space,
            self.hop_errors,
            self.fit,
            self.both_ends,
            self.sources,
            reach,
        )
        # The decaying phase relays over the decaying neighbours too, made when first needed.
        view_of = self.whole_view if phase == ANY_VISIBLE and self._whole is not None else None
        self.search = PathSearch(self.view, phase, options, targets, departed, view_of)
        self.results[phase] = self.search.results
        return self.search

    def live_targets(self) -> IntArray:
        """Its targets that have not departed, in target order."""
        targets = np.zeros(0, dtype=np.int64) if self.targets is None else self.targets
        return targets[~np.isin(targets, list(self.departed))] if self.departed else targets

    def estimates(self, sensor: Sensor | None = None) -> Estimates:
        """The estimate for every target that has not departed, in target order: those
        made with the other FLSs of its process (:func:`step_together`), or made here."""
        made, self._made = self._made, None
        if made is not None and made[0] is sensor:
            return made[1]
        sweet, radio, decaying = (self.results[phase] for phase in PHASES)
        return estimates_of(self.live_targets(), sweet, radio, decaying, sensor)

    def fitted(self, sensor: Sensor, radius: float, heard: Heard) -> Estimates:
        """The estimates with each pair's vector from this source's fit of ``heard``.

        As the engine's ``--estimator local-least-squares`` makes them
        (:func:`~swazure_ros.core.window_fit.window_fit`): the window is the source
        and its radio neighbours; a target that the window does not join to
        the source keeps its path, summed less the known bias.
        """
        estimates = list(self.estimates(sensor))
        with_path = [one for one in estimates if one.status in (SWEET_PATH, DECAYING_PATH)]
        if not with_path:
            return Estimates.of(estimates)
        targets = np.array([one.target for one in with_path], dtype=np.int64)
        sweet = np.array([one.status == SWEET_PATH for one in with_path], dtype=bool)
        vectors, covariances, _ = window_fit(
            sensor, radius, radio_window(self.view), heard, targets, sweet
        )
        fits: dict[int, Estimate] = {}
        for one, vector, covariance in zip(with_path, vectors, covariances, strict=True):
            if np.isnan(vector).any():
                phase = SWEET_VISIBLE if one.status == SWEET_PATH else ANY_VISIBLE
                found = self.results[phase].get(one.target)
                if found is None or found.unbiased is None or found.covariance is None:
                    continue  # a label from a run that does not fit (forged): the path's own
                vector, covariance = found.unbiased, found.covariance
            fits[one.target] = replace(
                one,
                vector=vector,
                covariance=covariance,
                predicted_error=float(np.sqrt(np.trace(covariance))),
                estimator=LOCAL_LEAST_SQUARES,
            )
        return Estimates.of([fits.get(one.target, one) for one in estimates])


class Participant:
    """One FLS's part of every discovery run: controls and offers in, broadcasts and reports out.

    ``view()`` tells what the FLS knows of its neighbours when a run starts;
    ``near_view()``, if given, the same with its blind and sweet neighbours
    only, and how to take the whole view of the same moment (None: take
    ``view()``): a run starts from it, and takes the whole view only when its
    decaying phase first relays or its FIT phase starts;
    ``sensor`` and ``radius`` (cm) what each hop may cost (bucket widths, hop
    errors), and ``id_space`` bounds the FLS ids. ``readings`` holds what the
    FLS has heard of other FLSs' cameras: a source of a fitting run reports
    once it has heard its whole window (:meth:`waiting_reports`).
    """

    def __init__(
        self,
        fls_id: int,
        view: Callable[[], LocalView],
        sensor: Sensor,
        radius: float,
        id_space: int,
        readings: ReadingsBook | None = None,
        near_view: Callable[[], NearView | None] | None = None,
    ) -> None:
        self.fls_id = fls_id
        self._view = view
        self._near_view = near_view
        self.sensor = sensor
        self.radius = radius
        self.id_space = id_space
        self.readings = ReadingsBook() if readings is None else readings
        self.runs: dict[int, FlsRun] = {}
        # Fitting runs that ended while this source had not heard its whole window.
        self.waiting: dict[int, FlsRun] = {}
        # Rounds count on across phases and restarts; buckets count from the phase's start.
        self._first_round: dict[int, int] = {}
        # Per fit, this FLS's position from the last run of the swarm's fit (a warm start).
        self.fit_positions: list[FloatArray] = []

    def on_control(
        self, control: Control, heard: RoundOffers | None = None
    ) -> Broadcast | Report | None:
        """Follow the round clock: START a phase, broadcast a ROUND's labels, report at END.

        ``heard`` are the offers of the rounds since the last control, taken
        first: a label of round k changes only buckets after k, which nobody
        broadcasts before round k + 1.
        """
        run_id = control.run_id
        if control.command == START:
            run = self.runs.get(run_id)
            if run is None:
                while len(self.runs) >= RUNS_KEPT:  # the oldest run is over or forged
                    oldest = next(iter(self.runs))
                    del self.runs[oldest]
                    self._first_round.pop(oldest, None)
                run = self.runs[run_id] = self._new_run(control)
            departed = frozenset(control.departed_ids)
            if control.phase == FIT:
                run.start_fit(self.sensor, self.radius, departed, self.fit_positions)
            else:
                reach = reach_rounds(self.sensor, self.radius, control.policy, control.reach_pass)
                run.start(control.phase, departed, reach, control.reach_pass, control.exhausted)
            self._first_round[run_id] = control.round
            return None
        if control.command == ROUND:
            run = self.runs.get(run_id)
            if run is not None and control.phase == FIT and run.fit_part is not None:
                said = run.fit_part.on_round(control.fit, heard)
                return Broadcast(
                    run_id, control.phase, control.round, self.fls_id, fit_offer(said)
                )
            if run is None or run.search is None:
                return None
            # Closed first: a label of a finished source is never sent, so relaxing
            # the round's labels of it would be work for nothing.
            run.search.close(control.finished)
            if heard is not None:
                run.search.hear(heard)
            offer = run.search.offer(control.round - self._first_round.get(run_id, 0))
            return Broadcast(run_id, control.phase, control.round, self.fls_id, offer)
        if control.command == END:
            run = self.runs.pop(run_id, None)
            self._first_round.pop(run_id, None)
            if run is not None and run.search is not None and heard is not None:
                run.search.hear(heard)
            if run is not None and run.fit_part is not None:
                # The next run starts its solves from this one's positions.
                self.fit_positions = [
                    layer.position[:, 0] for layer in run.fit_part.layers if layer is not None
                ]
            if run is not None and run.targets is not None:
                if run.estimator == SWARM_FIT:
                    return Report(run_id, self.fls_id, run.swarm_fitted(self.sensor, heard))
                if run.estimator == PATH:
                    return Report(run_id, self.fls_id, run.estimates(self.sensor))
                if self.readings.has(radio_window(run.view)):
                    return self._fitted(run_id, run)
                self.waiting[run_id] = run  # its readings are still on their way
        return None

    def waiting_reports(self, at_deadline: bool = False) -> list[Report]:
        """The reports of fitting runs whose source has now heard its whole window.

        ``at_deadline``: every waiting run reports, fitted to what was heard.
        """
        reports = []
        for run_id, run in list(self.waiting.items()):
            if at_deadline or self.readings.has(radio_window(run.view)):
                del self.waiting[run_id]
                reports.append(self._fitted(run_id, run))
        return reports

    def _fitted(self, run_id: int, run: FlsRun) -> Report:
        """Run ``run_id``'s report, fitted to what this FLS has heard of its window."""
        heard = self.readings.heard(radio_window(run.view))
        return Report(run_id, self.fls_id, run.fitted(self.sensor, self.radius, heard))

    def abandon(self) -> list[Report]:
        """Drop every run (their coordinator is gone); a source's targets are ABORTED."""
        reports = [
            Report(
                run_id,
                self.fls_id,
                Estimates.of(
                    [
                        Estimate(target, ABORTED, REASON_COORDINATOR_LOST)
                        for target in run.targets.tolist()
                        if target not in run.departed
                    ]
                ),
            )
            for run_id, run in sorted({**self.runs, **self.waiting}.items())
            if run.targets is not None and len(run.targets)
        ]
        self.runs.clear()
        self.waiting.clear()
        self._first_round.clear()
        return reports

    def _new_run(self, control: Control) -> FlsRun:
        near = None if self._near_view is None else self._near_view()
        view, whole_view = (self._view(), None) if near is None else near
        targets: IntArray | None = view.blind
        if control.source_ids:
            sources = control.sources  # one sorted array for the process's every FLS
            at = np.searchsorted(sources, self.fls_id)
            if at == len(sources) or sources[at] != self.fls_id:
                targets = None
            elif control.target_ids:
                # On demand, a source answers for its blind neighbours only.
                mine = np.asarray(control.source_ids, dtype=np.int64) == self.fls_id
                asked = np.asarray(control.target_ids, dtype=np.int64)[mine]
                targets = asked[np.isin(asked, view.blind)]
        width = bucket_width(self.sensor, self.radius, control.policy)
        hop_errors = hop_error(self.sensor, view.distance, self.radius)
        fit = (self.sensor, self.radius) if control.estimator == LOCAL_LEAST_SQUARES else None
        both_ends = reads_both_ends(self.sensor)
        whole = None if whole_view is None else partial(self._whole_view, whole_view)
        return FlsRun(
            RunView(view, hop_errors, whole),
            control.policy,
            width,
            self.id_space,
            targets,
            fit,
            both_ends,
            control.sources if control.source_ids else None,
            control.estimator,
        )

    def _whole_view(self, taken: Callable[[], LocalView]) -> tuple[LocalView, FloatArray]:
        """Its view with every neighbour (``taken()``), and the expected error of each hop."""
        view = taken()
        return view, hop_error(self.sensor, view.distance, self.radius)


@dataclass
class Stepped:
    """What a process's FLSs did together with one control (:func:`step_together`).

    ``broadcasts``: offers made FLS by FLS, by FLS id; ``block``: a FIT
    round's offers made in one, whose senders have none in ``broadcasts``.
    The FLSs of either are done with the control.
    """

    broadcasts: dict[int, Broadcast] = field(default_factory=dict)
    block: FitBlock | None = None

    def left(self, recipients: list[int]) -> list[int]:
        """Those of ``recipients`` (the FLS ids stepped) with no row in the block: each is
        handed the control itself (a broadcast made here it finds made)."""
        if self.block is None:
            return recipients
        made = set(self.block.senders.tolist())
        if made.issuperset(recipients):  # a packed process's every FLS, each round
            return []
        return [fls_id for fls_id in recipients if fls_id not in made]


def step_together(
    participants: Sequence[Participant], control: Control, heard: RoundOffers | None
) -> Stepped:
    """What each of ``participants`` does first with ``control``, done for all at once: hear
    the offers ``heard`` (:func:`.together.hear_together`), and in a ROUND close the
    finished sources, pick the labels due (:func:`.together.pick_together`) and make each
    FLS's offer; in the FIT phase, step the solve's rounds (:func:`..fit_together.fit_together`).

    Returns the offers made here: the FLSs that made them are done with
    ``control``. A process hands ``control`` to each of its other FLSs
    (:meth:`Participant.on_control`), which then finds the rest done.
    """
    fitting = [
        (participant.fls_id, run.fit_part)
        for participant in participants
        if (run := participant.runs.get(control.run_id)) is not None and run.fit_part is not None
    ]
    fit_round = control.command == ROUND and control.phase == FIT
    made = None
    if fitting:
        made = fit_together(
            [part for _, part in fitting], control.fit if fit_round else None, heard
        )
    stepped = Stepped()
    if control.command not in (ROUND, END):
        return stepped
    if control.command == END and fitting:
        _fitted_together(participants, control.run_id, heard)
    if fit_round:
        # The offers made together go out from here: a Python call per FLS and round is
        # most of what a process spends in the fit's hundreds of rounds.
        if made is not None:
            stepped.block = _fit_block(control, [fls_id for fls_id, _ in fitting], made)
            return stepped
        for fls_id, part in fitting:
            said = part.take_said(control.fit)
            if said is not None:
                stepped.broadcasts[fls_id] = Broadcast(
                    control.run_id, control.phase, control.round, fls_id, fit_offer(said)
                )
        return stepped
    # By the round of the phase: each FLS with its search.
    searches: dict[int, list[tuple[Participant, PathSearch]]] = {}
    for participant in participants:
        run = participant.runs.get(control.run_id)
        if run is not None and run.search is not None:
            round_ = control.round - participant._first_round.get(control.run_id, 0)
            searches.setdefault(round_, []).append((participant, run.search))
    for round_, group in searches.items():
        together = [search for _, search in group]
        if control.command == ROUND:  # as an FLS alone closes them: before it hears
            close_together(together, control.finished)
        if heard is not None:
            hear_together(together, heard)
        if control.command == END:
            _estimate_together([participant for participant, _ in group], control.run_id)
        if control.command == ROUND and pick_together(together, round_, control.finished):
            for participant, search in group:
                stepped.broadcasts[participant.fls_id] = Broadcast(
                    control.run_id,
                    control.phase,
                    control.round,
                    participant.fls_id,
                    search.offer(round_),
                )
    return stepped


def _fit_block(control: Control, senders: list[int], made: FitRows) -> FitBlock:
    """The offers ``made`` by ``senders`` (FLS ids, a row each) in ``control``'s round."""
    ids = np.asarray(senders, dtype=np.int64)
    values, partials = made
    if len(ids) > 1 and not (ids[1:] > ids[:-1]).all():
        order = np.argsort(ids, kind="stable")
        ids, values, partials = ids[order], values[order], partials[order]
    return FitBlock(control.run_id, control.round, ids, values, partials)


def _fitted_together(
    participants: Sequence[Participant], run_id: int, heard: RoundOffers | None
) -> None:
    """The sources among ``participants`` whose run ``run_id`` ends in the swarm's fit make
    their estimates a block at a time (:func:`..fit_shares.fitted_estimates`), for
    :meth:`FlsRun.swarm_fitted`."""
    fitting = [
        participant
        for participant in participants
        if (run := participant.runs.get(run_id)) is not None
        and run.fit_part is not None
        and run.estimator == SWARM_FIT
        and run.targets is not None
    ]
    if heard is None or len(fitting) < 2 or len({id(one.sensor) for one in fitting}) != 1:
        return  # one source, or FLSs whose sensors differ: each makes its own
    _estimate_together(fitting, run_id)
    sensor = fitting[0].sensor
    runs = [participant.runs[run_id] for participant in fitting]
    first, held = 0, 0
    for end, run in enumerate(runs, start=1):
        held += len(run.live_targets())
        if held < FITTED_AT_ONCE and end < len(runs):
            continue
        block = runs[first:end]
        made = fitted_estimates(
            [run.estimates(sensor) for run in block],
            [run.fit_part.shared() for run in block if run.fit_part is not None],
            sensor,
            heard,
        )
        for run, estimates in zip(block, made, strict=True):
            run._fitted = (sensor, estimates)
        first, held = end, 0


#: The most targets whose estimates a process's sources fit in one call: each holds its
#: target's share and the source's, two fits' positions and 64 samples (6.2 kB).
FITTED_AT_ONCE = 1 << 14


#: The most targets that a process's sources estimate in one call: the call joins their
#: results in a copy, bounded so (the race car's 13.8 million pairs would be 0.8 GB).
TARGETS_AT_ONCE = 1 << 16


def _estimate_together(participants: Sequence[Participant], run_id: int) -> None:
    """The sources among ``participants`` make their estimates of run ``run_id`` a block of
    them at a time (:func:`.estimate.estimates_of_sources`), for :meth:`FlsRun.estimates`."""
    sources = [
        (run, run.live_targets())
        for participant in participants
        if (run := participant.runs.get(run_id)) is not None and run.targets is not None
    ]
    sensors = {id(participant.sensor) for participant in participants}
    if len(sources) < 2 or len(sensors) != 1:
        return  # one source, or FLSs whose sensors differ: each makes its own
    sensor = participants[0].sensor
    id_space = max(participant.id_space for participant in participants)
    sweet, radio, decaying = PHASES
    first, held = 0, 0
    for end, (_, targets) in enumerate(sources, start=1):
        held += len(targets)
        if held < TARGETS_AT_ONCE and end < len(sources):
            continue
        block = sources[first:end]
        made = estimates_of_sources(
            [targets for _, targets in block],
            [(run.results[sweet], run.results[radio], run.results[decaying]) for run, _ in block],
            id_space,
            sensor,
        )
        for (run, _), estimates in zip(block, made, strict=True):
            run._made = (sensor, estimates)
        first, held = end, 0
