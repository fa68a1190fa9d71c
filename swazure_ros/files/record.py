"""One run as typed data: :class:`RunRecord`, and its ``record.json``.

A run record holds the evaluation's summary and the run's own facts (its
seconds, a swarm's bring-up and traffic, the engine's time and summary for the
same work, its pairs compared with the engine's). It is built once where the
run happens; the command line only renders it, and scripts and tests read its
``record.json`` (with a ``fileversion``), never printed text.
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import SwazureError
from ..core.summary import Document, Summary
from ..core.traffic import TopicCounts
from .atomic import write_json
from .reading import CONFIG_BYTES, read_text

if TYPE_CHECKING:
    # Named for the types only: `swazure evaluate` loads no protocol.
    from ..protocol.runs import DiscoveryResult, MoveResult

RECORD_FILE = "record.json"
#: The version of record.json's layout: raised whenever a field changes meaning or goes.
#: Version 1 held the comparison with the engine as text, "yes" or "no: ..." (its
#: ``identical``); version 2 holds it as a record (``comparison``). Both are read.
RECORD_VERSION = 2
#: The versions read_record reads: every one, the older turned into this version's record.
READ_VERSIONS = (1, RECORD_VERSION)


@dataclass(frozen=True)
class BringUp:
    """What bringing a swarm up took."""

    flss: int
    processes: int
    seconds: float  # launcher start to every process discovered
    peak_rss_mb: list[float] = field(default_factory=list)  # per process

    @property
    def total_peak_mb(self) -> float:
        """Sum of the processes' peak resident memory, MB."""
        return float(sum(self.peak_rss_mb))


@dataclass(frozen=True)
class MovesMade(TopicCounts):
    """A heuristic's moves made by the swarm: time, batches, commands and traffic."""

    seconds: float
    batches: int
    move_commands: int  # returns included
    path_walks: int
    timeouts: int  # waits that ended at their deadline
    messages: dict[str, int]  # per topic
    bytes: dict[str, int]  # per topic, serialised payloads

    @classmethod
    def of(cls, moves: MoveResult) -> MovesMade:
        """What the swarm's move run took, from its result."""
        outcome = moves.outcome
        return cls(
            seconds=moves.seconds,
            batches=outcome.batches,
            move_commands=outcome.moved,
            path_walks=outcome.walks,
            timeouts=outcome.timeouts,
            messages=dict(moves.traffic.messages),
            bytes=dict(moves.traffic.bytes),
        )


@dataclass(frozen=True)
class Distributed(TopicCounts):
    """A discovery run made by the swarm, and the moves after it, if any.

    Built from the runs' results (:meth:`of`) or read back from record.json:
    what each run took, without its estimates or evaluation.
    """

    seconds: float
    rounds: int
    restarts: int
    departed: list[int]
    messages: dict[str, int]  # per topic
    bytes: dict[str, int]  # per topic
    repairs: int = 0  # a lossy radio's repair requests and resends
    incomplete: bool = False  # deliveries lost for good: no estimates
    moves: MovesMade | None = None
    # The most memory the labels took in a round, every process's together, bytes.
    label_bytes: int = 0
    runs: int = 1  # the runs of its source blocks, one after the other

    @classmethod
    def of(cls, discovery: DiscoveryResult, moves: MoveResult | None = None) -> Distributed:
        """What the swarm's discovery run, and its move run if any, took, from their results."""
        found = discovery.outcome
        return cls(
            seconds=discovery.seconds,
            rounds=found.rounds,
            restarts=found.restarts,
            departed=sorted(found.departed),
            messages=dict(discovery.traffic.messages),
            bytes=dict(discovery.traffic.bytes),
            repairs=found.repairs,
            incomplete=found.incomplete,
            moves=None if moves is None else MovesMade.of(moves),
            label_bytes=found.label_bytes,
            runs=discovery.runs,
        )

    @property
    def total_messages(self) -> int:
        """Messages on every topic, discovery's and the moves'."""
        moved = self.moves.total_messages if self.moves is not None else 0
        return super().total_messages + moved

    @property
    def total_bytes(self) -> int:
        """Bytes on every topic, discovery's and the moves'."""
        moved = self.moves.total_bytes if self.moves is not None else 0
        return super().total_bytes + moved


