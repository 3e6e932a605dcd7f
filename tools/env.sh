# Source me (bash): the environment every twbr command, test and script runs in.
#
# - With a system ROS 2 Jazzy (/opt/ros/jazzy, or already sourced), that is the underlay; otherwise the
#   PyPI wheels in .venv are, and AMENT_PREFIX_PATH / CMAKE_PREFIX_PATH must name the venv.
# - DDS discovery stays on this machine: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST always, and a
#   ROS_DOMAIN_ID of the caller's or a per-shell one, so parallel runs never cross-talk.
TWBR_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export TWBR_ROOT

twbr_system_ros() {
  [ "${TWBR_PIP_ROS:-0}" = "1" ] && return 1
  [ "${ROS_DISTRO:-}" = "jazzy" ] && [ -n "${AMENT_PREFIX_PATH:-}" ] && return 0
  [ -f /opt/ros/jazzy/setup.bash ]
}

if twbr_system_ros; then
  if [ "${ROS_DISTRO:-}" != "jazzy" ]; then
    # shellcheck disable=SC1091
    . /opt/ros/jazzy/setup.bash
  fi
  export TWBR_UNDERLAY=system
else
  export TWBR_UNDERLAY=pip
fi

if [ -f "$TWBR_ROOT/.venv/bin/activate" ]; then
  # shellcheck disable=SC1091
  . "$TWBR_ROOT/.venv/bin/activate"
fi

if [ "$TWBR_UNDERLAY" = pip ] && [ -n "${VIRTUAL_ENV:-}" ]; then
  export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
  export CMAKE_PREFIX_PATH="$VIRTUAL_ENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
fi

if [ -f "$TWBR_ROOT/install/setup.bash" ]; then
  # colcon's setup script reads unset variables; keep `set -u` callers working.
  case $- in *u*) set +u; . "$TWBR_ROOT/install/setup.bash"; set -u ;; *) . "$TWBR_ROOT/install/setup.bash" ;; esac
fi

export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( ($$ % 100) + 101 ))}"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
# UDP on loopback, not shared memory: see LOOPBACK_TRANSPORT in twbr_runner/spawn.py.
export FASTDDS_BUILTIN_TRANSPORTS="${FASTDDS_BUILTIN_TRANSPORTS:-UDPv4}"
# Announce participants every 0.5 s (config/fastdds.xml): the processes of a graph find each other at once.
if [ -f "$TWBR_ROOT/config/fastdds.xml" ]; then
  export FASTRTPS_DEFAULT_PROFILES_FILE="${FASTRTPS_DEFAULT_PROFILES_FILE:-$TWBR_ROOT/config/fastdds.xml}"
fi
# Parameter and scenario files come from the checkout (edit them in place, no rebuild needed).
export TWBR_CONFIG_DIR="${TWBR_CONFIG_DIR:-$TWBR_ROOT/config}"

# MuJoCo picks its OpenGL backend at import: without a display, offscreen EGL (mujoco_driver's video).
if [ -z "${DISPLAY:-}" ] && [ -z "${MUJOCO_GL:-}" ]; then
  export MUJOCO_GL=egl
fi
