"""A process's FLSs solving the swarm's fit together send and end as each solving alone."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.fit import SWARM_ESTIMATORS, SWARM_FIT
from swazure_ros.core.observe import observations
from swazure_ros.protocol import loops
from swazure_ros.protocol.discovery import participant
from swazure_ros.protocol.discovery.messages import FitBlock
from swazure_ros.protocol.loops import RunOptions, discover
from swazure_ros.protocol.radio import RadioHub
from swazure_ros.protocol.swarm_fit import FitPart
from swazure_ros.sim.world import WorldSpec

from ..core.fits import stochastic_sensor


def one_per_process(participants, control, heard):
    """Each FLS stepped in a process of its own, as the single-FLS program steps it, its
    offers as Broadcasts of their own."""
    offers = {}
    for one in participants:
        stepped = participant.step_together([one], control, heard)
        offers.update(stepped.broadcasts)
        if stepped.block is not None:
            offers.update((out.sender, out) for out in stepped.block.broadcasts())
    return participant.Stepped(offers)


def not_together(parts, step, heard):
    """No round stepped together: each FLS's record does every round itself."""


@pytest.fixture(scope="module")
def hood():
    # torus:120 at beta 0.3 has sweet and decaying pairs, and the stochastic sensor a
    # covariance's solve with 64 columns besides the fits' one.
    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    return evaluate(world.swarm, stochastic_sensor(mean_error=0.03), "shortest-length").hood


@pytest.mark.parametrize("apart", ["one FLS per process", "each alone"])
def test_flss_solving_together_send_and_end_as_each_solving_alone(hood, monkeypatch, apart):
    made_alone = {"RESIDUAL": 0, "SUMS": 0, "STEP": 0, "WEIGH": 0}
    for stage, method in (("RESIDUAL", "_residual"), ("SUMS", "_sums"), ("STEP", "_step"),
                          ("WEIGH", "_weigh")):  # fmt: skip
        original = getattr(FitPart, method)

        def counted(self, *args, _stage=stage, _original=original):
            made_alone[_stage] += 1
            return _original(self, *args)

        monkeypatch.setattr(FitPart, method, counted)

    def run():
        return discover(observations(hood), hood.swarm.cloud_index, hood.sensor,
                        hood.swarm.radius, "shortest-length",
                        RunOptions(estimator=SWARM_FIT))  # fmt: skip

    blocks = []
    original_on_block = RadioHub.on_block

    def on_block(self, block):
        blocks.append(len(block))
        return original_on_block(self, block)

    fitted_for = []  # the sources of each call that made estimates from the fit's shares
    original_fitted = participant.fitted_estimates

    def fitted_estimates(made, shares, sensor, heard):
        fitted_for.append(len(made))
        return original_fitted(made, shares, sensor, heard)

    monkeypatch.setattr(participant, "fitted_estimates", fitted_estimates)
    with monkeypatch.context() as patch:
        patch.setattr(RadioHub, "on_block", on_block)
        together = run()
    # The SHARE round's estimates too: the 120 sources' in one call.
    assert fitted_for == [120]
    fitted_for.clear()
    # Every RESIDUAL, SUMS, STEP and WEIGH round of every solve was made for the process's
    # FLSs at once, and every SUMS and STEP round's offers went to the radio as one block.
    assert made_alone == {"RESIDUAL": 0, "SUMS": 0, "STEP": 0, "WEIGH": 0}
    # Each iteration is a SUMS and a STEP round; a solve's first SUMS comes before any.
    assert len(blocks) >= 2 * sum(map(sum, together.fit_iterations))
    assert set(blocks) == {120}
    with monkeypatch.context() as patch:
        if apart == "one FLS per process":
            patch.setattr(loops, "step_together", one_per_process)
        else:
            patch.setattr(participant, "fit_together", not_together)
        alone = run()
    if apart == "one FLS per process":
        assert fitted_for == [1] * 120
    if apart == "each alone":
        assert made_alone["SUMS"] > 1000 and made_alone["STEP"] > 1000
        # Each of the 120 FLSs starts a solve of each fit and of the covariance alone,
        # and weighs its pairs after each fit's first solve at least.
        assert made_alone["RESIDUAL"] >= 3 * 120
        assert made_alone["WEIGH"] >= 2 * 120
    assert together.rounds == alone.rounds
    assert together.fit_iterations == alone.fit_iterations
    assert sum(map(sum, together.fit_iterations)) > 50
    assert together.estimates.keys() == alone.estimates.keys()
    fitted = 0
    for source, mine in together.estimates.items():
        theirs = alone.estimates[source]
        for name in ("targets", "status", "vector", "covariance", "predicted_error", "estimator"):
            np.testing.assert_array_equal(getattr(mine, name), getattr(theirs, name))
        fitted += int((mine.estimator == SWARM_ESTIMATORS.index(SWARM_FIT)).sum())
    assert fitted > 1000


