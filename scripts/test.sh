#!/usr/bin/env bash
# The test command (README, .ci/run): set up if needed, then run pytest; its verdict is ours.
#
# Without arguments, two runs: the tests that start ROS (marker `ros`) one at a time, on a
# machine otherwise quiet, as their start-up and deadlines assume; then the rest on every
# core with pytest-xdist (PHD_SWARM_TEST_WORKERS workers, default: one per core). It fails
# if either fails.
# `scripts/test.sh --full` (what CI runs) then also runs the tests marked `full`: 50 robot
# processes through run_swarm.sh, the benchmarks' quick runs that start ROS runs and the
# live view in headless Chromium (about 7 minutes; it sets up the view first,
# scripts/setup.sh --with-view).
# With other arguments, one pytest run with them, e.g. `scripts/test.sh test/core -k ospa`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
set +u
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
set -u
cd "$ROOT"
run_pytest() {
  local rc=0
  python -m pytest "$@" || rc=$?
  if [ "$rc" -eq 5 ]; then
    echo "test.sh: pytest collected no tests (pytest $*); that is a failure" >&2
    rc=1
  fi
  return "$rc"
}
full=0
if [ "${1:-}" = "--full" ] && [ $# -eq 1 ]; then
  full=1
elif [ $# -gt 0 ]; then
  run_pytest "$@"
  exit $?
fi
if [ "$full" -eq 1 ]; then
  # The live view's tests (marker full) need rerun-sdk and chromium.
  "$ROOT/scripts/setup.sh" --with-view
fi
rc=0
# The real ros2 CLI, launch and launch_ros for the ROS tests (a no-op when done, or on a
# native install; the tests' ros2_cli fixture runs it again and fails them if it fails).
"$ROOT/scripts/ros2_tools.sh" || rc=$?
run_pytest -m "ros and not full" || rc=$?
run_pytest -m "not ros and not full" -n "${PHD_SWARM_TEST_WORKERS:-auto}" --dist worksteal \
  || rc=$?
if [ "$full" -eq 1 ]; then
  run_pytest -m full --full || rc=$?
fi
exit "$rc"
