"""The protocols run in one loop, in memory: the same state machines the nodes drive.

:func:`discover` runs distributed discovery (every FLS a
:class:`~.discovery.participant.Participant`, one :class:`~.radio.RadioHub` as the radio
of a single process, the coordinator's :class:`~.rounds.RoundClock`) with
messages handed over in order instead of over DDS. :func:`simulate_track`
runs a track (:class:`~.tracking.TrackSource` and the relays'
:class:`~.tracking.RelayStreams`) on a simulated clock. Neither has a second
copy of an algorithm: the nodes and these loops differ only in how a message
travels.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from ..core.arrays import FloatArray, IntArray
from ..core.estimators import TrackingError
from ..core.fit import PATH
from ..core.fit_measurements import fit_layers
from ..core.frames import through_metres
from ..core.motion import Motion
from ..core.observe import Observations, local_view
from ..core.relay import moving_senses
from ..core.sensor import Sensor
from ..core.tracking import ENDED, TIMED_OUT, TrackConfig, TrackRun, arrival, nanoseconds
from .discovery.messages import END, ROUND, Broadcast, Control, Report
from .discovery.participant import Participant, step_together
from .radio import RadioHub
from .readings import ReadingsBook, readings_of
from .rounds import Outcome, RoundClock
from .tracking import (
    RelayRequest,
    RelayStreams,
    Sample,
    TrackReport,
    TrackSource,
    relay_sense,
    source_senses,
)

_HOST = "memory"


@dataclass(frozen=True)
class RunOptions:
    """Which FLSs an in-memory discovery run asks, and how (see :func:`discover`)."""

    stopped: Iterable[int] = ()  # FLSs that never answer
    sources: Iterable[int] = ()  # the run's sources; every FLS by default
    targets: Iterable[int] = ()  # the sources' targets; their blind neighbours by default
    estimator: str = PATH
    run_id: int = 1


def discover(
    seen: Observations,
    ids: IntArray,
    sensor: Sensor,
    radius: float,
    policy: str,
    options: RunOptions = RunOptions(),
    kept: dict[int, Participant] | None = None,
) -> Outcome:
    """One discovery run over every FLS of ``seen`` (FLS ids ``ids``), with a perfect radio.

    ``options.stopped`` FLSs never answer: the clock declares them departed when a
    round times out, as it does over ROS. ``sensor`` and ``radius`` (cm) are the swarm's.
    Every FLS that answers has heard every other's readings (a fitting ``estimator``).
    ``kept``: the FLSs' machines to run (those of an earlier run, which remember
    it: a warm start), and where this run's are left; new ones by default.
    """
    ids = np.asarray(ids, dtype=np.int64)
    stopped = frozenset(int(fls) for fls in options.stopped)
    id_space = int(ids[-1]) + 1 if len(ids) else 0
    book = _readings_book(seen, ids, stopped)

    def view_of(row: int) -> Participant:
        fls_id = int(ids[row])
        view = partial(local_view, seen, ids, row)
        return Participant(fls_id, view, sensor, radius, id_space, book)

    participants = kept if kept else {
        int(ids[row]): view_of(row) for row in range(len(ids)) if int(ids[row]) not in stopped
    }  # fmt: skip
    if kept is not None:
        kept.update(participants)
    clock = RoundClock(
        options.run_id,
        policy,
        ids.tolist(),
        1,
        1.0,
        sources=tuple(options.sources),
        targets=tuple(options.targets),
        estimator=options.estimator,
        fit_layers=fit_layers(sensor),
    )
    return _run_rounds(clock, RadioHub(participants.keys()), participants)


def _readings_book(seen: Observations, ids: IntArray, stopped: frozenset[int]) -> ReadingsBook:
    """Every answering FLS's readings, as the measurements messages carry them: in metres."""
    book = ReadingsBook()
    for row in range(len(ids)):
        if int(ids[row]) not in stopped:
            read = readings_of(local_view(seen, ids, row))
            book.put(
                replace(
                    read,
                    vector=through_metres(read.vector),
                    distance=through_metres(read.distance),
                )
            )
    return book


