"""What a source makes of its phases' results: section 5 of the spec, pair by pair.

:func:`estimate` turns one target's phase results (:class:`Found`) into the
pair's status, reason and path, as section 5 orders the phases;
:class:`Estimates` holds a source's estimates as columns. How they compare
with the engine's evaluation is :mod:`.reported`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, overload

import numpy as np
from numpy.typing import NDArray

from ...core import csr
from ...core.arrays import FloatArray, IntArray
from ...core.evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
)
from ...core.fit import PATH, SWARM_ESTIMATORS
from ...core.hop_errors import expected_error
from ...core.lookup import sorted_rows
from ...core.sensor import Sensor


@dataclass(frozen=True)
class Found:
    """A path from a source to one FLS: ids, hops, length (cm) and summed vector (3,), cm."""

    path: tuple[int, ...]
    length: float
    vector: FloatArray
    error: float = float("nan")  # the hops' expected errors summed (core.hop_errors.hop_error)
    unbiased: FloatArray | None = None  # (3,), cm: the hops less their known bias, summed
    covariance: FloatArray | None = None  # (3, 3), cm^2: the hops' covariances summed

    @property
    def hops(self) -> int:
        """Number of hops."""
        return len(self.path) - 1


@dataclass(frozen=True)
class Estimate:
    """A source's pose relative to one target: status, reason, path and summed vector."""

    target: int
    status: int  # SWEET_PATH, DECAYING_PATH or NO_PATH
    reason: int  # REASON_NONE, REASON_BLOCKED or REASON_NO_SWEET_PATH
    path: tuple[int, ...] = ()
    length: float = float("nan")  # cm
    vector: FloatArray = field(default_factory=lambda: np.full(3, np.nan))  # cm
    radio_path: tuple[int, ...] = ()  # the policy's S_all path (obstruction statistics)
    predicted_error: float = float("nan")  # cm (core.hop_errors.expected_error); nan without path
    estimator: str = PATH  # what made ``vector``: one of core.fit.SWARM_ESTIMATORS
    covariance: FloatArray | None = None  # (3, 3), cm^2, of ``vector``: a fit's only

    @property
    def hops(self) -> int:
        """Number of hops; 0 without a path."""
        return max(len(self.path) - 1, 0)


