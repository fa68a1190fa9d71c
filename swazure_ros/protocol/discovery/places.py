"""What a place of a label table holds: its columns, their empty values, and its bytes.

A :class:`~.labels.LabelTable` lays out each column as an (F, R, ...) array: F FLSs
(rows), R places a row. A place holds one source's label at one FLS. What a place
takes is what a discovery's blocks of sources are sized by (``protocol.runs``).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from ...core import jit
from ...core.arrays import IntArray

#: An empty place of a hashed row (its key).
EMPTY = -1

#: A pred that no sender id reaches: a label not found yet loses every tie. Ids are below
#: 2**32 (uint32 on the wire), and a table keeps its preds in 32 bits.
NO_PRED = np.iinfo(np.uint32).max

Column = tuple[object, tuple[int, ...], type]

#: Each column of a table: the value of an empty place, its shape past (F, R), its type.
COLUMNS: dict[str, Column] = {
    "keys": (EMPTY, (), np.int64),
    "sent": (False, (), np.bool_),
    "hops": (np.inf, (), np.float64),
    "length": (np.inf, (), np.float64),
    "error": (np.inf, (), np.float64),
    # 32 bits where a place's value fits: a race car's phase holds 13.8 M places.
    "pred": (NO_PRED, (), np.uint32),
    # A label's path is its sender's (label via_label of the offers its FLS heard as
    # via_offers) plus its FLS: -1 where the FLS is the source. A process keeps a few
    # rounds' offers, and a round's offers hold millions of labels, not billions.
    "via_offers": (-1, (), np.int32),
    "via_label": (-1, (), np.int32),
    # Its vector too is its sender's there plus the hop, the row's link via_link: summed
    # when the label is sent (heard.offers_of), not kept, 24 bytes a place.
    "via_link": (-1, (), np.int32),
}
#: The columns a fitting run's labels add: their hops summed less the known bias, and
#: the hops' covariances (core.fit.path_estimates).
FIT_COLUMNS: dict[str, Column] = {
    "unbiased": (np.nan, (3,), np.float64),
    "covariance": (np.nan, (3, 3), np.float64),
}


def table_columns(fits: bool) -> dict[str, Column]:
    """The columns of a table whose labels sum fits too (``fits``), or not, in order."""
    return {**COLUMNS, **(FIT_COLUMNS if fits else {})}


# Asked by every table made and widened: a packed discovery makes one per FLS and phase
# (29,928 in a torus:10000 spread run), and working it out took most of a small table's
# making (81-126 us a table, 19-40 us since).
@functools.cache
def place_bytes(direct: bool = True, fits: bool = False) -> int:
    """The memory one place of a :class:`~.labels.LabelTable`'s row takes, bytes.

    Parameters
    ----------
    direct : bool
        A slot per source (True), or a hash, whose places keep their source's key too.
    fits : bool
        The labels also sum unbiased hops and covariances (a fitting run's).

    Returns
    -------
    int
        41 bytes a place of a slot per source, 49 in a hash; 96 more where labels fit.

    Examples
    --------
    >>> from swazure_ros.protocol.discovery.places import place_bytes
    >>> place_bytes(), place_bytes(direct=False), place_bytes(fits=True)
    (41, 49, 137)
    """
    return sum(
        np.dtype(dtype).itemsize * int(np.prod(shape))
        for name, (_, shape, dtype) in table_columns(fits).items()
        if not (name == "keys" and direct)  # a slot per source keeps no key
    )


@jit.kernel(cache=True, nogil=True)
def slot_of(run_ids: IntArray | None, first: int, source: int) -> int:
    """The slot of ``source`` in a direct row: its rank in ``run_ids`` (the run's sources,
    sorted; None: every id from ``first`` on is one), -1 if it is not one of them."""
    if run_ids is None:
        return source - first
    at = np.searchsorted(run_ids, source)
    return int(at) if at < len(run_ids) and run_ids[at] == source else -1


def slot_map(run_ids: IntArray, span: tuple[int, int]) -> NDArray[np.int32]:
    """Each id's slot among a run's sources, over the run's span of ids.

    Parameters
    ----------
    run_ids : (S,) array of int
        The run's sources, sorted ids.
    span : (int, int)
        (first, end): the ids a source of the run may have.

    Returns
    -------
    (end - first,) array of int32
        Entry ``id - first`` is the rank of ``id`` in ``run_ids``, -1 where it is not one.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.protocol.discovery.places import slot_map
    >>> slot_map(np.array([3, 5, 8]), (3, 9)).tolist()
    [0, -1, 1, -1, -1, 2]
    """
    first, end = span
    slots = np.full(end - first, -1, dtype=np.int32)
    inside = (run_ids >= first) & (run_ids < end)
    slots[run_ids[inside] - first] = np.flatnonzero(inside)
    return slots