@dataclass(frozen=True)
class EngineComparison:
    """A swarm's pairs beside the engine's for the same work, pair by pair.

    A pair is the engine's when its status, its path and its estimate are (the
    estimate to 1e-9 cm; a fit's covariance too, to 1e-9 of its largest
    entry). The pairs are compared one by one only when the swarm reported as
    many as the engine has; else what differs is None: not compared.

    ``source_body`` counts, for Move Source, the pairs the engine resolved where
    the source's own body at its probe point blocks the helper's view of the
    target: the spec's rule takes them, the swarm's walk cannot (0 with
    ``--source-body``; None for another technique).
    """

    pairs: int  # ordered blind pairs the swarm reported
    engine_pairs: int  # the engine's
    statuses: int | None = 0  # pairs whose status differs
    estimates: int | None = 0  # pairs whose estimate (or covariance) differs
    paths: bool | None = False  # whether any pair's path differs
    source_body: int | None = None  # Move Source: the engine's pairs the source's body blocks

    @property
    def identical(self) -> bool:
        """Whether every pair is the engine's: as many, and none differs."""
        return (
            self.pairs == self.engine_pairs
            and self.statuses == 0
            and self.estimates == 0
            and self.paths is False
        )

    def describe(self) -> str:
        """ "yes", or "no: " and what differs, in one line (what ``swazure spawn`` prints)."""
        if self.identical:
            return "yes"
        if self.pairs != self.engine_pairs:
            return f"no: {self.pairs} pairs reported, the engine has {self.engine_pairs}"
        differ = f"{self.statuses} statuses, {self.estimates} estimates differ"
        body = (
            f"; the source's body at its probe blocks the helper's view in {self.source_body} "
            "of the engine's pairs (--source-body checks it)"
            if self.source_body
            else ""
        )
        return f"no: {differ}; paths differ: {self.paths}{body}"

    def as_document(self) -> Document:
        """What record.json holds: whether the pairs are identical, then each count."""
        counts = asdict(self)
        if self.source_body is None:
            del counts["source_body"]  # not Move Source: records as they were
        return {"identical": self.identical, **counts}

    @classmethod
    def from_document(cls, document: Document) -> EngineComparison:
        """The comparison that :meth:`as_document` wrote; ValueError when its ``identical``
        is not what its counts say."""
        counts = dict(document)
        said = counts.pop("identical")
        comparison = cls(**counts)
        if said is not comparison.identical:
            raise ValueError(f"identical {said!r}, but its counts say {comparison.identical}")
        return comparison


#: A version 1 record's comparison, as describe() wrote it when the pairs differ.
_COUNTS_TEXT = re.compile(r"no: (\d+) pairs reported, the engine has (\d+)")
_PAIRS_TEXT = re.compile(r"no: (\d+) statuses, (\d+) estimates differ; paths differ: (True|False)")


def _comparison_of_text(
    text: str, summary: Summary | None, engine: Summary | None
) -> EngineComparison:
    """A version 1 record's comparison (its ``identical``, text) as a record.

    The text is what :meth:`EngineComparison.describe` gives; where it does not
    say how many pairs there were ("yes", or statuses and estimates that
    differ) the run's and the engine's summaries do. ValueError for any other
    text, or a record without both summaries.
    """
    counts = _COUNTS_TEXT.fullmatch(text)
    if counts is not None:
        return EngineComparison(int(counts[1]), int(counts[2]), None, None, None)
    if summary is None or engine is None:
        raise ValueError(f"identical {text!r} without the run's and the engine's summaries")
    found, known = summary.pairs.blind_pairs, engine.pairs.blind_pairs
    if text == "yes":
        return EngineComparison(found, known)
    pairs = _PAIRS_TEXT.fullmatch(text)
    if pairs is None:
        raise ValueError(f'identical {text!r} is neither "yes" nor what differs')
    return EngineComparison(found, known, int(pairs[1]), int(pairs[2]), pairs[3] == "True")


