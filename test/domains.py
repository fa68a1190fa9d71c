"""The ROS domain ids the tests may use, and one held by a test while it runs.

A test that talks over DDS holds a domain id of its own for its whole run, so
that tests on two workers (pytest-xdist), two runs of the suite side by side, or
another project's ROS tests on the same machine never meet. The ids come from
the environment variable ``SWAZURE_TEST_DOMAINS`` (README, "Tests"): ids and
ranges such as ``1-100`` (the default) or ``150-159,170``. On a shared machine,
give each person's runs their own ids.

An id is held as ROS 2's own ``domain_coordinator`` holds it, by binding TCP port
``32768 + id`` on this machine: a run of launch_testing or of another project
that uses it respects ours, and ours respects theirs. When every allowed id is
held, a test waits for one to come free (a run that holds them all only ever
holds them for a test's length) instead of failing at once.
"""

from __future__ import annotations

import contextlib
import errno
import os
import socket
import time
from collections.abc import Iterator

#: The environment variable that lists the domain ids the tests may use.
VARIABLE = "SWAZURE_TEST_DOMAINS"
#: Its value when unset: the ids ROS 2's own test tools take.
DEFAULT = "1-100"
#: The largest id DDS's port mapping leaves room for (Fast DDS: 7400 + 250 x id + 11 < 65536).
LARGEST = 232
#: domain_coordinator's: the port that holds id ``k`` is PORT_BASE + k.
PORT_BASE = 32768
#: Seconds a test waits for an allowed id to come free before it fails, saying why.
PATIENCE = 600.0


def allowed_domains(text: str) -> tuple[int, ...]:
    """The domain ids that ``text`` lists (``"1-100"``, ``"150-159,170"``), in order.

    Raises ValueError, with one line that names the variable, for anything else:
    an empty list, a reversed range, an id outside 0..232, a repeated id.
    """
    ids: list[int] = []
    for part in text.replace(" ", "").split(","):
        low, dash, high = part.partition("-")
        try:
            first, last = int(low), int(high if dash else low)
        except ValueError:
            raise ValueError(
                f"{VARIABLE}={text!r}: {part!r} is not an id or a range like 1-100"
            ) from None
        if not 0 <= first <= last <= LARGEST:
            raise ValueError(
                f"{VARIABLE}={text!r}: {part!r} is not a range of ids within 0..{LARGEST}"
            )
        ids.extend(range(first, last + 1))
    if len(set(ids)) != len(ids):
        raise ValueError(f"{VARIABLE}={text!r}: an id is listed twice")
    return tuple(ids)


def configured_domains() -> tuple[int, ...]:
    """The domain ids ``SWAZURE_TEST_DOMAINS`` allows (ValueError when it is malformed)."""
    return allowed_domains(os.environ.get(VARIABLE, DEFAULT) or DEFAULT)


@contextlib.contextmanager
def held_domain(domains: tuple[int, ...], patience: float = PATIENCE) -> Iterator[int]:
    """Hold one of ``domains`` (free on this machine) while the ``with`` block runs.

    Tries the ids from a place of this process's own, so that two workers do not
    race for the same id first. RuntimeError when none came free in ``patience`` s.
    """
    start = os.getpid() % len(domains)
    order = domains[start:] + domains[:start]
    deadline = time.monotonic() + patience
    while True:
        for domain in order:
            holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            try:
                holder.bind(("", PORT_BASE + domain))
            except OSError as error:
                holder.close()
                if error.errno != errno.EADDRINUSE:
                    raise
                continue
            try:
                yield domain
            finally:
                holder.close()
            return
        if time.monotonic() > deadline:
            raise RuntimeError(
                f"every ROS domain id that {VARIABLE} allows ({len(domains)}) was held by other "
                f"tests for {patience:g} s: allow more ids"
            )
        time.sleep(0.5)
