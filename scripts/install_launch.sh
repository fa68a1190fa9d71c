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
build="$here/build/composition_interfaces"
log="$here/build/composition_interfaces.log"
"$venv/bin/python" -m pip install --disable-pip-version-check --quiet --no-deps \
  lark==1.3.1 osrf-pycommon==2.0.2 "$wheels"/*.whl
mkdir -p "$build"
echo "building composition_interfaces for launch_ros (log: build/composition_interfaces.log)"
if ! {
  AMENT_PREFIX_PATH="$venv" cmake -S "$wheels/composition_interfaces" -B "$build" \
    -DCMAKE_PROJECT_INCLUDE="$wheels/drop-missing-includes.cmake" \
    -DCMAKE_PREFIX_PATH="$venv" -DCMAKE_INSTALL_PREFIX="$venv" \
    -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF &&
  cmake --build "$build" -j "$(nproc)" &&
  cmake --install "$build"
} >"$log" 2>&1; then
  tail -n 30 "$log" >&2
  echo "error: building composition_interfaces failed; the full log is $log" >&2
  exit 1
fi
