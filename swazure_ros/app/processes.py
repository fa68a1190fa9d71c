"""The processes of a swarm besides the launcher's: packed shares, or one per FLS.

A packed swarm runs its FLS nodes in the launcher's process and in further
processes (multiprocessing, spawn start method), each hosting one share and
reporting over a queue: nodes created, discovery complete (with its peak
memory), or one error line. A swarm of one process per FLS runs each FLS as
the ``fls`` program (:mod:`.per_fls`), and the launcher simulates the
cameras. :class:`RunningSwarm <.swarm.RunningSwarm>` drives either through
:class:`SwarmProcesses`.
"""

from __future__ import annotations

import multiprocessing
import queue
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

from ..core.errors import RunError, SwazureError
from ..ros.programs.host import SwarmHost
from ..ros.security.auth import SwarmKey
from ..sim.world import Held
from .config import SwarmConfig
from .per_fls import Ended, FlsProcesses
from .share import CREATED, FAILED, READY, host_share


class SwarmProcesses(Protocol):
    """What the launcher asks of the processes that host the FLSs it does not."""

    #: FLS ids whose nodes the launcher's process hosts.
    own_share: list[int]
    #: FLS ids whose observations the launcher's world lays out (None: every FLS's).
    laid_out: list[int] | None
    #: Processes whose radios take part in a run: one per share, or per FLS.
    radios: int
    #: Whether the launcher's leader simulates every FLS's camera (the FLSs sense
    #: by camera detections in processes of their own).
    simulates_cameras: bool

    def start(self) -> None:
        """Start every process."""

    def watch(self, up: bool) -> None:
        """Take the processes' news; SwazureError for one that failed (while not ``up``)."""

    def created(self, own: int, host: SwarmHost) -> int:
        """FLS nodes created so far, ``own`` of them by the launcher's ``host``."""

    def ready(self) -> bool:
        """Whether every process has reported its share up and discovered."""

    def peak_rss_mb(self) -> list[float]:
        """Peak resident memory of each process, MB, after the launcher's own."""

    def process_ids(self) -> list[int]:
        """The pids of these processes."""

    def stop(self) -> None:
        """Stop every process and wait for it."""


class PackedShares:
    """Further processes (multiprocessing, spawn) that host one share of FLS nodes each."""

    simulates_cameras = False

    def __init__(self, config: SwarmConfig, key: SwarmKey, shares: list[list[int]]) -> None:
        size = sum(map(len, shares))
        self.own_share = shares[0]
        self.laid_out: list[int] | None = shares[0]
        self.radios = max(config.processes, config.hosts)
        #: The FLS ids of each process's share, the launcher's first.
        self.shares = shares
        self._created = [0] * len(shares)
        self._peaks: dict[int, float] = {}
        self._held: dict[int, Held] = {}
        mp = multiprocessing.get_context("spawn")
        self._reports = mp.Queue()
        self._stop = mp.Event()
        material = key.material  # each further process signs as a sender of its own
        self._children = [
            mp.Process(
                target=host_share,
                args=(config, material, index, share, size, self._reports, self._stop),
                name=f"swazure-host-{index}",
                daemon=True,
            )
            for index, share in enumerate(shares)
            if index > 0
        ]

    def start(self) -> None:
        for child in self._children:
            child.start()

    def watch(self, up: bool) -> None:
        while True:
            try:
                kind, index, value = self._reports.get_nowait()
            except queue.Empty:
                break
            if kind == FAILED:
                raise SwazureError(value)
            if kind == CREATED:
                self._created[index] = value
            elif kind == READY:
                self._created[index] = len(self.shares[index])
                self._peaks[index], self._held[index] = value
        for child in self._children:
            if child.exitcode is not None and child.exitcode != 0:
                raise RunError(f"{child.name} exited with code {child.exitcode}")

    def created(self, own: int, host: SwarmHost) -> int:
        return own + sum(self._created[1:])

    def ready(self) -> bool:
        return len(self._peaks) == len(self._children)

    def peak_rss_mb(self) -> list[float]:
        return [self._peaks[index] for index in range(1, len(self.shares))]

    def held(self) -> list[Held]:
        """What each further process's world holds once up: pairs and observation rows.

        Its own FLSs' pairs and rows alone (``WorldSpec.build(hosted_ids,
        only_hosted_pairs=True)``), where the launcher's world holds the whole swarm's pairs.
        """
        return [self._held[index] for index in range(1, len(self.shares))]

    def process_ids(self) -> list[int]:
        return [child.pid for child in self._children if child.pid is not None]

    def stop(self) -> None:
        self._stop.set()
        for child in self._children:
            if child.pid is not None:
                child.join(timeout=30)
                if child.is_alive():
                    child.terminate()
                    child.join(timeout=5)


class ProcessPerFls:
    """One ``fls`` program per FLS of this host's share (:class:`.per_fls.FlsProcesses`).

    Once the swarm is up, an FLS process that ends is an FLS lost, as in
    flight: the swarm's rounds find it silent and go on without it
    (docs/protocol.md, departures).
    """

    simulates_cameras = True

    def __init__(
        self,
        config: SwarmConfig,
        key: SwarmKey,
        share: list[int],
        swarm_size: int,
        log_dir: Path,
        on_lost: Callable[[Ended], None],
    ) -> None:
        self.own_share: list[int] = []
        self.laid_out: list[int] | None = None
        self.radios = swarm_size
        self.fls = FlsProcesses(
            config.world,
            share,
            log_dir,
            namespace=config.namespace,
            key=key,
            parameters=config.parameters,
            fls_parameters=config.fls_parameters,
            params_file=config.params_file,
            domain_id=config.domain_id,
            discovery_servers=config.discovery_servers,
        )
        self._on_lost = on_lost
        #: The FLS processes that ended once the swarm was up.
        self.lost: list[Ended] = []
        self._reported: set[int] = set()  # FLSs whose process's end was reported
        #: How every FLS process ended, once stopped.
        self.ended: list[Ended] = []

    def start(self) -> None:
        self.fls.start()

    def watch(self, up: bool) -> None:
        ended = [one for one in self.fls.ended() if one.fls_id not in self._reported]
        if ended and not up:
            # While it comes up, an FLS that ends has a fault to fix: stop and say which.
            raise RunError(f"{ended[0].describe()} (log: {self.fls.log(ended[0].fls_id)})")
        for one in ended:
            self._reported.add(one.fls_id)
            self.lost.append(one)
            self._on_lost(one)

    def restart(self, fls_id: int) -> None:
        """Start FLS ``fls_id``'s process again once it has ended (FlsProcesses.restart)."""
        self.fls.restart(fls_id)
        self._reported.discard(fls_id)

    def created(self, own: int, host: SwarmHost) -> int:
        return min(host.publishers_seen(), self.radios)

    def ready(self) -> bool:
        return True

    def peak_rss_mb(self) -> list[float]:
        return self.fls.peak_rss_mb()

    def process_ids(self) -> list[int]:
        return []

    def stop(self) -> None:
        self.ended = self.fls.stop()