class Results:
    """A source's results of one phase, as arrays: per target found, its label's sums and path.

    A search adds the labels of each round (:meth:`add`); reading them joins
    the rounds into one table sorted by target (a target is found once).
    """

    def __init__(self) -> None:
        self._rounds: list[dict[str, Any]] = []
        self._count = 0
        self._table: dict[str, NDArray[Any]] | None = None

    def add(
        self,
        targets: IntArray,
        lengths: FloatArray,
        errors: FloatArray,
        vectors: FloatArray,
        paths: tuple[IntArray, IntArray],
        unbiased: FloatArray | None = None,
        covariances: FloatArray | None = None,
    ) -> None:
        """Targets (K,) found, with their paths' lengths (K,), cm, summed hop errors (K,),
        vectors (K, 3), cm, paths (offsets (K + 1,), FLS ids), and a fitting run's sums."""
        if not len(targets):
            return
        count = len(targets)
        self._rounds.append(
            {
                "targets": np.asarray(targets, dtype=np.int64),
                "lengths": np.asarray(lengths, dtype=np.float64),
                "errors": np.asarray(errors, dtype=np.float64),
                "vectors": np.asarray(vectors, dtype=np.float64).reshape(count, 3),
                "path_offsets": np.asarray(paths[0], dtype=np.int64),
                "path_ids": np.asarray(paths[1], dtype=np.int64),
                # Without a fitting run's sums, NaN: filled in when the rounds are joined.
                "unbiased": unbiased,
                "covariances": covariances,
                # Whether the sums came with the labels (a fitting run's), NaN or not.
                "carried": np.bool_(unbiased is not None and covariances is not None),
            }
        )
        self._count += count
        self._table = None

    def __len__(self) -> int:
        return self._count

    @property
    def table(self) -> dict[str, NDArray[Any]]:
        """Every result, sorted by target: the arrays :meth:`add` takes, joined.

        A fitting run's sums ("unbiased", "covariances", "carried") are columns only
        where some round carried them: a run without a fit holds no NaN for them.
        """
        if self._table is None:
            rounds = self._rounds
            columns = [
                ("targets", np.zeros(0, np.int64)),
                ("lengths", np.zeros(0)),
                ("errors", np.zeros(0)),
                ("vectors", np.zeros((0, 3))),
            ]
            # A joined table is a round too, its "carried" a column (or none).
            if any(np.any(one.get("carried", False)) for one in rounds):
                columns += [
                    ("unbiased", np.zeros((0, 3))),
                    ("covariances", np.zeros((0, 3, 3))),
                    ("carried", np.zeros(0, dtype=bool)),
                ]
            joined: dict[str, NDArray[Any]] = {
                name: np.concatenate([_filled(one, name) for one in rounds]) if rounds else empty
                for name, empty in columns
            }
            bounds, ids = csr.join(
                [(one["path_offsets"], one["path_ids"]) for one in rounds], np.zeros(0, np.int64)
            )
            order = np.argsort(joined["targets"], kind="stable")
            table = {name: values[order] for name, values in joined.items()}
            table["path_offsets"], table["path_ids"] = csr.take(bounds, ids, order)
            self._rounds = [] if not rounds else [table]
            self._table = table
        return self._table

    @classmethod
    def keyed(cls, parts: Sequence[Results], id_space: int) -> Results:
        """The results of several sources as one: part k's targets keyed ``k * id_space +
        target``, so that the joined table stays sorted (:func:`estimates_of_sources`).

        It holds what :func:`estimates_of` reads: no fitting run's sums (on the
        race car those would be 1.3 GB of NaN).
        """
        tables = [part.table for part in parts]
        table = {
            name: np.concatenate([one[name] for one in tables])
            for name in ("lengths", "errors", "vectors")
        }
        table["targets"] = np.concatenate(
            [one["targets"] + k * id_space for k, one in enumerate(tables)]
        )
        table["path_offsets"], table["path_ids"] = csr.join(
            [(one["path_offsets"], one["path_ids"]) for one in tables], np.zeros(0, np.int64)
        )
        keyed = cls()
        keyed._rounds, keyed._count, keyed._table = [table], len(table["targets"]), table
        return keyed

    def rows(self, targets: IntArray) -> IntArray:
        """(T,) the row of each of ``targets`` in :attr:`table`; -1 where not found."""
        found = self.table["targets"]
        rows, there = sorted_rows(found, targets)
        return np.where(there, rows, -1).astype(np.int64)

    def get(self, target: int) -> Found | None:
        """Target ``target``'s result; None when it was not found."""
        row = int(self.rows(np.array([target]))[0])
        if row < 0:
            return None
        table = self.table
        path = table["path_ids"][table["path_offsets"][row] : table["path_offsets"][row + 1]]
        carried = "carried" in table and bool(table["carried"][row])
        return Found(
            tuple(path.tolist()),
            float(table["lengths"][row]),
            table["vectors"][row],
            float(table["errors"][row]),
            table["unbiased"][row] if carried else None,
            table["covariances"][row] if carried else None,
        )


def _filled(added: dict[str, Any], name: str) -> NDArray[Any]:
    """Column ``name`` of a round :meth:`Results.add` took, its sums NaN where it had none."""
    value = added.get(name)  # a table joined without sums has no such column
    count = len(added["targets"])
    if name == "carried":
        return np.full(count, False if value is None else value, dtype=bool)
    if value is None:
        return np.full((count, 3) if name == "unbiased" else (count, 3, 3), np.nan)
    return np.asarray(value)


