#!/usr/bin/env bash
# Recompute OSPA and cardinality of a recorded run from its MCAP log, and draw it.
# Usage: scripts/evaluate.sh LOG [--out DIR] [--snapshot T ...] [--animate FILE.gif]
#                            [--every N] [--cumulative] [--config CONFIG] [--no-plots]
# Writes evaluation.json, series.csv, ospa.png and snapshot_<T>s.png (default: next to LOG,
# in evaluation/). See docs/evaluation.md.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
set +u
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
set -u
exec python3 -m phd_swarm.tools.evaluate "$@"
