"""The run's metrics (spec, section 6): the pairs' statistics, gathered block by block.

:class:`PairTally` gathers counts, errors and hops from one block of pairs
at a time (or from all at once); :func:`summarise` makes the run's
:class:`~.summary.Summary` from it and the neighbourhood.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .. import __version__
from .arrays import FloatArray, IntArray
from .evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    SWEET_PATH,
    PairResults,
)
from .metrics import NO_VALUES, Stats
from .neighbourhood import Neighbourhood
from .summary import FitFacts, FusionFacts, HeuristicFacts, PairStatistics, Parameters, Summary
from .tally import IntegerTally, RealTally


def _pct(part: int, whole: int) -> float:
    return 100.0 * part / whole if whole else 0.0


#: Real values a tally keeps for exact quantiles by default: the published shapes'
#: pairs (2.07 M at most) and more; a bounded run sets its own (core.blocks).
EXACT_VALUES = 50_000_000


@dataclass
class PairTally:
    """The summary's per-pair statistics, gathered from one block of pairs at a time."""

    exact_values: int = EXACT_VALUES
    pairs: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    reals: dict[str, RealTally] = field(default_factory=dict)
    integers: dict[str, IntegerTally] = field(default_factory=dict)
    known_predictions: int = 0  # pairs with a path and a predicted error
    within_predicted: int = 0  # of those, the pairs whose error is within it

    def _count(self, name: str, mask: NDArray[np.bool_]) -> None:
        self.counts[name] = self.counts.get(name, 0) + int(np.count_nonzero(mask))

    def _real(self, name: str, values: FloatArray) -> None:
        self.reals.setdefault(name, RealTally(self.exact_values)).add(values)

    def _integer(self, name: str, values: IntArray) -> None:
        self.integers.setdefault(name, IntegerTally()).add(values)

    def add(self, pairs: PairResults) -> None:
        """Gather the statistics of ``pairs``, a block of the run's."""
        self.pairs += len(pairs)
        has_path = pairs.status != NO_PATH
        # A pair a heuristic resolved has no predicted error: the mean is of those with one.
        known = np.isfinite(pairs.predicted_error) & has_path
        sweet, decaying = pairs.status == SWEET_PATH, pairs.status == DECAYING_PATH
        obstructed_paths = pairs.sweet_obstructed & pairs.sweet_connected
        for name, mask in (
            ("sweet", sweet),
            ("decaying", decaying),
            ("no_path", ~has_path),
            ("blocked", pairs.reason == REASON_BLOCKED),
            ("no_sweet_path", pairs.reason == REASON_NO_SWEET_PATH),
            ("sweet_connected", pairs.sweet_connected),
            ("obstructed", obstructed_paths),
        ):
            self._count(name, mask)
        for name, values in (
            ("distance_error_pct", pairs.distance_error[has_path]),
            ("distance_error_pct_sweet_paths", pairs.distance_error[sweet]),
            ("distance_error_pct_decaying_paths", pairs.distance_error[decaying]),
            ("alpha_deg", pairs.alpha[has_path]),
            ("theta_deg", pairs.theta[has_path]),
            ("phi_deg", pairs.phi[has_path]),
            ("predicted_error_cm", pairs.predicted_error[known]),
        ):
            self._real(name, values)
        for name, integers in (
            ("hops", pairs.hops[has_path]),
            ("hops_sweet_paths", pairs.hops[sweet]),
            ("hops_decaying_paths", pairs.hops[decaying]),
            ("obstructing_flss_per_path", pairs.obstructing_flss[obstructed_paths]),
        ):
            self._integer(name, integers)
        error = np.linalg.norm(pairs.estimate[known] - pairs.truth[known], axis=1)
        self.known_predictions += int(known.sum())
        self.within_predicted += int((error <= pairs.predicted_error[known]).sum())

    def statistics(self) -> PairStatistics:
        """The summary's per-pair fields (spec, section 6)."""
        total, count = self.pairs, self.counts.get
        described = {name: tally.describe() for name, tally in self.reals.items()}
        described |= {name: tally.describe() for name, tally in self.integers.items()}

        def stats(name: str) -> Stats:
            return described.get(name, NO_VALUES)

        obstructing = self.integers.get("obstructing_flss_per_path", IntegerTally()).counts
        return PairStatistics(
            blind_pairs=total,
            sweet_pairs=count("sweet", 0),
            decaying_pairs=count("decaying", 0),
            no_path_pairs=count("no_path", 0),
            sweet_pct=_pct(count("sweet", 0), total),
            decaying_pct=_pct(count("decaying", 0), total),
            no_path_pct=_pct(count("no_path", 0), total),
            blocked_pairs=count("blocked", 0),
            no_sweet_path_pairs=count("no_sweet_path", 0),
            distance_error_pct=stats("distance_error_pct"),
            distance_error_pct_sweet_paths=stats("distance_error_pct_sweet_paths"),
            distance_error_pct_decaying_paths=stats("distance_error_pct_decaying_paths"),
            alpha_deg=stats("alpha_deg"),
            theta_deg=stats("theta_deg"),
            phi_deg=stats("phi_deg"),
            hops=stats("hops"),
            hops_sweet_paths=stats("hops_sweet_paths"),
            hops_decaying_paths=stats("hops_decaying_paths"),
            sweet_connected_pairs=count("sweet_connected", 0),
            obstructed_path_pct=_pct(count("obstructed", 0), count("sweet_connected", 0)),
            obstructing_flss_per_path=stats("obstructing_flss_per_path"),
            predicted_error_cm=stats("predicted_error_cm"),
            within_predicted_pct=(
                _pct(self.within_predicted, self.known_predictions)
                if self.known_predictions
                else float("nan")
            ),
            obstructing_flss_histogram=tuple(obstructing.tolist()),
            quantiles="exact" if all(one.exact for one in self.reals.values()) else "sketched",
        )


