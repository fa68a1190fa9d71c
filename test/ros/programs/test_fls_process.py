"""An FLS in its own process imports only what it uses, and nothing of the simulator."""

from __future__ import annotations

import json
import subprocess
import sys

#: What importing a module loaded, asked of a fresh interpreter.
PROBE = """
import json, sys
import {module}
{then}
print(json.dumps(sorted(sys.modules)))
"""


def imported_by(module: str, then: str = "") -> set[str]:
    """Every module a fresh interpreter has loaded after importing ``module`` (and ``then``)."""
    run = subprocess.run(
        [sys.executable, "-c", PROBE.format(module=module, then=then)],
        capture_output=True,
        text=True,
        timeout=600,  # a fresh interpreter's imports, on a busy machine
        check=True,
    )
    return set(json.loads(run.stdout))


def test_the_fls_node_imports_nothing_of_the_simulator():
    # The whole `fls` program: the node, its radio and how it joins.
    loaded = imported_by("swazure_ros.ros.programs.fls_program")
    assert "swazure_ros.ros.nodes.fls_node" in loaded
    ours = sorted(name for name in loaded if name.startswith("swazure_ros."))
    assert not [name for name in ours if name.startswith("swazure_ros.sim")], ours
    assert not [name for name in ours if name.startswith(("swazure_ros.view", "swazure_ros.app"))]


def test_the_fls_node_imports_no_numerical_library_it_does_not_run():
    # numba (60 MB), scipy.stats through filterpy (0.4 s), OpenCV: an FLS alone
    # loads each only when it first calls what needs it (core.jit).
    loaded = imported_by("swazure_ros.ros.programs.fls_program")
    heavy = {"numba", "scipy", "cv2", "filterpy", "matplotlib"}
    assert not heavy & loaded, sorted(heavy & loaded)


def test_the_packed_host_still_brings_the_simulator():
    # The check above can fail: the host's process imports what the FLS does not.
    loaded = imported_by("swazure_ros.ros.programs.host")
    assert "swazure_ros.sim.replica" in loaded


def test_the_coordinator_plans_without_the_simulator():
    # It plans on the shape's assigned points (core.neighbourhood.neighbourhood), what the
    # swarm knows; the simulator's world is the world node's alone.
    loaded = imported_by("swazure_ros.ros.nodes.coordinator")
    assert not [name for name in loaded if name.startswith("swazure_ros.sim")]
