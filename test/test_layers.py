"""The layer contract (docs/architecture.md), read from every module's imports.

Each folder of the package may import only the folders below it; rclpy and the
ROS interface packages are imported only inside ``ros/``; the model (``core/``)
imports no OpenCV, YAML, ctypes or rclpy; no two modules import each other,
directly or around a loop. Imports inside functions count: a cycle hidden in a
function is still a cycle.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components

PACKAGE = "swazure_ros"
ROOT = Path(__file__).resolve().parents[1] / PACKAGE

#: What each layer may import of the package, besides itself and the package's root.
ALLOWED: dict[str, frozenset[str]] = {
    "core": frozenset(),
    "camera": frozenset({"core"}),
    "protocol": frozenset({"core"}),
    # A run record is built from the protocol's results (files.record).
    "files": frozenset({"core", "camera", "protocol"}),
    "sim": frozenset({"core", "camera", "files"}),
    "view": frozenset({"core", "files"}),
    "study": frozenset({"core", "camera", "files", "view"}),
    "ros": frozenset({"core", "camera", "files", "protocol", "sim", "view"}),
    "app": frozenset({"core", "files", "protocol", "sim", "ros", "study", "view"}),
    # The library for scripts and notebooks: the engine's functions and a swarm's client.
    "api": frozenset({"core", "files", "protocol", "sim", "ros", "view", "app"}),
    "cli": frozenset(
        {"core", "camera", "files", "protocol", "sim", "ros", "study", "view", "app", "api"}
    ),
}
#: What each room of ``ros/`` may import of ``ros/``, besides itself (docs/architecture.md):
#: programs run nodes; nodes, clients and conversion stand on the swarm's security and
#: the plumbing every process shares; a client never reaches into a node.
ROS_ALLOWED: dict[str, frozenset[str]] = {
    "plumbing": frozenset(),
    "security": frozenset({"plumbing"}),
    "convert": frozenset({"plumbing", "security"}),
    "recording": frozenset({"plumbing"}),
    "nodes": frozenset({"plumbing", "security", "convert"}),
    "clients": frozenset({"plumbing", "security", "convert"}),
    "programs": frozenset({"plumbing", "security", "convert", "nodes"}),
}
#: Distributions that only ``ros/`` may import: rclpy and the ROS 2 interface packages.
ROS_ONLY = ("rclpy", "rosidl_", "rcl_interfaces", "builtin_interfaces", "swazure_interfaces")
#: What the model never imports: it renders, reads, writes and talks to ROS through the
#: layers above it (camera/, files/, ros/).
NOT_IN_CORE = ("cv2", "yaml", "ctypes", "rclpy")


def module_name(path: Path) -> str:
    """The dotted name of the package module at ``path``."""
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> set[str]:
    """Every module ``path`` imports, at any depth, as absolute dotted names."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
                stem = ".".join([*base, node.module] if node.module else base)
            else:
                stem = node.module or ""
            # "from . import x" may name a module x: count both readings.
            found.add(stem)
            found.update(f"{stem}.{alias.name}" for alias in node.names)
    return found


def package_imports() -> dict[str, set[str]]:
    """Module name -> the package's modules and third-party names it imports."""
    paths = sorted(ROOT.rglob("*.py"))
    modules = {module_name(path) for path in paths}
    graph = {}
    for path in paths:
        names = imports_of(path)
        ours = {n for n in names if n in modules}
        # Third-party modules by the name imported from: "rclpy.node", not each name in it.
        theirs = {
            n for n in names if not n.startswith(PACKAGE) and n.rpartition(".")[0] not in names
        }
        graph[module_name(path)] = ours | theirs
    return graph


def layer(module: str) -> str | None:
    """The layer (first folder) of a package module, None for the package's root."""
    parts = module.split(".")
    return parts[1] if len(parts) > 2 or (len(parts) == 2 and parts[1] in ALLOWED) else None


def ros_room(module: str) -> str | None:
    """The room (folder of ``ros/``) of a package module, None outside one."""
    parts = module.split(".")
    return parts[2] if len(parts) > 3 and parts[1] == "ros" else None


