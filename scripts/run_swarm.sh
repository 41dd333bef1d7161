#!/usr/bin/env bash
# Run a whole swarm (world, monitor, recorder, one process per robot) on this machine.
# Usage: scripts/run_swarm.sh CONFIG [--robots N] [--targets M] [--duration S] [--seed K]
#          [--controller phd|uniform|chen_p|chen_o|<registered>] [--out DIR] [--name NAME] [--realtime]
#          [--robots-per-process P] [--no-record] [--view [--view-hold]]
# Results: <out>/<name>/run.mcap, summary.json, config.yaml, logs/ (default out: runs/).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# --view: the live view's extra too (rerun-sdk; docs/view.md).
case " $* " in
  *" --view "*) "$ROOT/scripts/setup.sh" --with-view >/dev/null ;;
  *) "$ROOT/scripts/setup.sh" >/dev/null ;;
esac
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
exec python3 -m phd_swarm.tools.run_swarm "$@"
