#!/usr/bin/env python3
"""Make the venv an ament prefix for swazure_ros, as a colcon install space would be.

`ros2 run swazure_ros fls` looks for lib/swazure_ros/fls under a prefix on
AMENT_PREFIX_PATH, and `ros2 launch swazure_ros swarm.launch.py` for
share/swazure_ros/launch/. An editable pip install puts neither there, so
this writes them into the venv: the package's marker in the ament index,
its share/ folder (package.xml and launch/ copied, config/ linked to the
repo) and the node programs of scripts/nodes/ with the
venv's Python.
Usage: scripts/ament_venv.py VENV
"""

import shutil
import sys
from pathlib import Path

PACKAGE = "swazure_ros"


def main() -> int:
    venv = Path(sys.argv[1]).resolve()
    repo = Path(__file__).resolve().parents[1]
    index = venv / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True, exist_ok=True)
    (index / PACKAGE).touch()
    share = venv / "share" / PACKAGE
    share.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(repo / "package.xml", share / "package.xml")
    config = share / "config"
    if config.is_symlink():
        config.unlink()
    config.symlink_to(repo / "config", target_is_directory=True)
    # Copied, not linked: ros2 launch finds launch files by walking share/, not links.
    launch = share / "launch"
    if launch.is_symlink():
        launch.unlink()
    launch.mkdir(exist_ok=True)
    for launch_file in (repo / "launch").glob("*.launch.py"):
        shutil.copyfile(launch_file, launch / launch_file.name)
    lib = venv / "lib" / PACKAGE
    lib.mkdir(parents=True, exist_ok=True)
    for program in sorted((repo / "scripts" / "nodes").iterdir()):
        text = program.read_text().split("\n", 1)[1]
        target = lib / program.name
        target.write_text(f"#!{venv / 'bin' / 'python'}\n{text}")
        target.chmod(0o755)
    print(f"{venv}: an ament prefix for {PACKAGE} (ros2 run, ros2 launch)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