def test_the_flss_left_to_take_a_control_alone_are_those_without_a_row_in_the_block():
    block = FitBlock(1, 4, np.array([2, 5, 9]), np.zeros((3, 0)), np.zeros((3, 0)))
    assert participant.Stepped(block=block).left([9, 3, 2, 5, 7]) == [3, 7]
    assert participant.Stepped(block=block).left([5, 2, 9]) == []
    assert participant.Stepped().left([9, 3]) == [9, 3]  # no block: every FLS


def test_what_a_process_s_flss_take_together_is_what_each_takes_alone(hood):
    from swazure_ros.core.observe import local_view
    from swazure_ros.protocol.discovery.messages import FitOffer, RoundOffers
    from swazure_ros.protocol.fit_together import take_together

    ids = hood.swarm.cloud_index
    seen = observations(hood)

    def parts():
        return [FitPart(local_view(seen, ids, fls), hood.sensor, hood.swarm.radius,
                        frozenset()) for fls in range(12)]  # fmt: skip

    def offers(made):
        return RoundOffers.of([(fls, participant.fit_offer(one)) for fls, one in made])

    everyone = [int(fls) for fls in ids]
    together, alone = parts(), parts()
    forger = int(together[0].measured_ids[0])
    rounds = {
        "labels": offers([(fls, FitOffer(label=fls % 7, changed=True)) for fls in everyone]),
        "vectors": offers([(fls, FitOffer(values=np.full(6, float(fls)))) for fls in everyone]),
        # One sender's vector of another length: each FLS judges its own neighbours'.
        "a forged length": offers(
            [(fls, FitOffer(values=np.full(3 if fls == forger else 6, 1.0))) for fls in everyone]
        ),
        "a stranger's only": offers([(119, FitOffer(values=np.ones(6)))]),
    }
    for name, heard in rounds.items():
        take_together(together, heard)
        for part in alone:
            part.take(heard)
        for mine, theirs in zip(together, alone, strict=True):
            np.testing.assert_array_equal(mine._neighbour_labels, theirs._neighbour_labels)
            np.testing.assert_array_equal(mine._heard_ids, theirs._heard_ids, err_msg=name)
            np.testing.assert_array_equal(mine._heard_block, theirs._heard_block, err_msg=name)
            mine.take(heard)  # taken once: a second take of the same offers changes nothing
            np.testing.assert_array_equal(mine._heard_ids, theirs._heard_ids, err_msg=name)
        heard_ids = [part._heard_ids.tolist() for part in together]
        # What each round said was kept: labels, vectors, all but the forger's, none.
        if name == "labels":
            assert all((part._neighbour_labels >= 0).all() for part in together)
        if name == "vectors":
            assert all(ids == part.measured_ids.tolist() for ids, part in zip(heard_ids, together))
        if name == "a forged length":
            assert all(ids == [fls for fls in part.measured_ids.tolist() if fls != forger]
                       for ids, part in zip(heard_ids, together))  # fmt: skip
        if name == "a stranger's only":
            assert heard_ids == [[]] * len(together)
