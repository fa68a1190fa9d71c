"""The relay's and the source's machines of a track, tick by tick, in nanoseconds."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.estimators import TrackingError
from swazure_ros.core.relay import RELAY_OK, RELAY_TARGET_LOST
from swazure_ros.core.tracking import ENDED, TIMED_OUT, TRACKING, TrackConfig
from swazure_ros.protocol.tracking import (
    START_RELAY,
    STOP_RELAY,
    RelayRequest,
    RelayStreams,
    Sample,
    StreamBound,
    TrackReport,
    TrackSource,
)

MS = 1_000_000
CONFIG = TrackConfig(frame_period=0.1, communication_delay=0.25, timeout=1.0)


def moving(source, target, seconds):
    """The target flies along x at 2 cm/s."""
    return RELAY_OK, np.array([2.0 * seconds, 0.0, 0.0])


def test_a_relay_senses_each_frame_at_its_own_time_and_releases_it_after_the_delay():
    relay = RelayStreams(1, moving, CONFIG)
    relay.on_request(RelayRequest(START_RELAY, 0, 1, 2, start=50 * MS))
    assert relay.tick(40 * MS) == [] and not relay.due(40 * MS)
    assert relay.tick(250 * MS) == []  # frames at 50, 150 and 250 ms wait for their delay
    assert relay.due(300 * MS)
    released = relay.tick(420 * MS)  # 50 + 250 and 150 + 250 are past, 250 + 250 is not
    assert [sample.sensed for sample in released] == [50 * MS, 150 * MS]
    assert released[1].position.tolist() == [0.3, 0.0, 0.0]
    relay.on_request(RelayRequest(STOP_RELAY, 0, 1, 2, start=0))
    assert relay.tick(10_000 * MS) == [] and len(relay) == 0


def test_a_relay_that_loses_the_target_sends_one_last_sample_and_stops():
    def lost_after_100ms(source, target, seconds):
        return (RELAY_OK, np.zeros(3)) if seconds < 0.1 else (RELAY_TARGET_LOST, np.ones(3))

    relay = RelayStreams(1, lost_after_100ms, TrackConfig(frame_period=0.1))
    relay.on_request(RelayRequest(START_RELAY, 0, 1, 2, start=0))
    samples = relay.tick(1000 * MS)
    assert [sample.status for sample in samples] == [RELAY_OK, RELAY_TARGET_LOST]
    assert np.isnan(samples[1].position).all() and len(relay) == 0


def source(relays=(1,), successor=None):
    return TrackSource(
        0,
        CONFIG,
        lambda target, seconds: relays[0] if relays else None,
        lambda target, relay, seconds: successor,
    )


def sample(sensed_ms, status=RELAY_OK, relay=1):
    return Sample(0, relay, 2, status, np.array([0.002 * sensed_ms, 0, 0]), sensed_ms * MS)


def test_a_source_estimates_the_present_and_times_a_silent_stream_out_once():
    tracker = source()
    (request,) = tracker.begin(2, "constant-velocity", 0)
    assert (request.command, request.relay, request.start) == (START_RELAY, 1, 0)
    reports = [out for ms in range(0, 600, 100) for out in tracker.on_sample(sample(ms))]
    assert all(isinstance(report, TrackReport) for report in reports)
    last = reports[-1].estimate
    assert last.status == TRACKING and last.time == pytest.approx(0.75)  # 0.5 s + the delay
    assert last.kalman.velocity[0] == pytest.approx(2.0, abs=1e-3)
    assert tracker.tick(1500 * MS) == []  # 1.0 s after the last sample: not yet
    (timed_out,) = tracker.tick(1501 * MS)
    assert timed_out.estimate.status == TIMED_OUT and timed_out.estimate.kalman is None
    assert tracker.tick(5000 * MS) == [] and tracker.on_sample(sample(600)) == []


def test_a_lost_stream_is_handed_over_or_ends():
    tracker = source(successor=3)
    tracker.begin(2, "constant-velocity", 0)
    tracker.on_sample(sample(0))
    (handover,) = tracker.on_sample(sample(100, RELAY_TARGET_LOST))
    assert (handover.command, handover.relay, handover.start) == (START_RELAY, 3, 350 * MS)
    assert tracker.on_sample(sample(200)) == []  # the old relay's: handed over
    assert tracker.on_sample(sample(350, relay=3))[0].estimate.relay == 3
    ending = source(successor=None)
    ending.begin(2, "constant-velocity", 0)
    (ended,) = ending.on_sample(sample(0, RELAY_TARGET_LOST))
    assert ended.estimate.status == ENDED and "lost sight" in ended.estimate.message


def test_a_track_needs_a_relay_and_a_second_track_stops_the_first():
    with pytest.raises(TrackingError, match="no sweet neighbour of FLS 0 sees FLS 2"):
        source(relays=()).begin(2, "constant-velocity", 0)
    with pytest.raises(TrackingError, match="sees FLS 0"):
        source().begin(0, "constant-velocity", 0)
    tracker = source()
    tracker.begin(2, "constant-velocity", 0)
    stop, start = tracker.begin(2, "constant-acceleration", 100 * MS)
    assert (stop.command, start.command, start.start) == (STOP_RELAY, START_RELAY, 100 * MS)


def test_a_process_relays_a_bounded_number_of_streams_and_a_new_one_stops_the_oldest():
    bound = StreamBound(most=3)
    running = {(1, 0, 2), (1, 0, 3), (4, 5, 6)}
    for stream in sorted(running):
        assert bound.started(stream, running.__contains__) == []
    # A fourth stream stops the oldest; one started again counts as new.
    assert bound.started((1, 0, 2), running.__contains__) == []
    running.add((7, 8, 9))
    assert bound.started((7, 8, 9), running.__contains__) == [(1, 0, 3)]
    running.discard((1, 0, 3))
    # A stream that ended by itself (its target out of sight) or was stopped frees its place.
    running.discard((4, 5, 6))
    bound.stopped((1, 0, 2))
    running.discard((1, 0, 2))
    for stream in [(2, 0, 1), (3, 0, 1)]:
        running.add(stream)
        assert bound.started(stream, running.__contains__) == []
    running.add((9, 9, 9))
    assert bound.started((9, 9, 9), running.__contains__) == [(7, 8, 9)]


def test_a_relay_tells_which_streams_it_relays():
    relay = RelayStreams(1, moving, CONFIG)
    relay.on_request(RelayRequest(START_RELAY, 0, 1, 2, start=50 * MS))
    assert relay.relays(0, 2) and not relay.relays(2, 0)
    relay.on_request(RelayRequest(STOP_RELAY, 0, 1, 2, start=0))
    assert not relay.relays(0, 2) and len(relay) == 0
