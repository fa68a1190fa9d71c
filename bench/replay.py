"""A swarm under valid queries while a peer replays an earlier swarm of the same key file.

The `replay` section of BENCHMARKS.md (`python -m bench --sections replay`).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from bench.clients import ask_random_pairs, close_client, hostile_figure, pose_client, soak_counts
from bench.common import REPO, SWAZURE, spawn_command, swarm_cloud

#: How long the replay soak runs, s; SWAZURE_REPLAY_SECONDS for a shorter try.
REPLAY_SECONDS = float(os.environ.get("SWAZURE_REPLAY_SECONDS", 600))


def replay_section(
    args: argparse.Namespace,
    shape: str = "chess_408",
    domain: int = 94,
    seconds: float = REPLAY_SECONDS,
    figures: Path = REPO / "docs" / "figures",
) -> list[str]:
    """A swarm under valid queries while a peer replays an earlier swarm of the same key file."""
    from swazure_ros.ros.security.keys import new_key, write_key

    cloud = swarm_cloud(shape)
    folder = Path(tempfile.mkdtemp(prefix="swazure-replay-soak-"))
    key = folder / "swarm.key"
    write_key(key, new_key())
    # The earlier swarm: a whole discovery and Move Obstructing's moves, recorded.
    bag = folder / "earlier"
    earlier = subprocess.run(
        spawn_command(cloud, domain, "--key-file", str(key), "--record", str(bag),
                      "--compute-all", "--technique", "move-obstructing", "--out",
                      str(folder / "earlier-out")),
        capture_output=True, text=True, timeout=1800,
    )  # fmt: skip
    if earlier.returncode != 0:
        return ["## Replay of an earlier swarm", "", f"the earlier swarm failed: {earlier.stderr}"]
    recorded = earlier.stderr.split("recorded ")[-1].split(" messages")[0]
    soak = replayed_soak(cloud, args.beta, domain, key, bag, seconds)
    if soak is None:
        return ["## Replay of an earlier swarm", "", "the chess swarm did not come up"]
    answers, samples, diagnostics, replays = soak
    hostile_figure(
        samples,
        figures / "replay-soak.png",
        "chess_408 swarm under queries, an earlier swarm replayed into it",
    )
    return replay_lines(seconds, recorded, answers, replays, samples, diagnostics)


def replayed_soak(
    cloud: str, beta: float, domain: int, key: Path, bag: Path, seconds: float
) -> tuple[tuple[int, int, int], list[tuple[float, float]], dict[str, Any], list[str]] | None:
    """Queries of a swarm of ``key`` for ``seconds`` while ``bag`` is replayed again and again.

    Right, wrong and unanswered queries, the memory samples, the swarm's diagnostics and
    each replay's report; None when the swarm does not come up.
    """
    import threading

    import numpy as np

    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    world = WorldSpec(cloud, beta=beta).build()
    engine = evaluate_pairs(world.hood, policy)
    rng = np.random.default_rng(0)
    diagnostics: dict[str, dict[str, str]] = {}
    replays: list[str] = []
    stop = threading.Event()

    def replay_again_and_again() -> None:
        while not stop.is_set():
            done = subprocess.run(
                [*SWAZURE, "replay", str(bag), "--domain-id", str(domain), "--rate", "4"],
                capture_output=True, text=True, timeout=1800,
            )  # fmt: skip
            replays.append(done.stdout.strip() or done.stderr.strip())

    # The with closes the swarm's pipe once it has stopped.
    with subprocess.Popen(
        spawn_command(cloud, domain, "--key-file", str(key)), stdout=subprocess.PIPE, text=True
    ) as swarm:
        try:
            assert swarm.stdout is not None
            if not swarm.stdout.readline().startswith("swarm up:"):
                return None
            context, node, executor, client = pose_client(domain, "bench_replay", diagnostics)
            peer = threading.Thread(target=replay_again_and_again, daemon=True)
            peer.start()
            right, wrong, unanswered, samples = ask_random_pairs(
                client, executor, world, engine, policy, seconds, swarm.pid, rng
            )
            stop.set()
            peer.join(timeout=1800)
            close_client(context, node, executor)
        finally:
            stop.set()
            swarm.terminate()
            swarm.wait(timeout=300)
    return (right, wrong, unanswered), samples, diagnostics, replays


def replay_lines(
    seconds: float,
    recorded: str,
    answers: tuple[int, int, int],
    replays: list[str],
    samples: list[tuple[float, float]],
    diagnostics: dict[str, dict[str, str]],
) -> list[str]:
    """The replay section from the soak's right, wrong and unanswered queries and counters."""
    right, wrong, unanswered = answers
    lines = [
        f"## Replay of an earlier swarm: valid queries for {seconds / 60:.0f} minutes "
        "while a peer plays back a recording of an earlier swarm of the same key file",
        "",
        "One key file (`swazure key`). The earlier swarm: `swazure spawn` of chess_408 (beta",
        "0.5, one process) with `--compute-all --technique move-obstructing --record`, so that",
        "its recording holds a whole discovery's controls, offers and reports and the",
        f"heuristic's moves and world revisions ({recorded} messages). The later swarm: the",
        "same command without the run, served; a client asks `/swarm/coordinator/compute_pose`",
        "for random blind pairs (seeded) one after another and compares each answer with the",
        "engine's (status, path, vector to 1e-9), while `swazure replay` of the earlier recording",
        '(4x its speed) runs again and again on the same domain. docs/security.md, "Replays',
        "bound to one swarm's life\", says why none of it is taken.",
        "",
        f"Valid queries: {right + wrong + unanswered}: {right} right, {wrong} wrong, "
        f"{unanswered} unanswered within 120 s.",
        f"Replays of the earlier swarm: {len(replays)} ({replays[-1] if replays else '-'}).",
        *soak_counts(samples, "replay-soak.png", diagnostics, dropped_only=True),
    ]
    return [*lines, ""]
