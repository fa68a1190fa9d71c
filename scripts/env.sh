# Source this file to use the venv's own `ros2` (and `ros2 launch`) with this
# repo's packages, as a colcon workspace's install/setup.bash would be sourced:
#
#     source scripts/env.sh
#     ros2 launch swazure_ros swarm.launch.py swarm:=torus
#
# It puts the venv first on PATH and names it on AMENT_PREFIX_PATH, where
# `ros2 interface`, `ros2 pkg`, `ros2 launch` and launch_ros find
# swazure_interfaces and swazure_ros (`make setup` makes the venv a prefix).
swazure_repo=$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")/.." && pwd)
swazure_venv="$swazure_repo/.venv"
if [ ! -x "$swazure_venv/bin/python" ]; then
  echo "scripts/env.sh: no venv at $swazure_venv; run make setup first" >&2
else
  export AMENT_PREFIX_PATH="$swazure_venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
  export PATH="$swazure_venv/bin:$PATH"
  export VIRTUAL_ENV="$swazure_venv"
fi
unset swazure_repo swazure_venv