@dataclass(frozen=True)
class RunRecord:
    """One run: its evaluation's summary and the run's facts (``record.json``)."""

    command: str  # the swazure verb that ran: "evaluate" or "spawn"
    seconds: float  # the run's computation, s (a swarm's: discovery and moves)
    summary: Summary | None  # the evaluation's (None: a swarm brought up, no run)
    engine: Summary | None = None  # the core engine's summary of the same work
    engine_seconds: float | None = None
    comparison: EngineComparison | None = None  # the pairs beside the engine's
    bring_up: BringUp | None = None
    distributed: Distributed | None = None
    # The per-pair output (PAIRS_OUTPUTS): "none" says no per-pair file was written;
    # None for a swarm only brought up.
    pairs: str | None = None
    fileversion: int = RECORD_VERSION

    def as_document(self) -> Document:
        """What record.json holds: each summary as summary.json holds it."""
        document: Document = {one.name: getattr(self, one.name) for one in fields(self)}
        # A swarm only brought up has no run: its record's summary is empty.
        document["summary"] = {} if self.summary is None else self.summary.as_document()
        document["engine"] = None if self.engine is None else self.engine.as_document()
        if self.comparison is not None:
            document["comparison"] = self.comparison.as_document()
        for name in ("bring_up", "distributed"):
            if document[name] is not None:
                document[name] = asdict(document[name])
        return document


def write_record(directory: Path, record: RunRecord) -> Path:
    """Write ``record`` as ``directory/record.json``, atomically; return its path."""
    path = directory / RECORD_FILE
    write_json(path, record.as_document())
    return path


def read_record(path: Path) -> RunRecord:
    """The run record in ``path``; SwazureError if it is not one of READ_VERSIONS.

    A record of version 1 comes back as this version's record: its comparison
    with the engine, text, as an :class:`EngineComparison`
    (:func:`_comparison_of_text`).
    """
    text = read_text(path, "run record", CONFIG_BYTES, SwazureError)
    try:
        document = json.loads(text)
    except ValueError as err:
        raise SwazureError(f"{path}: not a run record ({err})") from err
    version = document.get("fileversion") if isinstance(document, dict) else None
    if version not in READ_VERSIONS:
        raise SwazureError(
            f"{path}: record fileversion {version}, this reads "
            + " and ".join(map(str, READ_VERSIONS))
        )
    try:
        bring_up, distributed = document.pop("bring_up"), document.pop("distributed")
        found, known = document.pop("summary"), document.pop("engine")
        # A swarm only brought up has no run: its summary is empty.
        summary = Summary.from_document(found) if found else None
        engine = None if known is None else Summary.from_document(known)
        if version == 1:
            said = document.pop("identical")
            comparison = None if said is None else _comparison_of_text(said, summary, engine)
        else:
            said = document.pop("comparison")
            comparison = None if said is None else EngineComparison.from_document(said)
        if distributed is not None:
            moves = distributed.pop("moves")
            distributed = Distributed(
                **distributed, moves=None if moves is None else MovesMade(**moves)
            )
        return RunRecord(
            **{**document, "fileversion": RECORD_VERSION},
            summary=summary,
            engine=engine,
            comparison=comparison,
            bring_up=None if bring_up is None else BringUp(**bring_up),
            distributed=distributed,
        )
    except (AttributeError, KeyError, TypeError, ValueError) as err:
        # A field missing, unknown or of the wrong kind: the file is not what this reads.
        raise SwazureError(f"{path}: not a run record ({type(err).__name__}: {err})") from err
