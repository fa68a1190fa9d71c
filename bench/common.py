"""The bench's shared machinery: paths, timed runs, swarm commands, Markdown tables.

And the merge of a run's sections into BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import platform
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from swazure_ros.core.summary import FitFacts, Summary

REPO = Path(__file__).resolve().parents[1]


SHARED = REPO.parent / "shared"


DATASETS = SHARED / "datasets" / "swazure-paper"


SHAPES = [
    "chess_408",
    "palm_725",
    "kangaroo_972",
    "dragon_1147",
    "skateboard_1372",
    "racecar_3720",
]


POLICIES = ["fewest-hops", "shortest-length"]


HEURISTICS = [("move-obstructing", None), ("move-source", 2), ("move-source", 10)]


def machine() -> str:
    model = "unknown CPU"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    memory_kb = int(Path("/proc/meminfo").read_text().split()[1])
    return (
        f"{model}, {os.cpu_count()} cores, {memory_kb / 2**20:.0f} GiB, "
        f"{platform.system()} {platform.release()}, Python {platform.python_version()}"
    )


def measured_commit() -> str:
    """The commit measured, marked when the code or configuration differs from it."""

    def git(*arguments: str) -> str:
        result = subprocess.run(["git", "-C", str(REPO), *arguments], capture_output=True,
                                text=True)  # fmt: skip
        return result.stdout.strip() if result.returncode == 0 else ""

    commit = git("rev-parse", "--short", "HEAD") or "unknown"
    # The bench rewrites BENCHMARKS.md and docs/figures; only what runs counts as a change.
    changed = git("status", "--porcelain", "--", "swazure_ros", "msg_defs", "config",
                  "scripts", "bench", "setup.py", "requirements.lock")  # fmt: skip
    return f"{commit} with local changes" if changed else commit


def run(arguments: list[str]) -> tuple[float, float, int]:
    """Run a command; return wall seconds, peak RSS in MB, exit code."""
    seconds, memory, code, _ = run_output(arguments)
    return seconds, memory, code


def run_output(arguments: list[str]) -> tuple[float, float, int, str]:
    """Run a command; return wall seconds, peak RSS in MB (largest process), exit code, stdout."""
    began = time.perf_counter()
    process = subprocess.Popen(arguments, stdout=subprocess.PIPE, text=True)
    assert process.stdout is not None
    output = process.stdout.read()
    _, status, usage = os.wait4(process.pid, 0)
    seconds = time.perf_counter() - began
    # Reaped by wait4 (for its peak memory): tell the Popen, which would wait for it again.
    process.returncode = os.waitstatus_to_exitcode(status)
    process.stdout.close()
    return seconds, usage.ru_maxrss / 1024, process.returncode, output


SWAZURE = [sys.executable, "-m", "swazure_ros.cli.main"]


SECTIONS_DIR = REPO / "build" / "bench"

#: The ROS domain ids the bench's sections run their swarms on, each section's
#: default (bench.swarm 91, discovery 92, cells, hostile, swarm_fit and tracking 93,
#: replay and soak 94, faults 95, under_load 96, fls_process 151). A section that
#: takes another fixed id must add it here. bench.exits reserves a free one instead.
BENCH_DOMAINS = (91, 92, 93, 94, 95, 96, 151)
#: ROS 2's domain_coordinator holds domain id ``k`` by binding TCP port 32768 + k; the
#: tests hold theirs so too (test/domains.py).
DOMAIN_PORT_BASE = 32768


@contextlib.contextmanager
def held_domains(domains: tuple[int, ...] = BENCH_DOMAINS) -> Iterator[None]:
    """Hold ``domains`` on this machine while the ``with`` block runs.

    Held as the tests and launch_testing hold theirs, so that a `make test` or
    another project's ROS tests beside the bench never take them while it runs
    (those ids are in the tests' default range, 1-100). An id held by someone
    else is waited for, saying so: the tests hold theirs for one test's length.
    """
    holders: list[socket.socket] = []
    try:
        for domain in domains:
            said = False
            while True:
                holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                try:
                    holder.bind(("", DOMAIN_PORT_BASE + domain))
                except OSError as error:
                    holder.close()
                    if error.errno != errno.EADDRINUSE:
                        raise
                    if not said:
                        print(f"bench: waiting for ROS domain {domain}, held by another run",
                              flush=True)  # fmt: skip
                        said = True
                    time.sleep(1.0)
                    continue
                holders.append(holder)
                break
        yield
    finally:
        for holder in holders:
            holder.close()


def spawn_command(cloud: str, domain: int, *options: str) -> list[str]:
    """`swazure spawn --quiet` of ``cloud`` at beta 0.5 on domain ``domain``, plus ``options``."""
    return [
        *SWAZURE, "spawn", "--cloud", cloud, "--beta", "0.5", "--quiet",
        "--domain-id", str(domain), *options,
    ]  # fmt: skip


def du_mb(path: Path) -> float:
    """Disk use of a folder, MB."""
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) / 2**20


SHAPE_SIZES = {
    "chess_408": 408,
    "palm_725": 725,
    "kangaroo_972": 972,
    "dragon_1147": 1147,
    "skateboard_1372": 1372,
    "racecar_3720": 3720,
}


#: The longest a swarm may take to come up before its row says so.
BRING_UP_LIMIT = 900.0


def swarm_cloud(name: str) -> str:
    """The --cloud of a published shape; a built-in one (``torus:N``) as it is."""
    return name if name.startswith("torus") else str(DATASETS / f"{name}.xyz")


def children(pid: int) -> list[int]:
    """Ids of the child processes of ``pid``."""
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(child) for child in path.read_text().split()] if path.exists() else []


#: The longest a --compute-all run may take before its row says how far it got, s.
# The targets of issue 16 are 10 min (plain) and 15 min (the race car's heuristics):
# a run is stopped a little after its target, so that a missed one still shows.
RUN_LIMIT = {"plain": 720.0, "move-obstructing": 1080.0, "move-source": 1080.0}


def compute_all(
    cloud: str,
    technique: str,
    domain: int,
    out: Path,
    processes: int,
    limit: float,
    *options: str,
) -> dict[str, object]:
    """One `swazure spawn --compute-all` run; its timings, traffic and the engine check.

    A run still going after ``limit`` s is stopped: the row has how far it got.
    """
    command = [
        *SWAZURE, "spawn", "--cloud", cloud, "--beta", "0.5", "--domain-id", str(domain),
        "--processes", str(processes), "--policy", "shortest-length", "--compute-all",
        "--technique", technique, "--out", str(out), *options,
    ]  # fmt: skip
    log = out / "stderr.log"
    began = time.perf_counter()
    with log.open("w") as stderr:
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=stderr, text=True)
        try:
            process.communicate(timeout=limit)
        except subprocess.TimeoutExpired:
            process.terminate()
            process.communicate(timeout=900)
            # The last progress line: "  N s: batch k of n".
            said = [x.strip() for x in log.read_text().splitlines() if " s: " in x]
            where = said[-1].split(": ", 1)[1] if said else "bringing the swarm up"
            return {"failed": f"stopped after {limit / 60:.0f} min at {where}"}
    seconds = time.perf_counter() - began
    from swazure_ros.files.record import RECORD_FILE, read_record

    # Exit 1 with a record: the run finished but is not the engine's (its row says how).
    if process.returncode != 0 and not (process.returncode == 1 and (out / RECORD_FILE).exists()):
        tail = log.read_text().strip().splitlines()[-1:]
        return {"failed": f"exit {process.returncode}: {' '.join(tail)}"}

    record = read_record(out / RECORD_FILE)
    distributed, bring_up = record.distributed, record.bring_up
    assert distributed is not None and bring_up is not None
    moved = distributed.moves
    return {
        "wall": seconds,
        "peak": f"{bring_up.total_peak_mb:.0f}",
        "bring_up": bring_up.seconds,
        "discovery": distributed.seconds,
        "rounds": distributed.rounds,
        "restarts": distributed.restarts,
        "departed": len(distributed.departed),
        "moving": moved.seconds if moved is not None else 0.0,
        "timeouts": moved.timeouts if moved is not None else 0,
        "batches": moved.batches if moved is not None else 0,
        "messages": distributed.total_messages,
        "bytes": distributed.total_bytes,
        "engine": record.engine_seconds,
        "identical": "-" if record.comparison is None else record.comparison.describe(),
    }


def resident_mb(pid: int) -> float:
    """Resident memory of process ``pid`` and its children, MB."""
    pages = sum(
        int(Path(f"/proc/{one}/statm").read_text().split()[1]) for one in [pid, *children(pid)]
    )
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def table_cell(record: dict[str, Any], key: str, form: str, scale: float = 1.0) -> str:
    """A Markdown table cell: ``record[key]`` times ``scale`` in ``form``, "-" when absent."""
    value = record.get(key)
    return "-" if value is None else format(value * scale, form)


def stamped(body: list[str], stamp: str) -> list[str]:
    """A section's ``body`` with its ``stamp`` after its leading headings: a section
    that is a subsection of a shared heading ("## Under load", "### Exits ...") has its
    stamp in its subsection."""
    last = 0
    for k, line in enumerate(body):
        if line.startswith("#"):
            last = k
        elif line:
            break
    return [*body[: last + 1], "", stamp, "", *body[last + 1 :]]


def _split(lines: list[str], mark: str) -> list[list[str]]:
    """``lines`` cut before each line that starts with ``mark``: a preamble, then parts."""
    parts: list[list[str]] = [[]]
    for line in lines:
        if line.startswith(mark):
            parts.append([])
        parts[-1].append(line)
    return parts


def _replaced(old: list[str], new: list[str]) -> list[str]:
    """Section ``old`` run again as ``new``. A ``new`` with nothing of its own before its
    first "### " subsection adds to a heading that other sections share: each of its
    subsections replaces its namesake in ``old``, the others stay; else ``new`` is all."""
    preamble, *subsections = _split(new[1:], "### ")
    if not subsections or any(line.strip() for line in preamble):
        return new
    kept_preamble, *kept = _split(old[1:], "### ")
    fresh = {part[0]: part for part in subsections}
    parts = [fresh.pop(part[0], part) for part in kept]
    parts += [part for part in subsections if part[0] in fresh]
    ending = [part if part[-1] == "" else [*part, ""] for part in parts]
    return [old[0], *kept_preamble, *(line for part in ending for line in part)]


def merged(existing: str, fresh: list[list[str]]) -> str:
    """The benchmarks file: ``existing``'s sections, each replaced by its fresh run if any.

    A section is a "## " heading and what follows it. Sections run again
    replace theirs in place; new ones go at the end; the others stay as they
    were measured (a run of some sections must not drop the rest). Sections
    that share a heading, each a "### " subsection of it, replace only their
    own subsection (:func:`_replaced`).
    """
    chunks: list[list[str]] = []
    for line in existing.split("\n"):
        if line.startswith("## ") or not chunks:
            chunks.append([])
        chunks[-1].append(line)
    header = ["# Benchmarks", "", "Regenerate with `make bench` (writes this file).", ""]
    if chunks and not chunks[0][0].startswith("## "):
        header = chunks.pop(0)
    # A section may hold several headings (the engine's holds the heuristics'): each
    # replaces its own, so that a section run again is never left twice in the file.
    by_heading: dict[str, list[str]] = {}
    for section in fresh:
        for piece in _split(section, "## ")[1:]:
            known = by_heading.get(piece[0])
            by_heading[piece[0]] = piece if known is None else _replaced(known, piece)
    out = [
        _replaced(chunk, by_heading.pop(chunk[0])) if chunk[0] in by_heading else chunk
        for chunk in chunks
    ]
    out += list(by_heading.values())
    body = [line for chunk in out for line in (chunk if chunk[-1] == "" else [*chunk, ""])]
    return "\n".join([*header, *body]).rstrip("\n") + "\n"


def fit_facts(summary: Summary) -> FitFacts:
    """The fit's facts of a refined evaluation's summary; an error for a summary of no fit."""
    if summary.fit is None:
        raise ValueError("the summary is of no fit")
    return summary.fit


def record_file(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse ``args.out`` when it is a folder, before a measure's long run, not after."""
    if args.out.is_dir():
        parser.error(f"--out {args.out} is a folder; give the JSON file to write")
