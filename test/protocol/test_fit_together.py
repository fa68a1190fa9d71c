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
    made_alone = {"RESIDUAL": 0, "SUMS": 0, "STEP": 0}
    for stage, method in (("RESIDUAL", "_residual"), ("SUMS", "_sums"), ("STEP", "_step")):
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
    # Every RESIDUAL, SUMS and STEP round of every solve was made for the process's FLSs
    # at once, and every SUMS and STEP round's offers went to the radio as one block.
    assert made_alone == {"RESIDUAL": 0, "SUMS": 0, "STEP": 0}
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
        # Each of the 120 FLSs starts a solve of each fit and of the covariance alone.
        assert made_alone["RESIDUAL"] >= 3 * 120
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
