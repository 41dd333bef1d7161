#!/usr/bin/env bash
# Republish a recorded MCAP run as if live (node `replay`): recorded types, QoS and timing.
# Usage: scripts/replay.sh LOG [--rate R | --fast] [--topics T ...] [--start S] [--end E]
#          [--wait-subscribers N] [--wait-timeout W] [--dry-run] [--quiet]
#          [--view [--view-hold] [--view-save FILE]] [--ros-args ...]
#   LOG      the .mcap file, e.g. runs/<name>/run.mcap (a log cut short by a crash replays
#            its complete records, with a warning)
#   S, E     seconds after the log's first message; the window is [S, E)
#   --view   watch it in a browser: the live view on 127.0.0.1, its URL printed (docs/view.md)
# Exit codes: 0 done (or stopped by Ctrl-C / SIGTERM), 1 the log cannot be read, 2 bad usage.
# See docs/replay.md.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -lt 1 ]; then
  echo "usage: $0 LOG [--rate R | --fast] [--topics T ...] [--start S] [--end E]" \
       "[--wait-subscribers N] [--dry-run] [--quiet] [--view [--view-hold]" \
       "[--view-save FILE]]" >&2
  exit 2
fi
# --view: the live view's extra (rerun-sdk; docs/view.md).
case " $* " in *" --view "*) "$ROOT/scripts/setup.sh" --with-view >/dev/null ;; esac
set +u
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
set -u
exec python3 -m phd_swarm.tools.replay "$@"
