"""The swarm's Fast DDS profile: a host runs more than 100 participants of one domain."""

from __future__ import annotations

import contextlib
import socket
import subprocess
import sys
from contextlib import ExitStack
from pathlib import Path
from xml.etree import ElementTree

from swazure_ros.ros.plumbing.lease import (
    PROFILES_IN_FOLDER,
    PROFILES_VARIABLE,
    Lease,
    participant_lease,
)
from swazure_ros.ros.plumbing.participants import PROFILE, profile_environment

from ...conftest import REPO
from ...waits import PATIENCE
from ..helpers import free_udp_port

TRIO = REPO / "config" / "swarms" / "trio.yaml"
#: Fast DDS's port mapping (RTPS 2.2, 9.6.1.1): a domain's ports begin at PB + DG * domain,
#: and a participant's metatraffic unicast port is d1 + PG * its id past that.
PORT_BASE, DOMAIN_GAIN, PARTICIPANT_GAIN, METATRAFFIC_UNICAST = 7400, 250, 2, 10
#: Fast DDS's own limit: a participant tries its first id and at most 100 more.
DEFAULT_IDS = 101


def mutation_tries(path: Path) -> int:
    """The ``mutation_tries`` of the default participant profile in the XML file ``path``."""
    tree = ElementTree.parse(path)
    found = [element for element in tree.iter() if element.tag.endswith("}mutation_tries")]
    assert len(found) == 1, path
    return int(found[0].text or "")


def test_the_swarms_profile_and_the_short_lease_one_try_as_many_participant_ids():
    assert mutation_tries(PROFILE) == mutation_tries(REPO / "config" / "fastdds.xml") == 1000
    # Nothing else: the lease stays Fast DDS's default, the same in every process.
    assert participant_lease({PROFILES_VARIABLE: str(PROFILE)}) == Lease()


def test_the_swarms_profile_is_loaded_only_where_the_user_names_no_profiles(tmp_path):
    assert profile_environment({}, folder=tmp_path) == {PROFILES_VARIABLE: str(PROFILE)}
    assert profile_environment({PROFILES_VARIABLE: "mine.xml"}, folder=tmp_path) == {}
    (tmp_path / PROFILES_IN_FOLDER).write_text("<dds/>")
    assert profile_environment({}, folder=tmp_path) == {}


def test_a_swarm_comes_up_on_a_host_where_a_hundred_and_one_participants_hold_its_domain(
    domain, tmp_path
):
    # Every metatraffic port Fast DDS would try by default is held (by this test, not by
    # 101 processes): the launcher (the world in it) and each FLS process must find one further on.
    start = PORT_BASE + DOMAIN_GAIN * domain + METATRAFFIC_UNICAST
    server_port = free_udp_port()  # not among the ports held below (11811 + 17 was)
    with ExitStack() as held:
        for participant in range(DEFAULT_IDS):
            port = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            held.enter_context(port)
            # Held already, by a participant of this domain in another process: as well.
            with contextlib.suppress(OSError):
                port.bind(("0.0.0.0", start + PARTICIPANT_GAIN * participant))
        spawn = subprocess.run(
            [sys.executable, "-m", "swazure_ros.cli.main", "spawn", str(TRIO), "--per-fls",
             # Through a server: a participant without a metatraffic port hears nothing.
             "--discovery-server", f"127.0.0.1:{server_port}",
             "--log-dir", str(tmp_path), "--until-ready", "--quiet",
             "--discovery-timeout", str(PATIENCE)],
            capture_output=True, text=True, timeout=PATIENCE + 120,
        )  # fmt: skip
    assert spawn.returncode == 0, spawn.stdout + spawn.stderr
    assert "swarm up: 3 FLS nodes in 3 processes of one FLS each" in spawn.stdout, spawn.stdout
