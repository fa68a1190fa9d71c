"""One FLS's path search by hand: labels held per source that reached it, relaxed through a hop."""

from __future__ import annotations

import numpy as np

from swazure_ros.core.observe import LocalView
from swazure_ros.core.paths import SHORTEST_LENGTH
from swazure_ros.core.sensor import SWEET
from swazure_ros.protocol.discovery.messages import SWEET_VISIBLE, Offer, RoundOffers
from swazure_ros.protocol.discovery.search import PathSearch

# FLS 5 hears FLS 4 at 6 cm and FLS 6 at 7 cm, both sweet and in sight, in a swarm of 1,000 ids.
ID_SPACE = 1000
VIEW = LocalView(
    fls_id=5,
    other=np.array([4, 6]),
    range_class=np.array([SWEET, SWEET], dtype=np.int8),
    visible=np.array([True, True]),
    distance=np.array([6.0, 7.0]),
    vector=np.array([[6.0, 0.0, 0.0], [0.0, 7.0, 0.0]]),
)


def one_hop_offer(sender: int, sources: list[int], length: float) -> Offer:
    """Labels of ``sources``, each one hop of ``length`` cm from its source to ``sender``."""
    count = len(sources)
    return Offer(
        source_ids=np.array(sources, dtype=np.int64),
        hops=np.ones(count, dtype=np.int64),
        lengths=np.full(count, length),
        errors=np.zeros(count),
        vectors=np.zeros((count, 3)),
        path_offsets=np.arange(0, 2 * count + 1, 2, dtype=np.int64),
        path_ids=np.array([fls for source in sources for fls in (source, sender)], dtype=np.int64),
    )


def test_an_fls_holds_labels_only_for_the_sources_that_reached_it():
    search = PathSearch(VIEW, SWEET_VISIBLE, SHORTEST_LENGTH, 1.0, ID_SPACE)
    far = list(range(100, 140))  # 40 sources: more than a search's first slots
    search.close(np.array([139]))  # a finished source's labels take no slot
    heard = RoundOffers.of([(4, one_hop_offer(4, far[:30], 3.0)),
                            (6, one_hop_offer(6, far[20:], 1.0))])  # fmt: skip
    search.hear(heard)
    assert search.used == 39 < ID_SPACE
    offer = search.offer(round_=100)
    assert offer.source_ids.tolist() == far[:39]  # by source id
    # Sources 120-129 came both ways: through 6 (1 + 7 cm) beats through 4 (3 + 6 cm).
    lengths = dict(zip(offer.source_ids.tolist(), offer.lengths.tolist(), strict=True))
    assert [lengths[s] for s in (100, 119, 120, 129, 130, 138)] == [9.0, 9.0, 8.0, 8.0, 8.0, 8.0]
    assert offer.path(0) == (100, 4, 5) and offer.path(25) == (125, 6, 5)
    # Sent labels are final: a better one heard later changes nothing, nor takes a slot.
    search.hear(RoundOffers.of([(4, one_hop_offer(4, [100], 0.5))]))
    assert search.used == 39 and search.offer(round_=200).source_ids.tolist() == []
