"""The engine as library functions: a swarm from a cloud, evaluated as ``swazure evaluate`` does.

:func:`build_swarm` makes a swarm from a point cloud (an array, a file, a
built-in shape or a published cloud's name); :func:`evaluate` runs plain
Swazure, a heuristic, fusion or a least-squares estimator over it and returns
a :class:`Result`: the run's typed records (``core.summary.Summary``,
``files.results.RunRecord``) and its pairs as a ``pyarrow.Table``.
:func:`move_obstructing` and :func:`move_source` name the two heuristics.

``swazure evaluate`` and :func:`evaluate` run through the same pipeline,
``core.pipeline.run_engine``, which runs plain Swazure a block of pairs at a
time or holds every pair, as the run needs, so a script and the command line
get the same numbers and the same pairs.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..core.blocks import DEFAULT_MEMORY, Budget
from ..core.clouds import Cloud, validate_points
from ..core.errors import CloudError, OptionError, SwazureError
from ..core.evaluation import Evaluation, PairResults
from ..core.fit import PATH
from ..core.geometry import Swarm, make_swarm
from ..core.heuristics.result import MOVE_OBSTRUCTING, MOVE_SOURCE, PLAIN, HeuristicResult
from ..core.neighbourhood import Neighbourhood
from ..core.paths import SHORTEST_LENGTH
from ..core.pipeline import EngineRun, RunOptions, run_engine
from ..core.progress import Progress
from ..core.sensor import Sensor
from ..core.summary import Source, Summary
from ..files.cloud_files import load_cloud, resampled_cloud
from ..files.reading import available_memory
from ..files.record import RunRecord
from ..files.results import pairs_table
from ..files.sensors import load_sensor


@dataclass(frozen=True)
class SwarmSetup:
    """A swarm ready to evaluate: its cloud, the FLSs kept, its sensor, and their sources.

    ``swarm.points`` are the FLSs' centres, (N, 3), cm; ``swarm.cloud_index``
    their rows in ``cloud.points``, which are the FLS ids of every result.
    """

    cloud: Cloud
    swarm: Swarm
    sensor: Sensor
    seed: int  # of the choice of colliding FLSs removed
    sensor_file: str | Path | None  # None: config/sensor.yaml

    @property
    def source(self) -> Source:
        """Where the swarm came from, as a run's summary names it."""
        return Source.of(self.cloud, self.seed, self.sensor_file)


@dataclass(frozen=True)
class Result:
    """One evaluation: what was asked, its records, and every ordered blind pair.

    ``pairs`` is a ``pyarrow.Table``, one row per ordered blind pair, the
    columns of ``pairs.csv`` (docs/core.md) with paths and moved FLSs as lists
    of FLS ids; ``pairs.to_pandas()`` gives a DataFrame where pandas is
    installed. ``evaluation`` and ``heuristic`` are the core's own results of a
    run that held every pair at once (fusion or a fit); a plain run or a
    heuristic's, made a block at a time, has None (its moves are in ``pairs``).
    """

    setup: SwarmSetup
    options: RunOptions
    record: RunRecord  # what record.json holds; its summary is summary.json's
    pairs: Any  # pyarrow.Table
    evaluation: Evaluation | None = None
    heuristic: HeuristicResult | None = None

    @property
    def summary(self) -> Summary:
        """The run's summary (spec, section 6), as ``summary.json`` holds it."""
        summary = self.record.summary
        if summary is None:  # an evaluation's record always has one
            raise SwazureError("this run has no summary")
        return summary


