"""Regenerate the example outputs in README.md from real runs of the commands they show.

Each output block in the README follows a marker line ``<!-- output: NAME -->``
and is an excerpt of what ``swazure`` printed: the lines that :data:`BLOCKS`
keeps, in order, with ``...`` where lines were left out. ``--check`` runs the
same commands and exits 1 when a block no longer matches what they print, up
to the figures that differ from run to run (seconds, MB, memory); the test
suite runs it (test/test_readme.py), so the README cannot go stale unseen.

    .venv/bin/python scripts/readme_outputs.py           # rewrite README.md's blocks
    .venv/bin/python scripts/readme_outputs.py --check   # exit 1 if they are stale
    .venv/bin/python scripts/readme_outputs.py --times   # time a fresh clone's setup (minutes)
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
MARKER = re.compile(r"^<!-- output: (?P<name>[\w-]+) -->$")
#: Figures that differ from run to run on one machine: times, sizes, memory, the rounds
#: and messages of a discovery whose round restarted under load, and a message's stamp.
VOLATILE = re.compile(
    r"\d+(?:\.\d+)? (?:s|MB|rounds|messages)\b|\(\d+(?: \+ \d+)*\)|sec=\d+, nanosec=\d+"
)
#: The real ros2 command line, where ../shared's wheels were installed (make setup).
ROS2 = Path(sys.executable).parent / "ros2"
#: Seconds the example swarm may take to come up and answer.
ROS_WAIT = 180.0


@dataclass(frozen=True)
class Block:
    """One example output: the ``swazure`` arguments, and the lines kept, by their start."""

    name: str
    arguments: tuple[str, ...]
    kept: tuple[str, ...]  # a printed line is kept when it starts with one of these


#: The examples of "The two commands": make demo's three commands (Makefile).
BLOCKS = (
    Block(
        "demo-evaluate",
        ("evaluate", "--cloud", "torus", "--beta", "0.5", "--policy", "shortest-length"),
        (
            "torus: beta",
            "FLSs (removed)",
            "ordered blind pairs",
            "sweet path",
            "distance error, %",
        ),
    ),
    Block(
        "demo-spawn",
        (
            "spawn",
            "--cloud",
            "torus",
            "--beta",
            "0.5",
            "--policy",
            "shortest-length",
            "--compute-all",
            "--quiet",
        ),
        (
            "swarm up:",
            "torus: beta",
            "engine:",
            " " * 30,
            "ordered blind pairs",
            "sweet path",
            "pairs identical",
        ),
    ),
    Block(
        "demo-track",
        (
            "track",
            "--cloud",
            "config/track/trio.xyz",
            "--scale",
            "1",
            "--radius",
            "0.5",
            "--source",
            "0",
            "--target",
            "2",
            "--trajectory",
            "circle:0.5,4,-1,1,0",
            "--duration",
            "6",
            "--communication-delay",
            "0.3",
            "--every",
            "1",
        ),
        (
            "FLS 0 tracks",
            "estimator",
            "raw",
            "filtered",
            "predicted",
            "identical to the core's loop",
        ),
    ),
)


@dataclass(frozen=True)
class RosSession:
    """The README's first ROS example: ros2 commands against the launched example swarm.

    Each command runs again until it answers (the swarm takes a while to come
    up); the block shows each command after ``$`` and the lines it printed that
    start with one of ``kept``.
    """

    name: str
    launch: tuple[str, ...]
    commands: tuple[tuple[str, ...], ...]
    kept: tuple[str, ...]


SESSIONS = (
    RosSession(
        "ros2-first",
        ("launch", "swazure_ros", "swarm.launch.py"),
        (
            ("param", "get", "/swarm/fls_1", "publish_period"),
            (
                "service",
                "call",
                "/swarm/coordinator/compute_pose",
                "swazure_interfaces/srv/ComputePose",
                "{source_id: 0, target_id: 2, policy: 1}",
            ),
        ),
        ("Double value", "response:", "swazure_interfaces.srv.ComputePose_Response"),
    ),
)


def run_session(session: RosSession) -> list[str]:
    """Launch the example swarm, run the session's commands against it; the block's lines."""
    if not ROS2.exists():
        raise SystemExit(f"readme_outputs: {session.name} needs {ROS2} (../shared's wheels)")
    environment = dict(os.environ, AMENT_PREFIX_PATH=str(ROS2.parents[1]))
    launch = subprocess.Popen(
        [str(ROS2), *session.launch],
        env=environment,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    lines = [f"$ ros2 {shown(session.launch)}"]
    try:
        deadline = time.monotonic() + ROS_WAIT
        for command in session.commands:
            while True:
                done = subprocess.run(
                    [str(ROS2), *command], env=environment, capture_output=True, text=True,
                    timeout=ROS_WAIT,
                )  # fmt: skip
                if done.returncode == 0 and "success=False" not in done.stdout:
                    break
                if time.monotonic() > deadline:
                    raise SystemExit(f"readme_outputs: ros2 {shown(command)}: no answer")
                time.sleep(1.0)
            lines.append(f"$ ros2 {shown(command)}")
            lines += [
                line.rstrip() for line in done.stdout.splitlines() if line.startswith(session.kept)
            ]
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        launch.wait(timeout=60)
    return lines


def shown(command: Sequence[str]) -> str:
    """A command as a person types it: an argument with spaces in double quotes."""
    return " ".join(f'"{word}"' if " " in word else word for word in command)


#: The README's block of fresh-clone times (written by --times, never checked: they vary).
TIMES_BLOCK = "fresh-clone-times"
#: What --times measures in a fresh clone with no ../shared beside it, as a user's is.
TIMED = (
    ("make setup", "from nothing: venv, pinned wheels, interfaces, numba kernels"),
    ("make demo", "set up: evaluate, the same by the swarm, a track"),
    ("make colcon", "both packages built with colcon over the venv"),
)


def fresh_clone_times() -> list[str]:
    """Time TIMED's steps in a fresh clone of this repository, as README's times block."""
    lines = [f"measured {time.strftime('%Y-%m-%d')} by scripts/readme_outputs.py --times, "
             f"{os.cpu_count()} cores, a clone with no ../shared beside it:"]  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        clone = Path(folder) / "swazure"
        subprocess.run(["git", "clone", "--quiet", str(REPO), str(clone)], check=True)
        for step, what in TIMED:
            print(f"readme_outputs: {step} in {clone} ...", file=sys.stderr, flush=True)
            began = time.perf_counter()
            done = subprocess.run(step.split(), cwd=clone, capture_output=True, text=True)
            if done.returncode != 0:
                tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
                raise SystemExit(f"readme_outputs: {step} failed in the clone: {tail}")
            lines.append(f"{step:<12} {time.perf_counter() - began:6.0f} s   {what}")
    return lines


def excerpt(printed: str, kept: Sequence[str]) -> list[str]:
    """The lines of ``printed`` that start with one of ``kept``, ``...`` where lines were cut."""
    lines, skipped = [], False
    for line in printed.splitlines():
        if line.startswith(tuple(kept)):
            if skipped and lines:
                lines.append("...")
            lines.append(line.rstrip())
            skipped = False
        else:
            skipped = True
    return lines


def run(block: Block) -> list[str]:
    """Run ``swazure`` with the block's arguments; its excerpt. SystemExit if it failed."""
    done = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *block.arguments],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise SystemExit(f"readme_outputs: swazure {block.arguments[0]} failed: {tail}")
    return excerpt(done.stdout, block.kept)


