#!/usr/bin/env bash
# The main job: simulate the paper's robot (pattern 1, accurate physics) under a rotating field.
# Writes out/simulate/trajectory.csv and out/simulate/shapes.png. Extra arguments go to `msr simulate`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
export MPLBACKEND=Agg
.venv/bin/msr simulate --out out/simulate "$@"
