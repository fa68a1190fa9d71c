"""Sources' estimates from the swarm fit's SHARE round, made for many sources at once.

In the SHARE round each FLS sends its settled position and samples of every
fit (:meth:`.swarm_fit.FitPart.shared`); a source's estimate of a target is
then the target's position less its own, with the covariance of the
difference of their samples, as the engine's ``--estimator swarm-fit``
makes it. A packed process's sources read the same round's shares, so
:func:`fitted_estimates` reads each target's share once for all of them and
does each step for every pair at once: the arithmetic of a pair is the same
elementwise steps whether it is done alone or in a stack, so the bits are too.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..core.arrays import FloatArray
from ..core.evaluation import DECAYING_PATH, SWEET_PATH
from ..core.fit import SWARM_ESTIMATORS, SWARM_FIT
from ..core.fit_measurements import fit_layers
from ..core.sensor import Sensor
from ..core.swarm_fit import sample_covariance
from .discovery.estimate import Estimates
from .discovery.messages import RoundOffers


def fitted_estimates(
    made: Sequence[Estimates], shares: Sequence[FloatArray], sensor: Sensor, heard: RoundOffers
) -> list[Estimates]:
    """Each source's estimates with each pair's vector from the swarm's fit.

    Parameters
    ----------
    made : sequence of Estimates
        Each source's estimates from its paths, S of them.
    shares : sequence of (V,) array of float
        Each source's own share (cm): per fit, its position (3,) and its
        samples (3, K), flat.
    sensor : Sensor
        Says how many fits there are (``core.fit_measurements.fit_layers``).
    heard : RoundOffers
        The SHARE round's offers.

    Returns
    -------
    list of Estimates
        Per source, its estimates where a pair with a path takes the target's
        settled position less the source's (the sweet hops' fit for a pair
        with a sweet path, under a sensor with two fits), the covariance of
        the difference of their samples and its predicted error. A target
        whose share was not heard, or has another length than the source's
        own (not one it can read), keeps its path's estimate.
    """
    if len({len(share) for share in shares}) > 1:  # never in one swarm: each source alone
        return [
            fitted_estimates([one], [share], sensor, heard)[0]
            for one, share in zip(made, shares, strict=True)
        ]
    counts = [len(one) for one in made]
    if not sum(counts):
        return list(made)
    owns = np.stack([np.asarray(share, dtype=np.float64) for share in shares])
    size = owns.shape[1]
    targets = np.concatenate([np.asarray(one.targets, dtype=np.int64) for one in made])
    status = np.concatenate([one.status for one in made])
    source = np.repeat(np.arange(len(made)), counts)
    # Each target's share read once, whichever sources estimate it.
    wanted, target_row = np.unique(targets, return_inverse=True)
    _, offsets, values = heard.fit_of(wanted)
    readable = np.diff(offsets) == size
    fitted = np.flatnonzero(np.isin(status, (SWEET_PATH, DECAYING_PATH)) & readable[target_row])
    if not len(fitted):
        return list(made)
    layers = len(fit_layers(sensor))
    per_layer = size // layers
    # Each target's fit: the sweet hops' alone (the first) for a pair with a sweet path.
    layer = np.where((layers == 1) | (status[fitted] == SWEET_PATH), 0, 1)
    # The shares as (target, fit, value) blocks, so that a pair's are a row each to copy.
    blocks = values[offsets[:-1][readable][:, None] + np.arange(size)]
    block_of = np.cumsum(readable) - 1
    theirs = blocks.reshape(-1, layers, per_layer)[block_of[target_row[fitted]], layer]
    mine = owns.reshape(len(owns), layers, per_layer)[source[fitted], layer]
    spread = (theirs[:, 3:] - mine[:, 3:]).reshape(len(fitted), 3, -1)
    vector = theirs[:, :3] - mine[:, :3]
    covariance = sample_covariance(spread)
    error = np.sqrt(np.trace(covariance, axis1=1, axis2=2))
    # Back to each source: its pairs are a run of the stack, in its target order.
    bounds = np.searchsorted(source[fitted], np.arange(len(made) + 1))
    starts = np.concatenate([[0], np.cumsum(counts)])
    out = []
    for index, one in enumerate(made):
        low, high = bounds[index], bounds[index + 1]
        if low == high:
            out.append(one)
            continue
        rows = fitted[low:high] - starts[index]
        own_vector, own_covariance = one.vector.copy(), one.covariance.copy()
        own_error, estimator = one.predicted_error.copy(), one.estimator.copy()
        own_vector[rows] = vector[low:high]
        own_covariance[rows] = covariance[low:high]
        own_error[rows] = error[low:high]
        estimator[rows] = SWARM_ESTIMATORS.index(SWARM_FIT)
        out.append(
            replace(
                one,
                vector=own_vector,
                covariance=own_covariance,
                predicted_error=own_error,
                estimator=estimator,
            )
        )
    return out
