"""Tracking a neighbour out of sight through a relay, as two state machines (spec, section 9).

:class:`RelayStreams` is a relay's side: for each stream it was asked to
relay, it senses the target every frame, at the frame's own time
(``start + k * frame_period`` in whole nanoseconds, so that scheduling never
changes a number), and holds each sample for the known sensing and
communication delay. :class:`TrackSource` is the source's side: it picks the
relay, turns every sample into an estimate of the present
(:class:`~swazure_ros.core.tracking.Track`), hands a lost stream over to
another relay that sees the target, and times a silent stream out.

Time is the ROS clock's integer nanoseconds. The FLS nodes drive both
machines from their clock (simulated time in a track run), and
:func:`~swazure_ros.protocol.loops.simulate_track` drives the same machines
in one loop, so the two give the same numbers to the bit.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ..core.arrays import FloatArray
from ..core.estimators import TrackingError
from ..core.relay import RELAY_MESSAGES, RELAY_OK, RelaySenses
from ..core.tracking import (
    ENDED,
    TIMED_OUT,
    MotionEstimate,
    Track,
    TrackConfig,
    arrival,
    nanoseconds,
)

# Track request commands; the values equal TrackRequest's COMMAND_*.
START_RELAY, STOP_RELAY = 0, 1
#: Streams one process relays at once, all its FLSs' together: each senses its target and
#: sends a sample every frame for as long as the target stays in sight, so a request
#: that anyone may send must not start work without end.
RELAYED_STREAMS = 4
#: A relayed stream: (relay, source, target) FLS ids.
Stream = tuple[int, int, int]

#: sense(source, target, seconds) -> (RELAY_* status, (3,) cm): what the relay samples.
Sense = Callable[[int, int, float], tuple[int, FloatArray]]
#: choose(target, seconds) -> the relay for the source to track ``target`` then, or None.
ChooseRelay = Callable[[int, float], "int | None"]
#: handover(target, relay, seconds) -> the relay to take ``relay``'s stream over, or None.
NextRelay = Callable[[int, int, float], "int | None"]


def relay_sense(
    senses: RelaySenses, relay: int, source: int, target: int, seconds: float
) -> tuple[int, FloatArray]:
    """What ``relay`` samples of ``target`` for ``source`` at ``seconds``: a :data:`Sense`."""
    return senses.track_sample(source, relay, target, seconds)


def source_senses(senses: RelaySenses, source: int) -> tuple[ChooseRelay, NextRelay]:
    """The relay choice and handover of source FLS ``source``, for :class:`TrackSource`."""
    return partial(senses.choose_relay, source), partial(senses.next_relay, source)


@dataclass(frozen=True)
class Sample:
    """One relayed sample (a TrackSample message): status and relative position, cm."""

    source: int
    relay: int
    target: int
    status: int  # RELAY_*
    position: FloatArray  # (3,), NaN unless RELAY_OK
    sensed: int  # ns, when the relay's camera sensed it


@dataclass(frozen=True)
class TrackProgressReport:
    """One FLS's part in a track run (a TrackProgress message), for the driver of its clock.

    ``traffic`` counts requests_sent/heard, samples_sent/heard and
    estimates_sent; ``due``: a relay frame or sample due by ``time`` is still to go.
    """

    fls_id: int
    time: int  # ns on the FLS's clock
    traffic: Counter[str]
    due: bool


@dataclass(frozen=True)
class RelayRequest:
    """A source asks a relay to start (from ``start`` ns) or stop a stream (a TrackRequest)."""

    command: int  # START_RELAY or STOP_RELAY
    source: int
    relay: int
    target: int
    start: int  # ns: the relay's first frame


@dataclass(frozen=True)
class TrackReport:
    """A source's estimate of its target at one present (a TrackEstimate message)."""

    source: int
    target: int
    model: str
    estimate: MotionEstimate


@dataclass
class _Stream:
    source: int
    target: int
    next_frame: int  # ns
    outbox: deque[tuple[int, Sample]] = field(default_factory=deque)  # (release ns, sample)
    ended: bool = False


class RelayStreams:
    """The streams that FLS ``relay_id`` relays, sensing with ``sense``."""

    def __init__(self, relay_id: int, sense: Sense, config: TrackConfig) -> None:
        self.relay_id = relay_id
        self._sense = sense
        self._period = nanoseconds(config.frame_period)
        self._delay = nanoseconds(config.delay)
        self._streams: dict[tuple[int, int], _Stream] = {}

    def __len__(self) -> int:
        return len(self._streams)

    def relays(self, source: int, target: int) -> bool:
        """Whether a stream of ``target`` to ``source`` is relayed now."""
        return (source, target) in self._streams

    def on_request(self, request: RelayRequest) -> None:
        """Start a stream (its first frame at ``request.start`` ns) or stop one."""
        key = (request.source, request.target)
        if request.command == STOP_RELAY:
            self._streams.pop(key, None)
        else:
            self._streams[key] = _Stream(*key, next_frame=request.start)

    def due(self, now: int) -> bool:
        """True when a frame or a release is due by ``now`` ns: :meth:`tick` has work."""
        return any(
            (not stream.ended and stream.next_frame <= now)
            or (bool(stream.outbox) and stream.outbox[0][0] <= now)
            for stream in self._streams.values()
        )

    def tick(self, now: int) -> list[Sample]:
        """Sense every frame due by ``now`` ns; return the samples whose delay has passed."""
        released = []
        for key, stream in list(self._streams.items()):
            # Frame by frame at their own times, even if the clock jumped past several.
            while not stream.ended and stream.next_frame <= now:
                status, position = self._sense(
                    stream.source, stream.target, stream.next_frame / 1e9
                )
                sample = Sample(
                    stream.source,
                    self.relay_id,
                    stream.target,
                    status,
                    np.asarray(position, dtype=np.float64)
                    if status == RELAY_OK
                    else np.full(3, np.nan),
                    stream.next_frame,
                )
                stream.outbox.append((stream.next_frame + self._delay, sample))
                stream.ended = status != RELAY_OK
                stream.next_frame += self._period
            while stream.outbox and stream.outbox[0][0] <= now:
                released.append(stream.outbox.popleft()[1])
            if stream.ended and not stream.outbox:
                del self._streams[key]
        return released


