#!/usr/bin/env bash
# The README's colcon path, proven without /opt/ros: build both packages with
# colcon over the venv's ROS 2 Jazzy wheels (ament, rosidl, rclpy) as the
# underlay, source the install space, and run the CLI and a swarm from it.
# Usage: scripts/colcon_check.sh [VENV]   (default: .venv; needs `make setup`)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
venv=$(cd "${1:-$here/.venv}" && pwd)
ws="$here/build/colcon"
rm -rf "$ws"
mkdir -p "$ws"
cd "$ws"
# The venv stands where /opt/ros/jazzy would: its share/ holds the ament index.
export AMENT_PREFIX_PATH="$venv"
export PATH="$venv/bin:$PATH"
echo "colcon build (log: build/colcon/build.log)"
if ! colcon --log-base log build \
  --base-paths "$here" "$here/msg_defs" --build-base build --install-base install \
  --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$venv/bin/python" \
  >build.log 2>&1; then
  tail -n 30 build.log >&2
  echo "error: colcon build failed; the full log is build/colcon/build.log" >&2
  exit 1
fi
# setup.bash reads unset variables; source it as a user's shell would.
set +u
# shellcheck disable=SC1091
source install/setup.bash
set -u
# From the install space, not the venv's editable install or msg_defs build.
python - "$ws/install" <<'PY'
import sys
from pathlib import Path

import swazure_interfaces.msg
import swazure_ros
from swazure_ros.files.reading import config_dir

install = Path(sys.argv[1])
for module in (swazure_ros, swazure_interfaces.msg):
    where = Path(module.__file__).resolve()
    assert install in where.parents, f"{module.__name__} from {where}, not {install}"
assert install in config_dir().parents, config_dir()
print(f"swazure_ros and swazure_interfaces import from {install}")
PY
command -v swazure | grep -q "^$ws/install/" || {
  echo "error: swazure on PATH is $(command -v swazure), not the install space's" >&2
  exit 1
}
swazure --version
# The programs `ros2 run` starts and the launch file, where a colcon install puts them.
for program in fls world coordinator aruco_detector; do
  test -x "install/swazure_ros/lib/swazure_ros/$program" || {
    echo "error: install/swazure_ros/lib/swazure_ros/$program is missing" >&2
    exit 1
  }
done
test -f install/swazure_ros/share/swazure_ros/launch/swarm.launch.py || {
  echo "error: the launch file is not in install/swazure_ros/share/swazure_ros/launch" >&2
  exit 1
}
if command -v ros2 >/dev/null; then
  ros2 pkg executables swazure_ros --full-path | grep -q "^$ws/install/swazure_ros/lib/swazure_ros/fls$" || {
    echo "error: ros2 pkg executables does not find the install space's fls" >&2
    exit 1
  }
fi
swazure spawn --cloud torus:60 --beta 0.5 --compute-all --quiet --domain-id 137 | tail -n 1
echo "colcon: both packages built, sourced and run from $ws/install"
