"""The product imports only what requirements.lock installs.

A user's clone has no ``../shared`` beside it, so nothing installed from there
(the ``ros2`` command line, rosidl_runtime_py, launch) may be imported by the
package or the programs ``ros2 run`` starts. This imports every module of the
package in a process where only the standard library, the distributions named
in requirements.lock and the project's own packages can be imported, whatever
else this venv holds.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys

from .conftest import REPO

LOCK = REPO / "requirements.lock"
PROGRAMS = REPO / "scripts" / "nodes"
#: The project's own import packages: the Python package and the interfaces msg_defs builds
#: (swazure_interfaces, and tf2_msgs, which PyPI has no wheel of).
OWN = ("swazure_ros", "swazure_interfaces", "tf2_msgs")

#: Run in a child process: block every import outside the allowed distributions, then import
#: every module of the package and print the failures as JSON.
_IMPORT_ALL = r"""
import importlib, importlib.machinery, importlib.metadata, json, pkgutil, re, sys, sysconfig
import traceback

allowed = set(json.loads(sys.argv[1]))
own = set(json.loads(sys.argv[2]))
providers = importlib.metadata.packages_distributions()

stdlib = sysconfig.get_path("stdlib")
installed = (sysconfig.get_path("purelib"), sysconfig.get_path("platlib"))

def in_stdlib(top):
    # Private modules of the standard library (_sysconfigdata_*) are not in stdlib_module_names.
    spec = importlib.machinery.PathFinder.find_spec(top)
    origin = (spec.origin or "") if spec else ""
    return origin.startswith(stdlib) and not origin.startswith(installed)

def normal(name):
    return re.sub(r"[-_.]+", "-", name).lower()

class OnlyTheLock:
    def find_spec(self, name, path=None, target=None):
        top = name.partition(".")[0]
        if top in sys.stdlib_module_names or top in own:
            return None
        found = providers.get(top, [])
        if any(normal(dist) in allowed for dist in found) or in_stdlib(top):
            return None
        where = ", ".join(found) or "no distribution"
        raise ModuleNotFoundError(f"{top} ({where}) is not in requirements.lock", name=name)

sys.meta_path.insert(0, OnlyTheLock())
failures = {}
import swazure_ros

def failed(name):
    failures[name] = traceback.format_exc(limit=-3)

modules = pkgutil.walk_packages(swazure_ros.__path__, "swazure_ros.", onerror=failed)
for module in modules:
    try:
        importlib.import_module(module.name)
    except Exception:
        failed(module.name)
print(json.dumps(failures))
"""


def locked_distributions() -> set[str]:
    """The normalised names of the distributions requirements.lock pins."""
    names = set()
    for line in LOCK.read_text().splitlines():
        requirement = line.split("#", 1)[0].strip()
        if requirement:
            name = re.split(r"[=<>!~\[; ]", requirement, maxsplit=1)[0]
            names.add(re.sub(r"[-_.]+", "-", name).lower())
    return names


def test_every_module_imports_with_only_what_the_lock_installs():
    run = subprocess.run(
        [sys.executable, "-c", _IMPORT_ALL, json.dumps(sorted(locked_distributions())),
         json.dumps(OWN)],
        capture_output=True, text=True, timeout=300, cwd=REPO,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    failures = json.loads(run.stdout.splitlines()[-1])
    assert not failures, "\n".join(f"{name}:\n{trace}" for name, trace in failures.items())


def test_the_programs_ros2_run_starts_import_only_the_package():
    programs = sorted(path for path in PROGRAMS.iterdir() if path.is_file())
    assert {path.name for path in programs} >= {"fls", "world", "coordinator", "aruco_detector"}
    for path in programs:
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            for name in names:
                top = name.partition(".")[0]
                assert top in sys.stdlib_module_names or top in OWN, f"{path.name} imports {name}"


def test_the_lock_pins_nothing_that_only_shared_provides():
    # The wheels of ../shared (the ros2 command line, launch) are test aids, never pinned.
    shared_only = {"rosidl-runtime-py", "ros2cli", "ros2run", "ros2topic", "launch", "launch-ros"}
    assert not shared_only & locked_distributions()