def build_swarm(
    cloud: ArrayLike | str | Path,
    scale: float | None = None,
    beta: float | None = None,
    radius: float | None = None,
    sensor: Sensor | str | Path | None = None,
    accurate: bool = False,
    seed: int = 0,
    resample: int | None = None,
) -> SwarmSetup:
    """A swarm of FLSs at the points of ``cloud``, as ``swazure evaluate --cloud`` makes it.

    Parameters
    ----------
    cloud : (N, 3) array_like, cm; or str or pathlib.Path
        The points themselves; a point cloud file (.xyz .txt .csv .npy .ply); a
        built-in shape (``"torus"``, ``"sphere:500"``, ``NAME:COUNT``); or a
        published cloud by name (``"chess"`` or ``"chess_408"``), read from
        ``../shared/datasets/swazure-paper`` or ``$SWAZURE_DATASETS``.
    scale : float, optional
        Multiplies the coordinates to give cm. Default: the published scale for
        a published cloud, else 1.
    beta : float, optional
        FLS radius as a share of the least distance between points,
        ``r = beta * dmin``, in (0, 1]. Give ``beta`` or ``radius``.
    radius : float, optional
        FLS radius r, cm.
    sensor : Sensor or str or pathlib.Path, optional
        The sensor, or its YAML file. Default: ``config/sensor.yaml``.
    accurate : bool, default False
        Measure without error.
    seed : int, default 0
        Seed of the choice of colliding FLSs to remove, and of ``resample``.
    resample : int, optional
        Resample the cloud to this many points at its own mean spacing
        (``files.cloud_files.resampled_cloud``, seeded by ``seed``), from 8 to
        100,000: a display-size version of it.

    Returns
    -------
    SwarmSetup
        The cloud (cm), the swarm kept after collision removal, the sensor.

    Raises
    ------
    CloudError
        ``cloud`` is no known shape or readable file, not of shape (N, 3),
        not finite; both or neither of ``beta`` and ``radius``; a bad scale;
        ``resample`` out of range.
    SensorError
        The sensor file does not parse.

    Examples
    --------
    >>> from swazure_ros import api
    >>> setup = api.build_swarm("torus:120", scale=5, beta=0.5)
    >>> setup.swarm.size
    120
    """
    if beta is not None and radius is not None:
        raise CloudError("give beta or radius, not both")
    if beta is None and radius is None:
        raise CloudError("give beta (r = beta * dmin) or radius (cm)")
    # The summary names the sensor's file; one built in Python has none (its values are
    # in the summary's parameters either way).
    sensor_file = "(a Sensor given in Python)" if isinstance(sensor, Sensor) else sensor
    found = sensor if isinstance(sensor, Sensor) else load_sensor(sensor)
    if accurate:
        found = found.error_free()
    points = cloud_of(cloud, scale)
    if resample is not None:
        points = resampled_cloud(points, resample, seed)
    swarm = make_swarm(points.points, beta=beta, radius=radius, seed=seed)
    return SwarmSetup(points, swarm, found, seed, sensor_file)


def cloud_of(cloud: ArrayLike | str | Path, scale: float | None = None) -> Cloud:
    """The :class:`~swazure_ros.core.clouds.Cloud` that ``cloud`` names or holds, in cm.

    Parameters
    ----------
    cloud : (N, 3) array_like, cm; or str or pathlib.Path
        As :func:`build_swarm` takes it.
    scale : float, optional
        Multiplies the coordinates to give cm (default: as :func:`build_swarm`).

    Returns
    -------
    Cloud
        Its name, points (N, 3) in cm, scale and source (a path, ``"builtin"``
        or ``"array"``).

    Raises
    ------
    CloudError
        An unknown name, a file that cannot be read, an array not of shape
        (N, 3) or not finite, a scale that is not a positive number.

    Examples
    --------
    >>> from swazure_ros import api
    >>> api.cloud_of([[0, 0, 0], [1, 0, 0]], scale=2.0).points[1]
    array([2., 0., 0.])
    """
    if isinstance(cloud, str | Path):
        return load_cloud(cloud, scale)
    points = validate_points(cloud, "cloud")
    factor = 1.0 if scale is None else scale
    if not isinstance(factor, int | float) or not math.isfinite(factor) or factor <= 0:
        raise CloudError(f"scale must be a positive number, got {scale}")
    points = validate_points(points * factor, f"points at scale {factor:g}")
    return Cloud("points", points, float(factor), "array")


def evaluate(
    swarm: SwarmSetup,
    policy: str = SHORTEST_LENGTH,
    *,
    technique: str = PLAIN,
    threshold: int = 10,
    compat: str = "text",
    fuse: int = 1,
    estimator: str = PATH,
    memory: int = DEFAULT_MEMORY,
    progress: Progress | None = None,
    source_body: bool = False,
) -> Result:
    """Every ordered blind pair of ``swarm``, as ``swazure evaluate`` computes it.

    Plain Swazure is evaluated a block of pairs at a time within ``memory``;
    a heuristic, fusion or a fit holds every pair at once. The numbers and
    pairs are those ``swazure evaluate --out`` writes for the same options.

    Parameters
    ----------
    swarm : SwarmSetup
        From :func:`build_swarm`.
    policy : {"shortest-length", "fewest-hops", "least-error"}
        The path policy.
    technique : {"plain", "move-obstructing", "move-source"}
        Plain Swazure, or a heuristic tried on the BLOCKED pairs.
    threshold : int, default 10
        Move Source: probe up to this many steps of r per direction, 1 to 1000.
    compat : {"text", "published"}
        The heuristics as the paper's text describes them, or as its code runs.
    fuse : int, default 1
        Fuse each sweet pair's estimate from up to this many node-disjoint
        sweet paths (plain Swazure only).
    estimator : {"path", "least-squares", "local-least-squares", "swarm-fit"}
        The policy's path sum (the paper), or a least-squares fit with a
        covariance per estimate (plain Swazure only).
    memory : int, default 2 GiB
        Bytes a block of plain Swazure's pairs may hold.
    progress : Progress, optional
        Told each stage's start and advance (``core.evaluate.Progress``).
    source_body : bool, default False
        Move Source: take a helper only when the source's own body at its
        probe point leaves the helper's view of the target clear, as a swarm
        flies it (``--source-body``); the spec's rule does not check it.

    Returns
    -------
    Result
        ``summary`` (``core.summary.Summary``), ``record``
        (``files.results.RunRecord``), ``pairs`` (a ``pyarrow.Table``, one row
        per ordered blind pair; FLS ids are the cloud's row numbers; distances
        cm, angles degrees, errors %).

    Raises
    ------
    OptionError
        An option that is none of its choices or out of range, or ``swarm``
        not a SwarmSetup.
    SwazureError
        Options that do not go together (a heuristic with fusion or a fit), or a
        swarm whose pairs would not fit in memory held at once.

    Examples
    --------
    >>> from swazure_ros import api
    >>> result = api.evaluate(api.build_swarm("torus:120", scale=5, beta=0.5))
    >>> result.summary.pairs.blind_pairs == result.pairs.num_rows
    True
    """
    if not isinstance(swarm, SwarmSetup):
        kind = type(swarm).__name__
        raise OptionError(f"swarm must be a SwarmSetup (build_swarm(cloud, beta=...)), got {kind}")
    options = RunOptions(policy, technique, threshold, compat, fuse, estimator, source_body)
    run, table = _run(swarm, options, memory, progress)
    record = RunRecord("evaluate", run.summary.seconds or 0.0, run.summary)
    return Result(swarm, options, record, table, run.evaluation, run.heuristic)


