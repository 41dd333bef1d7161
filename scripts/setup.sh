#!/usr/bin/env bash
# Set up phd_swarm on this machine; idempotent, a warm call returns in a few seconds.
#
# Which install it sets up is decided once, by scripts/env.sh (phd_swarm_install_kind), and
# printed on stderr:
#
# - PyPI wheels (the default, and whenever .venv exists):
#   1. Creates the git-ignored virtual environment .venv (Python 3.11: requirements.lock is
#      resolved and tested on it) and installs the pinned requirements.lock into it (again
#      only when the lock changed).
#   2. Builds msg_defs (phd_swarm_msgs) and phd_swarm with colcon into the git-ignored
#      install/ (again only when a package's build inputs changed; Python sources are
#      symlinked, so editing them needs no rebuild).
# - Native ROS 2 (no .venv, and a ROS 2 environment already sourced, e.g.
#   `source /opt/ros/jazzy/setup.bash`): no virtual environment, no pip, any Python the ROS
#   install uses; checks that colcon, cmake and the Python modules are there (apt and
#   docs/install.md), then step 2 with the sourced ROS as the underlay.
#
# `scripts/setup.sh --with-view` also sets up the live view (docs/view.md): the pinned
# requirements-view.lock (rerun-sdk) into the venv, and Debian's chromium for its tests and
# screenshots (apt-get, as root; otherwise it says what to install).
# `scripts/setup.sh --with-fuzz` also installs the fuzz benchmark's atheris (the pinned
# requirements-fuzz.lock; `scripts/bench.sh fuzz`).
# `scripts/setup.sh --build-hash` prints the hash of the build inputs and exits.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
VENV="${PHD_SWARM_VENV:-$ROOT/.venv}"
LOCK="$ROOT/requirements.lock"

# The install this call uses (venv, native or none): env.sh decides, for every script.
set +u
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
set -u
KIND="$PHD_SWARM_INSTALL"

# Hash of what colcon builds from: the message package, the manifests and the lock. Python
# sources, config/*.yaml and launch files are installed as symlinks (--symlink-install), so
# only the *names* of the installed data files count: editing a config needs no rebuild,
# adding or removing one does. (config/sweeps is not installed.) A native build also
# depends on the interpreter and the ROS distribution it was built against.
build_inputs_hash() {
  { find msg_defs -type f -print0 | sort -z | xargs -0 sha256sum
    sha256sum package.xml setup.py setup.cfg resource/phd_swarm
    find config -maxdepth 1 -type f -name '*.yaml' -printf '%f\n' 2>/dev/null | sort
    for dir in launch config/rviz config/foxglove; do
      if [ -d "$dir" ]; then find "$dir" -type f -print; fi
    done | sort
    sha256sum "$LOCK" | cut -d' ' -f1
    if [ "$KIND" = native ]; then
      printf 'native %s %s\n' "${ROS_DISTRO:-}" "$(command -v python3)"
    fi; } | sha256sum | cut -d' ' -f1
}
if [ "${1:-}" = "--build-hash" ]; then
  build_inputs_hash
  exit 0
fi

WITH_VIEW=0
WITH_FUZZ=0
if [ "${1:-}" = "--with-view" ]; then
  WITH_VIEW=1
elif [ "${1:-}" = "--with-fuzz" ]; then
  WITH_FUZZ=1
