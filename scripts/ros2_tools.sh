#!/usr/bin/env bash
# The real `ros2` command line, `launch` and `launch_ros`, for the tests on a PyPI-wheel install.
#
# The ROS 2 Jazzy wheels have rclpy and the messages but not the `ros2` CLI, `launch` or
# `launch_ros`; ../shared/ros2-cli/ holds unmodified wheels of those (built from their jazzy
# branches) and the source of composition_interfaces, which launch_ros imports and which is
# not on PyPI (its README). This script, run by scripts/test.sh before the ROS tests and by
# the tests' `ros2_cli` fixture:
#
# 1. installs those wheels (--no-deps) and the PyPI packages they need into the project's
#    .venv (osrf-pycommon, psutil; argcomplete is in requirements.lock already). Not `lark`:
#    launch's grammar works with the lark-parser 0.12 of requirements.lock, and the `lark`
#    distribution would overwrite the same `lark` module under rosidl_parser's feet;
# 2. builds a copy of composition_interfaces with colcon into build/ros2_tools/install (git
#    ignored), with the CMake include-dir fix msg_defs uses (msg_defs/cmake/
#    fix_wheel_include_dirs.cmake, included after find_package(rcl_interfaces)). The shared
#    folder is only read.
#
# Idempotent: a stamp of the inputs (wheels, source, fix, this script) makes a second call
# return at once. Not a user requirement: a native ROS install has these tools; without a
# .venv (native) or without ../shared/ros2-cli there is nothing to do and it says so.
#
# Then: source build/ros2_tools/install/local_setup.bash after scripts/env.sh, and `ros2`
# (.venv/bin/ros2) runs `ros2 run`, `ros2 launch`, `ros2 topic` ... against this workspace.
#
# `scripts/ros2_tools.sh --setup-file` prints the file to source (nothing on a native install).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SHARED="$ROOT/../shared/ros2-cli"
VENV="${PHD_SWARM_VENV:-$ROOT/.venv}"
TOOLS="$ROOT/build/ros2_tools"
SETUP_FILE="$TOOLS/install/local_setup.bash"
FIX="$ROOT/msg_defs/cmake/fix_wheel_include_dirs.cmake"
#: PyPI packages the wheels need (their README), pinned.
DEPS=(osrf-pycommon==2.0.2 psutil==7.2.2)

log() { printf '[ros2_tools] %s\n' "$*"; }

if [ ! -x "$VENV/bin/python" ]; then
  [ "${1:-}" = "--setup-file" ] && exit 0
  log "no $VENV: a native ROS install provides ros2, launch and launch_ros; nothing to do"
  exit 0
fi
if [ "${1:-}" = "--setup-file" ]; then
  echo "$SETUP_FILE"
  exit 0
fi
if [ ! -d "$SHARED/wheels" ] || [ ! -d "$SHARED/src/composition_interfaces" ]; then
  log "no $SHARED (wheels/, src/composition_interfaces): the tests that need the ros2 CLI" \
      "will be skipped"
  exit 0
fi

inputs_hash() {
  { sha256sum "$SHARED"/wheels/*.whl | sed "s|  .*/|  |"
    (cd "$SHARED/src" && find composition_interfaces -type f -print0 | sort -z \
       | xargs -0 sha256sum)
    sha256sum "$FIX" "${BASH_SOURCE[0]}" | cut -d' ' -f1
    printf '%s\n' "${DEPS[@]}"; } | sha256sum | cut -d' ' -f1
}

mkdir -p "$ROOT/build"
# colcon's own marker: the project's colcon build (setup.sh) crawls the repository and must
# not take the copy below for one of its packages.
touch "$ROOT/build/COLCON_IGNORE"
# One caller at a time (the stamps are written last).
exec 9>"$ROOT/build/.ros2_tools.lock"
flock 9

want="$(inputs_hash)"
venv_stamp="$VENV/.phd_swarm_ros2_tools.sha256"
if [ "$(cat "$venv_stamp" 2>/dev/null)" != "$want" ] || [ ! -x "$VENV/bin/ros2" ]; then
  log "installing the ros2 CLI, launch and launch_ros wheels from $SHARED/wheels into $VENV"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps \
    "$SHARED"/wheels/*.whl
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps "${DEPS[@]}"
  echo "$want" > "$venv_stamp"
fi

build_stamp="$TOOLS/.stamp"
if [ "$(cat "$build_stamp" 2>/dev/null)" != "$want" ] || [ ! -f "$SETUP_FILE" ]; then
  log "building composition_interfaces (a copy of $SHARED/src) into $TOOLS/install"
  rm -rf "$TOOLS"
  mkdir -p "$TOOLS/src"
  cp -r "$SHARED/src/composition_interfaces" "$TOOLS/src/"
  chmod -R u+w "$TOOLS/src"
  cmakelists="$TOOLS/src/composition_interfaces/CMakeLists.txt"
  sed -i "/^find_package(rcl_interfaces REQUIRED)$/a\\
# phd_swarm (scripts/ros2_tools.sh): the PyPI wheels' include-dir snag, fixed as for msg_defs.\\
include(\"$FIX\")\\
phd_swarm_fix_wheel_include_dirs()" "$cmakelists"
  grep -q phd_swarm_fix_wheel_include_dirs "$cmakelists" || {
    echo "ros2_tools.sh: could not add the include-dir fix to $cmakelists" >&2
    exit 1
  }
  if ! command -v cmake >/dev/null 2>&1 && [ ! -x "$VENV/bin/cmake" ]; then
    log "no cmake on PATH: installing the cmake wheel into the venv"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "cmake>=3.22,<4"
  fi
  set +u
  # shellcheck disable=SC1091
  source "$ROOT/scripts/env.sh"
  set -u
  colcon --log-base "$TOOLS/log" build --base-paths "$TOOLS/src" \
    --build-base "$TOOLS/build" --install-base "$TOOLS/install" \
    --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$VENV/bin/python" \
    --event-handlers console_cohesion- summary+ status-
  echo "$want" > "$build_stamp"
fi

# A check that costs a second only when something was (re)done above is not worth a flag:
# the import below is what launch_ros needs, and `ros2 --help` that the CLI starts.
if [ ! -f "$TOOLS/.checked" ] || [ "$(cat "$TOOLS/.checked")" != "$want" ]; then
  (set +u
   # shellcheck disable=SC1091
   source "$ROOT/scripts/env.sh"
   # shellcheck disable=SC1090
   source "$SETUP_FILE"
   python -c "import composition_interfaces.srv, launch_ros.actions" \
     && ros2 --help >/dev/null) || {
    echo "ros2_tools.sh: the installed tools do not start (see above)" >&2
    exit 1
  }
  echo "$want" > "$TOOLS/.checked"
fi
log "ready: source $SETUP_FILE after scripts/env.sh"