def summarise(
    hood: Neighbourhood,
    policy: str,
    pairs: PairResults | PairTally,
    seconds: float | None = None,
    heuristic: HeuristicFacts | None = None,
    fusion: FusionFacts | None = None,
    fit: FitFacts | None = None,
) -> Summary:
    """The run's metrics (spec, section 6), from its pairs or their tally.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood: its FLSs, radius and neighbour counts.
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
        The path policy the pairs took.
    pairs : PairResults or PairTally
        Every ordered blind pair of the run, or their tally, block by block.
    seconds : float, optional
        What the run took, s.
    heuristic, fusion, fit : HeuristicFacts, FusionFacts, FitFacts, optional
        A later stage's facts, as the stage that made the pairs gives them.

    Returns
    -------
    Summary
        The run's summary.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.evaluate import evaluate_pairs
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> summary = summarise(hood, "fewest-hops", evaluate_pairs(hood, "fewest-hops"))
    >>> summary.flss, summary.sweet_neighbour_pairs, summary.pairs.hops.mean
    (3, 2, 2.0)
    """
    if isinstance(pairs, PairResults):
        tally = PairTally()
        tally.add(pairs)
        pairs = tally
    swarm, sensor = hood.swarm, hood.sensor
    neighbours = hood.counts
    return Summary(
        flss=swarm.size,
        cloud_points=swarm.size + swarm.removed,
        removed=swarm.removed,
        radius=swarm.radius,
        dmin=swarm.dmin,
        beta=swarm.beta,
        kissing_pairs=neighbours.kissing,
        sweet_neighbour_pairs=neighbours.sweet,
        decaying_neighbour_pairs=neighbours.decaying,
        pairs=pairs.statistics(),
        parameters=Parameters(policy, swarm.beta, swarm.radius, sensor.to_dict(), sensor.accurate),
        version=__version__,
        seconds=seconds,
        heuristic=heuristic,
        fusion=fusion,
        fit=fit,
    )
