"""The swarm's own fit, run by the protocol's machines in memory, against the engine's."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate, evaluate_pairs
from swazure_ros.core.evaluation import NO_PATH, Evaluation
from swazure_ros.core.fit import SWARM_FIT, refine
from swazure_ros.core.neighbourhood import without
from swazure_ros.core.observe import observations
from swazure_ros.core.pair_statistics import summarise
from swazure_ros.core.swarm_fit import HUBER, REJECTING
from swazure_ros.protocol.discovery.messages import (
    LABELS,
    POSITIONS,
    RESIDUAL,
    SAMPLES,
    SHARE,
    STEP,
    SUMS,
    WEIGH,
)
from swazure_ros.protocol.loops import RunOptions, discover
from swazure_ros.protocol.swarm_fit import FitSchedule, FitTally, process_sums
from swazure_ros.sim.world import WorldSpec

from ..core.fits import stochastic_sensor


def run(hood, kept=None, **options):
    """One in-memory swarm-fit run over ``hood``: {(source, target): Estimate}, the outcome."""
    outcome = discover(observations(hood), hood.swarm.cloud_index, hood.sensor,
                       hood.swarm.radius, "shortest-length",
                       RunOptions(estimator=SWARM_FIT, **options), kept)  # fmt: skip
    found = {(s, one.target): one for s, ones in outcome.estimates.items() for one in ones}
    return found, outcome


@pytest.mark.parametrize(
    ("shape", "noisy"),
    [("torus:120", True), ("torus:120", False), ("helix", True), ("helix", False)],
    ids=["torus-stochastic", "torus-published", "helix-stochastic", "helix-published"],
)
def test_the_swarm_s_fit_by_messages_equals_the_engine_s(shape, noisy):
    # torus:120 at beta 0.3 has sweet and decaying pairs; the helix's decaying hops join
    # sweet parts, so that the published sensor's two fits differ.
    world = WorldSpec(shape, scale=1.6, beta=0.3).build()
    sensor = stochastic_sensor(mean_error=0.03) if noisy else world.sensor
    engine = refine(evaluate(world.swarm, sensor, "shortest-length"), SWARM_FIT)
    found, outcome = run(engine.hood)
    assert outcome.restarts == 0
    # The same solves, iteration for iteration.
    assert [tuple(one) for one in outcome.fit_iterations] == list(engine.summary.fit.iterations)
    pairs, ids = engine.pairs, world.ids
    assert len(found) == len(pairs)
    with_path = 0
    for pair in range(len(pairs)):
        one = found[(int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))]
        assert one.status == pairs.status[pair]
        if one.status == NO_PATH:
            continue
        with_path += 1
        assert one.estimator == SWARM_FIT
        np.testing.assert_allclose(one.vector, pairs.estimate[pair], rtol=0, atol=1e-9)
        np.testing.assert_allclose(one.covariance, pairs.covariance[pair], rtol=1e-9, atol=1e-15)
    assert with_path > 1000


def test_a_second_run_starts_from_the_first_run_s_positions_and_settles_sooner():
    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    engine = refine(evaluate(world.swarm, stochastic_sensor(), "shortest-length"), SWARM_FIT)
    machines = {}
    _, first = run(engine.hood, kept=machines)
    found, second = run(engine.hood, kept=machines, run_id=2)
    # Its first solve (unit weights) starts at the last run's robust solution, not at zero.
    assert second.fit_iterations[0][0] < first.fit_iterations[0][0]
    assert second.restarts == 0
    pairs, ids = engine.pairs, world.ids
    for pair in np.flatnonzero(pairs.status != NO_PATH)[::50]:
        one = found[(int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))]
        np.testing.assert_allclose(one.vector, pairs.estimate[pair], rtol=0, atol=1e-6)


def test_a_silent_fls_departs_and_the_fit_equals_the_engine_s_without_it():
    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    hood = evaluate(world.swarm, stochastic_sensor(), "shortest-length").hood
    silent_index = 17
    silent = int(world.ids[silent_index])
    found, outcome = run(hood, stopped=[silent])
    assert outcome.departed == frozenset({silent})
    gone = without(hood, np.array([silent_index]))
    plain = evaluate_pairs(gone, "shortest-length")
    summary = summarise(gone, "shortest-length", plain)
    engine = refine(Evaluation(gone, "shortest-length", plain, summary), SWARM_FIT)
    assert [tuple(one) for one in outcome.fit_iterations] == list(engine.summary.fit.iterations)
    pairs, ids = engine.pairs, world.ids
    keep = (pairs.source != silent_index) & (pairs.target != silent_index)
    for pair in np.flatnonzero(keep & (pairs.status != NO_PATH)).tolist():
        one = found[(int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))]
        np.testing.assert_allclose(one.vector, pairs.estimate[pair], rtol=0, atol=1e-9)


def test_process_sums_are_exact_so_any_grouping_gives_the_engine_s_sum():
    rng = np.random.default_rng(2)
    shares = [rng.normal(size=3) * 10.0 ** rng.integers(-8, 8) for _ in range(60)]
    whole = process_sums(shares)
    tally = FitTally()
    for group in (shares[:7], shares[7:31], shares[31:]):
        tally.add(process_sums(group), 0.0, (True, True))
    # Each process's sum is rounded once, so a grouping may differ from the whole by an ulp.
    np.testing.assert_allclose(tally.totals(), whole, rtol=1e-15)
    single = FitTally()
    single.add(whole, 0.0, (True, True))
    assert single.totals().tolist() == list(whole)


def test_the_schedule_goes_labels_solve_weigh_reweigh_samples_share():
    schedule = FitSchedule((True,), samples=2)
    assert schedule.first().stage == LABELS
    quiet, busy = FitTally(), FitTally()
    assert schedule.after(busy, quiet=False).stage == LABELS  # a label still changed
    assert schedule.after(quiet, quiet=True).stage == POSITIONS
    assert schedule.after(quiet, quiet=True).stage == RESIDUAL
    scale = FitTally()
    scale.add((4.0,), 0.0, (True, True))
    assert schedule.after(scale, quiet=True).stage == SUMS
    unsettled = FitTally()
    unsettled.add((1.0, 2.0), 0.0, (True, True))
    step = schedule.after(unsettled, quiet=True)
    assert step.stage == STEP and step.sums == (1.0, 2.0)
    assert schedule.after(quiet, quiet=True).stage == SUMS
    settled = FitTally()
    settled.add((0.0, 1.0), 0.0, (True, True))
    assert schedule.after(settled, quiet=True).stage == POSITIONS
    assert schedule.after(quiet, quiet=True).stage == WEIGH
    changed = FitTally()
    changed.add((), 1.0, (False, False))
    step = schedule.after(changed, quiet=True)
    assert (step.stage, step.mode) == (RESIDUAL, HUBER)
    schedule.after(scale, quiet=True)
    assert schedule.after(settled, quiet=True).stage == POSITIONS
    schedule.after(quiet, quiet=True)
    # Huber's weights repeat: the rejecting ones do not, so they get a solve.
    repeat = FitTally()
    repeat.add((), 1.0, (True, False))
    step = schedule.after(repeat, quiet=True)
    assert (step.stage, step.mode) == (RESIDUAL, REJECTING)
    schedule.after(scale, quiet=True)
    schedule.after(settled, quiet=True)
    schedule.after(quiet, quiet=True)
    step = schedule.after(quiet, quiet=True)  # nothing changed: the covariance's solve
    assert (step.stage, step.mode) == (RESIDUAL, SAMPLES)
    schedule.after(scale, quiet=True)
    assert schedule.after(settled, quiet=True).stage == SHARE
    assert schedule.after(quiet, quiet=True) is None
    assert schedule.iterations == [[1, 0, 0, 0]]


def test_a_neighbour_s_vector_of_another_length_is_not_heard():
    from swazure_ros.core.observe import local_view
    from swazure_ros.protocol.discovery.messages import FitOffer, RoundOffers
    from swazure_ros.protocol.discovery.participant import fit_offer
    from swazure_ros.protocol.swarm_fit import FitPart

    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    hood = evaluate(world.swarm, stochastic_sensor(), "shortest-length").hood
    view = local_view(observations(hood), world.ids, 0)
    part = FitPart(view, hood.sensor, hood.swarm.radius, frozenset())
    neighbours = part.view.other[part._measured][:3].tolist()
    good = [(fls, fit_offer(FitOffer(values=np.full(3, float(fls))))) for fls in neighbours[:2]]
    forged = (neighbours[2], fit_offer(FitOffer(values=np.zeros(5 * 3))))
    part.take(RoundOffers.of([*good, forged]))
    assert part._heard_ids.tolist() == sorted(neighbours[:2])
    np.testing.assert_array_equal(
        part._heard_block[:, :, 0], [[f] * 3 for f in sorted(neighbours[:2])]
    )


def test_a_round_s_vectors_replace_the_last_round_s_even_when_no_neighbour_s_came():
    from swazure_ros.core.observe import local_view
    from swazure_ros.protocol.discovery.messages import FitOffer, RoundOffers
    from swazure_ros.protocol.discovery.participant import fit_offer
    from swazure_ros.protocol.swarm_fit import FitPart

    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    hood = evaluate(world.swarm, stochastic_sensor(), "shortest-length").hood
    view = local_view(observations(hood), world.ids, 0)
    part = FitPart(view, hood.sensor, hood.swarm.radius, frozenset())
    neighbours = part.measured_ids[:2].tolist()
    stranger = int(np.setdiff1d(world.ids, [*part.measured_ids, part.fls_id])[0])
    part.take(
        RoundOffers.of([(fls, fit_offer(FitOffer(values=np.ones(3)))) for fls in neighbours])
    )
    assert part._heard_ids.tolist() == neighbours
    # The next round's vectors come from an FLS it does not measure only: its neighbours'
    # are lost, and count as zero rather than as last round's (stepped together or alone).
    part.take(RoundOffers.of([(stranger, fit_offer(FitOffer(values=np.ones(3))))]))
    assert part._heard_ids.tolist() == []
