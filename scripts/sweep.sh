#!/usr/bin/env bash
# Run a parameter sweep of the in-memory engine and plot it (Dames 2020 Fig. 2 and 5,
# Chen, Dames & Park 2021 Fig. 3), see docs/sweeps.md.
# Usage: scripts/sweep.sh SPEC [--quick] [--workers N] [--engine E] [--out DIR] [--plot-only]
#                         [--dry-run] [--recheck N] [--scheduler tcp://HOST:PORT]
#                         [--shard K/N | --merge DIR...]
#   SPEC: a name under config/sweeps/ (dames_static, sung_planners, ...) or a path to a
#   spec file.
#   --scheduler: run the trials on a Dask cluster (workers with this checkout and
#   environment) instead of N local processes; same rows. --shard K/N: run every N-th
#   trial into <out>/shard-K-of-N (job arrays); --merge DIR...: join shard folders into
#   <out>. See docs/sweeps.md, "On a cluster".
# Results: <out>/results.csv, series/, boxplot.png, ospa_vs_time.png, summary.md
# (default out: results/sweeps/<name>, in git, or runs/sweeps/<name>_quick; _<engine>
# appended when --engine is not the spec's own). Rerun to resume.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" >/dev/null
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
exec python3 -m phd_swarm.tools.sweep "$@"
