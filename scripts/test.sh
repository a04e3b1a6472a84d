#!/usr/bin/env bash
# The whole test suite: lint, Python tests (numba JIT cached), docs build (warnings are errors),
# and the firmware checks when stm32/ provides them.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
export PATH="$root/.venv/bin:$PATH"
export MPLBACKEND=Agg
# two test workers share the machine's cores: one thread each for PyTorch and the training workers
# (small networks on two threads beside another busy process run 3x slower, not faster)
export OMP_NUM_THREADS=1

# numba compiles a kernel on its first call and caches it: compiled once here, beside ruff and the
# firmware build, the two test workers and the commands they start load the kernels instead of each
# compiling them again (a cold cache had made single tests take minutes)
echo "== numba: compiling the kernels (msr bench --quick) in the background =="
warm_log="$(mktemp)"
msr bench --quick --train-seeds 0 --json >"$warm_log" 2>&1 &
warm_pid=$!
trap 'kill "$warm_pid" 2>/dev/null || true' EXIT  # a failing step below stops it too

echo "== ruff =="
ruff check .

if [ -x stm32/ci.sh ] || [ -f stm32/ci.sh ]; then
  echo "== firmware: toolchain, host unit tests, cross build =="
  bash stm32/ci.sh
fi

if ! wait "$warm_pid"; then  # the tests still compile what they need; say why it failed
  echo "numba warm-up failed (the tests compile the kernels themselves):"; tail -n 20 "$warm_log"
fi
rm -f "$warm_log"

echo "== pytest =="
# two worker processes (pytest-xdist), a test file each at a time: module fixtures are built once;
# the files with a slow test first (tests/conftest.py), so that no minute-long file is left for last
python -m pytest -q -n "${MSR_TEST_WORKERS:-2}" --dist loadfile --no-loadscope-reorder --durations=15 "$@"

echo "== docs =="
python -m sphinx -W --keep-going -q -b html docs docs/_build/html
echo "docs built: docs/_build/html/index.html"
