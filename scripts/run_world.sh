#!/usr/bin/env bash
# Run the world simulator alone (for robots started by hand or on other machines).
# Usage: scripts/run_world.sh CONFIG [ROS args, e.g. -p mode:=realtime]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -lt 1 ]; then echo "usage: $0 CONFIG [-p name:=value ...]" >&2; exit 2; fi
CONFIG="$1"; shift
"$ROOT/scripts/setup.sh" >/dev/null
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
python3 -m phd_swarm.tools.check_config "$CONFIG"
exec python3 -m phd_swarm.nodes.world --ros-args --params-file "$CONFIG" "$@"
