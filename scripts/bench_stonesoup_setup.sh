#!/usr/bin/env bash
# Benchmark-only environment with Stone Soup, for `scripts/bench.sh estimators`.
# Idempotent: a warm call returns at once. Prints the path of its Python on stdout.
#
# Stone Soup is NOT a dependency of phd_swarm: it is not in requirements.lock, setup.py or
# the project's .venv. It goes into a separate, git-ignored virtual environment .venv-bench
# that sees the project's .venv (its site-packages, processed with their .pth files) and the
# repository through a .pth file, so it adds Stone Soup and its few pure-Python
# dependencies on top of the very numpy/scipy/matplotlib the project uses:
#
# - stonesoup and its dependencies that the .venv lacks are pinned below (STONESOUP_PINS);
# - everything the .venv has is pinned to its installed version by a constraints file
#   (a `pip freeze` of the .venv), so pip can never install a second numpy/scipy into
#   .venv-bench; the script checks afterwards that numpy and scipy still load from .venv.
#
# Needs PyPI on the first call (or when the pins or the .venv change). Remove .venv-bench to
# start over.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${PHD_SWARM_VENV:-$ROOT/.venv}"
BENCH_VENV="${PHD_SWARM_BENCH_VENV:-$ROOT/.venv-bench}"
STONESOUP_PINS=(
  "stonesoup==1.9.1"
  "ordered-set==4.1.0"
  "plotly==7.1.0"
  "narwhals==2.29.0"
  "pymap3d==3.2.0"
  "rtree==1.4.1"
  "utm==0.9.0"
)

log() { printf '[bench-setup] %s\n' "$*" >&2; }

[ -x "$VENV/bin/python" ] || { echo "bench_stonesoup_setup.sh: no $VENV; run scripts/setup.sh" >&2; exit 1; }
venv_site="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_path("purelib"))')"
stamp="$( { printf '%s\n' "${STONESOUP_PINS[@]}"; "$VENV/bin/python" -m pip freeze --all 2>/dev/null \
           | sort; echo "$ROOT"; } | sha256sum | cut -d' ' -f1)"

if [ "$(cat "$BENCH_VENV/.phd_swarm_bench.sha256" 2>/dev/null)" != "$stamp" ]; then
  if [ ! -x "$BENCH_VENV/bin/python" ]; then
    base="$("$VENV/bin/python" -c 'import sys; print(sys._base_executable)')"
    log "creating $BENCH_VENV with $base"
    "$base" -m venv "$BENCH_VENV"
  fi
  bench_site="$("$BENCH_VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_path("purelib"))')"
  # addsitedir (not a bare path line) so that the .venv's own .pth files run too.
  printf "import site; site.addsitedir(%s); site.addsitedir(%s)\n" \
    "'$venv_site'" "'$ROOT'" > "$bench_site/zz_phd_swarm_venv.pth"
  constraints="$BENCH_VENV/constraints.txt"
  "$VENV/bin/python" -m pip freeze --all 2>/dev/null | grep -v -e '^-e ' -e ' @ ' > "$constraints"
  log "installing ${STONESOUP_PINS[0]} into $BENCH_VENV (constrained to the .venv's versions)"
  "$BENCH_VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
    -c "$constraints" "${STONESOUP_PINS[@]}" >&2
  # Guard: numpy and scipy must be the .venv's, not a second copy.
  "$BENCH_VENV/bin/python" - "$venv_site" <<'EOF'
import sys
import numpy, scipy, stonesoup  # noqa: E401
for mod in (numpy, scipy):
    if not mod.__file__.startswith(sys.argv[1]):
        sys.exit(f"{mod.__name__} loads from {mod.__file__}, not from the project's .venv")
if stonesoup.__version__ != "1.9.1":
    sys.exit(f"stonesoup {stonesoup.__version__} != 1.9.1")
EOF
  echo "$stamp" > "$BENCH_VENV/.phd_swarm_bench.sha256"
fi
echo "$BENCH_VENV/bin/python"
