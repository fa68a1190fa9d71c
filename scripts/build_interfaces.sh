#!/usr/bin/env bash
# Build msg_defs/ (the swazure_interfaces package) with the rosidl tool chain
# from the venv's ROS 2 Jazzy wheels and install it into the venv's prefix,
# where the generated Python package is importable with no extra variables.
# Usage: scripts/build_interfaces.sh [VENV]   (default: .venv)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
venv=$(cd "${1:-$here/.venv}" && pwd)
build="$here/build/msg_defs"
log="$here/build/msg_defs.log"
mkdir -p "$build"
echo "building swazure_interfaces (log: build/msg_defs.log)"
# AMENT_PREFIX_PATH must name the venv while configuring, or cmake cannot find
# rosidl_typesupport_c.
if ! {
  AMENT_PREFIX_PATH="$venv" cmake -S "$here/msg_defs" -B "$build" \
    -DCMAKE_PREFIX_PATH="$venv" -DCMAKE_INSTALL_PREFIX="$venv" \
    -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF &&
  cmake --build "$build" -j "$(nproc)" &&
  cmake --install "$build"
} >"$log" 2>&1; then
  tail -n 30 "$log" >&2
  echo "error: building msg_defs failed; the full log is build/msg_defs.log" >&2
  exit 1
fi