def ros_room_imports(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """Every import between rooms of ``ros/`` that ROS_ALLOWED does not allow."""
    wrong = []
    for module, names in graph.items():
        own = ros_room(module)
        if own is None:
            continue
        for name in names:
            target = ros_room(name)
            if target is not None and target != own and target not in ROS_ALLOWED[own]:
                wrong.append(f"{module} -> {name}")
    return sorted(wrong)


def is_ros(name: str) -> bool:
    """Whether ``name`` is rclpy or a ROS 2 interface package."""
    return name.startswith(ROS_ONLY) or name.split(".")[0].endswith("_msgs")


def upward_imports(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """Every import of a layer that the layer may not make, as "module -> imported"."""
    wrong = []
    for module, names in graph.items():
        own = layer(module)
        for name in names:
            if name.startswith(PACKAGE + "."):
                target = layer(name)
                if own is None or target is None or target == own:
                    continue
                if target not in ALLOWED[own]:
                    wrong.append(f"{module} -> {name}")
            elif own != "ros" and is_ros(name):
                wrong.append(f"{module} -> {name}")
    return sorted(wrong)


def outside_the_model(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """Every import of :data:`NOT_IN_CORE` by a module of ``core/``, as "module -> imported"."""
    return sorted(
        f"{module} -> {name}"
        for module, names in graph.items()
        if layer(module) == "core"
        for name in names
        if name.split(".")[0] in NOT_IN_CORE
    )


def cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """The package's import cycles: each strongly connected set of two or more modules."""
    modules = sorted(graph)
    index = {module: i for i, module in enumerate(modules)}
    edges = [(index[m], index[n]) for m in modules for n in graph[m] if n in index and n != m]
    rows, cols = np.array(edges, dtype=np.int64).reshape(-1, 2).T
    adjacency = csr_array((np.ones(len(rows)), (rows, cols)), shape=(len(modules),) * 2)
    _, labels = connected_components(adjacency, directed=True, connection="strong")
    members: dict[int, list[str]] = {}
    for module, label in zip(modules, labels, strict=True):
        members.setdefault(int(label), []).append(module)
    loops = [m for m in members.values() if len(m) > 1]
    return sorted(loops)


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    return package_imports()


def test_every_folder_of_the_package_is_a_layer(graph: dict[str, set[str]]) -> None:
    folders = {p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file()}
    assert folders == set(ALLOWED)


def test_no_layer_imports_a_layer_above_it(graph: dict[str, set[str]]) -> None:
    assert upward_imports(graph) == []


def test_every_module_of_ros_is_in_a_room(graph: dict[str, set[str]]) -> None:
    rooms = {p.name for p in (ROOT / "ros").iterdir() if (p / "__init__.py").is_file()}
    assert rooms == set(ROS_ALLOWED)
    loose = [p.name for p in (ROOT / "ros").glob("*.py") if p.name != "__init__.py"]
    assert loose == []


def test_no_room_of_ros_imports_a_room_it_may_not(graph: dict[str, set[str]]) -> None:
    assert ros_room_imports(graph) == []


def test_an_added_import_between_rooms_of_ros_is_caught(graph: dict[str, set[str]]) -> None:
    """A client reaching into a node, or the plumbing into a program, fails the check."""
    broken = {module: set(names) for module, names in graph.items()}
    broken["swazure_ros.ros.clients.query"].add("swazure_ros.ros.nodes.coordinator")
    broken["swazure_ros.ros.plumbing.node"].add("swazure_ros.ros.programs.host")
    assert ros_room_imports(broken) == [
        "swazure_ros.ros.clients.query -> swazure_ros.ros.nodes.coordinator",
        "swazure_ros.ros.plumbing.node -> swazure_ros.ros.programs.host",
    ]


def test_no_import_cycle_in_the_package(graph: dict[str, set[str]]) -> None:
    assert cycles(graph) == []


def test_an_added_upward_import_is_caught(graph: dict[str, set[str]]) -> None:
    """The check fails on a broken build: core importing the app, or cli importing rclpy."""
    broken = {module: set(names) for module, names in graph.items()}
    broken["swazure_ros.core.paths"].add("swazure_ros.app.swarm")
    broken["swazure_ros.cli.main"].add("rclpy.node")
    assert upward_imports(broken) == [
        "swazure_ros.cli.main -> rclpy.node",
        "swazure_ros.core.paths -> swazure_ros.app.swarm",
    ]


def test_the_model_imports_no_opencv_yaml_ctypes_or_rclpy(graph: dict[str, set[str]]) -> None:
    assert outside_the_model(graph) == []


def test_an_added_import_outside_the_model_is_caught(graph: dict[str, set[str]]) -> None:
    broken = {module: set(names) for module, names in graph.items()}
    broken["swazure_ros.core.sensor"].add("cv2")
    broken["swazure_ros.core.clouds"].add("yaml")
    broken["swazure_ros.core.geometry"].add("ctypes")
    broken["swazure_ros.core.paths"].add("rclpy.node")
    # The layers above may: camera/ renders with OpenCV.
    broken["swazure_ros.camera.aruco"].add("yaml")
    assert outside_the_model(broken) == [
        "swazure_ros.core.clouds -> yaml",
        "swazure_ros.core.geometry -> ctypes",
        "swazure_ros.core.paths -> rclpy.node",
        "swazure_ros.core.sensor -> cv2",
    ]


def test_an_added_cycle_is_caught(graph: dict[str, set[str]]) -> None:
    # core.observe imports core.graph, which imports nothing that does: one import back is
    # a loop.
    assert "swazure_ros.core.graph" in graph["swazure_ros.core.observe"]
    broken = {module: set(names) for module, names in graph.items()}
    broken["swazure_ros.core.graph"].add("swazure_ros.core.observe")
    loop = {"swazure_ros.core.graph", "swazure_ros.core.observe"}
    assert any(loop <= set(found) for found in cycles(broken))


#: The launch files of the package (``ros2 launch swazure_ros ...``).
LAUNCH_FILES = sorted((ROOT.parent / "launch").glob("*.launch.py"))


def launch_imports(text: str) -> set[str]:
    """Every module a launch file imports, at any depth (it has no relative imports)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def command_line_imports(names: Iterable[str]) -> list[str]:
    """The package's command-line modules among ``names``: what no launch file imports."""
    return sorted(
        name for name in names if name.startswith(PACKAGE + ".") and layer(name) == "cli"
    )


def test_a_launch_file_imports_no_command_line_module() -> None:
    """A launch file reads its swarm file as the library does (app, files), never through the
    command line's parsing: the CLI is a client of the library, as a launch file is."""
    assert [path.name for path in LAUNCH_FILES] == ["swarm.launch.py"]
    for path in LAUNCH_FILES:
        imported = launch_imports(path.read_text())
        assert "swazure_ros.app.config" in imported  # what it reads the swarm file with
        assert command_line_imports(imported) == [], path.name


def test_an_added_command_line_import_in_a_launch_file_is_caught() -> None:
    text = (ROOT.parent / "launch" / "swarm.launch.py").read_text()
    for line in (
        "from swazure_ros.cli.swarm_file import swarm_file\n",
        "import swazure_ros.cli.main\n",
        "from swazure_ros.cli import spawn\n",
    ):
        broken = launch_imports(text + f"\ndef later():\n    {line}")
        assert command_line_imports(broken) != [], line