def blocks_in(text: str) -> dict[str, tuple[int, int]]:
    """Each marked block in ``text``: name -> (first, end) of the lines inside its fence."""
    lines = text.splitlines()
    found = {}
    for index, line in enumerate(lines):
        match = MARKER.match(line)
        if match is None:
            continue
        if index + 1 >= len(lines) or not lines[index + 1].startswith("```"):
            raise SystemExit(f"readme_outputs: no code block after {line}")
        end = next(k for k in range(index + 2, len(lines)) if lines[k].startswith("```"))
        found[match["name"]] = (index + 2, end)
    return found


def masked(lines: Sequence[str]) -> list[str]:
    """``lines`` with the figures that differ from run to run replaced by ``#``."""
    return [VOLATILE.sub("#", line) for line in lines]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a block is stale")
    parser.add_argument("--readme", type=Path, default=README, help="the README (default ours)")
    names = [one.name for one in (*BLOCKS, *SESSIONS)]
    parser.add_argument("--only", nargs="+", choices=names, help="these blocks only")
    parser.add_argument(
        "--skip-ros", action="store_true", help="leave out the blocks that need the ros2 tools"
    )
    parser.add_argument(
        "--times",
        action="store_true",
        help="measure the README's times in a fresh clone (make setup, demo, colcon: minutes) "
        "and rewrite its times block, nothing else",
    )
    args = parser.parse_args(argv)
    if args.times:
        return write_times(args.readme)
    every: list[Block | RosSession] = [*BLOCKS, *([] if args.skip_ros else SESSIONS)]
    chosen = [one for one in every if args.only is None or one.name in args.only]
    try:
        text = args.readme.read_text()
    except OSError as err:
        raise SystemExit(f"readme_outputs: {args.readme}: {err.strerror or err}") from None
    spans = blocks_in(text)
    missing = [block.name for block in chosen if block.name not in spans]
    if missing:
        raise SystemExit(f"readme_outputs: no marker for {', '.join(missing)} in {args.readme}")
    lines = text.splitlines()
    stale = []
    # From the last block up, so that earlier spans keep their line numbers.
    for block in sorted(chosen, key=lambda one: spans[one.name][0], reverse=True):
        first, end = spans[block.name]
        fresh = run(block) if isinstance(block, Block) else run_session(block)
        if masked(lines[first:end]) != masked(fresh):
            stale.append(block.name)
        lines[first:end] = fresh
    if args.check:
        if stale:
            print(f"README.md: stale output of {', '.join(sorted(stale))}", file=sys.stderr)
            return 1
        print(f"README.md: {len(chosen)} outputs match fresh runs")
        return 0
    sys.path.insert(0, str(REPO))
    from swazure_ros.files.atomic import atomic_write

    new = "\n".join(lines) + "\n"
    atomic_write(args.readme, lambda tmp: tmp.write_text(new))
    print(f"README.md: {len(chosen)} outputs regenerated ({len(stale)} had changed)")
    return 0


def write_times(readme: Path) -> int:
    """Rewrite README's fresh-clone times block from a new measurement."""
    text = readme.read_text()
    spans = blocks_in(text)
    if TIMES_BLOCK not in spans:
        raise SystemExit(f"readme_outputs: no marker for {TIMES_BLOCK} in {readme}")
    lines = text.splitlines()
    first, end = spans[TIMES_BLOCK]
    measured = fresh_clone_times()
    lines[first:end] = measured
    sys.path.insert(0, str(REPO))
    from swazure_ros.files.atomic import atomic_write

    new = "\n".join(lines) + "\n"
    atomic_write(readme, lambda tmp: tmp.write_text(new))
    print("\n".join(measured))
    return 0


if __name__ == "__main__":
    sys.exit(main())