@dataclass(frozen=True, eq=False)
class Estimates(Sequence[Estimate]):
    """One source's estimates as arrays (T targets); each an :class:`Estimate` when read.

    FLS ids (``targets``, ``path_ids``, ``radio_ids``) are int64, or uint32 as a report
    arrives over the wire (``ros.convert.discovery``), which is what a coordinator holds.
    """

    targets: IntArray  # (T,)
    status: NDArray[np.int8]  # (T,) SWEET_PATH, DECAYING_PATH, NO_PATH or ABORTED
    reason: NDArray[np.int8]  # (T,)
    path_offsets: IntArray  # (T + 1,)
    path_ids: IntArray  # FLS ids, source to target; none without a path
    length: FloatArray  # (T,), cm; NaN without a path
    vector: FloatArray  # (T, 3), cm; NaN without a path
    radio_offsets: IntArray  # (T + 1,): the S_all paths
    radio_ids: IntArray
    predicted_error: FloatArray  # (T,), cm
    estimator: NDArray[np.int8]  # (T,) index into core.fit.SWARM_ESTIMATORS
    covariance: FloatArray  # (T, 3, 3), cm^2; NaN where the estimate has none

    def __len__(self) -> int:
        return len(self.targets)

    @overload
    def __getitem__(self, index: int) -> Estimate: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[Estimate]: ...

    def __getitem__(self, index: int | slice) -> Estimate | Sequence[Estimate]:
        if isinstance(index, slice):
            return [self[k] for k in range(len(self))[index]]
        k = range(len(self))[index]
        path = self.path_ids[self.path_offsets[k] : self.path_offsets[k + 1]]
        radio = self.radio_ids[self.radio_offsets[k] : self.radio_offsets[k + 1]]
        covariance = self.covariance[k]
        return Estimate(
            int(self.targets[k]),
            int(self.status[k]),
            int(self.reason[k]),
            tuple(path.tolist()),
            float(self.length[k]),
            self.vector[k],
            tuple(radio.tolist()),
            float(self.predicted_error[k]),
            SWARM_ESTIMATORS[int(self.estimator[k])],
            None if np.isnan(covariance).any() else covariance,
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sequence):
            return NotImplemented
        return len(self) == len(other) and all(
            _same(one, two) for one, two in zip(self, other, strict=True)
        )

    __hash__ = None  # type: ignore[assignment]

    @classmethod
    def joined(cls, tables: Sequence[Estimates]) -> Estimates:
        """``tables`` one after the other, as one."""
        path_offsets, path_ids = csr.join(
            [(t.path_offsets, t.path_ids) for t in tables], np.zeros(0, np.int64)
        )
        radio_offsets, radio_ids = csr.join(
            [(t.radio_offsets, t.radio_ids) for t in tables], np.zeros(0, np.int64)
        )

        def column(name: str, empty: NDArray[Any]) -> NDArray[Any]:
            values = [getattr(t, name) for t in tables]
            return np.concatenate(values) if values else empty

        return cls(
            column("targets", np.zeros(0, np.int64)),
            column("status", np.zeros(0, np.int8)),
            column("reason", np.zeros(0, np.int8)),
            path_offsets,
            path_ids,
            column("length", np.zeros(0)),
            column("vector", np.zeros((0, 3))),
            radio_offsets,
            radio_ids,
            column("predicted_error", np.zeros(0)),
            column("estimator", np.zeros(0, np.int8)),
            column("covariance", np.zeros((0, 3, 3))),
        )

    def split(self, bounds: IntArray) -> list[Estimates]:
        """The tables of rows ``bounds[k]:bounds[k + 1]``, one after the other (K + 1 bounds)."""
        parts = []
        for low, high in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
            first, last = self.path_offsets[low], self.path_offsets[high]
            radio_first, radio_last = self.radio_offsets[low], self.radio_offsets[high]
            parts.append(
                Estimates(
                    self.targets[low:high],
                    self.status[low:high],
                    self.reason[low:high],
                    self.path_offsets[low : high + 1] - first,
                    self.path_ids[first:last],
                    self.length[low:high],
                    self.vector[low:high],
                    self.radio_offsets[low : high + 1] - radio_first,
                    self.radio_ids[radio_first:radio_last],
                    self.predicted_error[low:high],
                    self.estimator[low:high],
                    self.covariance[low:high],
                )
            )
        return parts

    @classmethod
    def of(cls, estimates: Sequence[Estimate]) -> Estimates:
        """``estimates`` as one table (an Estimates is returned as it is)."""
        if isinstance(estimates, Estimates):
            return estimates
        count = len(estimates)
        paths = csr.offsets([len(one.path) for one in estimates])
        radio = csr.offsets([len(one.radio_path) for one in estimates])
        covariance = np.full((count, 3, 3), np.nan)
        for row, one in enumerate(estimates):
            if one.covariance is not None:
                covariance[row] = one.covariance
        return cls(
            np.array([one.target for one in estimates], dtype=np.int64),
            np.array([one.status for one in estimates], dtype=np.int8),
            np.array([one.reason for one in estimates], dtype=np.int8),
            paths,
            np.array([fls for one in estimates for fls in one.path], dtype=np.int64),
            np.array([one.length for one in estimates], dtype=np.float64),
            np.array([one.vector for one in estimates], dtype=np.float64).reshape(count, 3),
            radio,
            np.array([fls for one in estimates for fls in one.radio_path], dtype=np.int64),
            np.array([one.predicted_error for one in estimates], dtype=np.float64),
            np.array([SWARM_ESTIMATORS.index(one.estimator) for one in estimates], dtype=np.int8),
            covariance,
        )


