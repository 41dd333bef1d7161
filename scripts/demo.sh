#!/usr/bin/env bash
# The demo: Dames static targets, 20 robots, 30 targets, 120 s of sim time, lockstep,
# recorded. Sets up the workspace first if needed; prints where the results are.
# Extra arguments go to run_swarm.sh (e.g. --robots 10, --controller uniform, or --view to
# watch it live in a browser: docs/view.md).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# --view: the live view's extra too (rerun-sdk; docs/view.md).
case " $* " in *" --view "*) "$ROOT/scripts/setup.sh" --with-view ;; *) "$ROOT/scripts/setup.sh" ;; esac
exec "$ROOT/scripts/run_swarm.sh" "$ROOT/config/dames_static.yaml" --robots 20 --targets 30 \
  --duration 120 --seed 1 --name demo "$@"