def _run_rounds(clock: RoundClock, hub: RadioHub, participants: dict[int, Participant]) -> Outcome:
    """Pass the clock's controls and the FLSs' offers and reports round by round, to the end."""
    controls: deque[Control] = deque(clock.start(0.0))
    while not clock.done:
        if not controls:
            # Everyone who answers has answered: the deadline passes.
            controls.extend(clock.on_tick(math.inf))
            continue
        control = controls.popleft()
        recipients, ack, heard = hub.on_control(control)
        # The FLSs whose offers were made together are done with a ROUND.
        stepped = step_together([participants[fls_id] for fls_id in recipients], control, heard)
        block, made = stepped.block, stepped.broadcasts
        broadcasts: list[Broadcast] = []
        for fls_id in stepped.left(recipients):
            out = made.get(fls_id) or participants[fls_id].on_control(control, heard)
            if isinstance(out, Broadcast):
                broadcasts.append(out)
            elif isinstance(out, Report):
                controls.extend(clock.on_estimates(out.source, out.estimates, 0.0))
        if control.command == END:
            # A stopped FLS's readings never come: the sources that wait for them fit without.
            for participant in participants.values():
                for report in participant.waiting_reports(at_deadline=True):
                    controls.extend(clock.on_estimates(report.source, report.estimates, 0.0))
        if ack is not None:
            controls.extend(clock.on_ack(ack.round, _HOST, 0.0))
        # As on ROS: the process tells the clock who of its FLSs spoke (the clock hears
        # no offer itself), then its radio hears them.
        hub.sent_all(broadcasts)
        if block is not None:
            hub.sent_block(block)
        if control.command == ROUND:
            sent = hub.take_sent(control.run_id, control.round)
            controls.extend(clock.on_sent(control.round, sent, 0.0))
        for ack in (
            hub.on_offers(control.run_id, control.round, broadcasts) if broadcasts else None,
            hub.on_block(block) if block is not None else None,
        ):
            if ack is not None:
                controls.extend(clock.on_ack(ack.round, _HOST, 0.0))
    assert clock.outcome is not None
    return clock.outcome


def simulate_track(
    sensor: Sensor,
    home: FloatArray,
    ids: IntArray,
    radius: float,
    motion: Motion,
    source: int,
    target: int,
    config: TrackConfig,
    duration: float,
) -> TrackRun:
    """Track ``target`` from ``source`` for ``duration`` simulated s; positions (N, 3) cm.

    The clock advances one frame at a time, as :func:`swazure_ros.app.track.run_track`
    advances it over ROS: at each tick the relays sense their due frames and
    release the samples whose delay has passed, the source times out silent
    streams, and then hears the samples (handing a lost stream over).
    Estimates up to the arrival of the sample sensed at ``duration`` are kept.
    """
    rows = np.searchsorted(ids, [source, target])
    if source == target or not all(ids[np.minimum(rows, len(ids) - 1)] == [source, target]):
        raise TrackingError(f"source {source} and target {target} must be two FLSs of the swarm")

    senses = moving_senses(sensor, radius, ids, home, motion)
    relays: dict[int, RelayStreams] = {}

    def deliver(requests: list[RelayRequest], now: int) -> list[Sample]:
        samples = []
        for request in requests:
            relay = request.relay
            if relay not in relays:
                relays[relay] = RelayStreams(relay, partial(relay_sense, senses, relay), config)
            relays[relay].on_request(request)
            # A relay senses as soon as it is asked, as the nodes do.
            samples.extend(relays[relay].tick(now))
        return samples

    tracker = TrackSource(source, config, *source_senses(senses, source))
    pending = deliver(tracker.begin(target, config.model, 0), 0)
    first_relay = tracker.relay(target)
    reports: list[TrackReport] = []
    step = nanoseconds(config.frame_period)
    config.frames(duration)  # bounded before any work
    horizon = nanoseconds(arrival(duration, config))
    for now in range(0, -(-horizon // step) * step + 1, step):
        samples = deque(pending)
        pending = []
        for relay in relays.values():
            samples.extend(relay.tick(now))
        reports.extend(tracker.tick(now))
        while samples:
            for out in tracker.on_sample(samples.popleft()):
                if isinstance(out, RelayRequest):
                    samples.extend(deliver([out], now))
                else:
                    reports.append(out)
        if reports and reports[-1].estimate.status in (ENDED, TIMED_OUT):
            break
    estimates = [r.estimate for r in reports if nanoseconds(r.estimate.time) <= horizon]
    return TrackRun(source, target, first_relay, estimates)