def _same(one: Estimate, two: Estimate) -> bool:
    """Two estimates alike, arrays compared by value (NaN equal to NaN)."""
    if (one.target, one.status, one.reason, one.path, one.radio_path, one.estimator) != (
        two.target, two.status, two.reason, two.path, two.radio_path, two.estimator
    ):  # fmt: skip
        return False
    numbers = [(one.length, two.length), (one.predicted_error, two.predicted_error)]
    if not all(a == b or (np.isnan(a) and np.isnan(b)) for a, b in numbers):
        return False
    if one.covariance is None or two.covariance is None:
        if (one.covariance is None) != (two.covariance is None):
            return False
    elif not np.array_equal(one.covariance, two.covariance, equal_nan=True):
        return False
    return bool(np.array_equal(one.vector, two.vector, equal_nan=True))


def estimates_of(
    targets: IntArray,
    sweet: Results,
    radio: Results,
    decaying: Results,
    sensor: Sensor | None = None,
) -> Estimates:
    """Section 5 of the spec for ``targets`` (T,) at once, from their phases' results.

    As :func:`estimate` decides each target, pair by pair, and to the bit.
    """
    targets = np.asarray(targets, dtype=np.int64)
    sweet_rows, radio_rows, decaying_rows = (
        results.rows(targets) for results in (sweet, radio, decaying)
    )
    is_sweet, is_decaying = sweet_rows >= 0, (sweet_rows < 0) & (decaying_rows >= 0)
    status = np.full(len(targets), NO_PATH, dtype=np.int8)
    status[is_decaying], status[is_sweet] = DECAYING_PATH, SWEET_PATH
    reason = np.where(radio_rows >= 0, REASON_BLOCKED, REASON_NO_SWEET_PATH).astype(np.int8)
    reason[is_sweet] = REASON_NONE
    count = len(targets)
    length, error = np.full(count, np.nan), np.full(count, np.nan)
    vector = np.full((count, 3), np.nan)
    paths: list[tuple[IntArray, IntArray]] = []
    where = np.empty(0, dtype=np.int64)
    phases = ((is_sweet, sweet, sweet_rows), (is_decaying, decaying, decaying_rows))
    for chosen, results, rows in phases:
        table = results.table
        picked = rows[chosen]
        length[chosen] = table["lengths"][picked]
        error[chosen] = table["errors"][picked]
        vector[chosen] = table["vectors"][picked]
        paths.append(csr.take(table["path_offsets"], table["path_ids"], picked))
        where = np.concatenate([where, np.flatnonzero(chosen)])
    # The two phases' paths, put back in target order (a target has one or none).
    bounds, ids = csr.join(paths, np.zeros(0, np.int64))
    counts = np.zeros(count, dtype=np.int64)
    counts[where] = np.diff(bounds)
    order = np.argsort(where, kind="stable")
    path_offsets = csr.offsets(counts)
    path_ids = csr.take(bounds, ids, order)[1]
    has_radio = radio_rows >= 0
    radio_table = radio.table
    radio_bounds, radio_ids = csr.take(
        radio_table["path_offsets"], radio_table["path_ids"], radio_rows[has_radio]
    )
    radio_counts = np.zeros(count, dtype=np.int64)
    radio_counts[has_radio] = np.diff(radio_bounds)
    predicted = np.full(count, np.nan)
    if sensor is not None:
        found = is_sweet | is_decaying
        predicted[found] = expected_error(sensor, error[found])
    return Estimates(
        targets,
        status,
        reason,
        path_offsets,
        path_ids,
        length,
        vector,
        csr.offsets(radio_counts),
        radio_ids,
        predicted,
        np.zeros(count, dtype=np.int8),
        np.full((count, 3, 3), np.nan),
    )


