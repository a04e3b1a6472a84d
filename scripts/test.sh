#!/usr/bin/env bash
# The whole test suite: lint, Python tests (numba JIT cached), docs build (warnings are errors),
# and the firmware checks when stm32/ provides them.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
export PATH="$root/.venv/bin:$PATH"
export MPLBACKEND=Agg

echo "== ruff =="
ruff check .

if [ -x stm32/ci.sh ] || [ -f stm32/ci.sh ]; then
  echo "== firmware: toolchain, host unit tests, cross build =="
  bash stm32/ci.sh
fi

echo "== pytest =="
# two worker processes (pytest-xdist), a test file each at a time: module fixtures are built once
python -m pytest -q -n "${MSR_TEST_WORKERS:-2}" --dist loadfile --durations=15 "$@"

echo "== docs =="
python -m sphinx -W --keep-going -q -b html docs docs/_build/html
echo "docs built: docs/_build/html/index.html"
