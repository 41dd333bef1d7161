#!/usr/bin/env bash
# Benchmarks: `scripts/bench.sh core|comms|swarm|engines|recorder|estimators|sung|shirsat|papaioannou|discovery|sweep-cluster|view|fuzz|auth|soak|floor [--quick]`. Sets up if needed; prints the
# figures and writes them as JSON under bench/results/. `estimators` runs in the benchmark-only .venv-bench with
# Stone Soup (scripts/bench_stonesoup_setup.sh), or from .venv without it given --no-stonesoup.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
usage() { echo "usage: scripts/bench.sh core|comms|swarm|engines|recorder|estimators|sung|shirsat|papaioannou|discovery|sweep-cluster|view|fuzz|auth|soak|floor [--quick] [options]" >&2; exit 2; }
[ $# -ge 1 ] || usage
what="$1"; shift
if [ "$what" = view ]; then "$ROOT/scripts/setup.sh" --with-view >/dev/null
elif [ "$what" = fuzz ]; then "$ROOT/scripts/setup.sh" --with-fuzz >/dev/null
else "$ROOT/scripts/setup.sh" >/dev/null; fi
set +u
# shellcheck disable=SC1091
source "$ROOT/scripts/env.sh"
set -u
case "$what" in
  core) exec python3 "$ROOT/bench/core.py" "$@" ;;
  comms) exec python3 "$ROOT/bench/comms.py" "$@" ;;
  swarm) exec python3 "$ROOT/bench/swarm.py" "$@" ;;
  engines) exec python3 "$ROOT/bench/engines.py" "$@" ;;
  recorder) exec python3 "$ROOT/bench/recorder.py" "$@" ;;
  sung) OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 exec python3 "$ROOT/bench/sung.py" "$@" ;;
  shirsat) OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 exec python3 "$ROOT/bench/shirsat.py" "$@" ;;
  discovery) exec python3 "$ROOT/bench/discovery.py" "$@" ;;
  sweep-cluster) exec python3 "$ROOT/bench/sweep_cluster.py" "$@" ;;
  view) exec python3 "$ROOT/bench/view.py" "$@" ;;
  fuzz) exec python3 "$ROOT/bench/fuzz.py" "$@" ;;
  auth) exec python3 "$ROOT/bench/auth.py" "$@" ;;
  soak) exec python3 "$ROOT/bench/soak.py" "$@" ;;
  floor) exec python3 "$ROOT/bench/floor.py" "$@" ;;
  papaioannou) OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 exec python3 "$ROOT/bench/papaioannou.py" "$@" ;;
  estimators) if [[ " $* " == *" --no-stonesoup "* ]]; then py=python; else py="$("$ROOT/scripts/bench_stonesoup_setup.sh")"; fi; exec "$py" "$ROOT/bench/estimators.py" "$@" ;;
  *) usage ;;
esac
