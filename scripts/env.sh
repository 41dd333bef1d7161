# shellcheck shell=bash
# Environment of phd_swarm, sourced by every script (and by users: `source scripts/env.sh`).
#
# - Decides which install this shell uses: PHD_SWARM_INSTALL, set here and nowhere else
#   (scripts/setup.sh sources this file first and follows it):
#     venv    the project's virtual environment .venv exists (PyPI wheels; setup.sh's default):
#             activates it and points the ament/CMake prefix paths at it;
#     native  no .venv, and a ROS 2 environment is sourced (ROS_DISTRO set and rclpy
#             importable by python3, as after `source /opt/ros/jazzy/setup.bash`): uses it as is;
#     none    neither (scripts/setup.sh then creates .venv).
# - Sources the colcon install space if it has been built.
# - Keeps DDS on loopback: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (or, with PHD_SWARM_DDS=profile,
#   the repository's Fast DDS profile bound to 127.0.0.1), and a ROS_DOMAIN_ID of its
#   own. Both can be overridden by the caller (export them before sourcing).

PHD_SWARM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PHD_SWARM_ROOT
PHD_SWARM_VENV="${PHD_SWARM_VENV:-$PHD_SWARM_ROOT/.venv}"
export PHD_SWARM_VENV

# venv, native or none (above). Cheap: no import, only a module lookup by python3.
phd_swarm_install_kind() {
  if [ -x "$PHD_SWARM_VENV/bin/python" ]; then
    echo venv
  elif [ -n "${ROS_DISTRO:-}" ] && command -v python3 >/dev/null 2>&1 \
      && python3 -c 'import importlib.util, sys
sys.exit(importlib.util.find_spec("rclpy") is None)' 2>/dev/null; then
    echo native
  else
    echo none
  fi
}
PHD_SWARM_INSTALL="$(phd_swarm_install_kind)"
export PHD_SWARM_INSTALL

if [ "$PHD_SWARM_INSTALL" = venv ]; then
  # shellcheck disable=SC1091
  VIRTUAL_ENV_DISABLE_PROMPT=1 source "$PHD_SWARM_VENV/bin/activate"
  case ":${AMENT_PREFIX_PATH:-}:" in
    *":$PHD_SWARM_VENV:"*) ;;
    *) export AMENT_PREFIX_PATH="$PHD_SWARM_VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;;
  esac
  case ":${CMAKE_PREFIX_PATH:-}:" in
    *":$PHD_SWARM_VENV:"*) ;;
    *) export CMAKE_PREFIX_PATH="$PHD_SWARM_VENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}" ;;
  esac
  # The Fast DDS tools in the venv (fastdds, fast-discovery-server) need its libraries.
  # fast-discovery-server also needs the tinyxml2 the fastrtps wheel vendors in its .libs.
  _phd_libs="$PHD_SWARM_VENV/lib"
  for _d in "$PHD_SWARM_VENV"/lib/python3*/site-packages/ros_fastrtps.libs; do
    [ -d "$_d" ] && _phd_libs="$_phd_libs:$_d"
  done
  case ":${LD_LIBRARY_PATH:-}:" in
    *":$PHD_SWARM_VENV/lib:"*) ;;
    *) export LD_LIBRARY_PATH="$_phd_libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" ;;
  esac
  unset _phd_libs _d
  export ROS_DISTRO="${ROS_DISTRO:-jazzy}"
fi

if [ -f "$PHD_SWARM_ROOT/install/local_setup.bash" ]; then
  # colcon's setup scripts read unset variables; relax -u around them.
  case $- in *u*) _phd_nounset=1; set +u ;; *) _phd_nounset=0 ;; esac
  # shellcheck disable=SC1091
  COLCON_CURRENT_PREFIX="$PHD_SWARM_ROOT/install" source "$PHD_SWARM_ROOT/install/local_setup.bash"
  [ "$_phd_nounset" = 1 ] && set -u
  unset _phd_nounset
fi

# PHD_SWARM_DDS=profile: the repository's Fast DDS profile instead of LOCALHOST (UDP bound to
# 127.0.0.1, 160 participant ports probed; what run_swarm.sh uses above 30 processes, so a
# shell that inspects such a run with the ros2 CLI sources this with it; docs/deployment.md).
case "${PHD_SWARM_DDS:-localhost}" in
  localhost|profile) ;;
  *) echo "env.sh: PHD_SWARM_DDS must be localhost or profile, got '${PHD_SWARM_DDS}'" >&2
     return 2 ;;
esac
if [ "${PHD_SWARM_DDS:-localhost}" = "profile" ]; then
  if [ ! -f "$PHD_SWARM_ROOT/config/dds/loopback_udp.xml" ]; then
    echo "env.sh: PHD_SWARM_DDS=profile but $PHD_SWARM_ROOT/config/dds/loopback_udp.xml is" \
      "missing; without it DDS would not stay on loopback" >&2
    return 2
  fi
  export ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT
  export FASTRTPS_DEFAULT_PROFILES_FILE="$PHD_SWARM_ROOT/config/dds/loopback_udp.xml"
  export FASTDDS_DEFAULT_PROFILES_FILE="$FASTRTPS_DEFAULT_PROFILES_FILE"
fi
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-42}"
export PYTHONUNBUFFERED=1