class StreamBound:
    """The streams one process relays, oldest first: ``most`` at once, a new one stops the oldest.

    A stream lasts while its target stays in sight, and a request to start one
    may be anyone's (without the swarm's key, anyone can send it): past the
    bound, the oldest stream stops, so that what a flood of requests leaves
    behind is ``most`` streams at most, and a source whose stream was stopped
    sees its track time out and may ask again.
    """

    def __init__(self, most: int = RELAYED_STREAMS) -> None:
        self.most = most
        self._order: dict[Stream, None] = {}  # oldest first

    def started(self, stream: Stream, running: Callable[[Stream], bool]) -> list[Stream]:
        """``stream`` started (or again): the streams to stop to keep within the bound.

        ``running(stream)``: whether a stream is still relayed (one ends by
        itself when its target leaves the relay's sight, or by its source's STOP).
        """
        self._order.pop(stream, None)
        self._order[stream] = None
        if len(self._order) <= self.most:
            return []
        self._order = {one: None for one in self._order if running(one)}
        stop = []
        while len(self._order) > self.most:
            oldest = next(iter(self._order))
            del self._order[oldest]
            stop.append(oldest)
        return stop

    def stopped(self, stream: Stream) -> None:
        """``stream`` stopped at its source's request."""
        self._order.pop(stream, None)


class TrackSource:
    """The tracks of source FLS ``fls_id``: one stream per target, each through a relay."""

    def __init__(
        self, fls_id: int, config: TrackConfig, choose: ChooseRelay, handover: NextRelay
    ) -> None:
        self.fls_id = fls_id
        self.config = config
        self._choose = choose
        self._handover = handover
        self.tracks: dict[int, Track] = {}  # target id -> its stream

    def begin(self, target: int, model: str, now: int) -> list[RelayRequest]:
        """Track ``target`` with filter ``model`` from ``now`` ns; TrackingError if no relay can.

        A track of the same target already running is stopped first.
        """
        relay = None if target == self.fls_id else self._choose(target, now / 1e9)
        if relay is None:
            raise TrackingError(f"no sweet neighbour of FLS {self.fls_id} sees FLS {target}")
        requests = []
        if target in self.tracks:
            requests.append(self._request(STOP_RELAY, self.tracks[target].relay, target, now))
        config = replace(self.config, model=model)
        self.tracks[target] = Track(config.tracker(), config.timeout, relay)
        requests.append(self._request(START_RELAY, relay, target, now))
        return requests

    def relay(self, target: int) -> int:
        """The FLS relaying ``target`` now."""
        return self.tracks[target].relay

    def on_sample(self, sample: Sample) -> list[RelayRequest | TrackReport]:
        """Take a relayed sample: the estimate of the present, or a handover to another relay."""
        track = self.tracks.get(sample.target)
        if track is None or track.relay != sample.relay:
            return []  # a stream this FLS stopped, or handed over
        sensed = sample.sensed / 1e9
        # The delay is known: the present is the sensing time plus the delay.
        present = arrival(sensed, self.config)
        if sample.status == RELAY_OK:
            try:
                track.add(sensed, sample.position)
            except TrackingError:
                return []  # out of order; the relay sends in order, so a duplicate
        else:
            successor = self._handover(sample.target, track.relay, present)
            if successor is not None:
                track.handover(successor)
                start = nanoseconds(present)
                return [self._request(START_RELAY, successor, sample.target, start)]
            track.end(RELAY_MESSAGES.get(sample.status, "the relay ended the stream"))
        return [self._report(sample.target, present)]

    def tick(self, now: int) -> list[TrackReport]:
        """At ``now`` ns: the streams that just timed out, each with its last estimate."""
        seconds = now / 1e9
        return [
            self._report(target, seconds)
            for target, track in list(self.tracks.items())
            if track.check(seconds)
        ]

    def _report(self, target: int, present: float) -> TrackReport:
        track = self.tracks[target]
        estimate = track.estimate(present)
        if estimate.status in (ENDED, TIMED_OUT):
            del self.tracks[target]
        return TrackReport(self.fls_id, target, track.tracker.model, estimate)

    def _request(self, command: int, relay: int, target: int, start: int) -> RelayRequest:
        return RelayRequest(command, self.fls_id, relay, target, start)
