#!/usr/bin/env bash
# Install `ros2 launch` into the venv from the Jazzy wheels beside the repo
# (../shared/wheels/ros2launch-jazzy, whose README this follows): launch,
# launch_ros and ros2launch, their two PyPI dependencies, and the interface
# package launch_ros imports (composition_interfaces), built like msg_defs.
# Usage: scripts/install_launch.sh VENV WHEELS_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
venv=$(cd "$1" && pwd)
wheels=$(cd "$2" && pwd)
"$venv/bin/python" -m pip install --disable-pip-version-check --quiet --no-deps \
  lark==1.3.1 osrf-pycommon==2.0.2 "$wheels"/*.whl
# The wheels' exported cmake targets name include folders of the machine that
# built them; their cmake include drops those without touching the package. Ours
# leaves out the C++ code and type supports, which nothing loads.
"$here/scripts/build_interfaces.sh" "$venv" "$wheels/composition_interfaces" \
  composition_interfaces -DCMAKE_PROJECT_INCLUDE="$wheels/drop-missing-includes.cmake" \
  -DCMAKE_PROJECT_composition_interfaces_INCLUDE="$here/scripts/c-type-supports-only-project.cmake"