def move_obstructing(
    swarm: SwarmSetup, policy: str = SHORTEST_LENGTH, compat: str = "text"
) -> Result:
    """Move Obstructing on ``swarm``'s BLOCKED pairs: :func:`evaluate` with that technique.

    Parameters
    ----------
    swarm : SwarmSetup
        From :func:`build_swarm`.
    policy : {"shortest-length", "fewest-hops", "least-error"}
        The path policy.
    compat : {"text", "published"}
        The heuristic as the paper's text describes it, or as its code runs.

    Returns
    -------
    Result
        With ``summary.heuristic`` (tried, resolved, moves in cm) and the
        pairs' ``tried``, ``resolved``, ``moves`` columns.

    Raises
    ------
    OptionError
        As :func:`evaluate`.

    Examples
    --------
    >>> from swazure_ros import api
    >>> moved = api.move_obstructing(api.build_swarm("torus:120", scale=1.6, beta=0.5))
    >>> moved.summary.heuristic.technique
    'move-obstructing'
    """
    return evaluate(swarm, policy, technique=MOVE_OBSTRUCTING, compat=compat)


def move_source(
    swarm: SwarmSetup,
    policy: str = SHORTEST_LENGTH,
    threshold: int = 10,
    compat: str = "text",
    source_body: bool = False,
) -> Result:
    """Move Source on ``swarm``'s BLOCKED pairs: :func:`evaluate` with that technique.

    Parameters
    ----------
    swarm : SwarmSetup
        From :func:`build_swarm`.
    policy : {"shortest-length", "fewest-hops", "least-error"}
        The path policy.
    threshold : int, default 10
        Probe up to this many steps of r per direction, 1 to 1000.
    compat : {"text", "published"}
        The heuristic as the paper's text describes it, or as its code runs.
    source_body : bool, default False
        Check that the source's own body at its probe point leaves the
        helper's view of the target clear, as a swarm flies it.

    Returns
    -------
    Result
        With ``summary.heuristic`` (its ``flown_distance`` and
        ``displacement`` in cm too).

    Raises
    ------
    OptionError
        As :func:`evaluate`.

    Examples
    --------
    >>> from swazure_ros import api
    >>> moved = api.move_source(api.build_swarm("torus:120", scale=1.6, beta=0.5), threshold=5)
    >>> moved.summary.heuristic.threshold
    5
    """
    return evaluate(
        swarm,
        policy,
        technique=MOVE_SOURCE,
        threshold=threshold,
        compat=compat,
        source_body=source_body,
    )


def _run(
    setup: SwarmSetup, options: RunOptions, memory: int, progress: Progress | None
) -> tuple[EngineRun, Any]:
    """The engine's run of ``setup``, and its pairs in one pyarrow Table."""
    tables: list[Any] = []
    run = run_engine(
        setup.swarm,
        setup.sensor,
        options,
        take=lambda hood, blocks, heuristic, _: tables.append(_table(hood, blocks, heuristic)),
        budget=Budget(memory, available_memory()),
        source=setup.source,
        progress=progress,
    )
    return run, tables[0]


def _table(
    hood: Neighbourhood, blocks: Iterator[PairResults], heuristic: HeuristicResult | None
) -> Any:
    """Every block's pairs in one pyarrow Table (paths as lists of FLS ids)."""
    import pyarrow as pa

    tables = [pairs_table(hood, pairs, heuristic, as_text=False) for pairs in blocks]
    if not tables:  # no blind pair: the columns still
        none = np.empty(0, dtype=np.int64)
        from ..core.evaluate import evaluate_pairs

        empty = evaluate_pairs(hood, SHORTEST_LENGTH, blind=(none, none))
        tables = [pairs_table(hood, empty, None, as_text=False)]
    return pa.concat_tables(tables)