elif [ $# -gt 0 ]; then
  echo "usage: $0 [--with-view | --with-fuzz | --build-hash]" >&2
  exit 2
fi

log() { printf '[setup] %s\n' "$*"; }

find_python() {
  for py in "${PHD_SWARM_PYTHON:-}" python3.11 python3; do
    [ -n "$py" ] || continue
    if command -v "$py" >/dev/null 2>&1 \
        && "$py" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
      command -v "$py"; return 0
    fi
  done
  return 1
}

if [ "$KIND" = native ]; then
  PY="$(command -v python3)"
  echo "[setup] native ROS 2 ${ROS_DISTRO}: the sourced ROS environment with $PY" \
       "($("$PY" -c 'import platform; print("Python", platform.python_version())')), no .venv" >&2
  missing_tools=()
  for tool in colcon cmake; do
    command -v "$tool" >/dev/null 2>&1 || missing_tools+=("$tool")
  done
  if [ ${#missing_tools[@]} -gt 0 ]; then
    echo "setup.sh: native ROS 2 install without ${missing_tools[*]} on PATH; install" \
         "them (sudo apt install python3-colcon-common-extensions cmake; docs/install.md)" >&2
    exit 1
  fi
  # Modules phd_swarm imports that ROS does not bring: apt for numpy, scipy, yaml and
  # matplotlib; mcap and mcap-ros2-support are not packaged by Ubuntu (docs/install.md).
  missing_modules="$("$PY" -c 'import importlib.util, sys
print(" ".join(m for m in sys.argv[1:] if importlib.util.find_spec(m) is None))' \
    numpy scipy yaml mcap mcap_ros2 matplotlib)"
  if [ -n "$missing_modules" ]; then
    echo "setup.sh: $PY cannot import: $missing_modules. This script installs nothing into" \
         "a native install; see docs/install.md (apt: python3-numpy python3-scipy" \
         "python3-yaml python3-matplotlib; pip --user: mcap mcap-ros2-support)" >&2
    exit 1
  fi
else
  echo "[setup] PyPI wheels in $VENV (Python 3.11)" >&2
  if [ ! -x "$VENV/bin/python" ]; then
    PY="$(find_python)" || {
      echo "setup.sh: Python 3.11 is required for the virtual environment (requirements.lock" \
           "is resolved and tested on it); set PHD_SWARM_PYTHON to its path, or source a" \
           "native ROS 2 install first (docs/install.md)" >&2
      exit 1
    }
    log "creating virtual environment $VENV with $PY"
    "$PY" -m venv "$VENV"
  fi
  PY="$VENV/bin/python"

  lock_sum="$(sha256sum "$LOCK" | cut -d' ' -f1)"
  if [ "$(cat "$VENV/.phd_swarm_lock.sha256" 2>/dev/null)" != "$lock_sum" ]; then
    log "installing pinned requirements (requirements.lock)"
    "$PY" -m pip install --quiet --disable-pip-version-check -r "$LOCK"
    echo "$lock_sum" > "$VENV/.phd_swarm_lock.sha256"
  fi

  if ! command -v cmake >/dev/null 2>&1; then
    log "no cmake on PATH: installing the cmake wheel into the venv"
    "$PY" -m pip install --quiet --disable-pip-version-check "cmake>=3.22,<4"
  fi
fi

build_sum="$(build_inputs_hash)"
if [ "$(cat install/.phd_swarm_build.sha256 2>/dev/null)" != "$build_sum" ]; then
  log "building msg_defs and phd_swarm with colcon"
  set +u
  # shellcheck source=scripts/env.sh
  source "$ROOT/scripts/env.sh"
  set -u
  colcon --log-base log build --symlink-install --base-paths "$ROOT/msg_defs" "$ROOT" \
    --build-base build --install-base install \
    --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$PY" \
    --event-handlers console_cohesion- summary+ status-
  echo "$build_sum" > install/.phd_swarm_build.sha256
fi
# extra_installed FLAG LOCK MODULE WHAT STAMP: install the pinned extra LOCK into the venv
# (again only when LOCK changed; true when it installed now). On a native install, only
# check that MODULE imports, and stop if not.
extra_installed() {
  local flag="$1" lock="$2" module="$3" what="$4" stamp="$VENV/.phd_swarm_$5.sha256" sum
  if [ "$KIND" = native ]; then
    if ! python3 -c "import $module" 2>/dev/null; then
      echo "setup.sh $flag: on a native install, pip install --user -r $lock ($what)" >&2
      exit 1
    fi
    return 1
  fi
  sum="$(sha256sum "$lock" | cut -d' ' -f1)"
  [ "$(cat "$stamp" 2>/dev/null)" != "$sum" ] || return 1
  log "installing $what ($(basename "$lock"))"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$lock"
  echo "$sum" > "$stamp"
}
if [ "$WITH_VIEW" -eq 1 ]; then
  if extra_installed --with-view "$ROOT/requirements-view.lock" rerun \
      "the live view: rerun-sdk; see docs/view.md" view; then
    # Rerun's usage analytics off for this user (the view server also runs with its own
    # configuration, analytics off): nothing leaves the machine.
    "$VENV/bin/rerun" analytics disable >/dev/null 2>&1 || true
  fi
  if ! command -v chromium >/dev/null 2>&1 && [ -z "${CHROMIUM:-}" ]; then
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
      log "installing chromium (Debian) for the view's tests and screenshots"
      DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null \
        || { apt-get update -q >/dev/null && \
             DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null; }
    else
      echo "setup.sh --with-view: no chromium on PATH; the view works in any browser, but" \
           "its tests need one (Debian: sudo apt-get install chromium; or set CHROMIUM)" >&2
    fi
  fi
fi
if [ "$WITH_FUZZ" -eq 1 ]; then
  extra_installed --with-fuzz "$ROOT/requirements-fuzz.lock" atheris \
    "the fuzz benchmark's atheris" fuzz || true
fi
log "ready (source scripts/env.sh to use it)"
