#!/usr/bin/env bash
# Record a run to an MCAP file (Ctrl-C or SIGTERM finishes the file cleanly).
# Usage: scripts/record.sh OUT [CONFIG] [ROS args, e.g. -p recorder:compression:=lz4]
#   OUT     the .mcap file to write
#   CONFIG  the run's config file: checked first, then its parameters are used and its text
#           and scenario are stored in the file; the recorder subscribes at once to every
#           topic of that team (without CONFIG it only discovers topics as they appear).
# A config's `recorder:` block beats a plain `-p name:=value`; write `-p recorder:name:=value`
# to override it (as this script does for output and params_file).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -lt 1 ] || [ "${1#-}" != "$1" ]; then
  echo "usage: $0 OUT [CONFIG] [-p recorder:name:=value ...]" >&2
  exit 2
fi
OUT="$1"; shift
ARGS=(-p "recorder:output:=$OUT")
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  CONFIG="$(realpath -m "$1")"; shift
fi
set +u
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
set -u
if [ -n "${CONFIG:-}" ]; then
  python3 -c 'import sys
from phd_swarm.config import load_run_config
try:
    load_run_config(sys.argv[1])
except ValueError as exc:
    sys.exit(f"record.sh: {exc}")' "$CONFIG"
  ARGS=(--params-file "$CONFIG" "${ARGS[@]}" -p "recorder:params_file:=$CONFIG")
fi
exec python3 -m phd_swarm.nodes.recorder --ros-args "${ARGS[@]}" "$@"
