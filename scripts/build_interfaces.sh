#!/usr/bin/env bash
# Build an interface package with the rosidl tool chain from the venv's ROS 2
# Jazzy wheels and install it into the venv's prefix, where the generated
# Python package is importable with no extra variables. By default msg_defs/
# (swazure_interfaces); scripts/install_launch.sh builds launch_ros's
# composition_interfaces with it too.
# Usage: scripts/build_interfaces.sh [VENV [SOURCE NAME [CMAKE_ARGS...]]]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
venv=$(cd "${1:-$here/.venv}" && pwd)
source_dir=${2:-$here/msg_defs}
name=${3:-msg_defs}
shift $(($# < 3 ? $# : 3))
build="$here/build/$name"
log="$here/build/$name.log"
mkdir -p "$build"
echo "building $(basename "$source_dir") (log: build/$name.log)"
# AMENT_PREFIX_PATH must name the venv while configuring, or cmake cannot find
# rosidl_typesupport_c.
if ! {
  AMENT_PREFIX_PATH="$venv" cmake -S "$source_dir" -B "$build" \
    -DCMAKE_PREFIX_PATH="$venv" -DCMAKE_INSTALL_PREFIX="$venv" \
    -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF "$@" &&
  cmake --build "$build" -j "$(nproc)" &&
  cmake --install "$build"
} >"$log" 2>&1; then
  tail -n 30 "$log" >&2
  echo "error: building $name failed; the full log is build/$name.log" >&2
  exit 1
fi