def estimates_of_sources(
    targets: Sequence[IntArray],
    phases: Sequence[tuple[Results, Results, Results]],
    id_space: int,
    sensor: Sensor | None = None,
) -> list[Estimates]:
    """:func:`estimates_of` of several sources at once: source k's ``targets[k]`` from its
    phases' results ``phases[k]`` (S_vis, S_all, SD_vis); each table what its own call gives.

    The sources' results are keyed apart (:meth:`Results.keyed`; FLS ids are
    below ``id_space``), so that one call decides every pair of them.
    """
    if not len(targets):
        return []
    keys = [np.asarray(mine, dtype=np.int64) + k * id_space for k, mine in enumerate(targets)]
    sweet, radio, decaying = (
        Results.keyed([mine[phase] for mine in phases], id_space) for phase in range(3)
    )
    whole = estimates_of(np.concatenate(keys), sweet, radio, decaying, sensor)
    parts = whole.split(csr.offsets([len(mine) for mine in keys]))
    return [
        replace(part, targets=np.asarray(mine, dtype=np.int64))
        for part, mine in zip(parts, targets, strict=True)
    ]


def estimate(
    target: int,
    sweet: Found | None,
    radio: Found | None,
    decaying: Found | None,
    sensor: Sensor | None = None,
) -> Estimate:
    """Section 5 of the spec for one target, from its S_vis, S_all and SD_vis results.

    With ``sensor``, the estimate's predicted error follows from its path's
    summed hop errors.
    """
    radio_path = radio.path if radio is not None else ()

    def predicted(found: Found) -> float:
        return float("nan") if sensor is None else float(expected_error(sensor, found.error))

    if sweet is not None:
        return Estimate(
            target,
            SWEET_PATH,
            REASON_NONE,
            sweet.path,
            sweet.length,
            sweet.vector,
            radio_path,
            predicted(sweet),
        )
    reason = REASON_BLOCKED if radio is not None else REASON_NO_SWEET_PATH
    if decaying is not None:
        return Estimate(
            target,
            DECAYING_PATH,
            reason,
            decaying.path,
            decaying.length,
            decaying.vector,
            radio_path,
            predicted(decaying),
        )
    return Estimate(target, NO_PATH, reason, radio_path=radio_path)
