#!/usr/bin/env bash
# Run one robot node: namespace /robot_<ID>, parameters from CONFIG.
# Usage: scripts/run_robot.sh ID CONFIG [ROS args, e.g. -p tick_period:=0.5]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -lt 2 ]; then echo "usage: $0 ID CONFIG [-p name:=value ...]" >&2; exit 2; fi
ID="$1"; CONFIG="$2"; shift 2
case "$ID" in
  ''|*[!0-9]*) echo "$0: robot id must be a non-negative integer, got '$ID'" >&2; exit 2 ;;
esac
"$ROOT/scripts/setup.sh" >/dev/null
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
python3 -m phd_swarm.tools.check_config "$CONFIG"
exec python3 -m phd_swarm.nodes.robot --ros-args --params-file "$CONFIG" \
  -r "__ns:=/robot_$ID" -p "robot_id:=$ID" "$@"
