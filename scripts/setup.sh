#!/usr/bin/env bash
# Set up phd_swarm on this machine; idempotent, a warm call returns in a few seconds.
#
# 1. Creates the git-ignored virtual environment .venv (Python 3.11: the ROS 2 Jazzy wheels
#    are cp311) and installs the pinned requirements.lock into it (again only when the lock
#    changed).
# 2. Builds msg_defs (phd_swarm_msgs) and phd_swarm with colcon into the git-ignored install/
#    (again only when a package's build inputs changed; Python sources are symlinked, so
#    editing them needs no rebuild).
#
# Native ROS install instead: `source /opt/ros/jazzy/setup.bash && colcon build` (README).
#
# `scripts/setup.sh --build-hash` prints the hash of the build inputs and exits.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
VENV="${PHD_SWARM_VENV:-$ROOT/.venv}"
LOCK="$ROOT/requirements.lock"

# Hash of what colcon builds from: the message package, the manifests and the lock. Python
# sources and config/*.yaml are installed as symlinks (--symlink-install), so only the
# *names* of the installed config files count: editing a config needs no rebuild, adding
# or removing one does. (config/sweeps is not installed.)
build_inputs_hash() {
  { find msg_defs -type f -print0 | sort -z | xargs -0 sha256sum
    sha256sum package.xml setup.py setup.cfg resource/phd_swarm
    find config -maxdepth 1 -type f -name '*.yaml' -printf '%f\n' 2>/dev/null | sort
    sha256sum "$LOCK" | cut -d' ' -f1; } | sha256sum | cut -d' ' -f1
}
if [ "${1:-}" = "--build-hash" ]; then
  build_inputs_hash
  exit 0
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

if [ ! -x "$VENV/bin/python" ]; then
  PY="$(find_python)" || {
    echo "setup.sh: Python 3.11 is required (the ROS 2 Jazzy wheels are built for cp311);" \
         "set PHD_SWARM_PYTHON to its path" >&2
    exit 1
  }
  log "creating virtual environment $VENV with $PY"
  "$PY" -m venv "$VENV"
fi

lock_sum="$(sha256sum "$LOCK" | cut -d' ' -f1)"
if [ "$(cat "$VENV/.phd_swarm_lock.sha256" 2>/dev/null)" != "$lock_sum" ]; then
  log "installing pinned requirements (requirements.lock)"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$LOCK"
  echo "$lock_sum" > "$VENV/.phd_swarm_lock.sha256"
fi

if ! command -v cmake >/dev/null 2>&1; then
  log "no cmake on PATH: installing the cmake wheel into the venv"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "cmake>=3.22,<4"
fi

build_sum="$(build_inputs_hash)"
if [ "$(cat install/.phd_swarm_build.sha256 2>/dev/null)" != "$build_sum" ]; then
  log "building msg_defs and phd_swarm with colcon"
  set +u
  # shellcheck disable=SC1091
  source "$ROOT/scripts/env.sh"
  set -u
  colcon --log-base log build --symlink-install --base-paths "$ROOT/msg_defs" "$ROOT" \
    --build-base build --install-base install \
    --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$VENV/bin/python" \
    --event-handlers console_cohesion- summary+ status-
  echo "$build_sum" > install/.phd_swarm_build.sha256
fi
log "ready (source scripts/env.sh to use it)"
